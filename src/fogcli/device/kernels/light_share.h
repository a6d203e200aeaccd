/* The kernels of light_share_depth. Included by preprocess.cl only. */
#ifndef LIGHT_SHARE_H
#define LIGHT_SHARE_H

/* A depth map holds one surface per pixel (a renderer's centre sample, a sensor's), the
 * colour the light of every surface the pixel covers: the anti-aliased rim of a lamp in
 * front of a dark wall has the wall's depth and mostly the lamp's light, which the point
 * spread then blurs and dims as the wall's (path-traced lamp scenes: lamps-haze 0.092 ->
 * 0.068 relative L1 with this). A pixel within `radius` of a nearer surface reads its colour
 * as a mix a c_near + (1 - a) c_far of luminances: c_near the brightest nearer pixel around
 * it, c_far the darkest of its own surface's (depth within SHARE_SAME of its own, the pixel
 * itself included); where the nearer surface's part a c_near is more than half of its
 * light, it takes that surface's depth. Only a nearer surface brighter than the own one
 * moves a pixel: the light of a dark one is not where the scattering comes from. A pixel n
 * is a nearer surface if its depth is below SHARE_NEARER of the own and the pixel opposite it
 * (as far the other way) is on the own surface: the pixel is at a step, not on a slope (a
 * ground to the horizon halves its depth within a few rows, evenly, and by its horizon
 * the sky is what lies opposite).
 *
 * The same the other way: a pixel next to (SHARE_FAR_RADIUS) a farther, brighter surface
 * whose light is mostly that surface's takes its depth, when its luminance lies within the
 * mix (at most the farther surface's brightest) and at least SHARE_FAR_COVER of it is the
 * farther surface. A half-covered pixel of a bright sky that carries a building's depth (a
 * sensor's depth, or one upsampled by nearest neighbour: edges a pixel off) sent the sky's
 * light out from the building: skyline-sea 0.091 -> 0.074 relative L1 to path tracing, and
 * 0.025 -> 0.013 from its smooth depth's output with the depth 2 x 2 replicated. The radius
 * and the cover keep a facade's texture beside the sky where it is (tools/light_share_effect.py).
 * Where both sides would take a pixel, the one with the larger part of its light does. The
 * numpy oracle is tools/oracles.py light_share_depth.
 *
 * Three passes: the least and the largest depth of each row's 2 SHARE_RADIUS + 1 pixels
 * around a pixel (rowext), of the column of those, then the depth: only a pixel with a
 * nearer or farther one within the radius (a few % of a frame) reads its neighbours'
 * colours. The first two have an
 * _inner kernel for whole work-groups away from the frame's edges (Plan.launch_inner):
 * unclamped reads, linear in the work-item. The three numbers are built in
 * (plan.LIGHT_SHARE) and the loops unrolled: with the radius an argument, or the loop
 * left rolled, PoCL did not vectorise across work-items (a pass 3.7 ms at 2 MPx, 0.4
 * unrolled). */

/* the depth a pixel takes (above); inner (a constant): its neighbours within the radius
 * are in the frame */
__attribute__((always_inline)) inline float share_depth(__global const float *depth, __global const float4 *image,
                                                        int i, int j, int width, int height, int inner)
{
    int idx = j * width + i;
    float z = depth[idx];
    float4 c = image[idx];
    float y = luminance((float3)(c.x, c.y, c.z));
    float near_y = 0.0f, near_z = z, far_y = INFINITY, back_y = 0.0f, back_z = z;
    float z_near = SHARE_NEARER * z, z_lo = (1.0f - SHARE_SAME) * z, z_hi = (1.0f + SHARE_SAME) * z;
    /* clamped reads at the frame's edge repeat an edge pixel: no change to a strict maximum
     * or to a minimum; an opposite pixel past the edge is none (clamped, it was the pixel
     * itself, and a plane steep at the frame's edge a step) */
    _Pragma("unroll") for (int dj = -SHARE_RADIUS; dj <= SHARE_RADIUS; ++dj) {
        int row = (inner ? j + dj : clampi_(j + dj, 0, height - 1)) * width;
        int opp = (inner ? j - dj : clampi_(j - dj, 0, height - 1)) * width;
        int opp_in = inner || (j - dj >= 0 && j - dj < height);
        _Pragma("unroll") for (int di = -SHARE_RADIUS; di <= SHARE_RADIUS; ++di) {
            int k = row + (inner ? i + di : clampi_(i + di, 0, width - 1));
            float zn = depth[k], zm = depth[opp + (inner ? i - di : clampi_(i - di, 0, width - 1))];
            float4 q = image[k];
            float yn = luminance((float3)(q.x, q.y, q.z));
            int across = (inner || (opp_in && i - di >= 0 && i - di < width)) && zm >= z_lo && zm <= z_hi;
            int take = zn < z_near && across && yn > near_y;
            near_y = take ? yn : near_y;
            near_z = take ? zn : near_z;
            int back = abs(di) <= SHARE_FAR_RADIUS && abs(dj) <= SHARE_FAR_RADIUS && SHARE_NEARER * zn > z
                       && across && yn > back_y;
            back_y = back ? yn : back_y;
            back_z = back ? zn : back_z;
            far_y = (zn >= z_lo && zn <= z_hi && yn < far_y) ? yn : far_y;
        }
    }
    /* a = (y - far_y) / (near_y - far_y), clamped to 1 (far_y <= y: the pixel is its own
     * surface's): the nearer surface's part of the light is a near_y; the farther's b back_y
     * likewise, unclamped (a pixel brighter than the farther surface is none of its mix) */
    float span = near_y - far_y, span_b = back_y - far_y;
    float a = span > 0.0f ? (y - far_y) / span : 0.0f;
    a = a < 1.0f ? a : 1.0f;
    float b = span_b > 0.0f ? (y - far_y) / span_b : 0.0f;
    float part = span > 0.0f ? a * near_y : 0.0f;
    float part_b = (span_b > 0.0f && y <= back_y && b >= SHARE_FAR_COVER) ? b * back_y : 0.0f;
    return (part >= part_b ? part : part_b) > 0.5f * y ? (part >= part_b ? near_z : back_z) : z;
}

