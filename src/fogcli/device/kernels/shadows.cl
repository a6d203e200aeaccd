/* Stage 1d (lights, shadows: screen): the visible surfaces of the depth map as occluders of
 * a light (docs/lights.md, Shadows). A point y on a pixel's ray is in shadow when its segment
 * to the light passes behind a visible surface within `thickness` metres of it:
 *
 *   z(q) + b(q) < z(x) < z(q) + thickness,   b(q) = min(max(0.05 m, 0.01 z(q)), thickness / 4)
 *
 * in depth along the view axis, at the pixel q (nearest) where the segment's point x is
 * seen; b keeps a surface from shadowing itself. Occluder points within max(0.05 m, 2 % of
 * the light's distance, 2 radii) of the light do not count (a lamp found in the image sits
 * just behind its own pixels).
 *
 * Every segment from a point of pixel p's ray to the light lies in the plane of the camera,
 * the light and that ray, so they all project onto one image line, from p towards the
 * light's image (the epipole; away from its antipode for a light behind the camera, along
 * the light's direction when it lies in the camera plane). Walking that line once, each
 * pixel q blocks one interval of the ray: the points whose segments pass behind q's surface.
 * With the ray cut into SH_N cells uniform in phi (points, spots: s = d1 + R tan phi, where
 * the airlight's integrand is smooth) or in s (directional), visibility is a bit mask of
 * SH_SUB bits per cell. What the light still gives is the lit share of the airlight's own
 * integrand (al_integrand at the cells' middles, times each cell's open share), for the
 * light reaching the camera (camera leg in extinction) and for all of it (in absorption),
 * applied to the light's a_dir and a_sc from whichever airlight kernel made them: an
 * unshadowed pixel keeps its value exactly. shadow_march does this for every pixel
 * (render.lights.method: march, the reference); epi_samples / epi_unwarp at samples on
 * epipolar lines, interpolated (method: epipolar, below). */
#include "density.h"
#include "lights.h"

#include "shadows.h"

/* render.lights.method: march, the reference: every pixel marched */
__kernel void shadow_march(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                           const int width, const int height, const camera_t cam, const lmedium_t m,
                           __global const float4 *prims, const light_t L, const float thickness,
                           const int offscreen_shadowed)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float4 od = a_dir[idx], os = a_sc[idx];
    if (od.x + od.y + od.z + os.x + os.y + os.z <= 0.0f) return;      /* no light here to shadow */
    float3 fA, fT;
    if (march_shares(depth, width, height, cam, m, prims, L, thickness, offscreen_shadowed, i + 0.5f, j + 0.5f,
                     &fA, &fT, 0, (float4)(0.0f)))
        apply_shares(a_dir, a_sc, idx, fA.x, fA.y, fA.z, fT.x, fT.y, fT.z);
}

/* render.lights.method: epipolar (Intel's epipolar sampling): the shares are found at
 * samples on S slices, half-lines from the light's image e (its
 * antipode for a light behind the camera; far away along the lines' direction when they are
 * nearly parallel), every `step` pixels along each, four times as dense within 15 % of the
 * image's size of e (radius r0 + m h1 up to rb, then rb + (m - m1) h2); a pixel takes them from the four samples
 * around it in (angle, radius) about e, weighted bilinearly and by their depth's agreement,
 * unless it is within 8 pixels of e or no sample near it sees its surface: then it is marched
 * itself. Slice k is at angle a0 + k da. */
/* Slice k's shadow map, Intel's 1D shadow map of an epipolar slice: its in-frame part walked
 * pixel by pixel, each pixel's stretch of the line giving its surface window (the occluder of
 * shadow_march) as a quad in the slice's half-plane; per bin of keys (the direction seen from
 * the light) the distance where a light ray first meets a quad. Twice: first the keys' range,
 * then the bins. maps[k]: a min and a max segment tree over the bins (leaves SH_BINS ..
 * 2 SH_BINS - 1 of each), what the samples' range tests read. ranges[k] = (first key, key
 * per bin, 0, off): off when the lines leave the frame before the light's image (a light
 * outside the frame, behind the camera or at infinity), for offscreen: shadowed. */
