/* The `noise` density primitive (docs/media.md, Noise): fractal value noise inside a box or
 * a sphere, its optical depth along a ray by marching (it has no closed form), and the
 * transmittance function maps (Delalandre et al. 2011) that carry the light leg's optical
 * depth. tools/light_oracles.py holds the same formulas in float64 (the tests' oracle), so any
 * change here is a change there. Builtins are avoided in the noise itself (floor by casts):
 * the density is evaluated hundreds of times per pixel. */
#ifndef FOGCLI_NOISE_H
#define FOGCLI_NOISE_H

#include "common.h"

/* noise_t.shape and tfm_t.kind; the host's are fogcli.structs.NOISE_SHAPES and TFM_KINDS,
 * tested against these (tests/test_structs.py) */
#define NOISE_BOX 0
#define NOISE_SPHERE 1
#define TFM_OCTAHEDRAL 0
#define TFM_PERSPECTIVE 1
#define TFM_ORTHOGRAPHIC 2

typedef struct {            /* fogcli/structs.py: NOISE_T */
    float4 center;          /* world, m */
    float4 hsize;           /* box: half edge lengths; sphere: radius in .x */
    float factor, inv_scale, amplitude, offset;
    float edge;             /* m, soft edge inside the bounds (0: hard) */
    float step;             /* m, march step */
    float norm;             /* 1 / sum of the octaves' weights: fbm in [-1, 1] */
    int octaves;
    uint seed;
    int shape;              /* NOISE_BOX, NOISE_SPHERE */
} noise_t;

/* a 32-bit integer hash of a lattice point (the same in numpy's uint32 arithmetic) */
inline uint lattice_hash(int x, int y, int z, uint seed)
{
    uint h = seed ^ ((uint)x * 0x8da6b343u) ^ ((uint)y * 0xd8163841u) ^ ((uint)z * 0xcb1ab31fu);
    h ^= h >> 16; h *= 0x7feb352du;
    h ^= h >> 15; h *= 0x846ca68bu;
    h ^= h >> 16;
    return h;
}

/* the lattice value in [-1, 1): the top 24 bits, exact in float32 */
inline float lattice_value(int x, int y, int z, uint seed)
{
    return (float)(lattice_hash(x, y, z, seed) >> 8) * (2.0f / 16777216.0f) - 1.0f;
}

inline int floor_i(float v) { int i = (int)v; return i - (v < (float)i ? 1 : 0); }

inline float quintic(float f) { return f * f * f * (f * (f * 6.0f - 15.0f) + 10.0f); }

/* value noise: the lattice values blended by the quintic fade (C2, so a march of it
 * converges like one of a smooth function) */
inline float value_noise(float x, float y, float z, uint seed)
{
    int ix = floor_i(x), iy = floor_i(y), iz = floor_i(z);
    float fx = x - (float)ix, fy = y - (float)iy, fz = z - (float)iz;
    float u = quintic(fx), v = quintic(fy), w = quintic(fz);
    float c000 = lattice_value(ix, iy, iz, seed), c100 = lattice_value(ix + 1, iy, iz, seed);
    float c010 = lattice_value(ix, iy + 1, iz, seed), c110 = lattice_value(ix + 1, iy + 1, iz, seed);
    float c001 = lattice_value(ix, iy, iz + 1, seed), c101 = lattice_value(ix + 1, iy, iz + 1, seed);
    float c011 = lattice_value(ix, iy + 1, iz + 1, seed), c111 = lattice_value(ix + 1, iy + 1, iz + 1, seed);
    float x00 = c000 + u * (c100 - c000), x10 = c010 + u * (c110 - c010);
    float x01 = c001 + u * (c101 - c001), x11 = c011 + u * (c111 - c011);
    float y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
    return y0 + w * (y1 - y0);
}

