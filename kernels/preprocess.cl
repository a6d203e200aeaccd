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
    float3 L = image[idx].xyz;
    float3 sa = m.sa.xyz, ss = m.ss.xyz, st = sa + ss;

    float3 t_all = exp(-st * P);
    float3 l_at = t_all * L;
    /* exp(-sa P)(1 - exp(-ss P)) = exp(-sa P) - exp(-st P); the thesis form (SPEC 4.2). */
    float3 l_sc = (exp(-sa * P) - t_all) * L;

    float3 l_med = (float3)(0.0f);
    if (m.has_medium_light) {
        /* expm1 keeps 1 - exp(-st P) exact in thin media; st -> 0 limits: emission grows
         * as P, ambient vanishes */
        float3 one_minus = -expm1(-st * P);
        float3 safe_st = fmax(st, (float3)(1e-30f));
        float3 em_w = select(one_minus / safe_st, (float3)(P), st <= 0.0f);
        float3 amb_w = select(ss / safe_st * one_minus, (float3)(0.0f), st <= 0.0f);
        l_med = m.emission.xyz * em_w + m.ambient.xyz * amb_w;
    }

    float sigma = spread_px(P, dist, m.sa.w, m.ss.w, m.g, m.spread_scale, m.cam.focal_px,
                            (float)width);

    direct[idx] = (float4)(l_at, image[idx].w);
    if (sep) {
        /* Iser eq. 4.25: bright (luminance of L above sep_par.x, width .y) and near (D' = P
         * below .z, width .w) pixels get a chain of their own */
        float ms = smoothstep_(sep_par.x, sep_par.x + sep_par.y, luminance(L))
                 * (1.0f - smoothstep_(sep_par.z - sep_par.w, sep_par.z, P));
        float3 l_sep = ms * l_sc;
        l_sc -= l_sep;
        sep_chain0[idx] = (float4)(l_sep, sigma);
        sep_prep0[idx] = prep_px(l_sep, sigma, thresh1, eps);
    }
    scat0[idx] = (float4)(l_sc, sigma);
    spread0[idx] = sigma;
    medium_term[idx] = (float4)(l_med, P);
    if (want_transmittance) transmittance[idx] = (float4)(t_all, 1.0f);
    if (source) prep0[idx] = prep_px(l_sc, sigma, thresh1, eps);
}
