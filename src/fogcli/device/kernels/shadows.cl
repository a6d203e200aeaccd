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

#ifndef SH_N
#define SH_N 64             /* cells per ray: integrand evaluations */
#endif
#ifndef SH_SUB
#define SH_SUB 16           /* visibility bits per cell: a shadow edge lands within 1/16 cell (32 cells of 32 bits
                             * missed the facade test's 1 %: 1.8 %; 64 of 16: 0.35 %, tests/test_shadows.py) */
#endif
#define SH_WORDS (SH_N * SH_SUB / 32)
#ifndef SH_BINS             /* shadow map bins per epipolar slice: the host sizes their buffers */
#error "SH_BINS is set by the host (fogcli.structs.SH_BINS)"
#endif

/* min and max by compare and select: fmin / fmax are out-of-line calls in PoCL, and the maps
 * and the samples' trees make millions of them */
inline float minf(float a, float b) { return a < b ? a : b; }
inline float maxf(float a, float b) { return a > b ? a : b; }

/* the self-shadowing bias of a surface at depth z: it blocks only from this far behind it */
inline float surface_bias(float z, float thickness) { return minf(maxf(0.05f, 0.01f * z), 0.25f * thickness); }

/* surfaces this close to a point or spot light at distance dl do not block it (its own) */
inline float light_bias(float dl, float radius) { return maxf(maxf(0.05f, 0.02f * dl), 2.0f * radius); }

/* world vector -> camera frame (R's transpose; rot0..2 are R's rows) */
inline float3 to_camera(const camera_t *cam, float3 v)
{
    return (float3)(cam->rot0.x * v.x + cam->rot1.x * v.y + cam->rot2.x * v.z,
                    cam->rot0.y * v.x + cam->rot1.y * v.y + cam->rot2.y * v.z,
                    cam->rot0.z * v.x + cam->rot1.z * v.y + cam->rot2.z * v.z);
}

/* unit world ray through the continuous image point (qx, qy); *dlen: its length per metre of
 * depth along the view axis */
inline float3 ray_at(const camera_t *cam, float qx, float qy, float *dlen)
{
    float dx = (qx - cam->cx) / cam->focal_px, dy = -(qy - cam->cy) / cam->focal_y;
    float3 v = (float3)(cam->rot0.x * dx + cam->rot0.y * dy - cam->rot0.z,
                        cam->rot1.x * dx + cam->rot1.y * dy - cam->rot1.z,
                        cam->rot2.x * dx + cam->rot2.y * dy - cam->rot2.z);
    *dlen = sqrt(dx * dx + dy * dy + 1.0f);
    return v / *dlen;
}

/* pixel (i, j)'s surface: its depth along the view axis; *D: its ray length (max_depth for
 * the sky) */
inline float pixel_z(const camera_t *cam, __global const float *depth, int width, int i, int j, float *D)
{
    float wx, wy, wz;
    *D = pixel_ray(cam, i, j, depth[j * width + i], &wx, &wy, &wz);
    /* the ray's length per metre of depth (ray_at's dlen), in scalars: epi_unwarp vectorises */
    float dx = (i + 0.5f - cam->cx) / cam->focal_px, dy = (j + 0.5f - cam->cy) / cam->focal_y;
    return *D / SQRT_(dx * dx + dy * dy + 1.0f);
}

/* set the visibility bits of [lo, hi] (in the integration variable): whole words at once */
#define SH_MASK (SH_SUB == 32 ? 0xffffffffu : (1u << SH_SUB) - 1u)
/* cell k's visibility bits */
#define CELL_BITS(bits, k) (((bits)[((k) * SH_SUB) >> 5] >> (((k) * SH_SUB) & 31)) & SH_MASK)

/* set the visibility bits k0 .. k1 (inclusive) */
inline void set_bits(uint *bits, int k0, int k1)
{
    for (int wd = k0 >> 5; wd <= (k1 >> 5) && k0 <= k1; ++wd) {
        int b0 = max(k0 - 32 * wd, 0), b1 = min(k1 - 32 * wd, 31);
        uint hi_mask = b1 == 31 ? ~0u : (1u << (b1 + 1)) - 1u;
        bits[wd] |= hi_mask & ~((1u << b0) - 1u);
    }
}

/* set the bits of [lo, hi] (in the integration variable) */
inline void mark(uint *bits, float lo, float hi, float a0, float da)
{
    float sub = da / SH_SUB;
    set_bits(bits, max((int)ceil((lo - a0) / sub - 0.5f), 0), min((int)floor((hi - a0) / sub - 0.5f), SH_N * SH_SUB - 1));
}

