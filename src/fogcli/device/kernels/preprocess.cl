/* Stage 1: split the input into attenuated, scattered and medium terms (docs/conventions.md, Per pixel, 4.3;
 * Elek sec. 3.2 with the thesis' eq. 4.4-4.5, Iser eq. 4.29, Delalandre eq. 7).
 * Depth arrives raw (as stored in the file, holes already filled); the camera model
 * turns it into a ray length here so that a z-buffer never reaches the physics. */
#include "common.h"
#include "density.h"
#include "medium.h"

#ifndef CAM_Z
#define CAM_Z 0     /* 1: the depth is planar (camera.depth is not distance) */
#endif


#ifdef EMISSION_LAMBERT
/* Camera-space point of pixel (i, j), clamped to the image (inner: known to be inside);
 * unclamped depth (surfaces) */
__attribute__((always_inline)) inline void cam_point(const camera_t *c, __global const float *depth, int w, int h,
                                                     int i, int j, int inner,
                      float *x, float *y, float *z)
{
    i = inner ? i : clampi_(i, 0, w - 1);
    j = inner ? j : clampi_(j, 0, h - 1);
    float dx = (i + 0.5f - c->cx) / c->focal_px, dy = -(j + 0.5f - c->cy) / c->focal_y;
    float dlen = SQRT_(dx * dx + dy * dy + 1.0f);
    float s = depth[j * w + i] * (c->depth_is_z ? 1.0f : 1.0f / dlen);   /* planar depth */
    *x = dx * s; *y = dy * s; *z = -s;
}

/* A pixel whose depth steps on both sides along an axis go opposite ways (nearer or
 * farther than both neighbours) and are each steeper than `steep` times the spacing:
 * something narrower than the step (a lamp, a pole, one block of a staircase) stands apart
 * from what surrounds it, and neither side is its surface. It is taken as facing the
 * camera along that axis (the neighbours moved to its depth): a garbage grazing normal
 * would multiply a small bright lamp's light by the table's largest weight. Returns 1 or 0
 * (the share to move them by). dz_f, dz_b: the forward and backward steps of camera z, pz
 * this pixel's, spacing: the step's width over the focal length (lateral distance per unit
 * depth). Comparisons only, and a blend by the result: with a branch, selects, or a ramp
 * between two limits PoCL did not vectorise view_cosines_inner (1.9 -> 9-22 ms at 2 MPx). */
__attribute__((always_inline)) inline float isolated(float dz_f, float dz_b, float pz, float spacing, float steep)
{
    float lim = steep * spacing * absf_(pz);
    return (float)(((dz_f > lim) & (dz_b < -lim)) | ((dz_f < -lim) & (dz_b > lim)));
}

/* |cos| between the surface normal and the line to the camera. The normal comes from the
 * depth map with, along each axis, the one-sided difference whose depth step is smaller,
 * so that a depth edge does not tilt the surfaces on either side of it. The differences
 * span sx columns and sy rows: a depth map upsampled by nearest neighbour is a staircase
 * of sx x sy blocks (preprocess.staircase finds them), whose one-pixel steps are flat or
 * a whole block's rise; over a block they are the surface's slope (on a regular grid of
 * blocks realign_blocks rebuilds the depth first, and the steps are 1). Sky and anything that
 * is not finite count as facing the camera. inner (a constant): the neighbours sx, sy away
 * are inside the image. */