/* how far x lies inside the bounds, m (negative outside) */
inline float noise_inside(__global const noise_t *n, float3 x)
{
    float3 r = x - n->center.xyz;
    if (n->shape == NOISE_BOX) {
        float3 d = n->hsize.xyz - fabs(r);
        return fmin(d.x, fmin(d.y, d.z));
    }
    return n->hsize.x - SQRT_(r.x * r.x + r.y * r.y + r.z * r.z);
}

/* factor * max(0, offset + amplitude * fbm) * soft edge; fbm's octave o has weight 2^-o,
 * frequency 2^o and a seed of its own, coordinates relative to the centre (the smoke moves
 * with its bounds) */
inline float noise_density(__global const noise_t *n, float3 x)
{
    float inside = noise_inside(n, x);
    if (inside <= 0.0f) return 0.0f;
    float3 p = (x - n->center.xyz) * n->inv_scale;
    float f = 0.0f, a = 1.0f;
    for (int o = 0; o < n->octaves; ++o) {
        f += a * value_noise(p.x, p.y, p.z, n->seed + (uint)o * 0x9e3779b9u);
        p *= 2.0f;
        a *= 0.5f;
    }
    float rho = n->factor * fmax(0.0f, n->offset + n->amplitude * n->norm * f);
    if (n->edge > 0.0f && inside < n->edge) {
        float t = inside / n->edge;
        rho *= t * t * (3.0f - 2.0f * t);
    }
    return rho;
}

inline float noise_sum(__global const noise_t *nz, int count, float3 x)
{
    float rho = 0.0f;
    for (int k = 0; k < count; ++k) rho += noise_density(nz + k, x);
    return rho;
}

/* [*t0, *t1]: where the line p + t u (unit u) is inside the bounds; returns 0 on a miss */
inline int noise_chord(__global const noise_t *n, float3 p, float3 u, float *t0, float *t1)
{
    float3 r = p - n->center.xyz;
    if (n->shape == NOISE_BOX) {
        float lo = -INFINITY, hi = INFINITY;
        float rv[3] = {r.x, r.y, r.z}, uv[3] = {u.x, u.y, u.z}, hv[3] = {n->hsize.x, n->hsize.y, n->hsize.z};
        for (int a = 0; a < 3; ++a) {
            if (fabs(uv[a]) < 1e-12f) {
                if (fabs(rv[a]) > hv[a]) return 0;
                continue;
            }
            float ia = 1.0f / uv[a];
            float ta = (-hv[a] - rv[a]) * ia, tb = (hv[a] - rv[a]) * ia;
            lo = fmax(lo, fmin(ta, tb));
            hi = fmin(hi, fmax(ta, tb));
        }
        *t0 = lo; *t1 = hi;
        return hi > lo;
    }
    float B = dot(r, u);
    float3 perp = r - B * u;        /* not B^2 - C: that cancels far from the sphere */
    float s2 = n->hsize.x * n->hsize.x - dot(perp, perp);
    if (s2 <= 0.0f) return 0;
    float s = sqrt(s2);
    *t0 = -B - s; *t1 = -B + s;
    return 1;
}

/* the union of the primitives' chords, clipped to [lo, hi]; returns 0 when empty.
 * *step: the finest march step among the primitives the line meets */
inline int noise_span(__global const noise_t *nz, int count, float3 p, float3 u, float lo, float hi,
                      float *t0, float *t1, float *step)
{
    float a = INFINITY, b = -INFINITY, h = INFINITY;
    for (int k = 0; k < count; ++k) {
        float c0, c1;
        if (!noise_chord(nz + k, p, u, &c0, &c1)) continue;
        c0 = fmax(c0, lo); c1 = fmin(c1, hi);
        if (c1 <= c0) continue;
        a = fmin(a, c0); b = fmax(b, c1); h = fmin(h, nz[k].step);
    }
    *t0 = a; *t1 = b; *step = h;
    return b > a;
}

/* whether the line p + t u, t in [0, L], meets a noise primitive */
inline int noise_meets(__global const noise_t *nz, int count, float3 p, float3 u, float L)
{
    float t0, t1, h;
    return noise_span(nz, count, p, u, 0.0f, L, &t0, &t1, &h);
}

