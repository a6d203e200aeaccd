/* pyramid.cl's reduce_source_inner for apsf on float8, eight destination pixels of a row a
 * work-item, for CPUs whose vectoriser leaves that kernel scalar (lanes.h: AVX2 without
 * AVX-512, where LLVM judges its strided RGBA reads and table reads not worth vectorising:
 * ~10 ms at level 1 of 2 MPx). Lane l of work-item i is destination pixel px0 + 8 i + l
 * of row py0 + j, whose taps start at source pixel 2 (px0 + 8 i + l) - FILTER_TAPS / 2 + 1:
 * channel c of tap tx is float 8 l + 4 tx + c from the work-item's first, so the rows are
 * read as contiguous float8 chunks and transposed (transpose8) instead of gathered. Each
 * lane sums its taps in reduce_source_inner's order, so the two agree to rounding.
 * Launched (device/pyramid.py) on a region whose width is a multiple of 8, below the top
 * level, with a bounds check on the work-items (n8 x ny). */
#include "common.h"
#include "lanes.h"

#define SHUF(a, b, ...) __builtin_shufflevector((a), (b), __VA_ARGS__)
/* eight floats at any float's alignment: one vector load (lane_load8's literal of eight
 * loads is the same code for PoCL, but Oclgrind's uninitialised-value check takes a
 * literal's lanes for undefined) */
typedef float float8_u __attribute__((ext_vector_type(8), aligned(4)));

/* the 8 x 8 transpose of rows r[0..7] into c[0..7] (c[o].s_l = r[l].s_o): unpack, shuffle
 * within 128-bit halves, swap halves, as the AVX idiom */
ALWAYS_INLINE void transpose8(const float8 *r, float8 *c)
{
    float8 t0 = SHUF(r[0], r[1], 0, 8, 1, 9, 4, 12, 5, 13), t1 = SHUF(r[0], r[1], 2, 10, 3, 11, 6, 14, 7, 15);
    float8 t2 = SHUF(r[2], r[3], 0, 8, 1, 9, 4, 12, 5, 13), t3 = SHUF(r[2], r[3], 2, 10, 3, 11, 6, 14, 7, 15);
    float8 t4 = SHUF(r[4], r[5], 0, 8, 1, 9, 4, 12, 5, 13), t5 = SHUF(r[4], r[5], 2, 10, 3, 11, 6, 14, 7, 15);
    float8 t6 = SHUF(r[6], r[7], 0, 8, 1, 9, 4, 12, 5, 13), t7 = SHUF(r[6], r[7], 2, 10, 3, 11, 6, 14, 7, 15);
    float8 u0 = SHUF(t0, t2, 0, 1, 8, 9, 4, 5, 12, 13), u1 = SHUF(t0, t2, 2, 3, 10, 11, 6, 7, 14, 15);
    float8 u2 = SHUF(t1, t3, 0, 1, 8, 9, 4, 5, 12, 13), u3 = SHUF(t1, t3, 2, 3, 10, 11, 6, 7, 14, 15);
    float8 u4 = SHUF(t4, t6, 0, 1, 8, 9, 4, 5, 12, 13), u5 = SHUF(t4, t6, 2, 3, 10, 11, 6, 7, 14, 15);
    float8 u6 = SHUF(t5, t7, 0, 1, 8, 9, 4, 5, 12, 13), u7 = SHUF(t5, t7, 2, 3, 10, 11, 6, 7, 14, 15);
    c[0] = SHUF(u0, u4, 0, 1, 2, 3, 8, 9, 10, 11); c[4] = SHUF(u0, u4, 4, 5, 6, 7, 12, 13, 14, 15);
    c[1] = SHUF(u1, u5, 0, 1, 2, 3, 8, 9, 10, 11); c[5] = SHUF(u1, u5, 4, 5, 6, 7, 12, 13, 14, 15);
    c[2] = SHUF(u2, u6, 0, 1, 2, 3, 8, 9, 10, 11); c[6] = SHUF(u2, u6, 4, 5, 6, 7, 12, 13, 14, 15);
    c[3] = SHUF(u3, u7, 0, 1, 2, 3, 8, 9, 10, 11); c[7] = SHUF(u3, u7, 4, 5, 6, 7, 12, 13, 14, 15);
}