__attribute__((always_inline)) inline float view_cosine(const camera_t *c, __global const float *depth, int w, int h,
                                                        int i, int j, int inner, int sx, int sy, float steep)
{
    float px, py, pz, ax, ay, az, bx, by, bz;
    cam_point(c, depth, w, h, i, j, inner, &px, &py, &pz);
    cam_point(c, depth, w, h, i + sx, j, inner, &ax, &ay, &az);
    cam_point(c, depth, w, h, i - sx, j, inner, &bx, &by, &bz);
    /* at the image's edge the inward side (clamped: the other may reach no pixel) */
    int fwd = inner ? absf_(az - pz) < absf_(pz - bz)
                    : i + sx < w && (i < sx || absf_(az - pz) < absf_(pz - bz));
    float iso = isolated(az - pz, pz - bz, pz, sx / c->focal_px, steep);
    float k = iso * (pz / (fwd ? az : bz)) + (1.0f - iso);     /* exactly 1 or the ratio */
    float ux = fwd ? k * ax - px : px - k * bx, uy = fwd ? k * ay - py : py - k * by, uz = fwd ? k * az - pz : pz - k * bz;
    cam_point(c, depth, w, h, i, j + sy, inner, &ax, &ay, &az);
    cam_point(c, depth, w, h, i, j - sy, inner, &bx, &by, &bz);
    fwd = inner ? absf_(az - pz) < absf_(pz - bz) : j + sy < h && (j < sy || absf_(az - pz) < absf_(pz - bz));
    iso = isolated(az - pz, pz - bz, pz, sy / c->focal_y, steep);
    k = iso * (pz / (fwd ? az : bz)) + (1.0f - iso);
    float vx = fwd ? k * ax - px : px - k * bx, vy = fwd ? k * ay - py : py - k * by, vz = fwd ? k * az - pz : pz - k * bz;
    if (w == 1) { ux = 1.0f; uy = 0.0f; uz = 0.0f; }
    if (h == 1) { vx = 0.0f; vy = 1.0f; vz = 0.0f; }
    float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    float cosv = absf_(nx * px + ny * py + nz * pz)
               / SQRT_((nx * nx + ny * ny + nz * nz) * (px * px + py * py + pz * pz));
    return (cosv == cosv && cosv <= 1.0f) ? cosv : 1.0f;   /* NaN (sky, flat zero) */
}

/* Stage 1a' (a noisy depth, preprocess.depth_noise): the depth the view cosines read,
 * smoothed along one axis (smooth_depth runs along x, then along y). A sensor's noise of
 * 0.5 % turns one-pixel differences into random grazing normals (the Lambertian weight then
 * multiplies whole surfaces that face the camera).
 * smoothed: the depth of the pixel at idx, at position `at` along a line of n pixels
 * `stride` apart, replaced by a line fitted to the run of its neighbours (below). A pixel
 * whose depth is not finite, or past max_depth, keeps it. inner (a constant): the radius
 * pixels on each side are inside the line, so the reads go unclamped (linear in the
 * work-item: vector loads, not gathers). */
__attribute__((always_inline)) inline float smoothed(__global const float *src, int idx, int at, int n, int stride,
                                                     int inner, int radius, float tau, float dist, float max_depth)
{
    float z = src[idx];
    float lim = dist < max_depth ? tau * z : -1.0f;
    /* the sky (max_depth and beyond) is neither smoothed nor a neighbour: it stays the sky
     * that view_cosines gives a cosine of 1, and its stand-in depth is no surface's. far:
     * the depth at which this pixel's ray reaches max_depth, for the neighbours too (their
     * rays are within radius pixels of it; a root per neighbour cost 5x) */
    float far = z * (max_depth / dist) - z;
    float zf = src[idx + (inner ? 1 : clampi_(at + 1, 0, n - 1) - at) * stride];
    float zb = src[idx - (inner ? 1 : at - clampi_(at - 1, 0, n - 1)) * stride];
    float ef = zf - z, eb = z - zb;
    float c = absf_(ef - eb) <= lim ? 0.5f * (ef + eb) : (absf_(ef) < absf_(eb) ? ef : eb);
    /* outwards on each side while every step is the centre's slope within 2 lim and the
     * offset from its line within lim (1 + o / 2): a ramp (a grazing surface) goes on, noise
     * does, a depth edge ends the run (with the line's test alone a small lamp took in the
     * wall behind it at 1 % noise; with the steps' alone a Kinect's quantised far floor
     * stopped at every step) */
    float s0 = lim >= 0.0f ? 1.0f : 0.0f, s1 = 0.0f, s2 = 0.0f, t0 = 0.0f, t1 = 0.0f;
    for (int side = -1; side <= 1; side += 2) {
        float prev = 0.0f, step = side * c;
        int go = lim >= 0.0f;
        for (int o = 1; o <= radius; ++o) {
            int k = at + side * o;
            go = go && (inner || (k >= 0 && k < n));
            float zn = src[idx + (inner ? side * o : clampi_(k, 0, n - 1) - at) * stride] - z;
            go = go && absf_(zn - prev - step) <= 2.0f * lim && absf_(zn - o * step) <= lim * (1.0f + 0.5f * o)
                 && zn < far;
            float fo = (float)(side * o), wn = (float)go;
            s0 += wn; s1 += wn * fo; s2 += wn * fo * fo;
            t0 += go ? zn : 0.0f; t1 += go ? zn * fo : 0.0f;    /* not wn * zn: zn is inf past the sky */
            prev = go ? zn : prev;
        }
    }
    /* a run shorter than radius + 1 (a lamp, a pole a few pixels wide) has no slope the
     * noise leaves: its mean, flat, faces the camera (as an isolated pixel does) */
    float det = s0 * s2 - s1 * s1;
    float a = det > 0.5f && s0 > radius + 0.5f ? (t0 * s2 - t1 * s1) / det : (s0 > 0.0f ? t0 / s0 : 0.0f);
    return z + a;
}

