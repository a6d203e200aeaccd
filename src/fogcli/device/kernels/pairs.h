/* Two horizontally adjacent pixels per work-item, for the part of a level away from its
 * edges: the source collapse (collapse_pairs, pyramid.cl) and its last step fused with the
 * final sum (composite_source_pairs, composite.cl); the host launches them there on whole
 * work-groups and the per-pixel kernels on the frame around it (device/plan.py: pair_region). Per
 * pixel, those read level k+1 at x >> 1 and the half image at clamped neighbours: gathers,
 * and float4 values, which keep PoCL from vectorising them (they ran scalar: ~35 ms at 2 MPx
 * for composite_source). Here the two pixels of a pair read level k+1 at the same UP_NT + 1
 * columns around i2 and the half image at x - 1 .. x + 2, none clamped, every channel a
 * scalar: the reads are linear in the work-item, and the kernels vectorise. Away from the
 * edges the apsf conservation factors are 1 (up2_cons). The sums are those of up2_fetch4,
 * half_blur and keep_px (common.h), regrouped (separable, shared between the two pixels):
 * equal to float32 rounding.
 * Addressing: the host passes the pair rectangle's first pair column px0 and row py0 as
 * arguments and launches with no global offset; every read and write is a row pointer made
 * of uniform values (the row, px0) indexed by K * i + c, i = get_global_id(0). LLVM sees
 * that form as strided and loads it with wide loads and shuffles; an index such as
 * 4 * (j * w + x), or a global offset, it turns into gathers and scatters, one per channel:
 * 548 of them kept composite_source_pairs at ~29 ms at 2 MPx (AVX-512). */
#ifndef FOGCLI_PAIRS_H
#define FOGCLI_PAIRS_H

#include "common.h"

#if INTERP == 0
#define UP_NT 2
__constant float UP_WE[2] = {0.25f, 0.75f};        /* even x: taps i2 - 1, i2 (up2_fetch4) */
__constant float UP_WO[2] = {0.75f, 0.25f};        /* odd x: taps i2, i2 + 1 */
#else
#define UP_NT 4
__constant float UP_WE[4] = {0.00260417f, 0.31510417f, 0.61197917f, 0.0703125f};
__constant float UP_WO[4] = {0.0703125f, 0.61197917f, 0.31510417f, 0.00260417f};
#endif

/* level k+1 (width w1) up-sampled at the two pixels of pair px0 + i of row j: e (even
 * x = 2 i2) and o (odd): columns i2 - UP_NT / 2 .. i2 + UP_NT / 2, the even pixel's taps the
 * first UP_NT, the odd one's the last UP_NT. `rows` holds level k+1 already up-sampled along
 * y to this level's rows (up_rows in pyramid.cl: three planes of n floats, row j at j w1),
 * so each tap is one unit-stride load per channel and only the horizontal sums are left
 * (the same sums in the same order as when the vertical ones were made here: 15 loads of a
 * pair where they took 60; composite_source_pairs ~1.5 ms less at 2 MPx). */
ALWAYS_INLINE void pair_up(__global const float *rows, int n, int w1, int px0, int i, int j, float *e0,
                           float *e1, float *e2, float *o0, float *o1, float *o2)
{
    __global const float *base = rows + j * w1 + px0 - UP_NT / 2 + i;
    float v0[UP_NT + 1], v1[UP_NT + 1], v2[UP_NT + 1];
#pragma unroll
    for (int t = 0; t <= UP_NT; ++t) {
        v0[t] = base[t]; v1[t] = base[t + n]; v2[t] = base[t + 2 * n];
    }
    float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, b0 = 0.0f, b1 = 0.0f, b2 = 0.0f;
#pragma unroll
    for (int t = 0; t < UP_NT; ++t) {
        a0 += UP_WE[t] * v0[t]; a1 += UP_WE[t] * v1[t]; a2 += UP_WE[t] * v2[t];
        b0 += UP_WO[t] * v0[t + 1]; b1 += UP_WO[t] * v1[t + 1]; b2 += UP_WO[t] * v2[t + 1];
    }
    *e0 = a0; *e1 = a1; *e2 = a2; *o0 = b0; *o1 = b1; *o2 = b2;
}

