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
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float wx, wy, wz;
    float D = pixel_ray(&cam, i, j, depth[idx], &wx, &wy, &wz);
    float p = exponential_p(pre, b, wx * n.x + wy * n.y + wz * n.z, D);
    P[idx] = accumulate ? P[idx] + p : p;
}

__kernel void p_sphere(__global const float *depth, __global float *P,
                       const int width, const int height, const camera_t cam,
                       const float factor, const float radius, const float4 centre,
                       const int accumulate)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float wx, wy, wz;
    float D = pixel_ray(&cam, i, j, depth[idx], &wx, &wy, &wz);
    float p = sphere_p(factor, radius, cam.pos.x - centre.x, cam.pos.y - centre.y,
                       cam.pos.z - centre.z, wx, wy, wz, D);
    P[idx] = accumulate ? P[idx] + p : p;
}

/* the noise primitives: marched (noise.h), all of them in one launch */
__kernel void p_noise(__global const float *depth, __global float *P,
                      const int width, const int height, const camera_t cam,
                      __global const noise_t *nz, const int count, const int accumulate)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float wx, wy, wz;
    float D = pixel_ray(&cam, i, j, depth[idx], &wx, &wy, &wz);
    float p = noise_march(nz, count, cam.pos.xyz, (float3)(wx, wy, wz), D);
    P[idx] = accumulate ? P[idx] + p : p;
}