__kernel void smooth_depth(__global const float *src, __global float *dst, const int width, const int height,
                           const int along_y, const int radius, const float tau, const camera_t cam)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    int idx = j * width + i;
    float wx, wy, wz;
    float dist = pixel_ray(&cam, i, j, src[idx], &wx, &wy, &wz);
    dst[idx] = smoothed(src, idx, along_y ? j : i, along_y ? height : width, along_y ? width : 1, 0, radius, tau,
                        dist, cam.max_depth);
}

/* smooth_depth's interior along x (along y), on whole work-groups of the rectangle
 * preprocess.py gives (Plan.launch_inner): the pixels radius or more from the left and
 * right (top and bottom) edges */
__kernel void smooth_depth_x_inner(__global const float *src, __global float *dst, const int width, const int height,
                                   const int along_y, const int radius, const float tau, const camera_t cam)
{
    int i = get_global_id(0), j = get_global_id(1), idx = j * width + i;
    float wx, wy, wz;
    float dist = pixel_ray(&cam, i, j, src[idx], &wx, &wy, &wz);
    dst[idx] = smoothed(src, idx, i, width, 1, 1, radius, tau, dist, cam.max_depth);
}

__kernel void smooth_depth_y_inner(__global const float *src, __global float *dst, const int width, const int height,
                                   const int along_y, const int radius, const float tau, const camera_t cam)
{
    int i = get_global_id(0), j = get_global_id(1), idx = j * width + i;
    float wx, wy, wz;
    float dist = pixel_ray(&cam, i, j, src[idx], &wx, &wy, &wz);
    dst[idx] = smoothed(src, idx, j, height, width, 1, radius, tau, dist, cam.max_depth);
}

/* Stage 1a (emission_profile: lambertian): the view cosine of every pixel, in a kernel of
 * its own so that the neighbour reads and their branches do not keep the preprocess
 * kernel from being vectorised. */
__kernel void view_cosines(__global const float *depth, __global float *cosv, const int width,
                           const int height, const camera_t cam, const int sx, const int sy, const float steep)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    float wx, wy, wz;
    float dist = pixel_ray(&cam, i, j, depth[j * width + i], &wx, &wy, &wz);
    /* sky and anything at max_depth: a dome facing the camera */
    float v = view_cosine(&cam, depth, width, height, i, j, 0, sx, sy, steep);  /* evaluated everywhere: no conditional loads */
    cosv[j * width + i] = dist < cam.max_depth ? v : 1.0f;
}

/* view_cosines' interior (every pixel whose neighbours sx, sy away are inside the image),
 * on whole work-groups of the rectangle preprocess.py gives (Plan.launch_inner): no
 * clamped reads, so the loads are linear in the work-item and PoCL vectorises it
 * (view_cosines' clamped neighbour reads are gathers). */
