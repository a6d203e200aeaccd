/* Shared physics and sampling helpers for every fogcli stage.
 * Each formula lives here once; the stage files only wire buffers. */
#ifndef FOGCLI_COMMON_H
#define FOGCLI_COMMON_H

/* sqrt() is an out-of-line library call in PoCL, and one call stops the vectoriser; the
 * clang builtin becomes the instruction. The host defines FOGCLI_POCL for PoCL only, so a
 * vendor compiler never sees the builtin. */
/* Outside the image: a work-item of a launch rounded up to whole work-groups. Programs built
 * with -D WHOLE_GROUPS run only where whole work-groups fit (Runtime.launch2d) and skip the
 * test: under it PoCL masks every memory access, and it vectorises masked RGBA and table
 * reads for AVX-512 only (tools/pocl_vectorisation.py). */
/* Helpers PoCL must inline: one that stays a call keeps the kernel from being vectorised
 * across work-items (LLVM's inliner leaves large ones out). */
#define ALWAYS_INLINE __attribute__((always_inline)) inline
/* v, made to depend on prev (0 * prev is not folded without fast math). LLVM's SLP pass pairs
 * side-by-side copies of a computation (the channels of a pixel, its taps) into short vectors
 * before PoCL builds the loop over work-items, and such a value stops that loop's vectoriser
 * ("instruction return type cannot be vectorized"): chaining the copies prevents the pairing. */
#define AFTER(v, prev) ((v) + 0.0f * (prev))
/* A kernel a compiler must not vectorise across work-items. Intel's CPU runtime (2026.2)
 * does it to airlight_noise and airlight_fill and loses some work-items' results after
 * ray_cuts (the noise span of every ray but one of a vector read as a miss; PoCL, Oclgrind
 * and Intel's own scalar build agree on them: docs/devices.md). A vector type hint is Intel's
 * documented way to keep a kernel scalar; other compilers take it as a hint. */
#define NOT_ACROSS_ITEMS __attribute__((vec_type_hint(float4)))

#ifdef WHOLE_GROUPS
#define OUTSIDE(i, j, w, h) 0
#else
#define OUTSIDE(i, j, w, h) ((i) >= (w) || (j) >= (h))
#endif

#ifdef FOGCLI_POCL
#define SQRT_(x) __builtin_sqrtf(x)
#define ABS_(x) __builtin_fabsf(x)
#else
/* the library's calls elsewhere: Oclgrind's uninitialised-value check stops at the
 * builtins' intrinsics (llvm.fabs: docs/devices.md) */
#define SQRT_(x) sqrt(x)
#define ABS_(x) fabs(x)
#endif

/* clamp by ternaries: the clamp / min / max builtins are out-of-line calls in PoCL */
inline float clampf_(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }
inline int clampi_(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
inline int mini_(int a, int b) { return a < b ? a : b; }
inline int maxi_(int a, int b) { return a > b ? a : b; }
inline float absf_(float v) { return v < 0.0f ? -v : v; }

/* e^y to ~2e-7 relative: 2^n from the exponent bits, 2^f (|f| <= 1/2) by its Taylor series
 * to degree 7; 0 below e^-87, inf above e^88. exp() is a per-lane library call in PoCL, and one such call
 * keeps the whole kernel from being vectorised across work-items. */
inline float exp_poly(float y)
{
    /* ternaries and casts only: PoCL does not inline clamp / rint / fabs / dot either */
    float z = y * 1.44269504f;
    z = clampf_(z, -127.0f, 128.0f);
    int ni = (int)(z + (z >= 0.0f ? 0.5f : -0.5f));
    float g = (z - (float)ni) * 0.69314718f;
    float p = 1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6.0f + g * (1.0f / 24.0f
              + g * (1.0f / 120.0f + g * (1.0f / 720.0f + g * (1.0f / 5040.0f)))))));
    return z <= -127.0f ? 0.0f : p * as_float((ni + 127) << 23);
}

/* exp_poly and SQRT_ lane by lane on float8 (explicit SIMD where work-items stay scalar, and
 * lanes.h's LANES 8): the library's exp and sqrt on vectors are calls in PoCL */