#define NOISE_MAX_STEPS 512

/* optical depth (density units) of the noise primitives from p along unit u over [0, L]:
 * the midpoint rule over the span, at most NOISE_MAX_STEPS steps */
inline float noise_march(__global const noise_t *nz, int count, float3 p, float3 u, float L)
{
    float t0, t1, h;
    if (count == 0 || !noise_span(nz, count, p, u, 0.0f, L, &t0, &t1, &h)) return 0.0f;
    int ns = (int)ceil((t1 - t0) / h);
    ns = ns < 1 ? 1 : (ns > NOISE_MAX_STEPS ? NOISE_MAX_STEPS : ns);
    float dt = (t1 - t0) / (float)ns, tau = 0.0f;
    for (int k = 0; k < ns; ++k) tau += noise_sum(nz, count, p + (t0 + (k + 0.5f) * dt) * u);
    return tau * dt;
}

/* ---- transmittance function maps: per light a square map of rays, each storing the
 * optical depth of the noise along it as DCT-II coefficients over the ray's own span ---- */

typedef struct {            /* fogcli/structs.py: TFM_T */
    float4 origin;          /* point, spot: the light; directional: the map plane's centre */
    float4 e1, e2, e3;      /* frame; e3 the map's axis (ray direction of an orthographic map) */
    float extent;           /* perspective: tan of the half angle; orthographic: half width, m */
    int kind;               /* TFM_OCTAHEDRAL, TFM_PERSPECTIVE, TFM_ORTHOGRAPHIC */
    int size;               /* texels per side */
    int ncoef;
} tfm_t;

/* octahedral: unit direction (in the map's frame) <-> [0, 1]^2 */
inline float2 oct_encode(float3 d)
{
    float s = fabs(d.x) + fabs(d.y) + fabs(d.z);
    float x = d.x / s, y = d.y / s;
    if (d.z < 0.0f) {
        float ox = (1.0f - fabs(y)) * (x < 0.0f ? -1.0f : 1.0f);
        float oy = (1.0f - fabs(x)) * (y < 0.0f ? -1.0f : 1.0f);
        x = ox; y = oy;
    }
    return (float2)(0.5f * x + 0.5f, 0.5f * y + 0.5f);
}

inline float3 oct_decode(float2 uv)
{
    float x = 2.0f * uv.x - 1.0f, y = 2.0f * uv.y - 1.0f;
    float z = 1.0f - fabs(x) - fabs(y);
    if (z < 0.0f) {
        float ox = (1.0f - fabs(y)) * (x < 0.0f ? -1.0f : 1.0f);
        float oy = (1.0f - fabs(x)) * (y < 0.0f ? -1.0f : 1.0f);
        x = ox; y = oy;
    }
    return normalize((float3)(x, y, z));
}

/* texel (i, j)'s ray: origin *o, unit direction *u */
inline void tfm_ray(const tfm_t *m, float i, float j, float3 *o, float3 *u)
{
    float2 uv = (float2)((i + 0.5f) / m->size, (j + 0.5f) / m->size);
    float3 e1 = m->e1.xyz, e2 = m->e2.xyz, e3 = m->e3.xyz;
    if (m->kind == TFM_OCTAHEDRAL) {
        float3 d = oct_decode(uv);
        *o = m->origin.xyz;
        *u = d.x * e1 + d.y * e2 + d.z * e3;
    } else if (m->kind == TFM_PERSPECTIVE) {
        *o = m->origin.xyz;
        *u = normalize(e3 + m->extent * ((2.0f * uv.x - 1.0f) * e1 + (2.0f * uv.y - 1.0f) * e2));
    } else {
        *o = m->origin.xyz + m->extent * ((2.0f * uv.x - 1.0f) * e1 + (2.0f * uv.y - 1.0f) * e2);
        *u = e3;
    }
}

#define TFM_MAX_COEF 32      /* config: render.lights.coefficients <= 32 */