inline int all_set(const uint *bits)
{
    uint all = ~0u;
    for (int k = 0; k < SH_WORDS; ++k) all &= bits[k];
    return all == ~0u;
}

/* A point x (relative to the camera) in the half-plane of a slice, bounded by the line
 * through the camera and the light (unit direction u, the light at distance dl): (key, depth)
 * = (its direction seen from the light as a pseudo-angle 1 - cos / (|cos| + sin), monotonic
 * in the angle from 0 to pi, without atan2's cost; its distance from the light); for a
 * directional light (its distance from that line, minus its distance along u). An occluder
 * shadows the points behind it: the same key, a larger depth. */
inline float2 plane_coords(float3 x, float3 u, float dl, int directional)
{
    float a = dot(x, u);
    float3 p = x - a * u;
    float b = SQRT_(dot(p, p));
    if (directional) return (float2)(b, -a);
    float q = a - dl, n = fabs(q) + b;
    return (float2)(n > 0.0f ? 1.0f - q / n : 0.0f, SQRT_(q * q + b * b));
}

/* whether the point at integration variable t (phi, or s for the sun) of ray w is behind an
 * occluder of the slice's map (mrange: first key, key per bin) */
inline int map_blocked(__global const float *map, float4 mrange, float3 c, float3 w, float3 u, float dl,
                       int directional, float d1, float R, float t)
{
    float s = directional ? t : d1 + R * native_tan(t);
    float2 kd = plane_coords(s * w, u, dl, directional);
    float f = (kd.x - mrange.x) / mrange.y;
    if (!(f >= 0.0f && f < SH_BINS)) return 0;
    return kd.y > map[SH_BINS + (int)f] * (1.0f + 1e-5f) + 1e-5f;
}

/* the smallest (tree: the min tree) or largest (the max tree) occluder distance of bins
 * [lo, hi) of a slice's map: a bottom-up segment-tree query */
inline float map_query(__global const float *tree, int lo, int hi, int largest)
{
    float r = largest ? -INFINITY : INFINITY;
    for (int l = lo + SH_BINS, h = hi + SH_BINS; l < h; l >>= 1, h >>= 1) {
        if (l & 1) { float v = tree[l++]; r = largest ? maxf(r, v) : minf(r, v); }
        if (h & 1) { float v = tree[--h]; r = largest ? maxf(r, v) : minf(r, v); }
    }
    return r;
}

/* a point of the ray at integration variable t (phi, or s for the sun) as the map sees it:
 * (its ray parameter s, its key, its distance) */
inline float3 map_point(float3 w, float3 u, float dl, int directional, float d1, float R, float t)
{
    float s = directional ? t : d1 + R * native_tan(t);
    float2 kd = plane_coords(s * w, u, dl, directional);
    return (float3)(s, kd.x, kd.y);
}

/* Intel's min/max test for the cells of a ray between its points pa and pb (map_point, pa
 * first): 0 if every point there is lit by the slice's map, 1 if every one is behind an
 * occluder, 2 if neither is certain. The keys grow monotonically along the ray; the distance
 * from a point light is convex (smallest at the ray's foot s = d1, distance Rt), from the sun
 * linear. */
inline int map_range(__global const float *map, float4 mrange, int directional, float d1, float Rt, float3 pa,
                     float3 pb)
{
    float f0 = (minf(pa.y, pb.y) - mrange.x) / mrange.y, f1 = (maxf(pa.y, pb.y) - mrange.x) / mrange.y;
    if (!(f1 >= 0.0f) || !(f0 < SH_BINS)) return 0;                 /* off the map: lit */
    int inside = f0 >= 0.0f && f1 < SH_BINS;
    int b0 = (int)maxf(f0, 0.0f), b1 = (int)minf(f1, SH_BINS - 1.0f) + 1;
    float dmax = maxf(pa.z, pb.z);
    float dmin = !directional && pa.x < d1 && d1 < pb.x ? Rt : minf(pa.z, pb.z);
    if (dmax <= map_query(map, b0, b1, 0) * (1.0f + 1e-5f) + 1e-5f) return 0;
    if (inside && dmin > map_query(map + 2 * SH_BINS, b0, b1, 1) * (1.0f + 1e-5f) + 1e-5f) return 1;
    return 2;
}

