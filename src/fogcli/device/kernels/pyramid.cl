/* Stage 2: one level of the scattering MIP chain (Elek eq. 6-9, Iser 4.4.2) and of the
 * spread chain used for depth blurring (Elek eq. 11, blurred in spread space).
 * All levels of a chain live in one buffer; `src`/`dst` are level offsets into it.
 * .w of the colour chain carries the luminance-weighted spread W^[k] (Elek sec. 3.5). */
#include "common.h"
#include "pairs.h"

__kernel void reduce_level(__global float4 *chain, __global float *spread_chain,
                           const int src_off, const int sw, const int sh,
                           const int dst_off, const int dw, const int dh,
                           const float thresh, const float eps, const int masked)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= dw || y >= dh) return;

    __global const float4 *src = chain + src_off;
    __global const float *ssrc = spread_chain + src_off;
    int x0 = 2 * x - FILTER_TAPS / 2 + 1, y0 = 2 * y - FILTER_TAPS / 2 + 1;

    float3 acc_c = (float3)(0.0f);
    float acc_g = 0.0f, acc_s = 0.0f;
    float acc_yw = 0.0f, acc_y = 0.0f, acc_w = 0.0f;
    int n = 0;
    for (int ty = 0; ty < FILTER_TAPS; ++ty) {
        int sy = y0 + ty;
        if (sy < 0 || sy >= sh) continue;
        for (int tx = 0; tx < FILTER_TAPS; ++tx) {
            int sx = x0 + tx;
            if (sx < 0 || sx >= sw) continue;
            int s = sy * sw + sx;
            float4 v = src[s];
            float wg = filter_w[tx] * filter_w[ty];
            float m = masked ? eq7_mask(v.w, thresh, eps) : 1.0f;
            acc_c += wg * m * v.xyz;
            acc_g += wg;
            acc_s += wg * ssrc[s];
            /* Eq. 8-9: box average of W weighted by the luminance of level k-1. */
            float yl = light_weight(v.xyz);
            acc_yw += yl * v.w;
            acc_y += yl;
            acc_w += v.w;
            ++n;
        }
    }
    /* closed border: taps that fall outside are dropped and the rest renormalised, so a
     * constant image stays constant and no energy leaves through the edge; open: what
     * falls outside is black, and light blurred across the edge is lost */
#ifdef BORDER_OPEN
    acc_g = 1.0f;
#endif
    float wk = acc_y > 1e-30f ? acc_yw / acc_y : acc_w / (float)n;
    int d = dst_off + y * dw + x;
    chain[d] = (float4)(acc_c / acc_g, wk);
    spread_chain[d] = acc_s / acc_g;
}

/* the arguments of reduce_level_source and reduce_source_inner (launched alike) */
#define REDUCE_SOURCE_ARGS                                                                       \
    __global float4 *chain, __global float4 *prep, const int src_off, const int sw, const int sh, \
    const int dst_off, const int dw, const int dh, const float thresh_next, const float eps,    \
    __global const float *lut, const int level, __global const float *edge, const int edge_off, \
    __global const float *cons, const int cons_off
/* The same level for the source collapse (`render.fetch: source`). Taps read the prep
 * chain (masked colour, log W; see prep_px): the colour of level k is the filtered masked
 * colour (eq. 6), W^[k] the geometric mean of W weighted by the luminance that actually
 * moves up, so that a small bright source next to a large dim one (a far lamp against the
 * sky) keeps its own spread. Writes I^[k], W^[k] and level k's own prep. */
__kernel void reduce_level_source(REDUCE_SOURCE_ARGS)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (x >= dw || y >= dh) return;

    __global const float4 *src = prep + src_off;
    int x0 = 2 * x - FILTER_TAPS / 2 + 1, y0 = 2 * y - FILTER_TAPS / 2 + 1;

    float3 acc_c = (float3)(0.0f);
    float acc_g = 0.0f, acc_yw = 0.0f, acc_y = 0.0f, acc_lw = 0.0f;
    int n = 0;
#ifdef PSF_APSF
    /* energy-conserving borders: each source pixel's taps scaled by its own factor
     * (apsf.conservation_tables; 1 away from the edges, where the fast path runs) */
    __global const float *rnx = cons + cons_off, *rny = cons + cons_off + sw;
    const int margin = FILTER_TAPS / 2;