/* cos(j pi x), j < n: the DCT basis at x, by cos((j + 1) a) = 2 cos a cos(j a) - cos((j - 1) a) */
inline void dct_basis(float x, int n, float *b)
{
    float c1 = cos(M_PI_F * x);
    b[0] = 1.0f;
    b[1] = c1;
    for (int j = 2; j < n; ++j) b[j] = 2.0f * c1 * b[j - 1] - b[j - 2];
}

/* what one texel stores at x in [0, 1] along its span, per metre of span: the DCT series
 * (basis b at x) plus a x + b x^2 (tfm.cl: tfm_build) over the span's length, clamped to
 * [0, total] (pitfall 5 of docs/lights.md); -1 for a texel whose ray misses the noise */
inline float tfm_texel(__global const float *coef, __global const float4 *span, int ncoef, int tex, float x,
                       const float *b)
{
    float4 sp = span[tex];          /* t0, t1, total */
    float len = sp.y - sp.x;
    if (!(len > 0.0f)) return -1.0f;
    __global const float *c = coef + (size_t)tex * (ncoef + 2);
    float f = x * (c[ncoef] + c[ncoef + 1] * x);
    for (int j = 0; j < ncoef; ++j) f += c[j] * b[j];
    return clamp(f, 0.0f, sp.z) / len;
}

/* map index of texel (i, j) with the octahedral map's edges folded back (its neighbours
 * across an edge are mirrored) and the others' clamped */
inline int tfm_index(const tfm_t *m, int i, int j)
{
    int S = m->size;
    if (m->kind == TFM_OCTAHEDRAL) {
        if (i < 0) { i = 0; j = S - 1 - j; } else if (i >= S) { i = S - 1; j = S - 1 - j; }
        if (j < 0) { j = 0; i = S - 1 - i; } else if (j >= S) { j = S - 1; i = S - 1 - i; }
    }
    return clampi_(j, 0, S - 1) * S + clampi_(i, 0, S - 1);
}

/* the noise's optical depth from x to the light (or, orthographic, from upstream of the
 * noise to x). The four nearest texels' series are read at x's place along its own ray's
 * span through the bounds, per metre, and scaled by that span's length: near the
 * silhouette of a hard-edged bound the span shrinks to 0 like a square root, which no
 * interpolation of the texels' optical depths follows (measured behind a hard sphere's rim,
 * 3000 points: max |dT| 0.21 interpolating optical depths, 0.004 this way). Texels that miss the noise
 * drop out of the bilinear weights. */