ALWAYS_INLINE float8 exp_poly8(float8 y)
{
    float8 z = y * 1.44269504f;
    z = z < -127.0f ? -127.0f : z;
    z = z > 128.0f ? 128.0f : z;
    int8 ni = __builtin_convertvector(z + (z >= 0.0f ? (float8)(0.5f) : (float8)(-0.5f)), int8);
    float8 g = (z - __builtin_convertvector(ni, float8)) * 0.69314718f;
    float8 p = 1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6.0f + g * (1.0f / 24.0f
               + g * (1.0f / 120.0f + g * (1.0f / 720.0f + g * (1.0f / 5040.0f)))))));
    return z <= -127.0f ? (float8)(0.0f) : p * as_float8((ni + 127) << 23);
}

/* p[k.s0] .. p[k.s7] as a float8: one load per lane (LLVM emits no gathers for AVX2 CPUs) */
#define GATHER8(p, k) ((float8)((p)[(k).s0], (p)[(k).s1], (p)[(k).s2], (p)[(k).s3],                    \
                                (p)[(k).s4], (p)[(k).s5], (p)[(k).s6], (p)[(k).s7]))

ALWAYS_INLINE float8 sqrt8(float8 v)
{
    return (float8)(SQRT_(v.s0), SQRT_(v.s1), SQRT_(v.s2), SQRT_(v.s3),
                    SQRT_(v.s4), SQRT_(v.s5), SQRT_(v.s6), SQRT_(v.s7));
}

ALWAYS_INLINE float hsum8(float8 v)
{
    float4 h = v.lo + v.hi;
    return (h.x + h.y) + (h.z + h.w);
}

/* 1 - e^-x for x >= 0, accurate in thin media where 1 - exp_poly(-x) would cancel: the
 * series to x^5 below 0.05 (error < 3e-11 relative), then at most 4e-6 relative. */
inline float one_minus_exp(float x)
{
    float series = x * (1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f - x * (1.0f / 120.0f)))));
    return x < 0.05f ? series : 1.0f - exp_poly(-x);
}

/* float4 pixels read and written as four floats: PoCL's loop vectoriser gives up on
 * vector-typed loads and stores ("instruction return type cannot be vectorized") and
 * handles strided scalar ones. */
inline void load4(__global const float4 *buf, int idx, float *a, float *b, float *c, float *d)
{
    __global const float *f = (__global const float *)buf + 4 * idx;
    *a = f[0]; *b = f[1]; *c = f[2]; *d = f[3];
}

inline void store4(__global float4 *buf, int idx, float a, float b, float c, float d)
{
    __global float *f = (__global float *)buf + 4 * idx;
    f[0] = a; f[1] = b; f[2] = c; f[3] = d;
}

/* Rec.709 luminance weights (docs/conventions.md, The reference and the pyramid); the host's
 * are physics/luminance.py's LUMA (tests/test_luminance.py holds the two together). */
#define LUMA_R 0.2126f
#define LUMA_G 0.7152f
#define LUMA_B 0.0722f

/* Rec.709 luminance. */
inline float luminance(float3 c) { return LUMA_R * c.x + LUMA_G * c.y + LUMA_B * c.z; }
/* the weight of a colour in the pyramid's light-weighted P: its luminance, of each channel's
 * magnitude (a ground's sources, its colour minus its mean (PRE_GROUND), have either sign;
 * a signed sum's cancellation would leave a weight of rounding) */
inline float light_weight(float3 c) { return LUMA_R * ABS_(c.x) + LUMA_G * ABS_(c.y) + LUMA_B * ABS_(c.z); }

/* Elek eq. 2 (Premoze): std-dev W of the beam after travel s.
 * Written as W^2 = 0.5 s^3 k / (2/3 sa s^2 k + 4), k = ss (1 - g), which is the printed
 * form multiplied through by s^3 k: no division by zero at s = 0, ss = 0 or sa = 0. */
inline float spread_w(float s, float sa, float ss, float g)
{
    float k = ss * (1.0f - g);
    float s2 = s * s;
    float w2 = 0.5f * s2 * s * k / ((2.0f / 3.0f) * sa * s2 * k + 4.0f);
    return SQRT_(w2 > 0.0f ? w2 : 0.0f);
}

/* Blur std-dev in output pixels (docs/conventions.md, How far the light spreads). d_res is the rescaled distance D' (= P),
 * dist the ray length. SPREAD_PAPER selects Elek's reading at compile time. */