#else
    const int margin = 0;
#endif
    if (x0 >= margin && y0 >= margin && x0 + FILTER_TAPS <= sw - margin && y0 + FILTER_TAPS <= sh - margin) {
        /* interior (almost every pixel): no bounds tests in the taps */
        for (int ty = 0; ty < FILTER_TAPS; ++ty) {
            __global const float4 *row = src + (y0 + ty) * sw + x0;
            for (int tx = 0; tx < FILTER_TAPS; ++tx) {
                float4 p = row[tx];
                float wg = filter_w[tx] * filter_w[ty];
                acc_c += wg * p.xyz;
                float yl = light_weight(p.xyz);
                acc_yw += yl * p.w;
                acc_y += yl;
                acc_lw += p.w;
            }
        }
        acc_g = 1.0f;
        n = FILTER_TAPS * FILTER_TAPS;
    } else for (int ty = 0; ty < FILTER_TAPS; ++ty) {
        int sy = y0 + ty;
        if (sy < 0 || sy >= sh) continue;
        for (int tx = 0; tx < FILTER_TAPS; ++tx) {
            int sx = x0 + tx;
            if (sx < 0 || sx >= sw) continue;
            float4 p = src[sy * sw + sx];
#ifdef PSF_APSF
            float wg = filter_w[tx] * filter_w[ty] * rnx[sx] * rny[sy];
#else
            float wg = filter_w[tx] * filter_w[ty];
#endif
            acc_c += wg * p.xyz;
            acc_g += wg;
            float yl = light_weight(p.xyz);
            acc_yw += yl * p.w;
            acc_y += yl;
            acc_lw += p.w;
            ++n;
        }
    }
#if defined(BORDER_OPEN) || defined(PSF_APSF)
    acc_g = 1.0f;   /* open: light filtered across the edge is lost; apsf: the taps are
                     * already normalised per source */
#endif
    float3 c = acc_c / acc_g;
    float lw = acc_y > 1e-30f ? acc_yw / acc_y : acc_lw / (float)n;
    int d = dst_off + y * dw + x;
#ifdef PSF_APSF
    /* .w is log P: the level's shares come from the table at the light-weighted P. The
     * top level keeps all it gets but what its `up` share says leaves the frame (open
     * border; apsf.build_lut) */
    store_prep_apsf(prep, d, c.x, c.y, c.z, lw, lut, level);
    if (level == (int)lut[3] - 1) {
        float4 p = prep[d];
        c -= p.xyz;
#ifdef BORDER_OPEN
        c *= edge_share(edge, edge_off, dw, dh, x, y, 0);
#endif
    }
    chain[d] = (float4)(c, lw);
#else
    float wk = exp_poly(lw);
    chain[d] = (float4)(c, wk);
    prep[d] = prep_px(c, wk, thresh_next, eps);
#endif
}

/* reduce_level_source's interior (destination pixels whose taps are inside the source level
 * and, for apsf, clear of its conservation factors' margin): destination pixel px0 + i of
 * row py0 + j, launched with no global offset on whole work-groups of the rectangle
 * reduce_region gives. No bounds tests, every channel a scalar and the sums chained
 * (AFTER), rows addressed by pointers indexed by the work-item (pairs.h, Addressing): PoCL
 * vectorises it with wide loads (the float3 sums and the branch of reduce_level_source left
 * it scalar, ~14 ms at level 1 of 2 MPx). The sums are reduce_level_source's in its order,
 * so the two agree to rounding. */