__kernel void epi_maps(__global const float *depth, __global float *maps, __global float4 *ranges,
                       const int width, const int height, const camera_t cam, const light_t L, const float thickness,
                       const float ex, const float ey, const float a0, const float da, const int ns, const int off)
{
    int k = get_global_id(0);
    if (k >= ns) return;
    int directional = L.type == LIGHT_DIRECTIONAL;
    float3 c = cam.pos.xyz, v = directional ? L.axis.xyz : L.pos.xyz - c;
    float dl = length(v);
    float3 u = directional ? v : v / dl;
    float bl = light_bias(dl, L.radius);
    float a = a0 + k * da, ux = cos(a), uy = sin(a);
    /* the half-line's part inside the frame */
    float rin = 0.0f, rout = INFINITY;
    if (ux != 0.0f) {
        float t0 = (0.0f - ex) / ux, t1 = (width - ex) / ux;
        rin = fmax(rin, fmin(t0, t1));
        rout = fmin(rout, fmax(t0, t1));
    } else if (ex < 0.0f || ex > width) rout = -1.0f;
    if (uy != 0.0f) {
        float t0 = (0.0f - ey) / uy, t1 = (height - ey) / uy;
        rin = fmax(rin, fmin(t0, t1));
        rout = fmin(rout, fmax(t0, t1));
    } else if (ey < 0.0f || ey > height) rout = -1.0f;
    __global float *map = maps + (size_t)k * 4 * SH_BINS;      /* min tree (leaves: the map), max tree */
    float kmin = INFINITY, kmax = -INFINITY;
    for (int pass = 0; pass < 2; ++pass) {
        float kscale = pass ? SH_BINS / fmax(kmax - kmin, 1e-20f) : 0.0f;
        /* pixel by pixel along the line (Amanatides-Woo, as march_shares walks it): each
         * stretch takes its own pixel's surface, exactly as a sample's walk would */
        int qi = (int)floor(ex + (rin + 1e-3f) * ux), qj = (int)floor(ey + (rin + 1e-3f) * uy);
        int sx_ = ux > 0.0f ? 1 : -1, sy_ = uy > 0.0f ? 1 : -1;
        float rnx = ux != 0.0f ? ((ux > 0.0f ? qi + 1 : qi) - ex) / ux : INFINITY;
        float rny = uy != 0.0f ? ((uy > 0.0f ? qj + 1 : qj) - ey) / uy : INFINITY;
        for (float r = rin; r < rout;) {
            float r1 = minf(minf(rnx, rny), rout);
            int ci = qi, cj = qj;
            if (rnx < rny) { qi += sx_; rnx += fabs(1.0f / ux); } else { qj += sy_; rny += fabs(1.0f / uy); }
            float r0 = r;
            r = r1;
            if (ci < 0 || cj < 0 || ci >= width || cj >= height || !(r1 > r0)) continue;
            float Dq, dla, dlb;
            float zq = pixel_z(&cam, depth, width, ci, cj, &Dq);
            if (Dq >= cam.max_depth) continue;                  /* sky: nothing there */
            float b = surface_bias(zq, thickness);
            float3 wa = ray_at(&cam, ex + r0 * ux, ey + r0 * uy, &dla), wb = ray_at(&cam, ex + r1 * ux, ey + r1 * uy, &dlb);
            if (!directional && length(Dq * (wa + wb) * 0.5f - v) < bl) continue;    /* the light's own surface */
            float2 p0 = plane_coords((zq + b) * dla * wa, u, dl, directional);
            float2 p1 = plane_coords((zq + thickness) * dla * wa, u, dl, directional);
            float2 p2 = plane_coords((zq + b) * dlb * wb, u, dl, directional);
            float2 p3 = plane_coords((zq + thickness) * dlb * wb, u, dl, directional);
            float lo = minf(minf(p0.x, p1.x), minf(p2.x, p3.x)), hi = maxf(maxf(p0.x, p1.x), maxf(p2.x, p3.x));
            if (!pass) {
                kmin = minf(kmin, lo);
                kmax = maxf(kmax, hi);
                continue;
            }
            /* the window's distance per bin: where a light ray of the bin's keys first meets
             * the quad, the least over its four edges of the edge's distance, interpolated in
             * the key, over the bin's keys. (The nearest of the four corners for every bin put
             * a wide pixel's far side as near as its near side: false shadows at the surfaces
             * behind a light.) */
            float2 eg[8] = {p0, p2, p1, p3, p0, p1, p2, p3};
            int b0 = max((int)((lo - kmin) * kscale), 0), b1 = min((int)((hi - kmin) * kscale), SH_BINS - 1);
            for (int bin = b0; bin <= b1; ++bin) {
                float kb0 = kmin + bin / kscale, kb1 = kmin + (bin + 1) / kscale;
                float d = INFINITY;
                for (int e = 0; e < 8; e += 2) {
                    float2 ea = eg[e].x <= eg[e + 1].x ? eg[e] : eg[e + 1], eb = eg[e].x <= eg[e + 1].x ? eg[e + 1] : eg[e];
                    float ka = maxf(kb0, ea.x), kz = minf(kb1, eb.x);
                    if (ka > kz) continue;                               /* the edge is not in this bin */
                    float slope = eb.x > ea.x ? (eb.y - ea.y) / (eb.x - ea.x) : 0.0f;
                    d = minf(d, minf(ea.y + slope * (ka - ea.x), ea.y + slope * (kz - ea.x)));
                }
                map[SH_BINS + bin] = minf(map[SH_BINS + bin], d);
            }
        }
        if (!pass) {
            for (int bin = 0; bin < SH_BINS; ++bin) map[SH_BINS + bin] = INFINITY;
            if (!(kmax >= kmin)) break;                         /* no occluder on this slice */
        }
    }
    __global float *mx = map + 2 * SH_BINS;
    for (int bin = SH_BINS; bin < 2 * SH_BINS; ++bin) mx[bin] = map[bin];
    for (int node = SH_BINS - 1; node >= 1; --node) {
        map[node] = minf(map[2 * node], map[2 * node + 1]);
        mx[node] = maxf(mx[2 * node], mx[2 * node + 1]);
    }
    ranges[k] = (float4)(kmax >= kmin ? kmin : 0.0f, kmax >= kmin ? maxf(kmax - kmin, 1e-20f) / SH_BINS : 1.0f,
                         0.0f, (float)off);
}