__kernel void view_cosines_inner(__global const float *depth, __global float *cosv, const int width,
                                 const int height, const camera_t cam, const int sx, const int sy,
                                 const float steep)
{
    int i = get_global_id(0), j = get_global_id(1);
#if CAM_Z
    /* Planar depth: a point is z (rx, ry, -1), and a neighbour's ray differs from this
     * pixel's by sx (sy) reciprocal focal lengths, so the five points need no square root
     * and no division (view_cosine's per-point ones made this kernel compute-bound). The
     * cosine does not depend on the scale of p, so p is the ray. */
    float ifx = 1.0f / cam.focal_px, ify = 1.0f / cam.focal_y;
    float rx = (i + 0.5f - cam.cx) * ifx, ry = -(j + 0.5f - cam.cy) * ify;
    float dx = sx * ifx, dy = sy * ify;
    int idx = j * width + i, row = sy * width;
    float z = depth[idx], zr = depth[idx + sx], zl = depth[idx - sx], zd = depth[idx + row], zu = depth[idx - row];
    /* the steps to the neighbours, z's own magnitude left out (exact where the depths are
     * far apart: an isolated pixel's zeroed steps are zero, not a far neighbour's rounding) */
    float er = zr - z, el = z - zl, ed = zd - z, eu = z - zu;
    int fx = absf_(er) < absf_(el), fy = absf_(ed) < absf_(eu);
    /* isolated (camera z is -z): the neighbours moved to this depth */
    float kx = 1.0f - isolated(-er, -el, z, dx, steep), ky = 1.0f - isolated(-ed, -eu, z, dy, steep);
    er *= kx; el *= kx; ed *= ky; eu *= ky;
    /* u = P(i+sx) - P(i) or P(i) - P(i-sx); v likewise down the rows (ray y falls by dy).
     * Each select picks a finished value: a select used in arithmetic after it (-(fx ? er :
     * el)) kept PoCL from vectorising this on AVX2 (2 -> 20 ms at 2 MPx) */
    float ux = fx ? er * (rx + dx) + z * dx : el * (rx - dx) + z * dx;
    float uy = fx ? er * ry : el * ry;
    float uz = fx ? -er : -el;
    float vx = fy ? ed * rx : eu * rx;
    float vy = fy ? ed * (ry - dy) - z * dy : eu * (ry + dy) - z * dy;
    float vz = fy ? -ed : -eu;
    float nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    float r2 = rx * rx + ry * ry + 1.0f;
    float v = absf_(nx * rx + ny * ry - nz) / SQRT_((nx * nx + ny * ny + nz * nz) * r2);
    v = (v == v && v <= 1.0f) ? v : 1.0f;   /* NaN (sky, flat zero) */
    cosv[idx] = z * z * r2 < cam.max_depth * cam.max_depth ? v : 1.0f;
#else
    float wx, wy, wz;
    float dist = pixel_ray(&cam, i, j, depth[j * width + i], &wx, &wy, &wz);
    float v = view_cosine(&cam, depth, width, height, i, j, 1, sx, sy, steep);
    cosv[j * width + i] = dist < cam.max_depth ? v : 1.0f;
#endif
}
#endif

/* realign_blocks (a nearest-neighbour-enlarged depth) and light_share_depth (edges by
 * the light of each side) */
#include "realign.h"
#include "light_share.h"

/* What a plan writes besides direct and scat0 is fixed when it is built (-D PRE_SOURCE,
 * PRE_SEP, PRE_SPLIT_MEDIUM, PRE_TRANSMITTANCE, each 0 or 1; left out, 0): a store under a
 * run-time flag is a masked store, which kept PoCL from vectorising this kernel on AVX2
 * (3x slower; tools/pocl_vectorisation.py has the pattern). */
#ifndef PRE_SOURCE
#define PRE_SOURCE 0
#endif
#ifndef PRE_SEP
#define PRE_SEP 0
#endif
#ifndef PRE_SPLIT_MEDIUM
#define PRE_SPLIT_MEDIUM 0
#endif
#ifndef PRE_TRANSMITTANCE
#define PRE_TRANSMITTANCE 0
#endif
/* the Gaussian spread of level 0: read by the Gaussian chains and the spread and level
 * AOVs; the apsf source collapse does without it (1 unless the plan leaves it out) */
#ifndef PRE_SPREAD
#define PRE_SPREAD 1
#endif
/* render.ground found a ground (device/ground.py): its slab's light is added from
 * ground_table (slab_table, ground.cl: SLAB_MU x SLAB_NU float4 over mu_v and u), and the
 * ground's (gcolour) and the sky's (scolour; .w: the ray length from which a ray above the
 * horizon is sky) mean colours leave their pixels' sources. gplane: the ground's unit
 * normal (world orientation) and the camera's height above it. */
#ifndef PRE_GROUND
#define PRE_GROUND 0
#endif

#if PRE_GROUND
#include "slab.h"
#endif
__kernel void preprocess(__global const float4 *image, __global const float *depth,
                         __global float4 *direct, __global float4 *scat0,
                         __global float *spread0, __global float4 *medium_term,
                         __global float4 *transmittance,
                         const int width, const int height, const medium_t m,
                         __global float4 *prep0, const float thresh1,
                         const float eps, __global float4 *sep_chain0, __global float4 *sep_prep0,
                         const float4 sep_par, __global const float *lut,
                         __global const float *cosines, __global const float4 *ground_table,
                         const float4 gplane, const float4 gcolour, const float4 scolour)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (OUTSIDE(i, j, width, height)) return;
    int idx = j * width + i;

    float wx, wy, wz;
    float dist = pixel_ray(&m.cam, i, j, depth[idx], &wx, &wy, &wz);
    /* spread0 is read before it is overwritten below, by this work-item only */
    float P = m.homogeneous * dist + (m.has_p ? spread0[idx] : 0.0f);
    /* per channel, scalar and with polynomial exponentials: PoCL vectorises the kernel
     * across work-items only without builtin calls and float3 arithmetic */
    float L[3], alpha;
    load4(image, idx, &L[0], &L[1], &L[2], &alpha);
    MEDIUM_RATES(m, sa, ss);
    float le[3] = {m.emission.x, m.emission.y, m.emission.z};
    float la[3] = {m.ambient.x, m.ambient.y, m.ambient.z};
    float at[3], sc[3], med[3], tr[3];