__kernel void reduce_source_inner(REDUCE_SOURCE_ARGS, const int px0, const int py0)
{
    int i = get_global_id(0), y = get_global_id(1) + py0;
    int x0 = 2 * px0 - FILTER_TAPS / 2 + 1, y0 = 2 * y - FILTER_TAPS / 2 + 1;
    __global const float *src = (__global const float *)(prep + src_off) + 4 * x0;
    float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, ayw = 0.0f, ay = 0.0f, alw = 0.0f;
#pragma unroll
    for (int ty = 0; ty < FILTER_TAPS; ++ty) {
        __global const float *row = src + 4 * (y0 + ty) * sw;
#pragma unroll
        for (int tx = 0; tx < FILTER_TAPS; ++tx) {
            int o = 8 * i + 4 * tx;
            float p0 = row[o], p1 = row[o + 1], p2 = row[o + 2], pw = row[o + 3];
            float wg = filter_w[tx] * filter_w[ty];
            a0 += wg * p0;
            a1 = AFTER(a1 + wg * p1, a0);
            a2 = AFTER(a2 + wg * p2, a1);
            float yl = LUMA_R * ABS_(p0) + LUMA_G * ABS_(p1) + LUMA_B * ABS_(p2);   /* light_weight */
            ayw = AFTER(ayw + yl * pw, a2);
            ay = AFTER(ay + yl, ayw);
            alw = AFTER(alw + pw, ay);
        }
    }
    float lw = ay > 1e-30f ? ayw / ay : alw / (float)(FILTER_TAPS * FILTER_TAPS);
    int d4 = 4 * (dst_off + y * dw + px0);
    __global float *crow = (__global float *)chain + d4, *prow = (__global float *)prep + d4;
#ifdef PSF_APSF
    float f;
    int li = lut_pos(lut, lw, &f);
    float q0 = lut_get(lut, lut_updown(level, 0, 0), li, f) * a0, q1 = lut_get(lut, lut_updown(level, 1, 0), li, f) * a1,
          q2 = lut_get(lut, lut_updown(level, 2, 0), li, f) * a2;
    if (level == (int)lut[3] - 1) {   /* the top level keeps what its `up` share leaves */
        float es = 1.0f;
#ifdef BORDER_OPEN
        es = edge_share(edge, edge_off, dw, dh, px0 + i, y, 0);
#endif
        a0 = (a0 - q0) * es; a1 = (a1 - q1) * es; a2 = (a2 - q2) * es;
    }
    prow[4 * i] = q0; prow[4 * i + 1] = q1; prow[4 * i + 2] = q2; prow[4 * i + 3] = lw;
    crow[4 * i] = a0; crow[4 * i + 1] = a1; crow[4 * i + 2] = a2; crow[4 * i + 3] = lw;
#else
    float wk = exp_poly(lw);
    float m = eq7_mask(wk, thresh_next, eps);
    crow[4 * i] = a0; crow[4 * i + 1] = a1; crow[4 * i + 2] = a2; crow[4 * i + 3] = wk;
    prow[4 * i] = m * a0; prow[4 * i + 1] = m * a1; prow[4 * i + 2] = m * a2;
    prow[4 * i + 3] = log_pos(wk > 1e-6f ? wk : 1e-6f);
#endif
}

/* Source collapse (`render.fetch: source`, docs/method.md), levels K-1 .. 0:
 * E_k = keep_k(I^[k]) + up(E_{k+1}), E_K = I^[K]. First split_level writes each pixel's
 * half-octave share to `half_img`, then collapse_level writes E_k over I^[k] in place (it
 * reads only its own pixel of the colour chain). Level 0 is composite_source. */
__kernel void split_level(__global const float4 *chain, const int off, const int h,
                          __global float4 *half_img, const float thresh, const float eps,
                          __global const float *lut, const int level, const int w,
                          __global const float *edge, const int edge_off)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    /* row pointers indexed by 4 x + c, and the edge table by x: strided loads and stores
     * (an index of 4 (y w + x), or x = i % w on a 1-D launch, made gathers of them) */
    __global const float *src = (__global const float *)(chain + off) + 4 * y * w;
    __global float *dst = (__global float *)half_img + 4 * y * w;
    float r = src[4 * x], g = src[4 * x + 1], b = src[4 * x + 2], w_ = src[4 * x + 3];
#ifdef PSF_APSF
    float f;
    int li = lut_pos(lut, w_, &f);
#ifdef BORDER_OPEN
    float e = edge_share(edge, edge_off, w, h, x, y, 1);
#else
    float e = 1.0f;
#endif
    dst[4 * x] = e * lut_get(lut, lut_updown(level, 0, 1), li, f) * r;
    dst[4 * x + 1] = e * lut_get(lut, lut_updown(level, 1, 1), li, f) * g;
    dst[4 * x + 2] = e * lut_get(lut, lut_updown(level, 2, 1), li, f) * b;
    dst[4 * x + 3] = 0.0f;
    return;
