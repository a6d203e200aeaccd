/* Stage 3: depth-blurred level selection and the final sum (Elek eq. 10-12, Iser 4.4.3,
 * 4.4.5). Level geometry comes from the plan: lv[k] = (offset, width, height, 0). */
#include "common.h"
#include "pairs.h"

/* level_fetch: one integer level, 2D interpolated at the level-0 pixel centre p0;
 * chain_linear: linear across the two levels around `level` (clamped to kmax). */
#define DEFINE_LEVEL_FETCH(T, S)                                                             \
inline T level_fetch##S(__global const T *chain, __global const int4 *lv, int k, float2 p0)  \
{                                                                                            \
    int4 l = lv[k];                                                                          \
    float2 q = level_coord(p0, k);                                                           \
    return fetch##S(chain + l.x, l.y, l.z, q.x, q.y);                                        \
}                                                                                            \
inline T chain_linear##S(__global const T *chain, __global const int4 *lv, int kmax,          \
                         float level, float2 p0)                                             \
{                                                                                            \
    int k = (int)level;                                      /* level >= 0: the floor */     \
    float f = level - k;                                                                     \
    T a = level_fetch##S(chain, lv, k < kmax ? k : kmax, p0);                                \
    if (f <= 0.0f || k >= kmax) return a;                                                    \
    return a + (level_fetch##S(chain, lv, k + 1, p0) - a) * f;                               \
}

DEFINE_LEVEL_FETCH(float4, 4)
DEFINE_LEVEL_FETCH(float, 1)

/* The colour across levels: linear (INTERP 0, 1) or Catmull-Rom over four (INTERP 2). */
inline float4 chain_fetch4(__global const float4 *chain, __global const int4 *lv, int kmax,
                           float level, float2 p0)
{
#if INTERP == 2
    int k = (int)floor(level);
    float f = level - k, f2 = f * f, f3 = f2 * f;
    float w0 = 0.5f * (-f3 + 2.0f * f2 - f), w1 = 0.5f * (3.0f * f3 - 5.0f * f2 + 2.0f);
    float w2 = 0.5f * (-3.0f * f3 + 4.0f * f2 + f), w3 = 0.5f * (f3 - f2);
    float4 r = w0 * level_fetch4(chain, lv, clamp(k - 1, 0, kmax), p0)
             + w1 * level_fetch4(chain, lv, clamp(k, 0, kmax), p0)
             + w2 * level_fetch4(chain, lv, clamp(k + 1, 0, kmax), p0)
             + w3 * level_fetch4(chain, lv, clamp(k + 2, 0, kmax), p0);
    return fmax(r, (float4)(0.0f));   /* Catmull-Rom overshoots; radiance cannot */
#else
    return chain_linear4(chain, lv, kmax, level, p0);
#endif
}

__kernel void composite(__global const float4 *direct, __global const float4 *medium_term,
                        __global const float4 *chain, __global const float *spread_chain,
                        __global const int4 *lv, const int kmax,
                        const float c, const int depth_blur, const int add_medium,
                        __global float4 *out, const int want_aov,
                        __global float *level_aov, __global float4 *scattered_aov)
{
    int i = get_global_id(0), j = get_global_id(1);
    int width = lv[0].y, height = lv[0].z;
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float2 p0 = (float2)(i + 0.5f, j + 0.5f);

    float level = level_of(spread_chain[idx], c, (float)kmax);
    if (depth_blur) {
        /* Eq. 11: read the spread blurred as much as this pixel's own blur, then map the
         * blurred spread to the level, so level changes at depth edges are gradual. */
        float s1 = chain_linear1(spread_chain, lv, kmax, level, p0);
        level = level_of(s1, c, (float)kmax);
    }
    float4 sc = chain_fetch4(chain, lv, kmax, level, p0);
    store_out(out, direct, medium_term, add_medium, idx, sc.xyz);
    if (want_aov) {
        level_aov[idx] = level;
        scattered_aov[idx] = (float4)(sc.xyz, 0.0f);
    }
}

/* `fetch: source`: the last collapse step (level 0) fused with the final sum. With pixel
 * separation it runs again for the separated chain built with COMP_ACCUMULATE, adding its
 * light to the output (and to the scattered AOV). What it writes is fixed at build time
 * (COMP_AOV, COMP_SPLIT_MEDIUM; left out, 0), as in preprocess: a store under a run-time
 * flag is masked, which PoCL vectorises for AVX-512 only. */
#ifndef COMP_ACCUMULATE
#define COMP_ACCUMULATE 0
#endif
#ifndef COMP_AOV
#define COMP_AOV 0
#endif
#ifndef COMP_SPLIT_MEDIUM
#define COMP_SPLIT_MEDIUM 0
#endif
/* the arguments of composite_source and composite_source_pairs (launched alike) */
#define COMP_SOURCE_ARGS                                                                          \
    __global const float4 *direct, __global const float4 *medium_term, __global const float4 *chain, \
    __global const float4 *half_img, __global const int4 *restrict lv, const int kmax, const float c, \
    const float a, __global float4 *out, __global float *level_aov, __global float4 *scattered_aov, \
    __global const float4 *prep, __global const float *spread0, __global const float *edge,      \
    __global const float *cons, const int cons_up
/* What composite_source and composite_source_pairs (pairs.h) write of pixel q's kept and
 * up-sampled light s: store_out and the AOVs, or (COMP_ACCUMULATE) s added; in scalars, which
 * the pair kernel needs to vectorise. The pointers start where q counts from (the buffers
 * themselves, or a pair row's first pixel: pairs.h, Addressing). */
ALWAYS_INLINE void comp_store(int q, float s0, float s1, float s2, __global const float *direct,
                              __global const float *medium_term, __global float *out,
                              __global float *level_aov, __global float *scattered_aov,
                              __global const float *spread0, float c, int kmax)
{
    const int q4 = 4 * q;
#if COMP_ACCUMULATE
    out[q4] += s0; out[q4 + 1] += s1; out[q4 + 2] += s2; out[q4 + 3] += 0.0f;
#if COMP_AOV
    scattered_aov[q4] += s0; scattered_aov[q4 + 1] += s1; scattered_aov[q4 + 2] += s2;
    scattered_aov[q4 + 3] += 0.0f;
#endif
#else
    float d0 = direct[q4], d1 = direct[q4 + 1], d2 = direct[q4 + 2], dw = direct[q4 + 3];
#if COMP_SPLIT_MEDIUM
    d0 += medium_term[q4];
    d1 += medium_term[q4 + 1];
    d2 += medium_term[q4 + 2];
#endif
    out[q4] = d0 + s0; out[q4 + 1] = d1 + s1; out[q4 + 2] = d2 + s2; out[q4 + 3] = dw;
#if COMP_AOV
    /* the level of this pixel's Gaussian spread (with apsf its light lands on several
     * levels around it) */
    level_aov[q] = level_of(spread0[q], c, (float)kmax);
    scattered_aov[q4] = s0; scattered_aov[q4 + 1] = s1; scattered_aov[q4 + 2] = s2; scattered_aov[q4 + 3] = 0.0f;
#endif
#endif
}

__kernel void composite_source(COMP_SOURCE_ARGS)
{
    int i = get_global_id(0), j = get_global_id(1);
    int width = lv[0].y, height = lv[0].z;
    if (OUTSIDE(i, j, width, height)) return;
    int idx = j * width + i;
    float4 v = chain[idx];
    float3 sc = v.xyz;
    if (kmax > 0)
    {
#ifdef PSF_APSF
        float4 up = UP2_APSF(chain + lv[1].x, lv[1].y, lv[1].z, i, j, cons, cons_up, width, height);
#else
        float4 up = up2_fetch4(chain + lv[1].x, lv[1].y, lv[1].z, i, j);
#endif
        sc = keep_px(v.xyz, prep[idx].xyz, half_img, width, height, i, j, a, edge, 0) + up.xyz;
    }
    comp_store(idx, sc.x, sc.y, sc.z, (__global const float *)direct, (__global const float *)medium_term,
               (__global float *)out, level_aov, (__global float *)scattered_aov, spread0, c, kmax);
}

/* pairs px0 + i of row py0 + j (pairs.h, Addressing; launched with no global offset);
 * up_planes: level 1 up-sampled along y to level 0's rows (up_rows, pyramid.cl) */
__kernel void composite_source_pairs(COMP_SOURCE_ARGS, __global const float *up_planes, const int px0,
                                     const int py0)
{
    int i = get_global_id(0), j = get_global_id(1) + py0;
    int width = lv[0].y, height = lv[0].z;
    int p1 = j * width + 2 * px0, r4 = 4 * p1;   /* the row's first pixel */
    __global const float *ch = (__global const float *)chain + r4, *pr = (__global const float *)prep + r4;
    __global const float *dr = (__global const float *)direct + r4, *mr = (__global const float *)medium_term + r4;
    __global float *orow = (__global float *)out + r4, *srow = (__global float *)scattered_aov + r4;
    float e0, e1, e2, o0, o1, o2, s0, s1, s2;
    pair_up(up_planes, height * lv[1].y, lv[1].y, px0, i, j, &e0, &e1, &e2, &o0, &o1, &o2);
    PAIR_ROWS(half_img, j, width, height, 2 * px0)
    float he[3], ho[3];
    pair_half(r0, r1, r2, i, a, he, ho);
    pair_keep(ch, pr, i, 0, j, width, height, r1, he, edge, edge + 2 * px0, e0, e1, e2, 1.0f, &s0, &s1, &s2);
    comp_store(2 * i, s0, s1, s2, dr, mr, orow, level_aov + p1, srow, spread0 + p1, c, kmax);
    pair_keep(ch, pr, i, 1, j, width, height, r1, ho, edge, edge + 2 * px0, o0, o1, o2, 1.0f, &s0, &s1, &s2);
    comp_store(2 * i + 1, s0, s1, s2, dr, mr, orow, level_aov + p1, srow, spread0 + p1, c, kmax);
}

/* Iser eq. 4.28 for the receiver fetch: the separated chain (a plain Gaussian chain of the
 * bright near pixels, eq. 4.27, with their luminance-weighted spread in .w, eq. 4.26) is
 * read at the level that its spread at level k_ssc asks for, and added (eq. 4.30). */
__kernel void composite_separated(__global const float4 *chain2, __global const int4 *lv,
                                  const int kmax, const float c, const float k_ssc,
                                  __global float4 *out, const int want_aov,
                                  __global float4 *scattered_aov)
{
    int i = get_global_id(0), j = get_global_id(1);
    int width = lv[0].y, height = lv[0].z;
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float2 p0 = (float2)(i + 0.5f, j + 0.5f);
    float w_ssc = chain_linear4(chain2, lv, kmax, k_ssc, p0).w;
    float3 sc = chain_fetch4(chain2, lv, kmax, level_of(w_ssc, c, (float)kmax), p0).xyz;
    out[idx].xyz += sc;
    if (want_aov) scattered_aov[idx].xyz += sc;
}
