/* Stage 1c for media with `noise` primitives (docs/lights.md, Smoke): the light leg through
 * the noise from a transmittance function map (Delalandre et al. 2011), the camera leg
 * marched. Per light, tfm_build marches the noise along each texel's ray and stores its
 * optical depth as DCT-II coefficients over the ray's span (the optical depth, not the
 * transmittance: no alpha to tune, exact for every channel's extinction, and more accurate:
 * docs/lights.md). airlight_noise then integrates each pixel's ray on a merged grid: the
 * analytic quadrature's pieces (lights.h: ray_cuts), each cut into `sub` equal parts of its
 * integration variable, and the noise's march steps; the midpoint rule on every interval,
 * the camera leg's noise optical depth accumulated interval by interval. */
#include "density.h"
#include "lights.h"

/* One texel: its ray's span through the noise and the optical depth f(x) along it
 * (x in [0, 1] over the span) at ns sample centres (ns from the noise's march step, 32 to
 * 512). A hard edge gives f a slope at the span's ends, which the DCT's even extension
 * turns into kinks (coefficients falling as 1/j^2); so q(x) = a x + b x^2 with the ends'
 * slopes is taken off first, and the rest, flat at both ends, stored as DCT-II coefficients
 * c_j = (1 or 2) / ns * sum_k r_k cos(j pi (k + 1/2) / ns) (row: c_0 .. c_N-1, a, b); the
 * total in span.z. */
__kernel void tfm_build(__global float *coef, __global float4 *span, const tfm_t tm,
                        __global const noise_t *nz, const int count)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= tm.size || j >= tm.size) return;
    int tex = j * tm.size + i;
    __global float *c = coef + (size_t)tex * (tm.ncoef + 2);
    for (int k = 0; k < tm.ncoef + 2; ++k) c[k] = 0.0f;
    float3 o, u;
    tfm_ray(&tm, (float)i, (float)j, &o, &u);
    float t0, t1, h;
    if (!noise_span(nz, count, o, u, 0.0f, INFINITY, &t0, &t1, &h)) {
        span[tex] = (float4)(0.0f);
        return;
    }
    int ns = clamp((int)ceil((t1 - t0) / h), 32, NOISE_MAX_STEPS);
    float dt = (t1 - t0) / ns, tau = 0.0f;
    float a = noise_sum(nz, count, o + (t0 + 0.5f * dt) * u) * (t1 - t0);
    float b = 0.5f * (noise_sum(nz, count, o + (t1 - 0.5f * dt) * u) * (t1 - t0) - a);
    for (int k = 0; k < ns; ++k) {
        float rho = noise_sum(nz, count, o + (t0 + (k + 0.5f) * dt) * u) * dt;
        float x = (k + 0.5f) / ns;
        float r = tau + 0.5f * rho - x * (a + b * x);      /* at the sample's centre */
        tau += rho;
        float basis[TFM_MAX_COEF];
        dct_basis(x, tm.ncoef, basis);
        for (int q = 0; q < tm.ncoef; ++q) c[q] += r * basis[q];
    }
    c[0] *= 1.0f / ns;
    for (int q = 1; q < tm.ncoef; ++q) c[q] *= 2.0f / ns;
    c[tm.ncoef] = a;
    c[tm.ncoef + 1] = b;
    span[tex] = (float4)(t0, t1, tau, 0.0f);
}

/* the integration variable (phi for points and spots, s for a directional light) at s */
inline float grid_var(int directional, float s, float d1, float R)
{
    return directional ? s : atan2(s - d1, R);
}

/* A ray's airlight through noise: (A_dir, 0) in *od, (A_sc, its luminance-weighted optical
 * depth) in *os, as lights.cl's airlight kernel writes them. */
