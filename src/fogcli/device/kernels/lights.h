/* What the light kernels share (lights.cl: the airlight; shadows.cl: its visibility): the
 * medium and light structs (device/structs.py: lmedium_struct; device/lights.py: light_struct), the phase
 * function, density and optical depth of the analytic primitives, and the integrand of the
 * airlight at one point of a ray. */
#ifndef FOGCLI_LIGHTS_H
#define FOGCLI_LIGHTS_H

#include "density.h"
#include "noise.h"

typedef struct {
    float4 sa, ss;          /* per RGB, 1/m */
    float g;                /* HG asymmetry */
    float homogeneous;      /* summed factor of the homogeneous primitives */
    int nprims;             /* other primitives in prims[3 k .. 3 k + 2] */
    int nodes;              /* Gauss-Legendre nodes per piece */
} lmedium_t;

/* light_t.type and the density primitive codes (prims[3k].x); the host's are
 * fogcli.structs.LIGHT_TYPES and PRIM_TYPES, tested against these (tests/test_structs.py) */
#define LIGHT_POINT 0
#define LIGHT_SPOT 1
#define LIGHT_DIRECTIONAL 2
#define PRIM_EXPONENTIAL 1
#define PRIM_SPHERE 2

typedef struct {
    float4 pos;             /* world position (point, spot); .w unused */
    float4 axis;            /* spot axis / directional: towards the light, unit, world */
    float4 intensity;       /* RGB intensity or irradiance */
    float radius;
    float cos_outer, cos_inner;
    int type;               /* LIGHT_POINT, LIGHT_SPOT, LIGHT_DIRECTIONAL */
    float4 gain;            /* all orders of scattering over what single scattering carries
                             * (device/lights.py: gain), per RGB: the rest joins the scattered part */
} light_t;

inline float hg(float g, float c)
{
    float d = 1.0f + g * g - 2.0f * g * c;
    return (1.0f - g * g) / (12.566370614f * d * native_sqrt(d));
}

/* prims[3k] = (type PRIM_EXPONENTIAL | PRIM_SPHERE, factor, falloff | radius, 0),
 * prims[3k+1] = direction n (unit) | centre, prims[3k+2] = offset */
