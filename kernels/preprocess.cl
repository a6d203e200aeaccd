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
    float4 cam_pos;     /* camera position, world */
    float4 rot0, rot1, rot2;   /* rows of R = Ry(yaw) Rx(pitch) Rz(roll) (SPEC 4.1) */
    float g;            /* phase asymmetry */
    float depth_scale;
    float max_depth;
    float focal_px;
    float spread_scale;
    int depth_is_z;
    int has_medium_light;   /* emission or ambient non-zero */
    int n_density;
} medium_t;

__kernel void preprocess(__global const float4 *image, __global const float *depth,
                         __global float4 *direct, __global float4 *scat0,
                         __global float *spread0, __global float4 *medium_term,
                         __global float4 *transmittance, const int want_transmittance,
                         const int width, const int height, const medium_t m,
                         __constant const density_t *dens,
                         __global float4 *prep0, const int source, const float thresh1,
                         const float eps, __global float4 *sep_chain0, __global float4 *sep_prep0,
                         const int sep, const float4 sep_par)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;

    /* camera-space ray of the pixel centre (SPEC 4.1), its length for z-depth */
    float3 dc = (float3)((i + 0.5f - 0.5f * width) / m.focal_px,
                         -(j + 0.5f - 0.5f * height) / m.focal_px, -1.0f);
    float dlen = length(dc);
    float raw = depth[idx] * m.depth_scale;
    float dist = m.depth_is_z ? raw * dlen : raw;
    /* +inf (sky) and anything beyond max_depth is clamped there; comparisons with inf
     * are well defined, so fmin does the job. */
    dist = fmin(dist, m.max_depth);

    float3 wc = dc / dlen;
    float3 w = (float3)(dot(m.rot0.xyz, wc), dot(m.rot1.xyz, wc), dot(m.rot2.xyz, wc));
    float P = optical_depth(dens, m.n_density, m.cam_pos.xyz, w, dist);
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

    float sigma = spread_px(P, dist, m.sa.w, m.ss.w, m.g, m.spread_scale, m.focal_px,
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