#if PRE_GROUND
    /* a ground pixel (within physics/ground.py's plane_tolerance, below the horizon) or a sky
     * pixel spreads only what differs from their mean colour, which the slab carries (below).
     * Selects and products, no branch: PoCL vectorises this kernel across work-items */
    float mu = gplane.x * wx + gplane.y * wy + gplane.z * wz;
    float above = dist * mu + gplane.w;
    float tol = GROUND_TOL_H * gplane.w + (GROUND_TOL_D + GROUND_TOL_PX / m.cam.focal_px) * dist;
    float on_ground = (above < tol ? 1.0f : 0.0f) * (above > -tol ? 1.0f : 0.0f) * (mu < 0.0f ? 1.0f : 0.0f);
    float in_sky = (dist >= scolour.w ? 1.0f : 0.0f) * (mu > 0.0f ? 1.0f : 0.0f);
    float mean[3] = {on_ground * gcolour.x + in_sky * scolour.x, on_ground * gcolour.y + in_sky * scolour.y,
                     on_ground * gcolour.z + in_sky * scolour.z};
#else
    float mean[3] = {0.0f, 0.0f, 0.0f};
#endif
    for (int c = 0; c < 3; ++c) {
        float st = sa[c] + ss[c];
        float t_all = exp_poly(-st * P);
        tr[c] = t_all;
        at[c] = t_all * L[c];
        /* exp(-sa P)(1 - exp(-ss P)) = exp(-sa P) - exp(-st P); the thesis form (docs/conventions.md, Per pixel) */
        sc[c] = (exp_poly(-sa[c] * P) - t_all) * (L[c] - mean[c]);
        /* 1 - exp(-st P) by its series in thin media; st -> 0 limits: emission grows as
         * P, ambient vanishes */
        float one_minus = one_minus_exp(st * P);
        float em_w = st > 0.0f ? one_minus / st : P;
        float amb_w = st > 0.0f ? ss[c] / st * one_minus : 0.0f;
        med[c] = m.has_medium_light ? le[c] * em_w + la[c] * amb_w : 0.0f;
    }
#if PRE_GROUND
    {
        /* the slab's light along this ray */
        float g0, g1, g2;
#ifdef MEDIUM_GREY
        /* one u for the three channels: one bilinear position */
        slab_light3(ground_table, mu, one_minus_exp((sa[0] + ss[0]) * P), &g0, &g1, &g2);
#else
        g0 = slab_light(ground_table, mu, one_minus_exp((sa[0] + ss[0]) * P), 0);
        g1 = slab_light(ground_table, mu, one_minus_exp((sa[1] + ss[1]) * P), 1);
        g2 = slab_light(ground_table, mu, one_minus_exp((sa[2] + ss[2]) * P), 2);
#endif
        med[0] += g0; med[1] += g1; med[2] += g2;
    }
#endif

    float sigma = spread_px(P, dist, m.sa.w, m.ss.w, m.g, m.spread_scale, m.cam.focal_px,
                            (float)width);
#ifdef PSF_APSF
    /* radiative transfer: the scattered energy is the thin-medium form times the table's
     * ratio (lower where long multiply scattered paths absorb more); the chain carries
     * log P, from which every level reads its shares */
    float lp = log_pos(P > 1e-30f ? P : 1e-30f);
    int nlev = (int)lut[3];
    float lf;
    int li = lut_pos(lut, lp, &lf);
    float e0, e1, e2;
    apsf_energy(lut, nlev, li, lf, VIEW_COS(cosines, idx), &e0, &e1, &e2);
    sc[0] *= e0; sc[1] *= e1; sc[2] *= e2;