#endif
    float m, mh;
    split_weights(w_, thresh, eps, &m, &mh);
    dst[4 * x] = (mh - m) * r;
    dst[4 * x + 1] = (mh - m) * g;
    dst[4 * x + 2] = (mh - m) * b;
    dst[4 * x + 3] = mh;
}

/* the arguments of collapse_level and collapse_pairs (launched alike) */
#define COLLAPSE_ARGS                                                                            \
    __global float4 *chain, const int off, const int w, const int h, __global const float4 *half_img, \
    const int up_off, const int uw, const int uh, const float a, __global const float4 *prep,   \
    __global const float *edge, const int edge_off, __global const float *cons, const int cons_up, \
    __global const float *lut, __global const float *rd, const int rd_off, const int level
__kernel void collapse_level(COLLAPSE_ARGS)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    int d = off + y * w + x;
    float4 v = chain[d];
#ifdef PSF_APSF
    float4 up = UP2_APSF(chain + up_off, uw, uh, x, y, cons, cons_up, w, h);
#else
    float4 up = up2_fetch4(chain + up_off, uw, uh, x, y);
#endif
    float3 e = keep_px(v.xyz, prep[d].xyz, half_img, w, h, x, y, a, edge, edge_off);
#ifdef RECEIVER_DEPTH
    e *= recv_weight(lut, level, v.w, rd[rd_off + y * w + x]);
#endif
    chain[d] = (float4)(e + up.xyz, v.w);
}

/* collapse_level on two pixels per work-item, away from the level's edges: pairs px0 + i of
 * row py0 + j (pairs.h, Addressing; launched with no global offset); up_planes: level k+1
 * up-sampled along y to level k's rows (up_rows) */
__kernel void collapse_pairs(COLLAPSE_ARGS, __global const float *up_planes, const int px0, const int py0)
{
    int i = get_global_id(0), y = get_global_id(1) + py0;
    __global float *ch = (__global float *)chain + 4 * (off + y * w + 2 * px0);
    __global const float *pr = (__global const float *)prep + 4 * (off + y * w + 2 * px0);
    __global const float *edge_l = edge + edge_off;
    float e0, e1, e2, o0, o1, o2, s0, s1, s2;
    pair_up(up_planes, h * uw, uw, px0, i, y, &e0, &e1, &e2, &o0, &o1, &o2);
    PAIR_ROWS(half_img, y, w, h, 2 * px0)
    /* each pixel reads only its own value of level k before writing it */
    float he[3], ho[3];
    pair_half(r0, r1, r2, i, a, he, ho);
    float vw = ch[8 * i + 3], vw1 = ch[8 * i + 7];
#ifdef RECEIVER_DEPTH
    __global const float *rdr = rd + rd_off + y * w + 2 * px0;
    float wr0 = recv_weight(lut, level, vw, rdr[2 * i]), wr1 = recv_weight(lut, level, vw1, rdr[2 * i + 1]);
#else
    float wr0 = 1.0f, wr1 = 1.0f;
#endif
    pair_keep(ch, pr, i, 0, y, w, h, r1, he, edge_l, edge_l + 2 * px0, e0, e1, e2, wr0, &s0, &s1, &s2);
    ch[8 * i] = s0; ch[8 * i + 1] = s1; ch[8 * i + 2] = s2; ch[8 * i + 3] = vw;
    pair_keep(ch, pr, i, 1, y, w, h, r1, ho, edge_l, edge_l + 2 * px0, o0, o1, o2, wr1, &s0, &s1, &s2);
    vw = vw1;
    ch[8 * i + 4] = s0; ch[8 * i + 5] = s1; ch[8 * i + 6] = s2; ch[8 * i + 7] = vw;
}

#ifdef RECEIVER_DEPTH
/* render.halo_depth: receiver. Level k of the receivers' log P (the mean over 2 x 2 of level
 * k-1, clamped at the edge) into rd at dst_off: level 1 from the colour chain's level 0
 * (its .w: src_off 3, stride 4; each pixel's own log P), higher levels from rd itself */
