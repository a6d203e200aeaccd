/* Stage 0 (heterogeneous media only): the optical depth of every non-homogeneous density
 * primitive, one launch per primitive, summed into `P`. Homogeneous terms are one factor
 * times D and stay in the preprocess kernel. Kept apart from preprocess because there the
 * same arithmetic stopped PoCL from vectorising the whole kernel (+38 ms at 2 MPx for one
 * exponential); here each kernel vectorises and costs about 1-2 ms. */
#include "density.h"
#include "noise.h"

__kernel void p_exponential(__global const float *depth, __global float *P,
                            const int width, const int height, const camera_t cam,
                            const float pre, const float b, const float4 n, const int accumulate)
{
    PIXEL_RAY
    float p = exponential_p(pre, b, wx * n.x + wy * n.y + wz * n.z, D);
    P[idx] = accumulate ? P[idx] + p : p;
}

__kernel void p_sphere(__global const float *depth, __global float *P,
                       const int width, const int height, const camera_t cam,
                       const float factor, const float radius, const float4 centre,
                       const int accumulate)
{
    PIXEL_RAY
    float p = sphere_p(factor, radius, cam.pos.x - centre.x, cam.pos.y - centre.y,
                       cam.pos.z - centre.z, wx, wy, wz, D);
    P[idx] = accumulate ? P[idx] + p : p;
}

/* The noise primitives' optical depth, marched (noise.h), all of them in one launch: at
 * every `stride`-th pixel of every `stride`-th row (and the last ones) into S ... */
__kernel void p_noise_samples(__global const float *depth, __global float *S,
                              const int width, const int height, const camera_t cam,
                              __global const noise_t *nz, const int count, const int stride, const int cw,
                              const int ch)
{
    SAMPLE_RAY
    S[cj * cw + ci] = noise_march(nz, count, cam.pos.xyz, (float3)(wx, wy, wz), D);
}

/* ... then every pixel from the four samples around it (bilinear) where they lie on its
 * surface (noise.h: grid_neighbours) and agree with it on meeting the noise (a sample's
 * optical depth > 0), else marched itself (stride 1: every pixel). tfm.cl's airlight_fill
 * makes the same choice. */
__kernel void p_noise(__global const float *depth, __global float *P,
                      const int width, const int height, const camera_t cam,
                      __global const noise_t *nz, const int count, __global const float *S, const int stride,
                      const int cw, const int ch, const int accumulate)
{
    PIXEL_RAY
    float3 w = (float3)(wx, wy, wz);
    float p = 0.0f;
    int ok = stride > 1;
    if (ok) {
        grid4_t g = grid_neighbours(depth, width, height, cam.max_depth, i, j, stride, cw, ch);
        int hit = noise_meets(nz, count, cam.pos.xyz, w, D);
        for (int k = 0; k < 4; ++k) {
            float ps = S[g.smp[k]];
            ok = ok && ((ps > 0.0f) == hit || g.wt[k] == 0.0f);
            p += g.wt[k] * ps;
        }
        ok = ok && g.same_surface;
    }
    if (!ok) p = noise_march(nz, count, cam.pos.xyz, w, D);
    P[idx] = accumulate ? P[idx] + p : p;
}
