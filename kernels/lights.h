/* What the light kernels share (lights.cl: the airlight; shadows.cl: its visibility): the
 * medium and light structs (fogcli/lights.py: medium_struct, light_struct), the phase
 * function, density and optical depth of the analytic primitives, and the integrand of the
 * airlight at one point of a ray. */
#ifndef FOGCLI_LIGHTS_H
#define FOGCLI_LIGHTS_H

#include "density.h"

typedef struct {
    float4 sa, ss;          /* per RGB, 1/m */
    float g;                /* HG asymmetry */
    float homogeneous;      /* summed factor of the homogeneous primitives */
    int nprims;             /* other primitives in prims[3 k .. 3 k + 2] */
    int nodes;              /* Gauss-Legendre nodes per piece */
} lmedium_t;

typedef struct {
    float4 pos;             /* world position (point, spot); .w unused */
    float4 axis;            /* spot axis / directional: towards the light, unit, world */
    float4 intensity;       /* RGB intensity or irradiance */
    float radius;
    float cos_outer, cos_inner;
    int type;               /* 0 point, 1 spot, 2 directional */
    float4 gain;            /* all orders of scattering over what single scattering carries
                             * (fogcli.lights.gain), per RGB: the rest joins the scattered part */
} light_t;

inline float hg(float g, float c)
{
    float d = 1.0f + g * g - 2.0f * g * c;
    return (1.0f - g * g) / (12.566370614f * d * native_sqrt(d));
}

/* prims[3k] = (type 1 exponential | 2 sphere, factor, falloff | radius, 0),
 * prims[3k+1] = direction n (unit) | centre, prims[3k+2] = offset */
inline float density_at(__global const float4 *prims, const lmedium_t *m, float3 x)
{
    float rho = m->homogeneous;
    for (int k = 0; k < m->nprims; ++k) {
        float4 a = prims[3 * k], b = prims[3 * k + 1], o = prims[3 * k + 2];
        if (a.x == 1.0f) {
            rho += a.y * exp(-a.z * dot(x - o.xyz, b.xyz));
        } else {
            float3 r = x - b.xyz;
            rho += a.y * fmax(0.0f, 1.0f - dot(r, r) / (a.z * a.z));
        }
    }
    return rho;
}

/* optical depth (in units of the coefficients) from p along unit u over length L */
inline float optical_depth(__global const float4 *prims, const lmedium_t *m, float3 p, float3 u, float L)
{
    float P = m->homogeneous * L;
    for (int k = 0; k < m->nprims; ++k) {
        float4 a = prims[3 * k], b = prims[3 * k + 1], o = prims[3 * k + 2];
        if (a.x == 1.0f) {
            float pre = a.y * exp(fmin(-a.z * dot(p - o.xyz, b.xyz), 80.0f));
            P += exponential_p(pre, a.z, dot(u, b.xyz), L);
        } else {
            float3 co = p - b.xyz;
            P += sphere_p(a.y, a.z, co.x, co.y, co.z, u.x, u.y, u.z, L);
        }
    }
    return P;
}

/* The airlight's integrand at ray parameter a (phi for points and spots, s for a
 * directional light) per unit of the integration variable: src (the light scattered towards
 * the camera at x, all factors but the camera leg), and the camera leg's optical depth P.
 * het: the medium without its homogeneous part (what dims a directional light). */
inline float3 al_integrand(const light_t *L, const lmedium_t *m, const lmedium_t *het, __global const float4 *prims,
                           float3 c, float3 w, float d1, float R, float a, float *P)
{
    float s, cosa, weight;
    float3 I = L->intensity.xyz;
    if (L->type == 2) {
        s = a;
        cosa = dot(L->axis.xyz, w);
        weight = 1.0f;
    } else {
        float sn = native_sin(a), cs = native_cos(a);
        s = d1 + R * sn / cs;
        cosa = -sn;
        weight = 1.0f / R;
    }
    float3 x = c + s * w;
    float rho = density_at(prims, m, x);
    *P = optical_depth(prims, m, c, w, s);
    float Pl;
    if (L->type == 2) {
        Pl = optical_depth(prims, het, x, L->axis.xyz, 1e6f);
    } else {
        float3 to = L->pos.xyz - x;
        float tl = length(to);
        /* the homogeneous part over the widened distance (R / cos(phi)), like 1 / t^2 */
        Pl = (tl > 0.0f ? optical_depth(prims, m, x, to / tl, tl) : 0.0f) + m->homogeneous * (hypot(s - d1, R) - tl);
        if (L->type == 1) {
            float ct = tl > 0.0f ? dot(-to / tl, L->axis.xyz) : 1.0f;
            I *= smoothstep(L->cos_outer, L->cos_inner, ct);
        }
    }
    return weight * rho * hg(m->g, cosa) * m->ss.xyz * I * native_exp(-(m->sa.xyz + m->ss.xyz) * Pl);
}

#endif