__kernel void epi_samples(__global const float *depth, __global float4 *sh_a, __global float4 *sh_t,
                          const int width, const int height, const camera_t cam, const lmedium_t m,
                          __global const float4 *prims, const light_t L, const float thickness,
                          const int offscreen_shadowed, const float ex, const float ey, const float a0,
                          const float da, const float r0, const float rb, const float h1, const float h2,
                          const int m1, const int nm, const int ns, __global const float *maps,
                          __global const float4 *ranges)
{
    int mi = get_global_id(0), k = get_global_id(1);
    if (mi >= nm || k >= ns) return;
    int s = k * nm + mi;
    float a = a0 + k * da, r = mi < m1 ? r0 + mi * h1 : rb + (mi - m1) * h2;
    float px = ex + r * cos(a), py = ey + r * sin(a);
    if (!(px >= 0.0f && py >= 0.0f && px < width && py < height)) {     /* outside: weight 0 */
        sh_a[s] = (float4)(0.0f);
        sh_t[s] = (float4)(0.0f);
        return;
    }
    float3 fA, fT;
#ifdef SH_WALK
    /* tools/shadows.py: each sample walks its line pixel by pixel as the march does, for
     * the agreement of the maps' visibility with the march's */
    __global const float *map = 0;
#else
    __global const float *map = maps + (size_t)k * 4 * SH_BINS;
#endif
    int shadowed = march_shares(depth, width, height, cam, m, prims, L, thickness, offscreen_shadowed, px, py,
                                &fA, &fT, map, ranges[k]);
    float Dn;
    sh_a[s] = (float4)(fA, pixel_z(&cam, depth, width, (int)px, (int)py, &Dn));
    sh_t[s] = (float4)(fT, shadowed ? 1.0f : 2.0f);      /* .w: 0 outside, 2 nothing in shadow */
}

#include "lanes.h"

/* atan2 to 2e-6 rad (an odd degree-11 polynomial of atan on [0, 1]): the slice index needs
 * far less than a slice's 6e-3 rad, and the library's atan2, a call per pixel, was a sixth
 * of the unwarp's time */
