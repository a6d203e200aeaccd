/* The kernel realign_blocks and, where the 3 x 3 blocks around a pixel hold a depth edge,
 * the pixel's depth by its colour. Included by preprocess.cl only. */
#ifndef REALIGN_H
#define REALIGN_H

#define PURE_TOL 0.2f       /* a block is uniform: each pixel within this of its mean (relative L1) */
#define SINGLE_TOL 0.1f     /* a uniform block this near the pixel's colour is its surface */
#define PAIR_SLACK 0.02f    /* mixes within this (relative L1) of the best count as equal */

/* The 3 x 3 blocks around block (bi, bj) of the grid kx x ky starting at px, py, those in
 * the frame: mean colour (mr, mg, mb), depth md (from d), whether pure (every pixel within
 * PURE_TOL of the mean), offset (oi, oj); *own_k: the pixel's own block. Returns how many. */
inline int edge_blocks(__global const float4 *image, float d[3][3], int bi, int bj, int kx, int ky, int px,
                       int py, int width, int height, float *mr, float *mg, float *mb, float *md, int *pure,
                       int *oi, int *oj, int *own_k)
{
    int nb = 0;
    for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
            int x0 = (bi + di) * kx + px, y0 = (bj + dj) * ky + py;
            int xa = max(x0, 0), xb = min(x0 + kx, width), ya = max(y0, 0), yb = min(y0 + ky, height);
            float r = 0.0f, g = 0.0f, b = 0.0f, n = 0.0f;
            for (int y = ya; y < yb; ++y)
                for (int x = xa; x < xb; ++x) {
                    float4 q = image[y * width + x];
                    r += q.x; g += q.y; b += q.z; n += 1.0f;
                }
            if (n == 0.0f) continue;
            r /= n; g /= n; b /= n;
            float mn = fabs(r) + fabs(g) + fabs(b), spread = 0.0f;
            for (int y = ya; y < yb; ++y)
                for (int x = xa; x < xb; ++x) {
                    float4 q = image[y * width + x];
                    spread = fmax(spread, (fabs(q.x - r) + fabs(q.y - g) + fabs(q.z - b))
                                          / (fabs(q.x) + fabs(q.y) + fabs(q.z) + mn + 1e-6f));
                }
            *own_k = (di == 0 && dj == 0) ? nb : *own_k;
            mr[nb] = r; mg[nb] = g; mb[nb] = b; md[nb] = d[dj + 1][di + 1]; pure[nb] = spread <= PURE_TOL;
            oi[nb] = di; oj[nb] = dj;
            ++nb;
        }
    return nb;
}

/* Which of the nb blocks (edge_blocks) gives its depth to a pixel of colour p; *mid: the
 * middle of their 1 / depth range, which parts the nearer surface from the farther. */