/* the least and the largest of src (one_in: src holds depths, else (least, largest) pairs)
 * over the 2 SHARE_RADIUS + 1 pixels `stride` apart centred on position `at` of a line of n
 * pixels starting at `base` (clamped to the line), written as the pair `to` of dst; inner (a
 * constant): all of them in the line, so the reads are linear in the work-item. Two scalar
 * stores, not a float2 literal: Oclgrind's uninitialised-value check takes a literal's
 * store for an undefined one (docs/devices.md) */
__attribute__((always_inline)) inline void extent_around(__global const float *src, __global float *dst, int to,
                                                         int base, int at, int n, int stride, int inner, int one_in)
{
    int c = base + at * stride;
    float lo = src[one_in ? c : 2 * c], hi = src[one_in ? c : 2 * c + 1];
    _Pragma("unroll") for (int d = -SHARE_RADIUS; d <= SHARE_RADIUS; ++d) {
        int k = base + (inner ? at + d : clampi_(at + d, 0, n - 1)) * stride;
        float zl = src[one_in ? k : 2 * k], zh = src[one_in ? k : 2 * k + 1];
        lo = zl < lo ? zl : lo;
        hi = zh > hi ? zh : hi;
    }
    dst[2 * to] = lo;
    dst[2 * to + 1] = hi;
}

/* each row's least and largest depth around a pixel, into rowext (pairs) */
__kernel void light_share_rows(__global const float *depth, __global float *rowext, const int width,
                               const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    extent_around(depth, rowext, j * width + i, j * width, i, width, 1, 0, 1);
}

__kernel void light_share_rows_inner(__global const float *depth, __global float *rowext, const int width,
                                     const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    extent_around(depth, rowext, j * width + i, j * width, i, width, 1, 1, 1);
}

/* the column's extent of rowext: the least and largest depth within the radius, into ext */
__kernel void light_share_cols(__global const float *rowext, __global float *ext, const int width,
                               const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    extent_around(rowext, ext, j * width + i, i, j, height, width, 0, 0);
}

__kernel void light_share_cols_inner(__global const float *rowext, __global float *ext, const int width,
                                     const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    extent_around(rowext, ext, j * width + i, i, j, height, width, 1, 0);
}

/* ext: the least and largest depth within the radius, in pairs; out: the depth each pixel
 * takes; eight pixels (in memory order) a work-item: the pixels with no nearer and no
 * farther pixel within the radius (about 97 %) are one comparison of eight and a store (per
 * pixel, the branch to share_depth kept the pass scalar: 4.5 ms at 2 MPx) */
__kernel void light_share_pick(__global const float *depth, __global const float4 *image,
                               __global const float *ext, __global float *out, const int width, const int height)
{
    int g = get_global_id(0), n = width * height, idx0 = 8 * g;
    if (idx0 >= n) return;
    if (idx0 + 8 <= n) {
        /* two float8 loads, not a float16 (its return changes the ABI without AVX-512: PoCL
         * warns on stderr) */
        float8 z = vload8(g, depth), e0 = vload8(2 * g, ext), e1 = vload8(2 * g + 1, ext);
        float8 lo = (float8)(e0.even, e1.even), hi = (float8)(e0.odd, e1.odd);
        if (!any(lo < SHARE_NEARER * z) && !any(SHARE_NEARER * hi > z)) { vstore8(z, g, out); return; }
    }
    for (int k = 0; k < 8 && idx0 + k < n; ++k) {
        int idx = idx0 + k, j = idx / width, i = idx - j * width;
        float z = depth[idx];
        if (!(ext[2 * idx] < SHARE_NEARER * z) && !(SHARE_NEARER * ext[2 * idx + 1] > z))
            out[idx] = z;
        else if (i >= SHARE_RADIUS && i < width - SHARE_RADIUS && j >= SHARE_RADIUS && j < height - SHARE_RADIUS)
            out[idx] = share_depth(depth, image, i, j, width, height, 1);
        else
            out[idx] = share_depth(depth, image, i, j, width, height, 0);
    }
}

#endif