inline float spread_px(float d_res, float dist, float sa, float ss, float g,
                       float scale, float focal_px, float width)
{
    float w = spread_w(d_res, sa, ss, g);
#ifdef SPREAD_PAPER
    return scale * w * width / 1280.0f;
#else
    /* W/D -> 0 as D -> 0 (W grows like D^1.5), so a zero distance has no spread. */
    return dist > 1e-6f ? scale * w / dist * focal_px : 0.0f;
#endif
}

/* GLSL smoothstep; e0 == e1 degrades to a hard step instead of 0/0. */
inline float smoothstep_(float e0, float e1, float x)
{
    float t = (x - e0) / (e1 - e0);
    t = clampf_(t, 0.0f, 1.0f);
    float s = t * t * (3.0f - 2.0f * t);
    return e1 <= e0 ? (x >= e1 ? 1.0f : 0.0f) : s;
}

/* Elek eq. 7, the mask M of a level: a pixel whose spread w is below the level's threshold
 * stays below (0), one above it passes up (1), with a smooth step over [thresh, (1 + eps)
 * thresh] between (eps: render.epsilon). The one definition; every chain calls it. */
inline float eq7_mask(float w, float thresh, float eps)
{
    return smoothstep_(thresh, (1.0f + eps) * thresh, w);
}

/* Natural log for positive normal floats, to ~1e-7 absolute: the exponent from the bits,
 * the mantissa reduced to [sqrt(1/2), sqrt(2)) and the atanh series to t^7. PoCL's log()
 * is a scalar library call that cost half of the preprocess stage. */
inline float log_pos(float x)
{
    /* the mantissa halved above sqrt(2) by integer arithmetic on its bits: the same numbers
     * as a float compare and select, which kept PoCL from vectorising every kernel that
     * called this (measured: the light table kernel, tools/pocl_vectorisation.py) */
    int bits = as_int(x);
    int m = (bits & 0x007fffff) | 0x3f800000;                  /* mantissa in [1, 2) */
    int big = m > 0x3fb504f3 ? 1 : 0;                          /* above sqrt(2) */
    int e = ((bits >> 23) & 0xff) - 127 + big;
    float mant = as_float(m - (big << 23));
    float t = (mant - 1.0f) / (mant + 1.0f), t2 = t * t;
    float series = t * (2.0f + t2 * (0.66666667f + t2 * (0.4f + t2 * 0.28571429f)));
    return series + (float)e * 0.69314718f;
}

/* Continuous MIP level of a blur of std-dev sigma (Elek eq. 10: level k holds c 2^k). */
inline float level_of(float sigma, float c, float kmax)
{
    /* log2 through log_pos, ternaries for clamp / fmax: each builtin is an out-of-line
     * call in PoCL, and this runs once or twice per pixel */
    float s = sigma / c;
    float l = log_pos(s > 1e-30f ? s : 1e-30f) * 1.44269504f;
    return clampf_(l, 0.0f, kmax);
}

/* Level-k coordinate of a level-0 pixel centre: level k pixel x has its centre at
 * 2^k (x + 0.5) in level-0 pixel units (even filters keep MIP alignment). */
inline float2 level_coord(float2 p0, int k)
{
    float s = 1.0f / (float)(1 << k);
    return p0 * s - 0.5f;
}

/* Cubic B-spline weights folded into two bilinear taps per axis (Sigg & Hadwiger 2005,
 * GPU Gems 2 ch. 20): returns (h0, h1, g0) with tap offsets -h0, +h1 and weight g0 on
 * the first tap. */
/* floor for any float, without the builtin call */
inline float floor_(float x)
{
    float t = (float)(int)x;
    return t > x ? t - 1.0f : t;
}

inline float3 bspline_taps(float f)
{
    float f2 = f * f, f3 = f2 * f;
    float w0 = (1.0f - 3.0f * f + 3.0f * f2 - f3) / 6.0f;
    float w1 = (4.0f - 6.0f * f2 + 3.0f * f3) / 6.0f;
    float w2 = (1.0f + 3.0f * f + 3.0f * f2 - 3.0f * f3) / 6.0f;
    float w3 = f3 / 6.0f;
    float g0 = w0 + w1;
    return (float3)(1.0f - w1 / g0 + f, 1.0f + w3 / (w2 + w3) - f, g0);
}

/* Samplers of a level, for float4 (colour) and float (spread) images, clamp-to-edge,
 * (x, y) in pixel-index space: bilinear; bicubic B-spline from 4 bilinear fetches (Sigg &
 * Hadwiger); fetch = the one INTERP selects (0: bilinear, else bicubic). */