__kernel void receiver_depth(__global const float *src, const int src_off, const int stride, const int sw,
                             const int sh, __global float *rd, const int dst_off, const int dw, const int dh)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, dw, dh)) return;
    int x0 = 2 * x, y0 = 2 * y, x1 = mini_(x0 + 1, sw - 1), y1 = mini_(y0 + 1, sh - 1);
    __global const float *s = src + src_off;
    rd[dst_off + y * dw + x] = 0.25f * ((s[(y0 * sw + x0) * stride] + s[(y0 * sw + x1) * stride])
                                        + (s[(y1 * sw + x0) * stride] + s[(y1 * sw + x1) * stride]));
}

/* render.border: extend. Level 0 of the extension plan's receivers (device/border.py): the
 * main frame's at level L (main_rd at main_off, mw x mh), cells past its edge the nearest
 * edge cell's (the continued edge stands there: border_sources); ox, oy in cells. With
 * `warped` the main level lies in the plane of angles: read where the cell lies there
 * (to_plane: device/warp.py, index space of the plane's level). */
__kernel void receiver_depth_ext(__global const float *main_rd, const int main_off, const int mw, const int mh,
                                 __global float *rd, const int pw, const int ph, const int ox, const int oy,
                                 const int warped, __global const float2 *to_plane)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, pw, ph)) return;
    int mx = clampi_(x - ox, 0, mw - 1), my = clampi_(y - oy, 0, mh - 1);
    if (warped) {
        float2 q = to_plane[my * mw + mx];
        mx = clampi_((int)(q.x + 0.5f), 0, mw - 1);    /* truncation is floor's where it is not clamped to 0 */
        my = clampi_((int)(q.y + 0.5f), 0, mh - 1);
    }
    rd[y * pw + x] = main_rd[main_off + my * mw + mx];
}

/* The top level's light times its receivers' weight, in place (collapse_level weights each
 * level below as it keeps it; level 0, the source's own pixel and its 3 x 3, is not) */
__kernel void receiver_weight_top(__global float4 *chain, const int off, const int w, const int h,
                                  __global const float *rd, const int rd_off, __global const float *lut,
                                  const int level)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    float4 v = chain[off + y * w + x];
    float wr = recv_weight(lut, level, v.w, rd[rd_off + y * w + x]);
    chain[off + y * w + x] = (float4)(v.xyz * wr, v.w);
}
#endif

/* Level k+1 (uw x uh at `off` in the chain) up-sampled along y to the h rows of level k,
 * as three colour planes of h x uw, R then G then B, for the pair kernels at level k
 * (pairs.h, pair_up): row j holds the UP_NT rows about j / 2 with row j's fixed-phase
 * weights, summed in up2_fetch4's order. The pair kernels then sum UP_NT + 1 columns of one
 * row: the vertical sums, which they did for each pair (4 of their 5 loads a tap), are
 * made once per level-k row and level-(k+1) column here. Rows beyond level k+1 are clamped;
 * the pair kernels read only rows whose taps are inside it. */
__kernel void up_rows(__global const float4 *chain, const int off, const int uw, const int uh, const int h,
                      __global float *planes)
{
    int x = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(x, j, uw, h)) return;
    int y0 = (j >> 1) - UP_NT / 2 + (j & 1);
    __global const float *col = (__global const float *)(chain + off) + 4 * x;
    float c0 = 0.0f, c1 = 0.0f, c2 = 0.0f;
#pragma unroll
    for (int r = 0; r < UP_NT; ++r) {
        float wr = (j & 1) ? UP_WO[r] : UP_WE[r];
        __global const float *q = col + 4 * clampi_(y0 + r, 0, uh - 1) * uw;
        c0 += wr * q[0];
        c1 += wr * q[1];
        c2 += wr * q[2];
    }
    int n = h * uw, o = j * uw + x;
    planes[o] = c0;
    planes[n + o] = c1;
    planes[2 * n + o] = c2;
}

/* Level 0 of the prep chain from level 0 of the colour chain (tests set level 0 directly;
 * the pipeline gets it from the preprocess kernel). */
__kernel void prep_level0(__global const float4 *chain, __global float4 *prep, const int n,
                          const float thresh1, const float eps)
{
    int i = get_global_id(0);
    if (i >= n) return;
    float4 v = chain[i];
    prep[i] = prep_px(v.xyz, v.w, thresh1, eps);
}

#ifdef PSF_APSF
#define PYRAMID_EDGE_BANDS
#include "edge_bands.h"