#if PRE_SOURCE
    /* level 0's shares passed up (store_prep_apsf's), read here with the other table reads:
     * after the stores below LLVM must assume they changed the table and reads it again,
     * by gathers (measured ~7 ms of the stage at 2 MPx) */
    float up0 = lut_get(lut, lut_updown(0, 0, 0), li, lf), up1 = lut_get(lut, lut_updown(0, 1, 0), li, lf),
          up2 = lut_get(lut, lut_updown(0, 2, 0), li, lf);
#endif
    float wv = lp;
#else
    float wv = sigma;
#endif

    /* emission and ambient travel in `direct` unless an AOV wants them apart: one buffer
     * less to write here and to read in the composite */
    float keep = PRE_SPLIT_MEDIUM ? 0.0f : 1.0f;
    store4(direct, idx, at[0] + keep * med[0], at[1] + keep * med[1], at[2] + keep * med[2], alpha);
#if PRE_SEP
    {
        /* Iser eq. 4.25: bright (luminance of L above sep_par.x, width .y) and near (D' = P
         * below .z, width .w) pixels get a chain of their own */
        float ms = smoothstep_(sep_par.x, sep_par.x + sep_par.y,
                               LUMA_R * L[0] + LUMA_G * L[1] + LUMA_B * L[2])
                 * (1.0f - smoothstep_(sep_par.z - sep_par.w, sep_par.z, P));
        float l0 = ms * sc[0], l1 = ms * sc[1], l2 = ms * sc[2];
        sc[0] -= l0; sc[1] -= l1; sc[2] -= l2;
        store4(sep_chain0, idx, l0, l1, l2, wv);
#ifdef PSF_APSF
        store_prep_apsf(sep_prep0, idx, l0, l1, l2, lp, lut, 0);
#else
        store_prep(sep_prep0, idx, l0, l1, l2, sigma, thresh1, eps);
#endif
    }
#endif
    store4(scat0, idx, sc[0], sc[1], sc[2], wv);
#if PRE_SPREAD
    spread0[idx] = sigma;
#endif
#if PRE_SPLIT_MEDIUM
    store4(medium_term, idx, med[0], med[1], med[2], P);
#endif
#if PRE_TRANSMITTANCE
    store4(transmittance, idx, tr[0], tr[1], tr[2], 1.0f);
#endif
#if PRE_SOURCE && defined(PSF_APSF)
    store4(prep0, idx, up0 * sc[0], up1 * sc[1], up2 * sc[2], lp);
#elif PRE_SOURCE
    store_prep(prep0, idx, sc[0], sc[1], sc[2], sigma, thresh1, eps);
#endif
}

/* Stage 1b (inputs with alpha): the output alpha of a premultiplied pixel. Its uncovered
 * part (1 - alpha) looks at camera.empty_depth; a plate composited there afterwards reaches
 * the camera as the model carries a source at that depth: transmitted plus scattered
 * (the scattered energy x the point-spread ratio, a surface facing the camera), weighted by
 * luminance. So out.a = 1 - (1 - a) t_e, and compositing the result over a smooth plate
 * equals processing the plate at that depth. P_empty: the heterogeneous primitives' optical
 * depth to empty_depth (has_p), else the homogeneous part alone. */
__kernel void coverage(__global float4 *direct, __global const float *P_empty, const int has_p,
                       const int width, const int height, const medium_t m, const float empty_depth,
                       __global const float *lut)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float4 d = direct[idx];
    if (d.w >= 1.0f) return;
    float wx, wy, wz;
    float dist = pixel_ray(&m.cam, i, j, empty_depth, &wx, &wy, &wz);
    float P = m.homogeneous * dist + (has_p ? P_empty[idx] : 0.0f);
    MEDIUM_RATES(m, sa, ss);
    float lum[3] = {LUMA_R, LUMA_G, LUMA_B};
    float r[3] = {1.0f, 1.0f, 1.0f};
#ifdef PSF_APSF
    float lp = log_pos(P > 1e-30f ? P : 1e-30f);
    int nlev = (int)lut[3];
    float lf;
    int li = lut_pos(lut, lp, &lf);
    apsf_energy(lut, nlev, li, lf, 1.0f, &r[0], &r[1], &r[2]);     /* as preprocess, facing the camera */
#endif
    float te = 0.0f;
    for (int c = 0; c < 3; ++c) {
        float t_all = exp_poly(-(sa[c] + ss[c]) * P);
        te += lum[c] * (t_all + (exp_poly(-sa[c] * P) - t_all) * r[c]);
    }
    te = te < 1.0f ? te : 1.0f;
    direct[idx].w = 1.0f - (1.0f - d.w) * te;
}