#define DEFINE_SAMPLERS(T, S)                                                               \
inline T bilinear##S(__global const T *img, int w, int h, float x, float y)                  \
{                                                                                           \
    /* ternaries, casts and plain arithmetic: clamp / floor / min / mix are out-of-line   \
     * calls in PoCL, and this runs up to 16 times per pixel */                             \
    float xm = (float)(w - 1), ym = (float)(h - 1);                                         \
    x = clampf_(x, 0.0f, xm);                                                               \
    y = clampf_(y, 0.0f, ym);                                                               \
    int x0 = (int)x, y0 = (int)y;                          /* x, y >= 0: the floor */       \
    int x1 = clampi_(x0 + 1, 0, w - 1), y1 = clampi_(y0 + 1, 0, h - 1);                     \
    float fx = x - x0, fy = y - y0;                                                         \
    T p = img[y0 * w + x0], q = img[y1 * w + x0];                                           \
    T a = p + (img[y0 * w + x1] - p) * fx;                                                  \
    T b = q + (img[y1 * w + x1] - q) * fx;                                                  \
    return a + (b - a) * fy;                                                                \
}                                                                                           \
inline T bicubic##S(__global const T *img, int w, int h, float x, float y)                   \
{                                                                                           \
    float ix = floor_(x), iy = floor_(y);                                                   \
    float3 tx = bspline_taps(x - ix), ty = bspline_taps(y - iy);                            \
    float x0 = x - tx.x, x1 = x + tx.y, y0 = y - ty.x, y1 = y + ty.y;                       \
    T a1 = bilinear##S(img, w, h, x1, y0), b1 = bilinear##S(img, w, h, x1, y1);             \
    T a = a1 + (bilinear##S(img, w, h, x0, y0) - a1) * tx.z;                                \
    T b = b1 + (bilinear##S(img, w, h, x0, y1) - b1) * tx.z;                                \
    return b + (a - b) * ty.z;                                                              \
}                                                                                           \
inline T fetch##S(__global const T *img, int w, int h, float x, float y)                     \
{                                                                                           \
    return INTERP == 0 ? bilinear##S(img, w, h, x, y) : bicubic##S(img, w, h, x, y);        \
}

DEFINE_SAMPLERS(float4, 4)
DEFINE_SAMPLERS(float, 1)

/* What a pixel of level k passes to level k+1 in the source collapse: its colour masked
 * by eq. 7 (M^[k+1] from its spread W and the threshold of level k+1) and log W, which the
 * next level averages geometrically. Stored once per pixel ("prep" chain) so the filter
 * taps that read it do no transcendental work. */
inline float4 prep_px(float3 rgb, float w, float thresh_next, float eps)
{
    float m = eq7_mask(w, thresh_next, eps);
    return (float4)(m * rgb, log_pos(w > 1e-6f ? w : 1e-6f));
}

/* prep_px of (r, g, b, w) stored at buf[idx], in scalars (see store4) */
inline void store_prep(__global float4 *buf, int idx, float r, float g, float b, float w,
                       float thresh_next, float eps)
{
    float m = eq7_mask(w, thresh_next, eps);
    store4(buf, idx, m * r, m * g, m * b, log_pos(w > 1e-6f ? w : 1e-6f));
}

/* Level k+1 read at the centre of level-k pixel (x, y): (x + 0.5) / 2 - 0.5 has the
 * fractional part 0.75 (even x) or 0.25 (odd x), so the B-spline (or tent) weights are
 * two constant sets and the 4x4 (2x2) taps are read directly: the same values as
 * fetch4() at that point, without the per-fetch floor and clamp work. */
inline float4 up2_fetch4(__global const float4 *img, int w, int h, int x, int y)
{
#if INTERP == 0
    int x0 = (x >> 1) - 1 + (x & 1), y0 = (y >> 1) - 1 + (y & 1);
    float fx = (x & 1) ? 0.25f : 0.75f, fy = (y & 1) ? 0.25f : 0.75f;
    int xa = clampi_(x0, 0, w - 1), xb = clampi_(x0 + 1, 0, w - 1);
    int ya = clampi_(y0, 0, h - 1), yb = clampi_(y0 + 1, 0, h - 1);
    float4 a = (1.0f - fx) * img[ya * w + xa] + fx * img[ya * w + xb];
    float4 b = (1.0f - fx) * img[yb * w + xa] + fx * img[yb * w + xb];
    return (1.0f - fy) * a + fy * b;
#else
    /* cubic B-spline weights at f = 0.25 (odd) and f = 0.75 (even) */
    const float wo[4] = {0.0703125f, 0.61197917f, 0.31510417f, 0.00260417f};
    const float we[4] = {0.00260417f, 0.31510417f, 0.61197917f, 0.0703125f};
    int x0 = (x >> 1) - 2 + (x & 1), y0 = (y >> 1) - 2 + (y & 1);
    int xi[4];
    for (int t = 0; t < 4; ++t) xi[t] = clampi_(x0 + t, 0, w - 1);
    float4 acc = (float4)(0.0f);
    for (int r = 0; r < 4; ++r) {
        __global const float4 *row = img + clampi_(y0 + r, 0, h - 1) * w;
        float4 racc = (float4)(0.0f);
        for (int t = 0; t < 4; ++t) racc += ((x & 1) ? wo[t] : we[t]) * row[xi[t]];
        acc += ((y & 1) ? wo[r] : we[r]) * racc;
    }
    return acc;
#endif
}

#ifdef PSF_APSF
/* up2_fetch4 for the apsf chain: the same fixed-phase taps, clamp-to-edge (closed) or zero
 * outside (open), and each input pixel's weights scaled by ux[j] uy[i] so that it hands
 * the level below exactly its energy (apsf.conservation_tables) */
ALWAYS_INLINE float4 up2_cons(__global const float4 *img, int w, int h, int x, int y,
                       __global const float *ux, __global const float *uy)
{
#if INTERP == 0
    const int NT = 2;
    int x0 = (x >> 1) - 1 + (x & 1), y0 = (y >> 1) - 1 + (y & 1);
    float fx = (x & 1) ? 0.25f : 0.75f, fy = (y & 1) ? 0.25f : 0.75f;
    float wx[2] = {1.0f - fx, fx}, wy[2] = {1.0f - fy, fy};
#else
    const int NT = 4;
    const float wo[4] = {0.0703125f, 0.61197917f, 0.31510417f, 0.00260417f};
    const float we[4] = {0.00260417f, 0.31510417f, 0.61197917f, 0.0703125f};
    int x0 = (x >> 1) - 2 + (x & 1), y0 = (y >> 1) - 2 + (y & 1);
    float wx[4], wy[4];
    for (int t = 0; t < 4; ++t) { wx[t] = (x & 1) ? wo[t] : we[t]; wy[t] = (y & 1) ? wo[t] : we[t]; }
#endif
    /* away from the edges every factor is 1: the plain fixed-tap fetch */
    if (x0 >= 2 && y0 >= 2 && x0 + NT <= w - 2 && y0 + NT <= h - 2)
        return up2_fetch4(img, w, h, x, y);
    float4 acc = (float4)(0.0f);
    for (int r = 0; r < NT; ++r) {
#ifdef BORDER_OPEN
        /* open: zero outside (apsf.conservation_tables) */
        if (y0 + r < 0 || y0 + r >= h) continue;
#endif
        int jy = clampi_(y0 + r, 0, h - 1);
        __global const float4 *row = img + jy * w;
        float4 racc = (float4)(0.0f);
        for (int t = 0; t < NT; ++t) {
#ifdef BORDER_OPEN
            if (x0 + t < 0 || x0 + t >= w) continue;
#endif
            int jx = clampi_(x0 + t, 0, w - 1);
            racc += (wx[t] * ux[jx]) * row[jx];
        }
        acc += (wy[r] * uy[jy]) * racc;
    }
    return acc;
}
#define UP2_APSF(img, w, h, x, y, cons, base, lw, lh) \
    up2_cons(img, w, h, x, y, (cons) + (base) + (lw) + (lh), (cons) + (base) + (lw) + (lh) + (w))
#endif

/* What level k keeps in the source collapse. The part of I^[k] that eq. 7 masks out of
 * level k+1 (W below T, the threshold of level k+1) stays at level k. Of it, the part with
 * W below T / sqrt(2) stays as it is (blur c 2^k); the part between T / sqrt(2) and T gets
 * a 3x3 blur of variance c^2 level-k pixels, so its total blur is c 2^k sqrt(2). Half-octave
 * steps make a spread between two levels a mix of two close Gaussians instead of two a
 * factor 2 apart, whose tails are up to 10x too heavy at 4 sigma.
 *
 * split_weights: per pixel, M and M_h; split_level stores (M_h - M) I and M_h, and keep_px sums the 3x3
 * of shares with weights (a, 1 - 2a, a) (clamp-to-edge, which conserves energy for a
 * symmetric 3-tap) and adds (1 - M_h) I of the pixel itself. */
inline float smooth01(float t)
{
    t = clampf_(t, 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

inline void split_weights(float w, float T, float eps, float *m, float *mh)
{
    float th = T * 0.70710678f;
    float et = eps * T, eth = eps * th;
    float m1 = smooth01((w - T) / (et > 1e-30f ? et : 1e-30f));
    float m2 = smooth01((w - th) / (eth > 1e-30f ? eth : 1e-30f));
    *m = m1;
    *mh = m1 > m2 ? m1 : m2;
}

inline float4 half_blur(__global const float4 *half_img, int w, int h, int x, int y, float a,
                        float4 *centre)
{
    float b = 1.0f - 2.0f * a;
    int x0 = clampi_(x - 1, 0, w - 1), x2 = clampi_(x + 1, 0, w - 1);
    __global const float4 *r0 = half_img + clampi_(y - 1, 0, h - 1) * w;
    __global const float4 *r1 = half_img + y * w;
    __global const float4 *r2 = half_img + clampi_(y + 1, 0, h - 1) * w;
    float4 c = r1[x];
    *centre = c;
    return a * (a * r0[x0] + b * r0[x] + a * r0[x2])
         + b * (a * r1[x0] + b * c + a * r1[x2])
         + a * (a * r2[x0] + b * r2[x] + a * r2[x2]);
}

#if defined(PSF_APSF) && defined(BORDER_OPEN)
/* Open border with apsf: the pyramid itself keeps light in the frame (the closed chain),
 * and what level k keeps at pixel (x, y) is scaled by the share of a Gaussian of that
 * slot's width, centred there, that lands in the frame (apsf.edge_tables: per level, the
 * x and y factors of the sharp and the half-blurred slot). So each source keeps what
 * the open reference keeps, shaped like the closed blur near the edge. */
inline float edge_share(__global const float *edge, int off, int w, int h, int x, int y, int which)
{
    int o = off + which * (w + h);
    return edge[o + x] * edge[o + w + y];
}
#endif

/* What level k keeps of I^[k] = rgb. Gaussian: the pixel's own sharp share is (1 - M_h),
 * stored in the half image's .w. apsf: the shares are per channel; the sharp one is what
 * is neither passed on (the prep chain's colour, `passed`) nor half-blurred. */
inline float3 keep_px(float3 rgb, float3 passed, __global const float4 *half_img, int w, int h,
                      int x, int y, float a, __global const float *edge, int edge_off)
{
    float4 c;
    float4 acc = half_blur(half_img, w, h, x, y, a, &c);
#ifdef PSF_APSF
#ifdef BORDER_OPEN
    /* the half image holds each pixel's half share already scaled by its edge share */
    float es = edge_share(edge, edge_off, w, h, x, y, 0), eh = edge_share(edge, edge_off, w, h, x, y, 1);
    return acc.xyz + (rgb - passed - c.xyz / eh) * es;
#else
    return acc.xyz + rgb - passed - c.xyz;
#endif
#else
    return acc.xyz + (1.0f - c.w) * rgb;
#endif
}

#include "apsf.h"

/* out = direct (+ L_em + L_amb when they were kept apart for an AOV) + blurred L_sc, alpha
 * from direct: the last step of every composite (pyramid, naive, reference). */
inline void store_out(__global float4 *out, __global const float4 *direct,
                      __global const float4 *medium_term, int add_medium, int idx, float3 sc)
{
    float4 d = direct[idx];
    float3 med = add_medium ? medium_term[idx].xyz : (float3)(0.0f);
    out[idx] = (float4)(d.xyz + med + sc, d.w);
}

/* Even-length separable pyramid filter: tap t of FILTER_TAPS reads source index
 * 2x - FILTER_TAPS/2 + 1 + t. FILTER_WEIGHTS is set by the host (-D). */
__constant float filter_w[FILTER_TAPS] = { FILTER_WEIGHTS };

#endif