/* The lit shares of march_shares where the medium is its homogeneous part alone (no other
 * primitives): al_integrand in closed form, eight cells at once (explicit SIMD: the samples'
 * work-items stay scalar). What all cells share (1 / R, the density, sigma_s, the intensity,
 * HG's numerator) cancels in the shares. The cells' phi advance by rotation, eight cells per
 * step: sin and cos of the first eight and of one step, not of all 64. */
ALWAYS_INLINE void shares_homogeneous(const lmedium_t *m, const light_t *L, float3 w, float3 lc, float d1, float R,
                                      float Rt, float a0, float da, const uint *bits, float3 *fA, float3 *fT)
{
    const float8 lane = (float8)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f);
    float hf = m->homogeneous, g = m->g;
    int directional = L->type == LIGHT_DIRECTIONAL, spot = L->type == LIGHT_SPOT;
    float kA0 = -hf * (m->sa.x + m->ss.x), kA1 = -hf * (m->sa.y + m->ss.y), kA2 = -hf * (m->sa.z + m->ss.z);
    float kT0 = -hf * m->sa.x, kT1 = -hf * m->sa.y, kT2 = -hf * m->sa.z;
    /* spot: the cosine to its axis at s is (q0 + s q1) / |x - light|, lc = camera - light */
    float q0 = dot(lc, L->axis.xyz), q1 = dot(w, L->axis.xyz);
    float sw = spot ? 1.0f / (L->cos_inner - L->cos_outer) : 0.0f;     /* device/lights.py: inner > outer */
    float8 ph = a0 + lane * da, sn = native_sin(ph), cs = native_cos(ph);
    float rc = native_cos(8.0f * da), rs = native_sin(8.0f * da);
    float8 tA0 = 0.0f, tA1 = 0.0f, tA2 = 0.0f, tT0 = 0.0f, tT1 = 0.0f, tT2 = 0.0f;
    float8 lA0 = 0.0f, lA1 = 0.0f, lA2 = 0.0f, lT0 = 0.0f, lT1 = 0.0f, lT2 = 0.0f;
    for (int k = 0; k < SH_N; k += 8) {
        float8 s, lw, f;
        if (directional) {
            s = a0 + (lane + (float)k) * da;
            lw = 0.0f;
            f = 1.0f;
        } else {
            float8 rcs = 1.0f / cs;
            s = d1 + R * sn * rcs;
            lw = R * rcs;
            float8 d = 1.0f + g * g + 2.0f * g * sn;
            f = 1.0f / (d * sqrt8(d));
            if (spot) {
                float8 x = (q0 + s * q1) / sqrt8(Rt * Rt + (s - d1) * (s - d1));
                float8 t = (x - L->cos_outer) * sw;
                t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
                f *= t * t * (3.0f - 2.0f * t);
            }
            float8 c2 = cs * rc - sn * rs;
            sn = sn * rc + cs * rs;
            cs = c2;
        }
        float8 open;
        for (int i = 0; i < 8; ++i) open[i] = 1.0f - popcount(CELL_BITS(bits, k + i)) * (1.0f / SH_SUB);
        float8 a0_ = f * exp_poly8(kA0 * (lw + s)), a1_ = f * exp_poly8(kA1 * (lw + s)), a2_ = f * exp_poly8(kA2 * (lw + s));
        float8 t0_ = f * exp_poly8(kA0 * lw + kT0 * s), t1_ = f * exp_poly8(kA1 * lw + kT1 * s),
               t2_ = f * exp_poly8(kA2 * lw + kT2 * s);
        tA0 += a0_; tA1 += a1_; tA2 += a2_; tT0 += t0_; tT1 += t1_; tT2 += t2_;
        lA0 += open * a0_; lA1 += open * a1_; lA2 += open * a2_;
        lT0 += open * t0_; lT1 += open * t1_; lT2 += open * t2_;
    }
    float3 totA = (float3)(hsum8(tA0), hsum8(tA1), hsum8(tA2)), totT = (float3)(hsum8(tT0), hsum8(tT1), hsum8(tT2));
    float3 litA = (float3)(hsum8(lA0), hsum8(lA1), hsum8(lA2)), litT = (float3)(hsum8(lT0), hsum8(lT1), hsum8(lT2));
    *fA = select((float3)(1.0f), litA / totA, totA > 0.0f);
    *fT = select((float3)(1.0f), litT / totT, totT > 0.0f);
}