ALWAYS_INLINE lanef fast_atan2(lanef y, lanef x)
{
    lanef ax = LANE_ABS(x), ay = LANE_ABS(y), mx = ax > ay ? ax : ay, mn = ax > ay ? ay : ax;
    lanef a = mx > 0.0f ? mn / mx : 0.0f, q = a * a;
    lanef r = a * (((((-0.0117212f * q + 0.05265332f) * q - 0.11643287f) * q + 0.19354346f) * q - 0.33262347f) * q
                 + 0.99997726f);
    r = ay > ax ? 1.57079633f - r : r;
    r = x < 0.0f ? 3.14159265f - r : r;
    return y < 0.0f ? -r : r;
}

ALWAYS_INLINE lanei sh_floor(lanef v)
{
    lanei i = LANE_INT(v);
    return v < LANE_FLOAT(i) ? i - 1 : i;
}

/* Every pixel from the four samples around it: Intel's unwarp, bilinear weights times
 * (thr / max(|dz|, thr))^4, thr 3 % of the pixel's depth, so that samples on another surface
 * hardly count. A pixel within 8 pixels of the light's image, or whose weights sum to less
 * than 1e-2, is flagged (march[idx] = 1) and marched by epi_march. Kept free of calls,
 * atomics and float3 values, with the march out of it and the channels chained by AFTER,
 * so that PoCL vectorises it: a call anywhere in a kernel, even on a branch a pixel in 10000
 * takes, or side-by-side steps that LLVM pairs kept the whole of it scalar (95 ms at 2 MPx,
 * now 33). A sample's .w of sh_t says whether nothing on its ray is in shadow (2). */