inline int edge_pick(float4 p, const float *mr, const float *mg, const float *mb, const float *md,
                     const int *pure, int nb, int own_k, float *mid_out)
{
    float pn = fabs(p.x) + fabs(p.y) + fabs(p.z) + 1e-6f;
    /* a pure block of the pixel's colour: its depth */
    float ilo = INFINITY, ihi = 0.0f, best_pure = INFINITY, any_best = INFINITY;
    int at_pure = own_k, at_any = own_k;
    for (int k = 0; k < nb; ++k) {
        float dist = (fabs(p.x - mr[k]) + fabs(p.y - mg[k]) + fabs(p.z - mb[k])) / (pn + fabs(mr[k]) + fabs(mg[k]) + fabs(mb[k]));
        dist -= k == own_k ? 1e-3f : 0.0f;      /* the own block wins a tie */
        if (pure[k] && dist < best_pure) { best_pure = dist; at_pure = k; }
        if (dist < any_best) { any_best = dist; at_any = k; }
        ilo = fmin(ilo, 1.0f / md[k]); ihi = fmax(ihi, 1.0f / md[k]);
    }
    int best = best_pure <= SINGLE_TOL ? at_pure : at_any;
    /* else the pixel as a mix of a nearer and a farther surface (anti-aliased edges are): of
     * every pair of a pure block nearer than the middle of the blocks' 1 / depth range and a
     * pure one farther, the mix a c_near + (1 - a) c_far nearest the pixel's colour (relative
     * L1; among those within PAIR_SLACK of the best, the pair with an end nearest the pixel);
     * the nearer's depth where a >= 1/2, as a depth sampled at the pixel's centre has. The
     * nearest block alone put a half-covered sky pixel beside a half-covered block on the
     * building (skyline-sea with a replicated depth: 0.062 relative L1; lamps' edges: 0.03-0.04).
     * Without a pure block on each side (texture) the nearest block's depth. */
    float mid = 0.5f * (ilo + ihi), best_res = INFINITY, best_end = INFINITY;
    for (int pass = best_pure <= SINGLE_TOL ? 2 : 0; pass < 2; ++pass) {
        float bound = best_res + PAIR_SLACK;
        for (int k = 0; k < nb; ++k) {
            if (!pure[k] || 1.0f / md[k] <= mid) continue;
            for (int m = 0; m < nb; ++m) {
                if (!pure[m] || 1.0f / md[m] > mid) continue;
                float sr = mr[k] - mr[m], sg = mg[k] - mg[m], sb = mb[k] - mb[m];
                float s2 = sr * sr + sg * sg + sb * sb;
                float a = s2 > 1e-12f ? ((p.x - mr[m]) * sr + (p.y - mg[m]) * sg + (p.z - mb[m]) * sb) / s2 : 1.0f;
                a = clamp(a, 0.0f, 1.0f);
                float res = (fabs(p.x - mr[m] - a * sr) + fabs(p.y - mg[m] - a * sg) + fabs(p.z - mb[m] - a * sb)) / pn;
                if (pass == 0) { best_res = fmin(best_res, res); continue; }
                float end = fmin(fabs(p.x - mr[k]) + fabs(p.y - mg[k]) + fabs(p.z - mb[k]),
                                 fabs(p.x - mr[m]) + fabs(p.y - mg[m]) + fabs(p.z - mb[m])) / pn;
                if (res <= bound && end < best_end) { best_end = end; best = a >= 0.5f ? k : m; }
            }
        }
    }
    *mid_out = mid;
    return best;
}

/* d: the 3 x 3 blocks' depths around the pixel's block (bi, bj of the grid kx x ky starting
 * at px, py); p: its colour; fx, fy: its offset from its block's centre, in blocks. */
inline float edge_depth(__global const float4 *image, float d[3][3], float4 p, int bi, int bj, int kx, int ky,
                        int px, int py, int width, int height, float fx, float fy)
{
    float mr[9], mg[9], mb[9], md[9], mid;
    int pure[9], oi[9], oj[9], own_k = 0;
    int nb = edge_blocks(image, d, bi, bj, kx, ky, px, py, width, height, mr, mg, mb, md, pure, oi, oj, &own_k);
    int best = edge_pick(p, mr, mg, mb, md, pure, nb, own_k, &mid);
    /* The chosen block's surface carried on to the pixel, linear in 1 / depth with its slope
     * toward a neighbour block of the same surface (below), along each axis: a block's depth copied to
     * the pixels at an edge left flat steps there, which the view cosines (taken after this)
     * read as surfaces facing the camera (a box face at 82 degrees: cosine 0.93, not 0.15) */
    int bdi = oi[best] + 1, bdj = oj[best] + 1;
    float ib = 1.0f / md[best], q = ib;
    int near_side = ib > mid;
    fx -= (float)oi[best];
    fy -= (float)oj[best];
    for (int axis = 0; axis < 2; ++axis) {
        float f = axis == 0 ? fx : fy;
        for (int t = 0; t < 2; ++t) {
            int step = (t == 0) == (f >= 0.0f) ? -1 : 1;      /* away from the pixel first */
            int a = axis == 0 ? bdj : bdj + step, b = axis == 0 ? bdi + step : bdi;
            if (a < 0 || a > 2 || b < 0 || b > 2) continue;
            int x0 = (bi + b - 1) * kx + px, y0 = (bj + a - 1) * ky + py;
            if (x0 + kx <= 0 || x0 >= width || y0 + ky <= 0 || y0 >= height) continue;   /* past the frame */
            float inb = 1.0f / d[a][b];
            /* the same surface: on the chosen block's side of mid and within a factor 2 of it
             * (a third layer or the sky on that side is not its continuation) */
            if ((inb > mid) != near_side || !(fabs(inb - ib) <= 0.5f * ib)) continue;
            q += f * (inb - ib) * (float)step;
            break;
        }
    }
    float z = 1.0f / q;
    return (z > 0.0f && z < INFINITY) ? z : md[best];
}