inline float density_at(__global const float4 *prims, const lmedium_t *m, float3 x)
{
    float rho = m->homogeneous;
    for (int k = 0; k < m->nprims; ++k) {
        float4 a = prims[3 * k], b = prims[3 * k + 1], o = prims[3 * k + 2];
        if (a.x == (float)PRIM_EXPONENTIAL) {
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
        if (a.x == (float)PRIM_EXPONENTIAL) {
            float pre = a.y * exp(fmin(-a.z * dot(p - o.xyz, b.xyz), 80.0f));
            P += exponential_p(pre, a.z, dot(u, b.xyz), L);
        } else {
            float3 co = p - b.xyz;
            P += sphere_p(a.y, a.z, co.x, co.y, co.z, u.x, u.y, u.z, L);
        }
    }
    return P;
}

/* The uniforms of airlight_table and airlight_table_grey (device/lights.py: table_args):
 * per channel the medium's st, ln st, sa, r = sa / st, the table's x range (xm, em) and its
 * offset in the tables; ln(ss I) per channel (lk; grey media: its largest, lkm, and
 * k = exp(lk - lkm)), the gain; g, the homogeneous factor hf, camera to light (vx, vy, vz),
 * the light's radius squared. Scalars and arrays of them, no float4: LLVM pairs the lanes
 * of a float4 worked on the same way, which stops PoCL's vectoriser. */
typedef struct {
    float st[3], lst[3], sa[3], r[3], xm[3], em[3];
    int off[3];
    float lk[3], k[3], gn[3];
    float g, hf, lkm, vx, vy, vz, rad2;
} al_table_t;

/* What the integrand needs of the noise primitives (the marched airlight, tfm.cl): the
 * primitives, the light's transmittance function map, and the camera leg's noise optical
 * depth up to s_prev (the march's last node); rho_noise returns the density at x. */
typedef struct {
    __global const noise_t *nz;
    int count;
    const tfm_t *tm;
    __global const float *coef;
    __global const float4 *span;
    float acc, s_prev, rho_noise;
} noise_ctx_t;

/* The airlight's integrand at ray parameter a (phi for points and spots, s for a
 * directional light) per unit of the integration variable: src (the light scattered towards
 * the camera at x, all factors but the camera leg), and the camera leg's optical depth P.
 * het: the medium without its homogeneous part (what dims a directional light). nc: 0 without
 * noise primitives; with them, its camera leg is nc->acc plus the density here times
 * s - nc->s_prev (the midpoint rule of the march), its light leg read from the map. */
inline float3 al_integrand(const light_t *L, const lmedium_t *m, const lmedium_t *het, __global const float4 *prims,
                           noise_ctx_t *nc, float3 c, float3 w, float d1, float R, float a, float *P)
{
    float s, cosa, weight;
    float3 I = L->intensity.xyz;
    if (L->type == LIGHT_DIRECTIONAL) {
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
    float Pn = 0.0f;
    if (nc) {
        float rn = noise_sum(nc->nz, nc->count, x);
        nc->rho_noise = rn;
        rho += rn;
        *P += nc->acc + rn * (s - nc->s_prev);
        Pn = tfm_tau(nc->tm, nc->coef, nc->span, nc->nz, nc->count, x);
    }
    float Pl;
    if (L->type == LIGHT_DIRECTIONAL) {
        Pl = optical_depth(prims, het, x, L->axis.xyz, 1e6f);
    } else {
        float3 to = L->pos.xyz - x;
        float tl = length(to);
        /* the homogeneous part over the widened distance (R / cos(phi)), like 1 / t^2 */
        Pl = (tl > 0.0f ? optical_depth(prims, m, x, to / tl, tl) : 0.0f) + m->homogeneous * (SQRT_((s - d1) * (s - d1) + R * R) - tl);
        if (L->type == LIGHT_SPOT) {
            float ct = tl > 0.0f ? dot(-to / tl, L->axis.xyz) : 1.0f;
            I *= smoothstep(L->cos_outer, L->cos_inner, ct);
        }
    }
    float3 k = -(m->sa.xyz + m->ss.xyz) * (Pl + Pn);
    return weight * rho * hg(m->g, cosa) * m->ss.xyz * I * (float3)(exp_poly(k.x), exp_poly(k.y), exp_poly(k.z));
}

#define MAX_CUTS 24

/* ray parameters s in (lo, hi) where the ray c + s w crosses the sphere primitives */
inline int sphere_cuts(__global const float4 *prims, const lmedium_t *m, float3 c, float3 w,
                       float lo, float hi, float *cuts, int n)
{
    for (int k = 0; k < m->nprims && n < MAX_CUTS - 2; ++k) {
        float4 a = prims[3 * k], b = prims[3 * k + 1];
        if (a.x != 2.0f) continue;
        float3 co = c - b.xyz;
        float B = dot(w, co);
        float3 perp = co - B * w;
        float s2 = a.z * a.z - dot(perp, perp);
        if (s2 <= 0.0f) continue;
        float s = sqrt(s2);
        float t0 = -B - s, t1 = -B + s;
        if (t0 > lo && t0 < hi) cuts[n++] = t0;
        if (t1 > lo && t1 < hi) cuts[n++] = t1;
    }
    return n;
}

/* ray parameters where the light's ray to x grazes a sphere primitive: the light leg's
 * chord through the sphere has a square-root kink there. Directional: the camera ray meets
 * the cylinder of the sphere's radius along the light direction; point: the tangent cone
 * from the light, |v x a|^2 = r^2 |v|^2 with v = x - l, a = centre - l. */
inline int graze_cuts(__global const float4 *prims, const lmedium_t *m, float3 c, float3 w, float3 l,
                      float3 ax, int directional, float lo, float hi, float *cuts, int n)
{
    for (int k = 0; k < m->nprims && n < MAX_CUTS - 2; ++k) {
        float4 pa = prims[3 * k], pb = prims[3 * k + 1];
        if (pa.x != 2.0f) continue;
        float A, B, C, r2 = pa.z * pa.z;
        if (directional) {
            float3 q = c - pb.xyz;
            float3 qp = q - dot(q, ax) * ax, wp = w - dot(w, ax) * ax;
            A = dot(wp, wp); B = dot(qp, wp); C = dot(qp, qp) - r2;
        } else {
            float3 v0 = c - l, a = pb.xyz - l;
            float aa = dot(a, a) - r2, wa = dot(w, a), va = dot(v0, a);
            A = aa - wa * wa; B = aa * dot(v0, w) - va * wa; C = aa * dot(v0, v0) - va * va;
        }
        float disc = B * B - A * C;
        if (disc < 0.0f || fabs(A) < 1e-12f) continue;
        float r = sqrt(disc);
        float t0 = (-B - r) / A, t1 = (-B + r) / A;
        if (t0 > lo && t0 < hi) cuts[n++] = t0;
        if (t1 > lo && t1 < hi) cuts[n++] = t1;
    }
    return n;
}

/* ray parameters where the ray enters or leaves the spot's (single-nappe) cone of cosine cc */
inline int cone_cuts(float3 c, float3 w, float3 l, float3 ax, float cc, float lo, float hi, float *cuts, int n)
{
    float3 v = c - l;
    float wa = dot(w, ax), va = dot(v, ax), cc2 = cc * cc;
    float A = wa * wa - cc2, B = wa * va - cc2 * dot(w, v), C = va * va - cc2 * dot(v, v);
    float disc = B * B - A * C;
    if (disc < 0.0f || fabs(A) < 1e-12f) return n;
    float r = sqrt(disc);
    float t0 = (-B - r) / A, t1 = (-B + r) / A;
    if (t0 > lo && t0 < hi && va + t0 * wa > 0.0f && n < MAX_CUTS) cuts[n++] = t0;
    if (t1 > lo && t1 < hi && va + t1 * wa > 0.0f && n < MAX_CUTS) cuts[n++] = t1;
    return n;
}

inline void sort_cuts(float *c, int n)
{
    for (int i = 1; i < n; ++i) {
        float v = c[i];
        int j = i - 1;
        while (j >= 0 && c[j] > v) { c[j + 1] = c[j]; --j; }
        c[j + 1] = v;
    }
}


/* One node's share of the airlight: src, the light scattered towards the camera there (times
 * the node's weight), split by the camera leg's optical depth P into what arrives unscattered
 * (dir) and what scatters again on the way (sc), with sc's luminance-weighted P in wp. */
inline void al_accumulate(float3 src, float P, float3 sa, float3 st, float3 *dir, float3 *sc, float *wp)
{
    float3 tdir = exp(-st * P);
    float3 add = src * (exp(-sa * P) - tdir);
    *dir += src * tdir;
    *sc += add;
    *wp += luminance(add) * P;
}

/* The emitter's radius r keeps a light on a pixel ray finite: R, the ray's distance from the
 * light, is taken at least r (R^2 = max(R0^2, r^2)). Near the light the airlight goes as
 * 1 / R0, so the rays within r would lose energy (R widened to sqrt(R0^2 + r^2), as before,
 * lost 2 pi r over the image: a lamp of 0.25 m at 20 m in sea water a third of its airlight).
 * Within r the airlight at r is taken times 3 - 2 (R0 / r)^2: continuous at r, and its
 * integral over the disc is 1 / R0's. phi0, phi1: the ray's ends as angles seen from the
 * light (atan2(s - d1, R)); the share (phi1 - phi0) / pi of the near field the ray covers
 * scales it, so a ray that ends before the light (the light's own pixels) takes less. */
#define AL_RADIUS_GAIN(R02, rad2, phi0, phi1) \
    (1.0f + ((phi1) - (phi0)) * 0.63661977237f * fmax(1.0f - (R02) / fmax(rad2, 1e-30f), 0.0f))

/* Points and spots, after their quadrature over the ray from c along w to D (d1, R: ray_cuts'):
 * the radius' energy back (AL_RADIUS_GAIN); what all orders of scattering carry beyond single
 * scattering (the gain) joins sc, and sc spreads at Pd, the optical depth where the ray passes
 * the light (as the table kernel does); a directional light keeps the luminance-weighted
 * optical depth of its scatter points. */
inline void al_point_gain(const light_t *L, float3 c, float3 w, float d1, float R, float D,
                          float3 *dir, float3 *sc, float *wp, float Pd)
{
    float3 cr = cross(w, L->pos.xyz - c);
    float rg = AL_RADIUS_GAIN(dot(cr, cr), L->radius * L->radius, atan2(-d1, R), atan2(D - d1, R));
    *dir *= rg;
    *sc *= rg;
    *sc += (L->gain.xyz - 1.0f) * (*dir + *sc);
    *wp = luminance(*sc) * Pd;
}

/* The pieces of a pixel's ray [0, D] that its quadrature treats apart: where the light's
 * foot is (phi = 0), the phase function's forward peak, e-folds of the camera leg, sphere
 * primitives and their grazing light rays, a spot's cone. *d1, *R: the light's place in
 * the plane of the ray (d1 along it, R from it, at least the emitter's radius). Sorted. */
inline int ray_cuts(const light_t *L, const lmedium_t *m, __global const float4 *prims, float3 c, float3 w,
                    float D, float *d1_, float *R_, float *cuts)
{
    float3 l = L->pos.xyz, ax = L->axis.xyz, st = m->sa.xyz + m->ss.xyz;
    int n = 0;
    float d1 = 0.0f, R = 1.0f;
    cuts[n++] = 0.0f;
    cuts[n++] = D;
    if (L->type != 2) {
        float3 v = l - c;
        d1 = dot(w, v);
        float3 cr = cross(w, v);
        R = sqrt(fmax(dot(cr, cr), L->radius * L->radius));
        if (d1 > 0.0f && d1 < D) cuts[n++] = d1;                     /* phi = 0 */
        /* the phase function's forward peak (light ahead, scattered back along the ray to
         * the camera) sits at phi = -pi/2, about 2 (1 - g) wide: a piece of its own */
        float sp = d1 - R / tan(fmin(2.0f * (1.0f - m->g), 1.0f));
        if (sp > 0.0f && sp < D) cuts[n++] = sp;
    }
    /* the camera leg decays as exp(-k s): pieces that double in length from 1 / k, so that
     * none holds more than a few e-folds (k the largest homogeneous extinction). Points and
     * spots start at 8 / k: the phi substitution already crowds their nodes where the light
     * is (measured: the same worst error, 1.9x faster) */
    float k = m->homogeneous * fmax(st.x, fmax(st.y, st.z));
    for (float e = L->type == LIGHT_DIRECTIONAL ? 1.0f : 8.0f; k > 0.0f && e < k * D && n < MAX_CUTS - 6; e *= 2.0f) cuts[n++] = e / k;
    n = sphere_cuts(prims, m, c, w, 0.0f, D, cuts, n);
    n = graze_cuts(prims, m, c, w, l, ax, L->type == LIGHT_DIRECTIONAL, 0.0f, D, cuts, n);
    if (L->type == LIGHT_SPOT) {     /* both ends of the soft edge: smoothstep's curvature jumps there */
        n = cone_cuts(c, w, l, ax, L->cos_outer, 0.0f, D, cuts, n);
        n = cone_cuts(c, w, l, ax, L->cos_inner, 0.0f, D, cuts, n);
    }
    sort_cuts(cuts, n);
    *d1_ = d1;
    *R_ = R;
    return n;
}

#endif