inline float tfm_tau(const tfm_t *m, __global const float *coef, __global const float4 *span,
                     __global const noise_t *nz, int count, float3 x)
{
    float3 v = x - m->origin.xyz;
    float3 e1 = m->e1.xyz, e2 = m->e2.xyz, e3 = m->e3.xyz;
    float a = dot(v, e1), b = dot(v, e2), c = dot(v, e3), t;
    float2 uv;
    float3 o = m->origin.xyz, u;
    if (m->kind == TFM_OCTAHEDRAL) {
        t = length(v);
        if (t <= 0.0f) return 0.0f;
        uv = oct_encode((float3)(a, b, c));
        u = v / t;
    } else if (m->kind == TFM_PERSPECTIVE) {
        t = length(v);
        if (c <= 0.0f) return 0.0f;
        uv = (float2)(0.5f + 0.5f * a / (c * m->extent), 0.5f + 0.5f * b / (c * m->extent));
        if (uv.x < 0.0f || uv.x > 1.0f || uv.y < 0.0f || uv.y > 1.0f) return 0.0f;
        u = v / t;
    } else {
        t = c;
        uv = (float2)(0.5f + 0.5f * a / m->extent, 0.5f + 0.5f * b / m->extent);
        if (uv.x < 0.0f || uv.x > 1.0f || uv.y < 0.0f || uv.y > 1.0f) return 0.0f;
        o += a * e1 + b * e2;
        u = e3;
    }
    float q0, q1, h;
    if (!noise_span(nz, count, o, u, 0.0f, INFINITY, &q0, &q1, &h) || t <= q0) return 0.0f;
    float xq = fmin((t - q0) / (q1 - q0), 1.0f);
    float fx = uv.x * m->size - 0.5f, fy = uv.y * m->size - 0.5f;
    int i0 = floor_i(fx), j0 = floor_i(fy);
    float wx = fx - i0, wy = fy - j0;
    float basis[TFM_MAX_COEF];
    dct_basis(xq, m->ncoef, basis);
    float g[4], wt[4] = {(1.0f - wx) * (1.0f - wy), wx * (1.0f - wy), (1.0f - wx) * wy, wx * wy};
    g[0] = tfm_texel(coef, span, m->ncoef, tfm_index(m, i0, j0), xq, basis);
    g[1] = tfm_texel(coef, span, m->ncoef, tfm_index(m, i0 + 1, j0), xq, basis);
    g[2] = tfm_texel(coef, span, m->ncoef, tfm_index(m, i0, j0 + 1), xq, basis);
    g[3] = tfm_texel(coef, span, m->ncoef, tfm_index(m, i0 + 1, j0 + 1), xq, basis);
    float sum = 0.0f, ws = 0.0f;
    for (int k = 0; k < 4; ++k)
        if (g[k] >= 0.0f) { sum += wt[k] * g[k]; ws += wt[k]; }
    return ws > 0.0f ? (q1 - q0) * sum / ws : 0.0f;
}

/* ---- rays marched on a grid (render.noise_stride): every `stride`-th pixel of every
 * `stride`-th row and the last ones; cw x ch samples ---- */

typedef struct {
    int pix[4];             /* the four samples around a pixel: their pixel indices */
    int smp[4];             /* their sample indices */
    float wt[4];            /* bilinear weights */
    int same_surface;       /* their bilinear 1 / z is the pixel's own within 1 %: a plane's
                             * 1 / z is linear across the image (the sky: 1 / z = 0) */
} grid4_t;

/* the pixel column (or row) of sample c of the grid */
inline int grid_at(int c, int stride, int n) { return mini_(c * stride, n - 1); }

inline grid4_t grid_neighbours(__global const float *depth, int width, int height, float max_depth, int i, int j,
                               int stride, int cw, int ch)
{
    grid4_t g;
    int ci = mini_(i / stride, cw - 1), cj = mini_(j / stride, ch - 1);
    int ci1 = mini_(ci + 1, cw - 1), cj1 = mini_(cj + 1, ch - 1);
    int si0 = grid_at(ci, stride, width), si1 = grid_at(ci1, stride, width);
    int sj0 = grid_at(cj, stride, height), sj1 = grid_at(cj1, stride, height);
    float fx = si1 > si0 ? (float)(i - si0) / (si1 - si0) : 0.0f;
    float fy = sj1 > sj0 ? (float)(j - sj0) / (sj1 - sj0) : 0.0f;
    g.pix[0] = sj0 * width + si0; g.pix[1] = sj0 * width + si1; g.pix[2] = sj1 * width + si0; g.pix[3] = sj1 * width + si1;
    g.smp[0] = cj * cw + ci; g.smp[1] = cj * cw + ci1; g.smp[2] = cj1 * cw + ci; g.smp[3] = cj1 * cw + ci1;
    g.wt[0] = (1.0f - fx) * (1.0f - fy); g.wt[1] = fx * (1.0f - fy); g.wt[2] = (1.0f - fx) * fy; g.wt[3] = fx * fy;
    float z = depth[j * width + i], iz = z < max_depth ? 1.0f / z : 0.0f, izs = 0.0f;
    for (int k = 0; k < 4; ++k) {
        float zs = depth[g.pix[k]];
        izs += g.wt[k] * (zs < max_depth ? 1.0f / zs : 0.0f);
    }
    g.same_surface = fabs(izs - iz) <= 0.01f * iz;
    return g;
}

#endif