/* A depth enlarged by nearest neighbour (preprocess.block_grid: blocks of kx x ky pixels whose
 * grid starts at px, py) puts edges up to a block off: a small lamp's pixels take the wall's
 * depth, and its light the wall's medium (lamps-fog with such a depth: 0.20 relative L1).
 * Where the 3 x 3 blocks around a pixel hold a depth edge (their depths span more than
 * 1 + tol, and its own block's second difference of 1 / depth along x or y exceeds tol of
 * its 1 / depth: a plane is linear in 1 / depth, so a ground's far rows, steep and curved in
 * depth, are no edge), the pixel takes the depth of a block among them by its colour: a
 * uniform block of its colour, or the nearer or the farther of the two uniform blocks whose
 * colours, mixed, explain its own, carried on along that block's surface (below).
 * Elsewhere (a surface) the depth goes smoothly between the blocks' centres. The view
 * cosines are taken from what this writes (preprocess.preprocess). */
__kernel void realign_blocks(__global const float *depth, __global const float4 *image, __global float *out,
                             const int width, const int height, const int kx, const int ky, const int px,
                             const int py, const float tol)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    int idx = j * width + i;
    /* the own block's index (floor division: the grid may start inside the frame) */
    int bi = (i - px + kx * width) / kx - width, bj = (j - py + ky * height) / ky - height;
    float d[3][3];
    for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di)
            d[dj + 1][di + 1] = depth[clampi_((bj + dj) * ky + py, 0, height - 1) * width
                                      + clampi_((bi + di) * kx + px, 0, width - 1)];
    float own = depth[idx], lo = own, hi = own;
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) { lo = fmin(lo, d[a][b]); hi = fmax(hi, d[a][b]); }
    float c = d[1][1], ic = 1.0f / c;
    /* a block past the frame's edge continues the ramp (its clamped read is the own block's),
     * in 1 / depth as the test and the interpolation below: continued in depth, a grazing
     * ground's outermost blocks read as an edge */
    int xl = (bi - 1) * kx + px + kx <= 0, xr = (bi + 1) * kx + px >= width;
    int yu = (bj - 1) * ky + py + ky <= 0, yd = (bj + 1) * ky + py >= height;
    float il = xl ? 2.0f * ic - 1.0f / d[1][2] : 1.0f / d[1][0];
    float ir = xr ? 2.0f * ic - 1.0f / d[1][0] : 1.0f / d[1][2];
    float iu = yu ? 2.0f * ic - 1.0f / d[2][1] : 1.0f / d[0][1];
    float iv = yd ? 2.0f * ic - 1.0f / d[0][1] : 1.0f / d[2][1];
    /* at the frame's edge the continued ramp is a plane by construction: there the second
     * difference is taken about the inner neighbour (one block further in) */
    float cx = fabs(il - 2.0f * ic + ir), cy = fabs(iu - 2.0f * ic + iv);
    if (xl | xr) {
        int o = xl ? 1 : -1;
        float f2 = depth[clampi_(bj * ky + py, 0, height - 1) * width + clampi_((bi + 2 * o) * kx + px, 0, width - 1)];
        cx = fabs(ic - 2.0f / d[1][1 + o] + 1.0f / f2);
    }
    if (yu | yd) {
        int o = yu ? 1 : -1;
        float f2 = depth[clampi_((bj + 2 * o) * ky + py, 0, height - 1) * width + clampi_(bi * kx + px, 0, width - 1)];
        cy = fabs(ic - 2.0f / d[1 + o][1] + 1.0f / f2);
    }
    float curve = fmax(cx, cy);
    /* the pixel's offset from its block's centre, in blocks */
    float fx = ((float)(i - bi * kx - px) + 0.5f) / (float)kx - 0.5f;
    float fy = ((float)(j - bj * ky - py) + 0.5f) / (float)ky - 0.5f;
    if (!(hi > lo * (1.0f + tol) && curve > tol / c)) {
        /* no edge: the surface between the blocks' samples, taken at the blocks' centres (a
         * sensor's pixel centres), linear in 1 / depth (a plane's is, in planar depth) toward
         * the nearer neighbour along each axis. On a grazing ground every other row holding the
         * farther row's depth put ground-fog's Lambertian output 0.029 off the smooth depth's */
        float inx = fx < 0.0f ? il : ir, iny = fy < 0.0f ? iu : iv;
        float q = 1.0f / own + fabs(fx) * (inx - ic) + fabs(fy) * (iny - ic);
        float z = 1.0f / q;
        out[idx] = (z > 0.0f && z < INFINITY) ? z : own;
        return;
    }
    out[idx] = edge_depth(image, d, image[idx], bi, bj, kx, ky, px, py, width, height, fx, fy);
}

#endif
