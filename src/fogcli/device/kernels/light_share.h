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
 * the sky is what lies opposite). The numpy oracle is tools/oracles.py light_share_depth.
 *
 * Three passes: the least depth of each row's 2 SHARE_RADIUS + 1 pixels around a pixel
 * (rowmin), of the column of those, then the depth: only a pixel with a nearer one within
 * the radius (about 1 % of a frame) reads its neighbours' colours. The first two have an
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
    float near_y = 0.0f, near_z = z, far_y = INFINITY;
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
            int take = zn < z_near && (inner || (opp_in && i - di >= 0 && i - di < width)) && zm >= z_lo
                       && zm <= z_hi && yn > near_y;
            near_y = take ? yn : near_y;
            near_z = take ? zn : near_z;
            far_y = (zn >= z_lo && zn <= z_hi && yn < far_y) ? yn : far_y;
        }
    }
    /* a = (y - far_y) / (near_y - far_y), clamped to 1 (far_y <= y: the pixel is its own
     * surface's); moved iff a near_y > y / 2 */
    float span = near_y - far_y;
    float a = span > 0.0f ? (y - far_y) / span : 0.0f;
    a = a < 1.0f ? a : 1.0f;
    return (span > 0.0f && a * near_y > 0.5f * y) ? near_z : z;
}

/* the least of src over the 2 SHARE_RADIUS + 1 pixels `stride` apart centred on position
 * `at` of a line of n pixels starting at `base` (clamped to the line); inner (a constant):
 * all of them in the line, so the reads are linear in the work-item */
__attribute__((always_inline)) inline float least_around(__global const float *src, int base, int at, int n,
                                                         int stride, int inner)
{
    float zmin = src[base + at * stride];
    _Pragma("unroll") for (int d = -SHARE_RADIUS; d <= SHARE_RADIUS; ++d) {
        float zn = src[base + (inner ? at + d : clampi_(at + d, 0, n - 1)) * stride];
        zmin = zn < zmin ? zn : zmin;
    }
    return zmin;
}

/* each row's least depth around a pixel, into rowmin */
__kernel void light_share_rows(__global const float *depth, __global float *rowmin, const int width,
                               const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    rowmin[j * width + i] = least_around(depth, j * width, i, width, 1, 0);
}

__kernel void light_share_rows_inner(__global const float *depth, __global float *rowmin, const int width,
                                     const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    rowmin[j * width + i] = least_around(depth, j * width, i, width, 1, 1);
}

/* the column's least of rowmin: the least depth within the radius, into out */
__kernel void light_share_cols(__global const float *rowmin, __global float *out, const int width, const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    out[j * width + i] = least_around(rowmin, i, j, height, width, 0);
}

__kernel void light_share_cols_inner(__global const float *rowmin, __global float *out, const int width,
                                     const int height)
{
    int i = get_global_id(0), j = get_global_id(1);
    out[j * width + i] = least_around(rowmin, i, j, height, width, 1);
}

/* out: the least depth within the radius in, the depth each pixel takes out; eight pixels
 * (in memory order) a work-item: the 99 % with no nearer pixel within the radius are one
 * comparison of eight and a store (per pixel, the branch to share_depth kept the pass
 * scalar: 4.5 ms at 2 MPx) */
__kernel void light_share_pick(__global const float *depth, __global const float4 *image, __global float *out,
                               const int width, const int height)
{
    int g = get_global_id(0), n = width * height, idx0 = 8 * g;
    if (idx0 >= n) return;
    if (idx0 + 8 <= n) {
        float8 z = vload8(g, depth), m = vload8(g, out);
        if (!any(m < SHARE_NEARER * z)) { vstore8(z, g, out); return; }
    }
    for (int k = 0; k < 8 && idx0 + k < n; ++k) {
        int idx = idx0 + k, j = idx / width, i = idx - j * width;
        float z = depth[idx];
        if (!(out[idx] < SHARE_NEARER * z))
            out[idx] = z;
        else if (i >= SHARE_RADIUS && i < width - SHARE_RADIUS && j >= SHARE_RADIUS && j < height - SHARE_RADIUS)
            out[idx] = share_depth(depth, image, i, j, width, height, 1);
        else
            out[idx] = share_depth(depth, image, i, j, width, height, 0);
    }
}

#endif