/* The 3x3 half blur of keep_px (half_blur, common.h) at both pixels of pair i of a row: the
 * columns' vertical sums first, shared by the two (x - 1 .. x + 2), then three of them for
 * each pixel. r0, r1, r2: the half image's rows j - 1, j, j + 1 from pixel 2 px0 (clamped by
 * the caller) -> channel c of the even pixel in he[c], the odd one's in ho[c]. */
ALWAYS_INLINE void pair_half(__global const float *r0, __global const float *r1, __global const float *r2, int i,
                             float a, float *he, float *ho)
{
    float b = 1.0f - 2.0f * a, prev = 0.0f;
#pragma unroll
    for (int c = 0; c < 3; ++c) {
        float v[4];
#pragma unroll
        for (int k = 0; k < 4; ++k) {
            int o = 8 * i + 4 * (k - 1) + c;
            v[k] = AFTER(a * r0[o] + b * r1[o] + a * r2[o], prev);   /* chained: see AFTER */
            prev = v[k];
        }
        he[c] = a * v[0] + b * v[1] + a * v[2];
        ho[c] = AFTER(a * v[1] + b * v[2] + a * v[3], he[c]);
        prev = ho[c];
    }
}

/* keep_px times wr (the receiver's weight, recv_weight) + u of pixel x = 2 (px0 + i) + p of
 * row j of a level (width w, height h), its half
 * blur hb (pair_half). The pointers start at pixel 2 px0 of the row: ch, pr of `chain` and
 * `prep`, r1 of the half image's row j, ex of the level's edge table along x (edge + 2 px0);
 * edge itself for the row's entries -> s */
ALWAYS_INLINE void pair_keep(__global const float *ch, __global const float *pr, int i, int p, int j,
                             int w, int h, __global const float *r1, const float *hb,
                             __global const float *edge, __global const float *ex, float u0, float u1, float u2,
                             float wr, float *s0_, float *s1_, float *s2_)
{
    const int x4 = 8 * i + 4 * p;     /* this pixel's first float in each row */
    float h0 = hb[0], h1 = hb[1], h2 = hb[2];
    float v0, v1, v2, vw, p0, p1, p2, pw;
    v0 = ch[x4]; v1 = ch[x4 + 1]; v2 = ch[x4 + 2]; vw = ch[x4 + 3];
    p0 = pr[x4]; p1 = pr[x4 + 1]; p2 = pr[x4 + 2]; pw = pr[x4 + 3];
    float c0 = r1[x4], c1 = r1[x4 + 1], c2 = r1[x4 + 2], cw = r1[x4 + 3];
#ifdef PSF_APSF
#ifdef BORDER_OPEN
    float es = ex[2 * i + p] * edge[w + j], eh = ex[w + h + 2 * i + p] * edge[2 * w + h + j];
    float s0 = h0 + (v0 - p0 - c0 / eh) * es;
    float s1 = AFTER(h1 + (v1 - p1 - c1 / eh) * es, s0);
    float s2 = AFTER(h2 + (v2 - p2 - c2 / eh) * es, s1);
#else
    float s0 = h0 + v0 - p0 - c0;
    float s1 = AFTER(h1 + v1 - p1 - c1, s0);
    float s2 = AFTER(h2 + v2 - p2 - c2, s1);
#endif
#else
    float s0 = h0 + (1.0f - cw) * v0;
    float s1 = AFTER(h1 + (1.0f - cw) * v1, s0);
    float s2 = AFTER(h2 + (1.0f - cw) * v2, s1);
#endif
    s0 = s0 * wr + u0;
    *s0_ = s0;
    *s1_ = AFTER(s1 * wr + u1, s0);
    *s2_ = AFTER(s2 * wr + u2, *s1_);
}

/* the half image's rows around row j of a level of width w, height h, from pixel x0 */
#define PAIR_ROWS(half_img, j, w, h, x0)                                                        \
    __global const float *hb_ = (__global const float *)(half_img) + 4 * (x0);                   \
    __global const float *r0 = hb_ + 4 * ((j) > 0 ? (j) - 1 : 0) * (w);                          \
    __global const float *r1 = hb_ + 4 * (j) * (w);                                              \
    __global const float *r2 = hb_ + 4 * ((j) + 1 < (h) ? (j) + 1 : (h) - 1) * (w);

#endif