/* The lit shares of the airlight's integrand (fA: camera leg in extinction, fT: in
 * absorption) along the ray through the continuous image point (px, py), whose surface is
 * that of the nearest pixel taken as facing the camera. Returns 0 when nothing is in shadow
 * (the shares are then 1). */
inline int march_shares(__global const float *depth, const int width, const int height, const camera_t cam,
                        const lmedium_t m, __global const float4 *prims, const light_t L, const float thickness,
                        const int offscreen_shadowed, float px, float py, float3 *fA, float3 *fT,
                        __global const float *map, float4 mrange)
{
    *fA = (float3)(1.0f);
    *fT = (float3)(1.0f);
    int i = clamp((int)px, 0, width - 1), j = clamp((int)py, 0, height - 1);
    float Dn, dlp;
    float zn = pixel_z(&cam, depth, width, i, j, &Dn);
    float3 w = ray_at(&cam, px, py, &dlp), c = cam.pos.xyz;
    float D = fmin(zn * dlp, cam.max_depth);
    lmedium_t het = m;
    het.homogeneous = 0.0f;
    int directional = L.type == LIGHT_DIRECTIONAL;

    /* the plane's second axis e2 (towards the light), the light's in-plane place (d1, Rt),
     * the integration variable's range [a0, a1] (phi or s) */
    float3 v = directional ? L.axis.xyz : L.pos.xyz - c;
    float d1 = dot(w, v);
    float3 perp = v - d1 * w;
    float Rt = length(perp);
    float R = directional ? 1.0f : sqrt(Rt * Rt + L.radius * L.radius);
    float a0 = directional ? 0.0f : atan2(-d1, R), a1 = directional ? D : atan2(D - d1, R);
    float da = (a1 - a0) / SH_N;
    if (!(da > 0.0f)) return 0;
    float3 e2 = Rt > 0.0f ? perp / Rt : (float3)(0.0f);
    float dl = length(v);
    float bl = light_bias(dl, L.radius);

    uint bits[SH_WORDS];
    for (int k = 0; k < SH_WORDS; ++k) bits[k] = 0u;

    /* the walk: from p along g, for at most len pixels (to the epipole of a light in front) */
    float3 vc = to_camera(&cam, v);
    float gx = (cam.cx - px) * (-vc.z) + cam.focal_px * vc.x;
    float gy = (cam.cy - py) * (-vc.z) - cam.focal_y * vc.y;
    float glen = hypot(gx, gy);
    int off = 0;
    if (glen <= 1e-6f * (fabs(vc.z) * (width + height) + cam.focal_px * hypot(vc.x, vc.y)) || Rt <= 1e-6f * dl) {
        /* the light on this pixel's ray: its segments run along the ray itself, past the
         * pixel's own surface when the light is behind it (no map sees that: a slice's
         * samples at the light's image take this too) */
        float b = surface_bias(D, thickness);
        if (!directional && d1 > D + b && d1 - bl > D + b && D < cam.max_depth)
            for (int k = 0; k < SH_WORDS; ++k) bits[k] = ~0u;
    } else if (map) {
        /* a sample on a slice: its slice's shadow map (epi_maps) tells the visibility. Intel's
         * min/max trees: ranges of sub-cells decided by the map's bounds over their keys,
         * halved while undecided, a single undecided sub-cell tested at its middle */
        float3 u = directional ? v : v / dl;
        float sub = da / SH_SUB;
        /* a stack of ranges with their end points, each point computed once (a split's
         * middle serves both halves) */
        int lo_[32], hi_[32], sp = 1;
        float3 pl_[32], ph_[32];
        lo_[0] = 0;
        hi_[0] = SH_N * SH_SUB;
        pl_[0] = map_point(w, u, dl, directional, d1, R, a0);
        ph_[0] = map_point(w, u, dl, directional, d1, R, a0 + SH_N * SH_SUB * sub);
        while (sp > 0) {
            --sp;
            int k0 = lo_[sp], k1 = hi_[sp];
            float3 pa = pl_[sp], pb = ph_[sp];
            int st = map_range(map, mrange, directional, d1, Rt, pa, pb);
            if (st == 2 && k1 - k0 == 1)
                st = map_blocked(map, mrange, c, w, u, dl, directional, d1, R, a0 + (k0 + 0.5f) * sub);
            if (st == 1) {
                set_bits(bits, k0, k1 - 1);
            } else if (st == 2) {
                int km = (k0 + k1) / 2;
                float3 pm = map_point(w, u, dl, directional, d1, R, a0 + km * sub);
                lo_[sp] = km; hi_[sp] = k1; pl_[sp] = pm; ph_[sp++] = pb;
                lo_[sp] = k0; hi_[sp] = km; pl_[sp] = pa; ph_[sp++] = pm;
            }
        }
        off = mrange.w > 0.0f;
        if (off && offscreen_shadowed)
            for (int k = 0; k < SH_WORDS; ++k) bits[k] = ~0u;
    } else {
        float ux = gx / glen, uy = gy / glen;
        float len = vc.z < 0.0f ? glen / (-vc.z) : INFINITY;
        /* pixel by pixel along the line (Amanatides-Woo): each pixel's surface blocks, over
         * the stretch of the line it covers, the segments that pass behind it; the stretch's
         * two ends bound the interval of the ray they come from (s is monotonic along it) */
        int qi = i, qj = j;
        int sx_ = ux > 0.0f ? 1 : -1, sy_ = uy > 0.0f ? 1 : -1;
        float tdx = ux != 0.0f ? fabs(1.0f / ux) : INFINITY, tdy = uy != 0.0f ? fabs(1.0f / uy) : INFINITY;
        float tnx = ux != 0.0f ? (ux > 0.0f ? (qi + 1 - px) : (px - qi)) * tdx : INFINITY;
        float tny = uy != 0.0f ? (uy > 0.0f ? (qj + 1 - py) : (py - qj)) * tdy : INFINITY;
        float ct0 = 1.0f, st0 = 0.0f, dl0;      /* the ray where the stretch starts: p's own */
        ray_at(&cam, px, py, &dl0);
        int marks = 0;
        for (float t0 = 0.0f; t0 < len;) {
            if (qi < 0 || qj < 0 || qi >= width || qj >= height) { off = 1; break; }
            float t1 = fmin(fmin(tnx, tny), len);
            float dl1;
            float3 wq = ray_at(&cam, px + t1 * ux, py + t1 * uy, &dl1);
            float ct1 = dot(wq, w), st1 = dot(wq, e2);
            float cta = ct0, sta = st0, dla = dl0;
            int ci = qi, cj = qj;
            ct0 = ct1;
            st0 = st1;
            dl0 = dl1;
            t0 = t1;
            if (tnx < tny) { qi += sx_; tnx += tdx; } else { qj += sy_; tny += tdy; }
            float Dq;
            float zq = pixel_z(&cam, depth, width, ci, cj, &Dq);
            if (Dq >= cam.max_depth) continue;                  /* sky: nothing there */
            /* the window behind the surface in depth along the view axis (z), where a surface
             * facing the camera is exact across the pixel, as ray lengths at the stretch's ends */
            float b = surface_bias(zq, thickness);
            float tlo0 = (zq + b) * dla, thi0 = (zq + thickness) * dla;
            float tlo1 = (zq + b) * dl1, thi1 = (zq + thickness) * dl1;
            float lo, hi;
            if (directional) {
                /* the light's direction in the plane is (d1, Rt) (unit); the point t wq lies
                 * on the line from s w along it where s = t (cos - sin d1 / Rt) */
                float k0 = cta - sta * d1 / Rt, k1 = ct1 - st1 * d1 / Rt;
                if (fmax(k0, k1) <= 0.0f) continue;
                lo = fmin(fmax(k0, 0.0f) * tlo0, fmax(k1, 0.0f) * tlo1);
                hi = fmax(k0 * thi0, k1 * thi1);
            } else {
                float ctm = 0.5f * (cta + ct1), stm = 0.5f * (sta + st1);
                float sx = Dq * ctm - d1, sy = Dq * stm - Rt;
                if (sx * sx + sy * sy < bl * bl) continue;      /* the light's own surface */
                /* the segment from s w to the light meets the ray at angle (c, s) at
                 * t = s Rt / (Rt c - d1 s' + s s'), i.e. s = t aa / (Rt - t s'), aa = Rt c - d1 s' */
                float aa0 = Rt * cta - d1 * sta, aa1 = Rt * ct1 - d1 * st1;
                if (aa0 <= 0.0f && aa1 <= 0.0f) continue;       /* it meets the ray behind the camera */
                /* where the window lies beyond the light (n <= 0) that end blocks nothing;
                 * where aa changes sign over the stretch, s sweeps down to 0 */
                float n0 = Rt - tlo0 * sta, n1 = Rt - tlo1 * st1;
                float slo = fmin(n0 > 0.0f ? (aa0 <= 0.0f ? 0.0f : tlo0 * aa0 / n0) : INFINITY,
                                 n1 > 0.0f ? (aa1 <= 0.0f ? 0.0f : tlo1 * aa1 / n1) : INFINITY);
                if (slo == INFINITY) continue;
                float m0 = Rt - thi0 * sta, m1 = Rt - thi1 * st1;
                float lanei = fmax(aa0 > 0.0f ? (m0 > 0.0f ? thi0 * aa0 / m0 : INFINITY) : 0.0f,
                                 aa1 > 0.0f ? (m1 > 0.0f ? thi1 * aa1 / m1 : INFINITY) : 0.0f);
                lo = atan2(slo - d1, R);
                hi = lanei < INFINITY ? atan2(lanei - d1, R) : 0.5f * M_PI_F;
            }
            mark(bits, lo, hi, a0, da);
            if ((++marks & 15) == 0 && all_set(bits)) break;      /* nothing left to shadow */
        }
        if (off && offscreen_shadowed)
            for (int k = 0; k < SH_WORDS; ++k) bits[k] = ~0u;
    }

    uint any = 0u;
    for (int k = 0; k < SH_WORDS; ++k) any |= bits[k];
    if (any == 0u) return 0;                                     /* all lit */
    if (all_set(bits)) {                                          /* all in shadow */
        *fA = (float3)(0.0f);
        *fT = (float3)(0.0f);
        return 1;
    }

    if (m.nprims == 0) {
        shares_homogeneous(&m, &L, w, c - L.pos.xyz, d1, R, Rt, a0, da, bits, fA, fT);
        return 1;
    }
    /* the lit share of the integrand, camera leg in extinction (A) and in absorption (all) */
    float3 st = m.sa.xyz + m.ss.xyz;
    float3 litA = (float3)(0.0f), totA = litA, litT = litA, totT = litA;
    for (int k = 0; k < SH_N; ++k) {
        float P;
        float3 src = al_integrand(&L, &m, &het, prims, 0, c, w, d1, R, a0 + (k + 0.5f) * da, &P);
        /* exp_poly (common.h): inline, where exp is a call per channel */
        float3 fa = src * (float3)(exp_poly(-st.x * P), exp_poly(-st.y * P), exp_poly(-st.z * P));
        float3 ft = src * (float3)(exp_poly(-m.sa.x * P), exp_poly(-m.sa.y * P), exp_poly(-m.sa.z * P));
        float open = 1.0f - popcount(CELL_BITS(bits, k)) * (1.0f / SH_SUB);
        totA += fa;
        totT += ft;
        litA += open * fa;
        litT += open * ft;
    }
    *fA = select((float3)(1.0f), litA / totA, totA > 0.0f);
    *fT = select((float3)(1.0f), litT / totT, totT > 0.0f);
    return 1;
}