/* render.border: extend. Level 0 of the padded frame's chain at 1/scale resolution (the
 * extension plan, device/border.py: extend; scale = 2^L, its pixels those of level L here):
 * the sources past the frame's edge, each pixel past it the band next to the nearest edge
 * pixel (edge_bands), out to `margin` pixels; inside the frame nothing (the main chain has
 * it). A cell's colour is the mean over its scale x scale pixels, its log P weighted by their
 * luminance, like a reduce. Along an axis a cell's pixels are a run before the frame (all
 * continuing pixel 0), the pixels inside, and a run after it (continuing n - 1): one read per
 * run, not per pixel. */
inline void cell_runs(int a0, int s, int n, int m, int *before, int *lo, int *hi, int *after)
{
    int b0 = maxi_(a0, -m), b1 = mini_(a0 + s, n + m);     /* the part within the margin */
    *before = maxi_(0, mini_(b1, 0) - b0);
    *after = maxi_(0, b1 - maxi_(b0, n));
    *lo = maxi_(b0, 0);
    *hi = maxi_(*lo, mini_(b1, n));
}

__kernel void border_sources(__global const float4 *bands, const int w, const int h,
                             __global float4 *chain, __global float4 *prep, const int pw, const int ph,
                             const int ox, const int oy, const int mx, const int my, const int scale,
                             __global const float *lut)
{
    int X = get_global_id(0), Y = get_global_id(1);
    if (X >= pw || Y >= ph) return;
    int bx, x0, x1, ax, by, y0, y1, ay;
    cell_runs(X * scale - ox, scale, w, mx, &bx, &x0, &x1, &ax);
    cell_runs(Y * scale - oy, scale, h, my, &by, &y0, &y1, &ay);
    int d = Y * pw + X;
    if (bx + ax + by + ay == 0) {            /* inside the frame, or past the margin */
        chain[d] = (float4)(0.0f);
        prep[d] = (float4)(0.0f);
        return;
    }
    float3 c = (float3)(0.0f);
    float yw = 0.0f, ys = 0.0f, lw = 0.0f, n = 0.0f;
    int nyi = y1 - y0, nxi = x1 - x0;
    for (int ey = -1; ey <= nyi; ++ey) {
        int cy = ey < 0 ? by : (ey == nyi ? ay : 1);
        if (cy == 0) continue;
        for (int ex = -1; ex <= nxi; ++ex) {
            int cx = ex < 0 ? bx : (ex == nxi ? ax : 1);
            int in_y = ey >= 0 && ey < nyi, in_x = ex >= 0 && ex < nxi;
            if (cx == 0 || (in_y && in_x)) continue;   /* inside */
            int e = in_y ? (ex < 0 ? 0 : h) + y0 + ey                      /* a row's left or right end */
                  : in_x ? 2 * h + (ey < 0 ? 0 : w) + x0 + ex              /* a column's top or bottom end */
                         : 2 * (h + w) + (ex < 0 ? 0 : 1) + (ey < 0 ? 0 : 2);   /* a corner */
            float k = (float)(cy * cx);
            float4 b0 = bands[2 * e], b1 = bands[2 * e + 1];
            c += k * b0.xyz;
            yw += k * b0.w;
            ys += k * b1.x;
            lw += k * b1.y;
            n += k;
        }
    }
    c /= (float)(scale * scale);
    float lp = ys > 1e-30f ? yw / ys : (n > 0.0f ? lw / n : 0.0f);
    store_prep_apsf(prep, d, c.x, c.y, c.z, lp, lut, 0);
    chain[d] = (float4)(c, lp);
}

/* The extension plan's result (its pixels are level L's, origin ox, oy of them out) added
 * to E_L of the source collapse once level L is collapsed: the levels below up-sample it
 * with the chain's own energy-conserving filters. */
__kernel void border_inject(__global float4 *chain, const int off, const int w, const int h,
                            __global const float4 *ext, const int pw, const int ox, const int oy)
{
    int x = get_global_id(0), y = get_global_id(1);
    if (OUTSIDE(x, y, w, h)) return;
    int d = off + y * w + x;
    float4 e = ext[(y + oy) * pw + x + ox];
    chain[d] = (float4)(chain[d].xyz + e.xyz, chain[d].w);
}
#endif