/* four planes of eight pixels back to 32 interleaved floats at p */
ALWAYS_INLINE void store_rgba8(__global float *p, float8 a, float8 b, float8 c, float8 d)
{
    float8 u0 = SHUF(a, b, 0, 8, 1, 9, 4, 12, 5, 13), u1 = SHUF(a, b, 2, 10, 3, 11, 6, 14, 7, 15);
    float8 u2 = SHUF(c, d, 0, 8, 1, 9, 4, 12, 5, 13), u3 = SHUF(c, d, 2, 10, 3, 11, 6, 14, 7, 15);
    float8 w[4] = {SHUF(u0, u2, 0, 1, 8, 9, 2, 3, 10, 11), SHUF(u1, u3, 0, 1, 8, 9, 2, 3, 10, 11),
                   SHUF(u0, u2, 4, 5, 12, 13, 6, 7, 14, 15), SHUF(u1, u3, 4, 5, 12, 13, 6, 7, 14, 15)};
#pragma unroll
    for (int k = 0; k < 4; ++k) {
        __global float *q = p + 8 * k;
        q[0] = w[k].s0; q[1] = w[k].s1; q[2] = w[k].s2; q[3] = w[k].s3;
        q[4] = w[k].s4; q[5] = w[k].s5; q[6] = w[k].s6; q[7] = w[k].s7;
    }
}

/* chunks of 8 floats a tap row needs: lane 7's last tap ends at float 56 + 4 FILTER_TAPS */
#define RL_CHUNKS (8 + (4 * FILTER_TAPS - 1) / 8)
#define RL_SETS ((4 * FILTER_TAPS + 7) / 8)

__kernel void reduce_source_lanes(__global float4 *chain, __global float4 *prep, const int src_off, const int sw,
                                  const int dst_off, const int dw, __global const float *lut, const int level,
                                  const int px0, const int py0, const int n8, const int ny)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= n8 || j >= ny) return;
    int y = j + py0, px = px0 + 8 * i;
    int x0 = 2 * px - FILTER_TAPS / 2 + 1, y0 = 2 * y - FILTER_TAPS / 2 + 1;
    __global const float *src = (__global const float *)(prep + src_off) + 4 * x0;
    float8 a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, ayw = 0.0f, ay = 0.0f, alw = 0.0f;
#pragma unroll
    for (int ty = 0; ty < FILTER_TAPS; ++ty) {
        __global const float *row = src + 4 * (y0 + ty) * sw;
        float8 v[RL_CHUNKS], c[8 * RL_SETS];
#pragma unroll
        for (int k = 0; k < RL_CHUNKS; ++k)
            v[k] = *(__global const float8_u *)(row + 8 * k);
#pragma unroll
        for (int s = 0; s < RL_SETS; ++s)
            transpose8(v + s, c + 8 * s);
#pragma unroll
        for (int tx = 0; tx < FILTER_TAPS; ++tx) {
            float8 p0 = c[4 * tx], p1 = c[4 * tx + 1], p2 = c[4 * tx + 2], pw = c[4 * tx + 3];
            float wg = filter_w[tx] * filter_w[ty];
            a0 += wg * p0;
            a1 += wg * p1;
            a2 += wg * p2;
            float8 yl = LUMA_R * LANE_ABS(p0) + LUMA_G * LANE_ABS(p1) + LUMA_B * LANE_ABS(p2);   /* light_weight */
            ayw += yl * pw;
            ay += yl;
            alw += pw;
        }
    }
    float8 lw = ay > 1e-30f ? ayw / ay : alw * (1.0f / (float)(FILTER_TAPS * FILTER_TAPS));
    /* lut_pos and lut_get lane by lane */
    float8 u = LUT_U(lut, lw);
    u = u < 0.0f ? (float8)(0.0f) : u;
    u = u > LUT_U_MAX ? (float8)(LUT_U_MAX) : u;
    int8 li = LANE_INT(u);
    float8 f = u - LANE_FLOAT(li);
    __global const float *t0 = lut + lut_updown(level, 0, 0), *t1 = lut + lut_updown(level, 1, 0),
                         *t2 = lut + lut_updown(level, 2, 0);
    float8 g0 = GATHER8(t0, li), g1 = GATHER8(t1, li), g2 = GATHER8(t2, li);
    float8 q0 = (g0 + (GATHER8(t0, li + 1) - g0) * f) * a0;
    float8 q1 = (g1 + (GATHER8(t1, li + 1) - g1) * f) * a1;
    float8 q2 = (g2 + (GATHER8(t2, li + 1) - g2) * f) * a2;
    int d4 = 4 * (dst_off + y * dw + px);
    store_rgba8((__global float *)prep + d4, q0, q1, q2, lw);
    store_rgba8((__global float *)chain + d4, a0, a1, a2, lw);
}