__kernel void epi_unwarp(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                         __global const float4 *sh_a, __global const float4 *sh_t,
                         const int width, const int height, const camera_t cam,
                         const float ex, const float ey, const float a0,
                         const float da, const float r0, const float rb, const float h1, const float h2,
                         const int m1, const int nm, const int ns,
                         const int full_circle, __global uchar *march)
{
    int i0 = LANES * get_global_id(0), j = get_global_id(1);
    if (i0 >= width || j >= height) return;
    /* the lanes past the row's end read its last pixel and store nothing */
    lanei i = i0 + LANE0;
#if LANES == 8
    i = i < width - 1 ? i : width - 1;
#endif
    lanei idx = j * width + i;
    __global const float *fd = (__global const float *)a_dir, *fs = (__global const float *)a_sc;
    lanef d0 = LANE_READ4(fd, idx, 0), d1 = LANE_READ4(fd, idx, 1), d2 = LANE_READ4(fd, idx, 2);
    lanef s0 = LANE_READ4(fs, idx, 0), s1 = LANE_READ4(fs, idx, 1), s2 = LANE_READ4(fs, idx, 2);
    lanei light = d0 + d1 + d2 + s0 + s1 + s2 > 0.0f;           /* no light here: nothing to shadow */
    lanef px = LANE_FLOAT(i) + 0.5f;
    float py = j + 0.5f;
    lanef dx = px - ex;
    float dy = py - ey;
    lanef r = LANE_SQRT(dx * dx + dy * dy);
    lanef rel = fast_atan2(dy, dx) - a0;
    const float two_pi = 2.0f * M_PI_F;
    rel = full_circle ? rel - two_pi * LANE_FLOAT(sh_floor(rel / two_pi)) : rel;
    lanef fk = rel / da, fm = r < rb ? (r - r0) / h1 : m1 + (r - rb) / h2;
    /* clamped before the conversion: far outside the slices fk can exceed the int range */
    fk = fk < -4.0f ? -4.0f : (fk > ns + 4.0f ? ns + 4.0f : fk);
    lanei k0 = sh_floor(fk);
    lanef tk = fk - LANE_FLOAT(k0);
    fm = AFTER(fm, tk);
    fm = fm < -4.0f ? -4.0f : (fm > nm + 4.0f ? nm + 4.0f : fm);
    lanei m0 = sh_floor(fm);
    lanef tm = fm - LANE_FLOAT(m0);
    lanei k1 = k0 + 1;
    k0 = full_circle ? (k0 % ns + ns) % ns : k0;
    k1 = full_circle ? (k1 % ns + ns) % ns : k1;
    lanei ok = r >= 8.0f && m0 >= 0 && m0 + 1 < nm && k0 >= 0 && k1 < ns;
    /* out of range: read sample 0 (weights unused) rather than branch around the reads */
    lanei kk0 = ok ? k0 : 0, kk1 = ok ? k1 : 0, mm0 = ok ? m0 : 0;
    /* the pixel's depth along the view axis (pixel_z, on the lanes) */
    lanef qx = (LANE_FLOAT(i) + 0.5f - cam.cx) / cam.focal_px;
    float qy = (j + 0.5f - cam.cy) / cam.focal_y;
    lanef dlen = LANE_SQRT(qx * qx + qy * qy + 1.0f);
    lanef dist = LANE_LOAD(depth, idx) * (cam.depth_is_z ? dlen : 1.0f);
    lanef zp = (dist < cam.max_depth ? dist : cam.max_depth) / dlen, thr = 0.03f * zp;
    lanef sum = 0.0f, fa0 = 0.0f, fa1 = 0.0f, fa2 = 0.0f, ft0 = 0.0f, ft1 = 0.0f, ft2 = 0.0f;
    lanei lit = LANE_TRUE;      /* all four samples unshadowed: the pixel keeps its airlight */
    __global const float *fa = (__global const float *)sh_a, *ft = (__global const float *)sh_t;
#pragma unroll
    for (int c = 0; c < 4; ++c) {
        lanei s = ((c & 1) ? kk1 : kk0) * nm + mm0 + (c >> 1);
        lanef a_0 = LANE_READ4(fa, s, 0), a_1 = LANE_READ4(fa, s, 1), a_2 = LANE_READ4(fa, s, 2), a_w = LANE_READ4(fa, s, 3);
        lanef t_0 = LANE_READ4(ft, s, 0), t_1 = LANE_READ4(ft, s, 1), t_2 = LANE_READ4(ft, s, 2), t_w = LANE_READ4(ft, s, 3);
        lit &= t_w == 2.0f;
        lanef dz = LANE_ABS(AFTER(a_w, sum) - zp);
        lanef q = thr / (dz > thr ? dz : thr);
        lanef wgt = (t_w > 0.0f ? 1.0f : 0.0f) * ((c & 1) ? tk : 1.0f - tk) * ((c >> 1) ? tm : 1.0f - tm) * (q * q) * (q * q);
        sum += wgt;
        fa0 += wgt * a_0;
        fa1 += AFTER(wgt, fa0) * a_1;
        fa2 += AFTER(wgt, fa1) * a_2;
        ft0 += AFTER(wgt, fa2) * t_0;
        ft1 += AFTER(wgt, ft0) * t_1;
        ft2 += AFTER(wgt, ft1) * t_2;
    }
    ok = ok && sum >= 1e-2f;
    lanei flag = light && !ok, apply = light && ok && !lit;
    lanef inv = 1.0f / (sum > 0.0f ? sum : 1.0f);
#if LANES == 8
#pragma unroll
    for (int l = 0; l < 8; ++l) {
        int o = j * width + i0 + l;
        if (i0 + l < width)
            march[o] = flag[l] != 0;
        if (i0 + l < width && apply[l])
            apply_shares(a_dir, a_sc, o, fa0[l] * inv[l], fa1[l] * inv[l], fa2[l] * inv[l],
                         ft0[l] * inv[l], ft1[l] * inv[l], ft2[l] * inv[l]);
    }
#else
    march[idx] = flag;
    if (apply)
        apply_shares(a_dir, a_sc, idx, fa0 * inv, fa1 * inv, fa2 * inv, ft0 * inv, ft1 * inv, ft2 * inv);
#endif
}

/* The pixels epi_unwarp flagged, marched themselves (marched[0] counts them). */
__kernel void epi_march(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                        const int width, const int height, const camera_t cam, const lmedium_t m,
                        __global const float4 *prims, const light_t L, const float thickness,
                        const int offscreen_shadowed, __global const uchar *march, __global int *marched)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    if (!march[idx]) return;
    atomic_inc(marched);
    float3 fA, fT;
    if (march_shares(depth, width, height, cam, m, prims, L, thickness, offscreen_shadowed, i + 0.5f, j + 0.5f,
                     &fA, &fT, 0, (float4)(0.0f)))
        apply_shares(a_dir, a_sc, idx, fA.x, fA.y, fA.z, fT.x, fT.y, fT.z);
}
