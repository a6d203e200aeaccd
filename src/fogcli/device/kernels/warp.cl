/* render.spread_space: angles (device/warp.py). A pinhole image is a plane of tangents: a
 * glow of the same angular size covers more pixels the farther it lies from the principal
 * point (1 / cos^2 along the radius), and two pixels' distance is not their angle. From level
 * WARP_LEVEL up, where the wide part of the glow lives, the source collapse runs on a plane
 * of angles instead (azimuthal equidistant; physics/apsf.py: plane_to_image). The level is
 * resampled into it (bilinear) after the reduce made it, and back after the collapse made
 * it. Where each pixel samples comes from the host (device/warp.py: maps, per camera and
 * size), index-space coordinates in the other plane's level: the kernels call no tan, sin
 * or atan (PoCL's are library calls, ~3 ms a frame at 2 MPx). The numpy oracle:
 * tools/oracles_warp.py. */
#include "common.h"

/* Level `off` (w x h) of the colour chain into the plane of angles, into `out` (the
 * scratch, from 0). to_image[i]: where plane pixel i lies on the image's level (x, y index
 * space), sin(rho) / rho there (what a plane pixel holds of the sphere: the sources' solid
 * angle), and 1 where it lies on the frame, 0 where not (the frame's corners and edges lie
 * inside the plane's rectangle: those pixels only receive light). The light bilinear, log P
 * weighted by the light's luminance as the reduce weights it. */
__kernel void warp_level(__global const float4 *chain, const int off, const int w, const int h,
                         __global float4 *out, __global const float4 *to_image)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    float4 m = to_image[y * w + x];
    float u = clampf_(m.x, 0.0f, (float)(w - 1)), v = clampf_(m.y, 0.0f, (float)(h - 1));
    int x0 = (int)u, y0 = (int)v;
    int x1 = mini_(x0 + 1, w - 1), y1 = mini_(y0 + 1, h - 1);
    float ax = u - (float)x0, ay = v - (float)y0;
    __global const float4 *c = chain + off;
    float4 t[4] = {c[y0 * w + x0], c[y0 * w + x1], c[y1 * w + x0], c[y1 * w + x1]};
    float wt[4] = {(1.0f - ax) * (1.0f - ay), ax * (1.0f - ay), (1.0f - ax) * ay, ax * ay};
    float3 col = (float3)(0.0f);
    float yw = 0.0f, ys = 0.0f, lw = 0.0f;
    for (int i = 0; i < 4; ++i) {
        col += wt[i] * t[i].xyz;
        float yl = wt[i] * light_weight(t[i].xyz);
        yw += yl * t[i].w;
        ys += yl;
        lw += wt[i] * t[i].w;
    }
    float lp = ys > 1e-30f ? yw / ys : lw;
    out[y * w + x] = (float4)(col * (m.z * m.w), lp);
}

/* The resampled level back into the chain, and its prep (the share each channel passes
 * on, from the table at its log P), as the reduce would have written them. */
__kernel void warp_store(__global float4 *chain, __global float4 *prep, const int off, const int w, const int h,
                         __global const float4 *src, __global const float *lut, const int level)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    float4 v = src[y * w + x];
    int d = off + y * w + x;
    chain[d] = v;
    store_prep_apsf(prep, d, v.x, v.y, v.z, v.w, lut, level);
}

/* render.halo_depth: receiver. Level `off` of the receivers' log P into the plane of
 * angles (bilinear, the edge's past the frame), into `out` from 0. */
__kernel void warp_receivers(__global const float *rd, const int off, const int w, const int h,
                             __global float *out, __global const float4 *to_image)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    float4 m = to_image[y * w + x];
    out[y * w + x] = bilinear1(rd + off, w, h, m.x, m.y);
}

/* Level `off` of the collapsed chain (the light each pixel of the level gets, in the plane
 * of angles) back to the image's plane, into `out` from 0: bilinear at to_plane[i] (where
 * image pixel i lies on the plane's level, index space), radiance needing no factor. */
__kernel void unwarp_level(__global const float4 *chain, const int off, const int w, const int h,
                           __global float4 *out, __global const float2 *to_plane)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    float2 q = to_plane[y * w + x];
    out[y * w + x] = bilinear4(chain + off, w, h, q.x, q.y);
}
