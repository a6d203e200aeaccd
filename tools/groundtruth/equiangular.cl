// A path tracer for the night scenes of tools/groundtruth (point lights in a homogeneous
// medium, black emissive surfaces), written because Mitsuba's volpath samples the light's
// in-scattering by free flight: its variance near a point light grows as 1/R^3 and the held-out
// renders stayed at noise 0.11-0.13 after 10000-20000 spp.
//
// Estimator (unbiased): on every segment of the walk, the point lights' in-scattering is
// sampled equiangularly (Kulla & Fajardo 2012), which cancels the 1/r^2 of the light; the walk
// itself continues by HG sampling and a scattering distance forced before the next surface,
// whose emission it adds with the exact transmittance (surfaces are black: they reflect
// nothing). Point lights are never hit, so the two parts do not overlap. One grey medium per launch (a chromatic medium is one launch per
// channel, as in render.py).

#define PI_F 3.14159265358979f
#define SHAPE_STRIDE 16
#define TEX_STRIDE 8

typedef struct { uint s; } rng_t;

// PCG-style hash: per (pixel, sample, seed) streams without state between launches.
inline uint hash_u(uint v) {
    uint s = v * 747796405u + 2891336453u;
    uint w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

inline float rnd(rng_t *r) {
    r->s = hash_u(r->s);
    return (float)(r->s >> 8) * (1.0f / 16777216.0f);
}

// Object space: a shape's world->object affine map A x + b is stored row-major in shp[0..11];
// shp[12] kind (0 rectangle z=0 |x|,|y|<=1, 1 unit sphere, 2 cube [-1,1]^3, 3 disc z=0 r<=1),
// shp[13] flip,
// shp[14] texture index (-1: no emission).
inline float3 to_obj_p(__global const float *m, float3 p) {
    return (float3)(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                    m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                    m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

inline float3 to_obj_v(__global const float *m, float3 v) {
    return (float3)(m[0] * v.x + m[1] * v.y + m[2] * v.z,
                    m[4] * v.x + m[5] * v.y + m[6] * v.z,
                    m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

#define T_EPS 1e-5f

// Nearest hit in (T_EPS, tmax) of one shape, in the ray's own parameter (affine maps keep t).
inline float hit_shape(__global const float *m, float3 o, float3 d, float tmax) {
    int kind = (int)m[12];
    float3 oo = to_obj_p(m, o), dd = to_obj_v(m, d);
    if (kind == 0 || kind == 3) {
        if (fabs(dd.z) < 1e-12f) return INFINITY;
        float t = -oo.z / dd.z;
        if (t <= T_EPS || t >= tmax) return INFINITY;
        float3 p = oo + t * dd;
        if (kind == 3) return p.x * p.x + p.y * p.y <= 1.0f ? t : INFINITY;
        return (fabs(p.x) <= 1.0f && fabs(p.y) <= 1.0f) ? t : INFINITY;
    }
    if (kind == 1) {
        float a = dot(dd, dd), b = dot(oo, dd), c = dot(oo, oo) - 1.0f;
        float disc = b * b - a * c;
        if (disc < 0.0f) return INFINITY;
        float q = sqrt(disc);
        float t0 = (-b - q) / a, t1 = (-b + q) / a;
        float t = t0 > T_EPS ? t0 : t1;
        return (t > T_EPS && t < tmax) ? t : INFINITY;
    }
    float3 inv = 1.0f / dd;
    float3 ta = (-1.0f - oo) * inv, tb = (1.0f - oo) * inv;
    float3 lo = fmin(ta, tb), hi = fmax(ta, tb);
    float tn = fmax(fmax(lo.x, lo.y), lo.z), tf = fmin(fmin(hi.x, hi.y), hi.z);
    if (tn > tf) return INFINITY;
    float t = tn > T_EPS ? tn : tf;
    return (t > T_EPS && t < tmax) ? t : INFINITY;
}

inline float nearest(__global const float *shp, int ns, float3 o, float3 d, float tmax, int *id) {
    float best = tmax;
    *id = -1;
    for (int k = 0; k < ns; ++k) {
        float t = hit_shape(shp + k * SHAPE_STRIDE, o, d, best);
        if (t < best) { best = t; *id = k; }
    }
    return best;
}

inline int occluded(__global const float *shp, int ns, float3 o, float3 d, float tmax) {
    for (int k = 0; k < ns; ++k)
        if (hit_shape(shp + k * SHAPE_STRIDE, o, d, tmax) < tmax) return 1;
    return 0;
}

// Mitsuba 3's uv of each shape (rectangle.cpp, sphere.cpp, the vertex table of cube.cpp) and its
// bitmap lookup (nearest, repeat, row 0 at v = 0).
inline float3 emission(__global const float *m, __global const float *tex,
                       __global const float *texel, float3 o, float3 d, float t) {
    int ti = (int)m[14];
    if (ti < 0) return (float3)(0.0f);
    int kind = (int)m[12];
    float3 p = to_obj_p(m, o + t * d), dd = to_obj_v(m, d);
    float3 n;
    float u, v;
    if (kind == 0) {
        n = (float3)(0.0f, 0.0f, 1.0f);
        u = 0.5f * p.x + 0.5f; v = 0.5f * p.y + 0.5f;
    } else if (kind == 3) {                  // disk.cpp: (r, phi / 2 pi)
        n = (float3)(0.0f, 0.0f, 1.0f);
        u = sqrt(p.x * p.x + p.y * p.y);
        v = atan2(p.y, p.x) * (0.5f / PI_F);
        if (v < 0.0f) v += 1.0f;
    } else if (kind == 1) {
        n = p;
        float phi = atan2(p.y, p.x);
        if (phi < 0.0f) phi += 2.0f * PI_F;
        u = phi * (0.5f / PI_F);
        v = acos(clamp(p.z, -1.0f, 1.0f)) * (1.0f / PI_F);
    } else {
        float3 a = fabs(p);
        if (a.y >= a.x && a.y >= a.z) {
            if (p.y < 0.0f) { n = (float3)(0, -1, 0); u = 0.5f * (p.z + 1.0f); v = 0.5f * (p.x + 1.0f); }
            else            { n = (float3)(0, 1, 0);  u = 0.5f * (1.0f - p.x); v = 0.5f * (1.0f - p.z); }
        } else if (a.x >= a.z) {
            if (p.x > 0.0f) { n = (float3)(1, 0, 0);  u = 0.5f * (p.y + 1.0f); v = 0.5f * (1.0f - p.z); }
            else            { n = (float3)(-1, 0, 0); u = 0.5f * (p.y + 1.0f); v = 0.5f * (p.z + 1.0f); }
        } else {
            if (p.z > 0.0f) { n = (float3)(0, 0, 1);  u = 0.5f * (p.y + 1.0f); v = 0.5f * (p.x + 1.0f); }
            else            { n = (float3)(0, 0, -1); u = 0.5f * (1.0f - p.y); v = 0.5f * (p.x + 1.0f); }
        }
    }
    if (m[13] != 0.0f) n = -n;
    // One-sided emitters; the sign of n.d is the same in object and world space for an affine map.
    if (dot(n, dd) >= 0.0f) return (float3)(0.0f);
    __global const float *tx = tex + ti * TEX_STRIDE;
    int w = (int)tx[0], h = (int)tx[1];
    float uu = u * tx[2], vv = v * tx[3];
    uu -= floor(uu); vv -= floor(vv);
    int ix = min((int)(uu * w), w - 1), iy = min((int)(vv * h), h - 1);
    __global const float *c = texel + (int)tx[4] + 3 * (iy * w + ix);
    return (float3)(c[0], c[1], c[2]);
}

inline float hg(float g, float c) {
    float den = 1.0f + g * g - 2.0f * g * c;
    return (1.0f - g * g) / (4.0f * PI_F * den * sqrt(den));
}

inline float3 sample_hg(float3 w, float g, float u1, float u2) {
    float c;
    if (fabs(g) < 1e-3f) c = 1.0f - 2.0f * u1;
    else {
        float q = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        c = (1.0f + g * g - q * q) / (2.0f * g);
    }
    c = clamp(c, -1.0f, 1.0f);
    float s = sqrt(fmax(0.0f, 1.0f - c * c)), ph = 2.0f * PI_F * u2;
    float3 a = fabs(w.x) > 0.9f ? (float3)(0, 1, 0) : (float3)(1, 0, 0);
    float3 t1 = normalize(cross(a, w)), t2 = cross(w, t1);
    return normalize(s * cos(ph) * t1 + s * sin(ph) * t2 + c * w);
}

// CDF over mu in [-1, 1] of the HG phase (normalised on the sphere) and its inverse.
inline float hg_cdf(float g, float mu) {
    if (fabs(g) < 1e-3f) return 0.5f * (mu + 1.0f);
    return (1.0f - g * g) / (2.0f * g) * (rsqrt(1.0f + g * g - 2.0f * g * mu) - 1.0f / (1.0f + g));
}

inline float hg_cdf_inv(float g, float c) {
    if (fabs(g) < 1e-3f) return 2.0f * c - 1.0f;
    float X = 2.0f * g * c / (1.0f - g * g) + 1.0f / (1.0f + g);
    return clamp((1.0f + g * g - 1.0f / (X * X)) / (2.0f * g), -1.0f, 1.0f);
}

// The segment x + s w, 0 <= s < t, seen from a point c (a light, a lamp's centre): s = d1 + R
// tan th, th in [ta, tb] (span); c_lo and Z: the HG CDF at mu = -sin tb and its mass over the
// span (mu = -sin th is the cosine towards c). False when the span is empty.
typedef struct { float d1, R, ta, tb, span, c_lo, Z; } seg_t;

inline int segment_from(float3 c, float3 x, float3 w, float t, float g, seg_t *q) {
    float3 dl = c - x;
    q->d1 = dot(dl, w);
    q->R = fmax(length(cross(w, dl)), 1e-6f);
    q->ta = atan2(-q->d1, q->R);
    q->tb = isinf(t) ? 0.5f * PI_F - 1e-6f : atan2(t - q->d1, q->R);
    q->span = q->tb - q->ta;
    q->c_lo = hg_cdf(g, -sin(q->tb));
    q->Z = hg_cdf(g, -sin(q->ta)) - q->c_lo;
    return q->span > 0.0f;
}

// One light's single scattering along the segment x + s w, 0 <= s < t. In the angle th seen
// from the light (s = d1 + R tan th, Kulla & Fajardo's equiangular sampling) the 1/r^2 is gone,
// but the HG peak is not: looking towards a light, mu = -sin th goes to 1 at the start of the
// segment and p(mu) is (1 - g)^-3 = 300 times its mean there (g 0.85). So each stratum draws one
// angle uniformly in th and one from HG in mu restricted to the segment, combined by the balance
// heuristic (both pdfs in th: 1 / span and p_HG(mu) cos th / Z).
inline float3 light_segment(__global const float *shp, int ns, float3 x, float3 w, float t,
                            float3 lp, float3 li, float ss, float st, float g, int neq, rng_t *r) {
    seg_t q;
    if (!segment_from(lp, x, w, t, g, &q)) return (float3)(0.0f);
    float d1 = q.d1, R = q.R, ta = q.ta, tb = q.tb, span = q.span, c_lo = q.c_lo, Z = q.Z;
    float acc = 0.0f;
    for (int k = 0; k < 2 * neq; ++k) {
        float xi = ((float)(k >> 1) + rnd(r)) / (float)neq;
        float th = (k & 1) ? asin(-hg_cdf_inv(g, c_lo + xi * Z)) : ta + span * xi;
        th = clamp(th, ta, tb);
        float s = d1 + R * tan(th);
        if (!(s >= 0.0f) || !(s < t)) continue;
        float3 xs = x + s * w, v = lp - xs;
        float r2 = dot(v, v), rr = sqrt(r2);
        float3 vn = v / rr;
        float mu = dot(w, vn);
        float ph = hg(g, mu);
        // f(th) = p(mu) T / R (ds / r^2 = dth / R; the ratio is 1 up to rounding)
        float e = s - d1;
        float f = ph * exp(-st * (s + rr)) / R * ((R * R + e * e) / r2);
        float p_u = 1.0f / span;
        float p_h = Z > 0.0f ? 2.0f * PI_F * hg(g, -sin(th)) * cos(th) / Z : 0.0f;
        if (occluded(shp, ns, xs, vn, rr)) continue;
        acc += f / (p_u + p_h);
    }
    return (ss * acc / (float)neq) * li;
}

// Next-event estimation of the lamps (emissive spheres seen from outside; NEE_STRIDE floats
// each, built by equiangular.py: shape id, the weight that picks it, radius, centre). A walk
// that only scatters reaches a lamp of 0.25 m by chance: in fog the glow of such lamps stayed
// at noise 0.16 after 2624 samples (plaza-fog, 970 s). On every segment one lamp is picked (by
// its weight over the squared distance from the segment, times the transmittance over that
// distance), a point along the segment drawn as for a point light (equiangular, or by HG in
// the angle, each half of the time) and a direction in the lamp's cone. The same path can also
// be made by the walk (a forced scattering distance, then an HG direction that hits the lamp):
// both count it by the balance heuristic, so nothing is counted twice. Signs and panels
// (rectangles) are left to the walk: sampled by area they cost more time than they saved
// (signs-sea: 2x the variance per second).
#define NEE_STRIDE 16

// The weight that picks an emitter for a segment: its power over the squared distance from
// the segment, times the transmittance over that distance (any positive weight is unbiased;
// this one costs no trigonometry, which took most of the time).
inline float nee_weight(__global const float *e, float3 x, float3 w, float t, float st) {
    float3 dl = (float3)(e[4], e[5], e[6]) - x;
    float d1 = clamp(dot(dl, w), 0.0f, t);
    float3 q = dl - d1 * w;
    float d = sqrt(dot(q, q));
    float near = fmax(d - e[3], 0.0f), de = fmax(d, e[3]);
    return e[2] * exp(-st * near) / (de * de);
}

// The pdf (per metre) of the segment point s = d1 + R tan(th) under the half-and-half mixture
// of th uniform on its span and th by HG restricted to the segment (Z: HG's mass there).
inline float seg_pdf(const seg_t *q, float s, float th, float g) {
    float e2 = s - q->d1;
    float p_h = q->Z > 0.0f ? 2.0f * PI_F * hg(g, -sin(th)) * cos(th) / q->Z : 0.0f;
    return 0.5f * (1.0f / q->span + p_h) * q->R / (q->R * q->R + e2 * e2);
}

// The same for the segment x + s w, 0 <= s < t, towards lamp e, from s alone.
inline float nee_s_pdf(__global const float *e, float3 x, float3 w, float t, float g, float s) {
    seg_t q;
    if (!segment_from((float3)(e[4], e[5], e[6]), x, w, t, g, &q)) return 0.0f;
    return seg_pdf(&q, s, atan2(s - q.d1, q.R), g);
}

// The solid-angle pdf of a direction in lamp e's cone seen from x.
inline float nee_dir_pdf(__global const float *e, float3 x) {
    float3 c = (float3)(e[4], e[5], e[6]) - x;
    float d2 = dot(c, c), r2 = e[3] * e[3];
    if (d2 <= r2) return 0.0f;
    return 1.0f / (2.0f * PI_F * (1.0f - sqrt(1.0f - r2 / d2)));
}

#define NEE_MAX 32

// Picks emitter *k with probability weight / sum; returns that probability (0: none).
inline float nee_pick(__global const float *nee, int nn, float3 x, float3 w, float t, float st, float u, int *k) {
    float wt[NEE_MAX], sum = 0.0f;
    for (int i = 0; i < nn; ++i) { wt[i] = nee_weight(nee + i * NEE_STRIDE, x, w, t, st); sum += wt[i]; }
    *k = -1;
    if (!(sum > 0.0f)) return 0.0f;
    float acc = 0.0f, target = u * sum;
    for (int i = 0; i < nn; ++i) {
        acc += wt[i];
        if (target < acc || i == nn - 1) { *k = i; return wt[i] / sum; }
    }
    return 0.0f;
}

// p_walk(s, v): the walk's pdf of the same path (forced distance on the segment, HG direction).
inline float walk_pdf(float st, float t, float s, float g, float mu) {
    float tr = isinf(t) ? 0.0f : exp(-st * t);
    return st * exp(-st * s) / (1.0f - tr) * hg(g, mu);
}

inline float3 nee_segment(__global const float *shp, int ns, __global const float *tex,
                          __global const float *texel, __global const float *nee, int nn,
                          float3 x, float3 w, float t, float ss, float st, float g, int walk_goes_on, rng_t *r) {
    int k;
    float pk = nee_pick(nee, nn, x, w, t, st, rnd(r), &k);
    if (k < 0 || !(pk > 0.0f)) return (float3)(0.0f);
    __global const float *e = nee + k * NEE_STRIDE;
    seg_t q;
    if (!segment_from((float3)(e[4], e[5], e[6]), x, w, t, g, &q)) return (float3)(0.0f);
    float xi = rnd(r);
    float th = rnd(r) < 0.5f ? q.ta + q.span * xi : asin(-hg_cdf_inv(g, q.c_lo + xi * q.Z));
    th = clamp(th, q.ta, q.tb);
    float s = q.d1 + q.R * tan(th);
    if (!(s >= 0.0f) || !(s < t)) return (float3)(0.0f);
    float3 xs = x + s * w;
    float3 c = (float3)(e[4], e[5], e[6]) - xs;
    float d2 = dot(c, c), r2 = e[3] * e[3];
    if (d2 <= r2) return (float3)(0.0f);
    float ct = 1.0f - rnd(r) * (1.0f - sqrt(1.0f - r2 / d2)), sn_ = sqrt(fmax(0.0f, 1.0f - ct * ct));
    float ph = 2.0f * PI_F * rnd(r);
    float3 a = c * rsqrt(d2);
    float3 b0 = fabs(a.x) > 0.9f ? (float3)(0, 1, 0) : (float3)(1, 0, 0);
    float3 t1 = normalize(cross(b0, a)), t2 = cross(a, t1);
    float3 v = normalize(sn_ * cos(ph) * t1 + sn_ * sin(ph) * t2 + ct * a);
    int id;
    float th2 = nearest(shp, ns, xs, v, INFINITY, &id);
    if (id != (int)e[0]) return (float3)(0.0f);
    float3 le = emission(shp + id * SHAPE_STRIDE, tex, texel, xs, v, th2);
    float mu = dot(w, v);
    float p_nee = pk * seg_pdf(&q, s, th, g) * nee_dir_pdf(e, xs);
    float p_w = walk_goes_on ? walk_pdf(st, t, s, g, mu) : 0.0f;
    if (!(p_nee > 0.0f)) return (float3)(0.0f);
    float f = ss * exp(-st * (s + th2)) * hg(g, mu);
    return (f / (p_nee + p_w)) * le;
}

// The balance weight of the walk's own hit on an emitter it could have found by NEE from the
// previous segment (x_p + s_p w_p, then along w for t).
inline float walk_weight(__global const float *nee, int nn, int id, float3 x_p, float3 w_p, float t_p,
                         float s_p, float3 w, float t, float st, float g) {
    int k = -1;
    for (int i = 0; i < nn; ++i)
        if ((int)nee[i * NEE_STRIDE] == id) k = i;
    if (k < 0) return 1.0f;
    float sum = 0.0f;
    for (int i = 0; i < nn; ++i) sum += nee_weight(nee + i * NEE_STRIDE, x_p, w_p, t_p, st);
    __global const float *e = nee + k * NEE_STRIDE;
    float pk = sum > 0.0f ? nee_weight(e, x_p, w_p, t_p, st) / sum : 0.0f;
    float3 xs = x_p + s_p * w_p;
    float p_nee = pk * nee_s_pdf(e, x_p, w_p, t_p, g, s_p) * nee_dir_pdf(e, xs);
    float p_w = walk_pdf(st, t_p, s_p, g, dot(w_p, w));
    return p_w / (p_w + p_nee);
}

__kernel void trace(__global const float *shp, int ns, __global const float *tex,
                    __global const float *texel, __global const float *lights, int nl,
                    __global const float *nee, int nn,
                    int width, int height, float focal, int spp, uint seed,
                    float ss, float st, float g, int neq, int rr_depth, float rr_q, int max_depth, int jitter,
                    __global float *out) {
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int pix = j * width + i;
    float3 sum = (float3)(0.0f);
    for (int n = 0; n < spp; ++n) {
        rng_t r;
        r.s = hash_u(hash_u((uint)pix * 9781u + seed) ^ (uint)n * 6271u + 17u);
        float px = (float)i + (jitter ? rnd(&r) : 0.5f), py = (float)j + (jitter ? rnd(&r) : 0.5f);
        float3 w = normalize((float3)((px - 0.5f * width) / focal, -(py - 0.5f * height) / focal, -1.0f));
        float3 x = (float3)(0.0f);
        float beta = 1.0f;
        float3 L = (float3)(0.0f);
        float3 x_p = x, w_p = w;
        float t_p = 0.0f, s_p = 0.0f;
        for (int depth = 0; max_depth < 0 || depth < max_depth; ++depth) {
            int id;
            float th = nearest(shp, ns, x, w, INFINITY, &id);
            if (ss > 0.0f)
                for (int l = 0; l < nl; ++l) {
                    __global const float *lt = lights + 8 * l;
                    L += beta * light_segment(shp, ns, x, w, th, (float3)(lt[0], lt[1], lt[2]),
                                              (float3)(lt[3], lt[4], lt[5]), ss, st, g, neq, &r);
                }
            // The surface's emission is added with its exact transmittance and the walk is forced
            // to scatter before the surface (a truncated exponential), instead of choosing
            // between the two by one free-flight sample, whose yes/no adds variance wherever the
            // transmittance is neither 0 nor 1 (measured: a small part of the noise here).
            float tr = isinf(th) ? 0.0f : exp(-st * th);
            if (id >= 0) {
                float wt = (depth > 0 && nn > 0) ? walk_weight(nee, nn, id, x_p, w_p, t_p, s_p, w, th, st, g) : 1.0f;
                L += (beta * tr * wt) * emission(shp + id * SHAPE_STRIDE, tex, texel, x, w, th);
            }
            int goes_on = st > 0.0f && ss > 0.0f && tr < 1.0f && (max_depth < 0 || depth + 1 < max_depth);
            if (nn > 0 && ss > 0.0f)
                L += beta * nee_segment(shp, ns, tex, texel, nee, nn, x, w, th, ss, st, g, goes_on, &r);
            if (!(st > 0.0f) || !(ss > 0.0f) || tr >= 1.0f) break;
            float sf = -log(1.0f - rnd(&r) * (1.0f - tr)) / st;
            x_p = x; w_p = w; t_p = th;
            s_p = fmin(sf, th * (1.0f - 1e-6f));
            x += s_p * w;
            beta *= (1.0f - tr) * (ss / st);
            if (depth + 1 >= rr_depth) {
                float q = fmin(beta, rr_q);
                if (rnd(&r) >= q) break;
                beta /= q;
            }
            float u1 = rnd(&r), u2 = rnd(&r);
            w = sample_hg(w, g, u1, u2);
        }
        sum += L;
    }
    out[3 * pix + 0] = sum.x;
    out[3 * pix + 1] = sum.y;
    out[3 * pix + 2] = sum.z;
}