inline void noise_ray(float3 c, float3 w, float D, const light_t *L, const lmedium_t *m,
                      __global const float4 *prims, __global const noise_t *nz, const int count, const tfm_t *tm,
                      __global const float *coef, __global const float4 *span, const int sub, float4 *od, float4 *os)
{
    float3 sa = m->sa.xyz, st = sa + m->ss.xyz;
    float3 dir = (float3)(0.0f), sc = (float3)(0.0f);
    float wp = 0.0f;
    int directional = L->type == LIGHT_DIRECTIONAL;
    lmedium_t het = *m;
    het.homogeneous = 0.0f;

    float cuts[MAX_CUTS];
    float d1, R;
    int n = ray_cuts(L, m, prims, c, w, D, &d1, &R, cuts);

    /* the noise's march nodes on this ray: n0 + k dn, k = 0 .. nn */
    float n0, n1, h;
    int nn = 0;
    float dn = 0.0f;
    if (noise_span(nz, count, c, w, 0.0f, D, &n0, &n1, &h)) {
        nn = clamp((int)ceil((n1 - n0) / h), 1, NOISE_MAX_STEPS);
        dn = (n1 - n0) / nn;
    }
    int kb = 0;
    noise_ctx_t nc = {nz, count, tm, coef, span, 0.0f, 0.0f, 0.0f};
    float acc_d1 = 0.0f;        /* the camera leg's noise optical depth where the ray passes the light */
    float s_prev = 0.0f;
    for (int p = 0; p + 1 < n; ++p) {
        float s0 = cuts[p], s1 = cuts[p + 1];
        if (s1 <= s0) continue;
        float a0 = grid_var(directional, s0, d1, R), a1 = grid_var(directional, s1, d1, R);
        for (int q = 1; q <= sub; ++q) {
            float sA = q == sub ? s1 : (directional ? s0 + (s1 - s0) * q / sub
                                                    : d1 + R * tan(a0 + (a1 - a0) * q / sub));
            while (s_prev < sA) {
                float sB = kb <= nn && nn > 0 ? n0 + kb * dn : INFINITY;
                if (sB <= s_prev) { ++kb; continue; }
                float s_next = fmin(sA, sB);
                float ga = grid_var(directional, s_prev, d1, R), gb = grid_var(directional, s_next, d1, R);
                float P;
                nc.s_prev = s_prev;
                float3 src = (gb - ga) * al_integrand(L, m, &het, prims, &nc, c, w, d1, R, 0.5f * (ga + gb), &P);
                al_accumulate(src, P, sa, st, &dir, &sc, &wp);
                if (s_prev <= d1 && d1 < s_next) acc_d1 = nc.acc + nc.rho_noise * (d1 - s_prev);
                nc.acc += nc.rho_noise * (s_next - s_prev);
                s_prev = s_next;
            }
        }
    }
    if (!directional)       /* the noise's share of Pd: the camera leg's up to the light's foot */
        al_point_gain(L, c, w, d1, R, D, &dir, &sc, &wp, optical_depth(prims, m, c, w, clamp(d1, 0.0f, D))
                      + (d1 >= D ? nc.acc : (d1 > 0.0f ? acc_d1 : 0.0f)));
    *od = (float4)(dir, 0.0f);
    *os = (float4)(sc, wp);
}

#define NOISE_ARGS const camera_t cam, const lmedium_t m, __global const float4 *prims, const light_t L, \
    __global const noise_t *nz, const int count, const tfm_t tm, __global const float *coef, \
    __global const float4 *span, const int sub

/* the airlight at every `stride`-th pixel of every `stride`-th row (and the last ones): the
 * samples airlight_fill interpolates; .w of a sample's A_dir: 1 where its ray meets the
 * noise. stride 1: every pixel, written straight to a_dir, a_sc. */
__kernel NOT_ACROSS_ITEMS void airlight_noise(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                             const int width, const int height, NOISE_ARGS, const int stride, const int cw,
                             const int ch)
{
    SAMPLE_RAY
    float3 w = (float3)(wx, wy, wz);
    float4 od, os;
    noise_ray(cam.pos.xyz, w, D, &L, &m, prims, nz, count, &tm, coef, span, sub, &od, &os);
    od.w = stride > 1 && noise_meets(nz, count, cam.pos.xyz, w, D) ? 1.0f : 0.0f;
    a_dir[cj * cw + ci] = od;
    a_sc[cj * cw + ci] = os;
}

/* Every pixel from the four samples around it (bilinear), where all four lie on its surface,
 * agree with it on meeting the noise, and it is more than 12 strides from the light's image
 * (lx, ly; the 1/R peak); elsewhere its own ray, integrated. */
__kernel NOT_ACROSS_ITEMS void airlight_fill(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                            __global const float4 *s_dir, __global const float4 *s_sc,
                            const int width, const int height, NOISE_ARGS, const int stride, const int cw,
                            const int ch, const float lx, const float ly)
{
    PIXEL_RAY
    float3 w = (float3)(wx, wy, wz);
    float hit = noise_meets(nz, count, cam.pos.xyz, w, D) ? 1.0f : 0.0f;
    grid4_t g = grid_neighbours(depth, width, height, cam.max_depth, i, j, stride, cw, ch);
    int ok = g.same_surface && (i - lx) * (i - lx) + (j - ly) * (j - ly) > 144.0f * stride * stride;
    float4 od = (float4)(0.0f), os = (float4)(0.0f);
    float ylo = INFINITY, yhi = 0.0f;
    for (int k = 0; k < 4; ++k) {
        float4 sd = s_dir[g.smp[k]], ss = s_sc[g.smp[k]];
        ok = ok && (sd.w == hit || g.wt[k] == 0.0f);
        float y = luminance(sd.xyz + ss.xyz);
        ylo = fmin(ylo, y);
        yhi = fmax(yhi, y);
        od += g.wt[k] * (float4)(sd.xyz, 0.0f);
        os += g.wt[k] * ss;
    }
    /* ... and vary by at most 50 % (a cone's edge, the light's peak: curvature the
     * bilinear weights miss) */
    ok = ok && yhi <= 1.5f * ylo;
    if (!ok) noise_ray(cam.pos.xyz, w, D, &L, &m, prims, nz, count, &tm, coef, span, sub, &od, &os);
    a_dir[idx] = (float4)(od.xyz, 0.0f);
    a_sc[idx] = os;
}

/* the map's optical depth at given points (tests/test_noise.py, tools/shadows.py) */
__kernel void tfm_probe(__global const float4 *x, __global float *tau, const int n, const tfm_t tm,
                        __global const float *coef, __global const float4 *span, __global const noise_t *nz,
                        const int count)
{
    int k = get_global_id(0);
    if (k < n) tau[k] = tfm_tau(&tm, coef, span, nz, count, x[k].xyz);
}
