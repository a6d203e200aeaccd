/* The screen-space shadow model shadows.cl's kernels share: the visibility bits of a ray's
 * cells, the epipolar shadow maps and their min/max test, the lit shares of the airlight's
 * integrand, marched (march_shares) or in closed form (shares_homogeneous). */
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
    float y0 = LUMA_R * s0 + LUMA_G * s1 + LUMA_B * s2, y1 = LUMA_R * c0 + LUMA_G * c1 + LUMA_B * c2;
    store4(a_dir, idx, n0, n1, n2, dw);
    store4(a_sc, idx, c0, c1, c2, y0 > 0.0f ? sw * (y1 / y0) : 0.0f);
}

