/* Stage 1: split the input into attenuated, scattered and medium terms (SPEC 4.2, 4.3;
 * Elek sec. 3.2 with the thesis' eq. 4.4-4.5, Iser eq. 4.29, Delalandre eq. 7).
 * Depth arrives raw (as stored in the file, holes already filled); the camera model
 * turns it into a ray length here so that a z-buffer never reaches the physics. */
#include "common.h"
#include "density.h"

typedef struct {
    float4 sa;          /* absorption per RGB, 1/m; .w = mean over RGB */
    float4 ss;          /* scattering per RGB; .w = mean */
    float4 emission;    /* L_e */
    float4 ambient;     /* L_a */
    camera_t cam;
    float g;            /* phase asymmetry */
    float spread_scale;
    float homogeneous;  /* sum of the homogeneous density factors: their P is this times D */
    int has_medium_light;   /* emission or ambient non-zero */
    int has_p;          /* the density stage left the other primitives' P in spread0 */
} medium_t;

__kernel void preprocess(__global const float4 *image, __global const float *depth,
                         __global float4 *direct, __global float4 *scat0,
                         __global float *spread0, __global float4 *medium_term,
                         __global float4 *transmittance, const int want_transmittance,
                         const int split_medium,
                         const int width, const int height, const medium_t m,
                         __global float4 *prep0, const int source, const float thresh1,
                         const float eps, __global float4 *sep_chain0, __global float4 *sep_prep0,
                         const int sep, const float4 sep_par)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;

    float wx, wy, wz;
    float dist = pixel_ray(&m.cam, i, j, depth[idx], &wx, &wy, &wz);
    /* spread0 is read before it is overwritten below, by this work-item only */
    float P = m.homogeneous * dist + (m.has_p ? spread0[idx] : 0.0f);
    /* per channel, scalar and with polynomial exponentials: PoCL vectorises the kernel
     * across work-items only without builtin calls and float3 arithmetic */
    float L[3], alpha;
    load4(image, idx, &L[0], &L[1], &L[2], &alpha);
    float sa[3] = {m.sa.x, m.sa.y, m.sa.z}, ss[3] = {m.ss.x, m.ss.y, m.ss.z};
    float le[3] = {m.emission.x, m.emission.y, m.emission.z};
    float la[3] = {m.ambient.x, m.ambient.y, m.ambient.z};
    float at[3], sc[3], med[3], tr[3];
    for (int c = 0; c < 3; ++c) {
        float st = sa[c] + ss[c];
        float t_all = exp_poly(-st * P);
        tr[c] = t_all;
        at[c] = t_all * L[c];
        /* exp(-sa P)(1 - exp(-ss P)) = exp(-sa P) - exp(-st P); the thesis form (SPEC 4.2) */
        sc[c] = (exp_poly(-sa[c] * P) - t_all) * L[c];
        /* 1 - exp(-st P) by its series in thin media; st -> 0 limits: emission grows as
         * P, ambient vanishes */
        float one_minus = one_minus_exp(st * P);
        float em_w = st > 0.0f ? one_minus / st : P;
        float amb_w = st > 0.0f ? ss[c] / st * one_minus : 0.0f;
        med[c] = m.has_medium_light ? le[c] * em_w + la[c] * amb_w : 0.0f;
    }

    float sigma = spread_px(P, dist, m.sa.w, m.ss.w, m.g, m.spread_scale, m.cam.focal_px,
                            (float)width);

    /* emission and ambient travel in `direct` unless an AOV wants them apart: one buffer
     * less to write here and to read in the composite */
    float keep = split_medium ? 0.0f : 1.0f;
    store4(direct, idx, at[0] + keep * med[0], at[1] + keep * med[1], at[2] + keep * med[2], alpha);
    if (sep) {
        /* Iser eq. 4.25: bright (luminance of L above sep_par.x, width .y) and near (D' = P
         * below .z, width .w) pixels get a chain of their own */
        float ms = smoothstep_(sep_par.x, sep_par.x + sep_par.y,
                               0.2126f * L[0] + 0.7152f * L[1] + 0.0722f * L[2])
                 * (1.0f - smoothstep_(sep_par.z - sep_par.w, sep_par.z, P));
        float l0 = ms * sc[0], l1 = ms * sc[1], l2 = ms * sc[2];
        sc[0] -= l0; sc[1] -= l1; sc[2] -= l2;
        store4(sep_chain0, idx, l0, l1, l2, sigma);
        store_prep(sep_prep0, idx, l0, l1, l2, sigma, thresh1, eps);
    }
    store4(scat0, idx, sc[0], sc[1], sc[2], sigma);
    spread0[idx] = sigma;
    if (split_medium) store4(medium_term, idx, med[0], med[1], med[2], P);
    if (want_transmittance) store4(transmittance, idx, tr[0], tr[1], tr[2], 1.0f);
    if (source) store_prep(prep0, idx, sc[0], sc[1], sc[2], sigma, thresh1, eps);
}