/* a_dir = A, a_sc = gain (A + A_sc) - A (lights.cl): A -> fA A, A + A_sc -> fT (A + A_sc); in
 * scalars, each channel after the last (AFTER), so that epi_unwarp vectorises */
ALWAYS_INLINE void apply_shares(__global float4 *a_dir, __global float4 *a_sc, int idx, float fa0, float fa1,
                                float fa2, float ft0, float ft1, float ft2)
{
    float d0, d1, d2, dw, s0, s1, s2, sw;
    load4(a_dir, idx, &d0, &d1, &d2, &dw);
    load4(a_sc, idx, &s0, &s1, &s2, &sw);
    float n0 = fa0 * d0, n1 = AFTER(fa1 * d1, n0), n2 = AFTER(fa2 * d2, n1);
    float c0 = AFTER(ft0 * (s0 + d0) - n0, n2);
    float c1 = AFTER(ft1 * (s1 + d1) - n1, c0);
    float c2 = AFTER(ft2 * (s2 + d2) - n2, c1);
    c0 = c0 > 0.0f ? c0 : 0.0f;
    c1 = c1 > 0.0f ? c1 : 0.0f;
    c2 = c2 > 0.0f ? c2 : 0.0f;
    float y0 = 0.2126f * s0 + 0.7152f * s1 + 0.0722f * s2, y1 = 0.2126f * c0 + 0.7152f * c1 + 0.0722f * c2;
    store4(a_dir, idx, n0, n1, n2, dw);
    store4(a_sc, idx, c0, c1, c2, y0 > 0.0f ? sw * (y1 / y0) : 0.0f);
}

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
