/* Stage 1c (lights): single-scattered light of point, spot and directional lights along each
 * pixel's ray (docs/lights.md):
 *
 *   A = integral_0^D ss rho(x) p(cos a) I f(x) exp(-tau_cam(s)) exp(-tau_light(x)) / t^2 ds
 *
 * For a point or spot light at distance t = |x - l| the substitution s = d1 + R tan(phi)
 * (d1 = <w, l - c>, R = |w x (l - c)|) gives ds / t^2 = dphi / R, a smooth bounded
 * integrand over phi in [atan2(-d1, R), atan2(D - d1, R)], lights behind the camera
 * included (Pradhan & Kumar's split at the foot of the perpendicular, phi = 0). Gauss-
 * Legendre nodes on each piece between phi = 0, the spot cone's crossings and the sphere
 * primitives' crossings. R is computed from the cross product and kept at least the
 * emitter's radius, so a light on a pixel ray stays finite (its energy kept: lights.h,
 * AL_RADIUS_GAIN). The camera leg splits A into what reaches the camera unscattered
 * (a_dir, exp(-st P)) and what scatters again on the way (a_sc, exp(-sa P)
 * (1 - exp(-ss P))), which the pyramid spreads; a_sc.w holds its luminance
 * times the optical depth where the ray passes the light (a directional light: the
 * luminance-weighted optical depth of the scatter points). This kernel serves spots and media
 * with exponential or sphere primitives; points and directional lights in homogeneous media
 * use airlight_table(_grey) and airlight_sun below. Builtins, not the polynomial
 * forms of common.h: this kernel is not vectorised across work-items anyway (loops over
 * nodes and primitives); native_ sin/cos/exp/sqrt where the airlight test measured no loss
 * on PoCL (a GPU driver's native_ may be coarser: tests/test_lights.py would show it). */
#include "density.h"
#include "lights.h"

/* Pradhan & Kumar's closed form (render.lights.airlight: pk), isotropic phase, homogeneous
 * medium, point lights: with theta the angle at the light measured from the foot of the
 * perpendicular, the part towards the camera integrates exp(-k (sec - tan)) with their
 * three-piece linear fit of sec - tan, the part beyond it their ratio fit
 * f(theta) exp(-g(theta) k^h(theta)) times the forward integral to pi/2. The errata of
 * docs/lights.md are applied (exp(-st d1) kept, st in the exponents, ss in front). */
inline float pk_forward(float k, float th)
{
    const float lo[3] = {0.0f, 0.3959f, 0.8395f}, hi[3] = {0.3959f, 0.8395f, 1.5707964f};
    const float a[3] = {-0.8405f, -0.6331f, -0.5216f}, b[3] = {0.9915f, 0.9094f, 0.8158f};
    float acc = 0.0f;
    for (int i = 0; i < 3; ++i) {
        float t0 = lo[i], t1 = fmin(hi[i], th);
        if (t1 <= t0) break;
        float ka = k * a[i];
        acc += fabs(ka) > 1e-6f ? exp(-k * b[i]) * (exp(-ka * t0) - exp(-ka * t1)) / ka
                                : exp(-k * b[i]) * (t1 - t0);
    }
    return acc;
}

inline float pk_backward(float k, float th)
{
    float f = ((-0.0394f * th + 0.1065f) * th + 0.5774f) * th + 0.0058f;
    float g = ((-0.1299f * th + 0.4204f) * th + 0.3811f) * th + 0.5993f;
    float h = ((0.0171f * th - 0.1586f) * th - 0.0424f) * th + 1.0879f;
    return th > 0.0f ? pk_forward(k, 1.5707964f) * f * exp(-g * pow(fmax(k, 1e-12f), h)) : 0.0f;
}

/* integral over phi in [p0, p1] of exp(-k (tan phi + sec phi)) */
inline float pk_phi(float k, float p0, float p1)
{
    float neg = p0 < 0.0f ? pk_forward(k, -p0) - pk_forward(k, -fmin(p1, 0.0f)) : 0.0f;
    float pos = p1 > 0.0f ? pk_backward(k, p1) - pk_backward(k, fmax(p0, 0.0f)) : 0.0f;
    return neg + pos;
}

__kernel void airlight_pk(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                          const int width, const int height, const camera_t cam, const lmedium_t m,
                          const light_t L)
{
    PIXEL_RAY
    float3 w = (float3)(wx, wy, wz), v = L.pos.xyz - cam.pos.xyz;
    float d1 = dot(w, v);
    float3 cr = cross(w, v);
    float R = sqrt(fmax(dot(cr, cr), L.radius * L.radius));
    float p0 = atan2(-d1, R), p1 = atan2(D - d1, R);
    float3 st = (m.sa.xyz + m.ss.xyz) * m.homogeneous, sa = m.sa.xyz * m.homogeneous;
    float3 pre = m.ss.xyz * m.homogeneous * L.intensity.xyz / (12.566370614f * R)
                 * AL_RADIUS_GAIN(dot(cr, cr), L.radius * L.radius, p0, p1);
    /* the direct part has exp(-st (s + t)); the twice-scattered part
     * exp(-st t) (exp(-sa s) - exp(-st s)), whose first term is not of PK's form: it is
     * left at the direct part's share, (1 - exp(-ss s_foot)) exp(-sa s_foot) / exp(-st s_foot) */
    float3 dir = (float3)(pre.x * exp(-st.x * d1) * pk_phi(st.x * R, p0, p1),
                          pre.y * exp(-st.y * d1) * pk_phi(st.y * R, p0, p1),
                          pre.z * exp(-st.z * d1) * pk_phi(st.z * R, p0, p1));
    float sf = clamp(d1, 0.0f, D);
    float3 ratio = exp(-sa * sf) * (1.0f - exp(-(st - sa) * sf)) / exp(-st * sf);
    float3 sc = dir * ratio;
    sc += (L.gain.xyz - 1.0f) * (dir + sc);
    float P = m.homogeneous * sf;
    float4 od = (float4)(dir, 0.0f), os = (float4)(sc, (LUMA_R * sc.x + LUMA_G * sc.y + LUMA_B * sc.z) * P);
    a_dir[idx] = od;
    a_sc[idx] = os;
}

__kernel void airlight(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                       const int width, const int height, const camera_t cam, const lmedium_t m,
                       __global const float4 *prims, __global const float2 *gl, const light_t L)
{
    PIXEL_RAY
    float3 w = (float3)(wx, wy, wz), c = cam.pos.xyz;
    float3 sa = m.sa.xyz, ss = m.ss.xyz, st = sa + ss;
    float3 dir = (float3)(0.0f), sc = (float3)(0.0f);
    float wp = 0.0f;

    /* a directional light is dimmed by the non-homogeneous primitives only (docs/lights.md) */
    lmedium_t het = m;
    het.homogeneous = 0.0f;
    float cuts[MAX_CUTS];
    float d1, R;
    int n = ray_cuts(&L, &m, prims, c, w, D, &d1, &R, cuts);

    for (int p = 0; p + 1 < n; ++p) {
        float s0 = cuts[p], s1 = cuts[p + 1];
        if (s1 <= s0) continue;
        /* points and spots integrate in phi, the directional light in s */
        float a0 = L.type == LIGHT_DIRECTIONAL ? s0 : atan2(s0 - d1, R);
        float a1 = L.type == LIGHT_DIRECTIONAL ? s1 : atan2(s1 - d1, R);
        float hw = 0.5f * (a1 - a0), mid = 0.5f * (a1 + a0);
        for (int k = 0; k < m.nodes; ++k) {
            float2 nw = gl[k];
            float P;
            float3 src = hw * nw.y * al_integrand(&L, &m, &het, prims, 0, c, w, d1, R, mid + hw * nw.x, &P);
            al_accumulate(src, P, sa, st, &dir, &sc, &wp);
        }
    }
    if (L.type != LIGHT_DIRECTIONAL)
        al_point_gain(&L, c, w, d1, R, D, &dir, &sc, &wp, optical_depth(prims, &m, c, w, clamp(d1, 0.0f, D)));
    float4 od = (float4)(dir, 0.0f), os = (float4)(sc, wp);
    a_dir[idx] = od;
    a_sc[idx] = os;
}

/* ---- point and directional lights in a homogeneous medium: tables, not quadrature ----
 * fogcli/physics/airlight_table.py: with s = d1 + R sinh(x) the airlight is
 * ss I / R exp(-a d1) int_{x0}^{x1} h(x) exp(-beta E_r(x)) dx, h = p_g(-tanh x) / cosh x,
 * E_r = r sinh x + cosh x, beta = sigma R, r = a / sigma; the tables hold the integral's
 * cumulative sums from the left (F) and the right (C) on (ln beta, x), as logarithms with
 * beta times a known factor added (taken off here exactly). A difference of two cumulative
 * sums that would lose its digits (less than half of either) is integrated directly: the
 * interval is then short against the integrand's scale and Simpson's rule does. */
#ifdef AL_NX
/* Written for PoCL's vectoriser, which only widens the loop over work-items when the body
 * has no calls, no conditional loads and no vector-typed values (measured on this kernel):
 *  - helpers forced inline (past LLVM's budget they stay calls);
 *  - exp_poly, log_pos and SQRT_ (common.h), not the library's exp, log, sqrt;
 *  - sinh, cosh, asinh from e^x, which the geometry gives directly: e^x = (q + t) / R with
 *    q = s - d1, t = |x - l| (R / (t - q) where q < 0, without cancellation);
 *  - table indices clamped by fabs (a compare-and-select clamp before a gather stops it);
 *  - uniform values from the host as scalars, and isomorphic steps chained by AFTER:
 *    LLVM's SLP pass pairs two side-by-side copies of a computation into 2-wide vectors
 *    before PoCL builds the work-item loop, and such a value stops the loop's vectoriser
 *    ("instruction return type cannot be vectorized"; seen with llvm-dis on PoCL's
 *    parallel.bc, POCL_LEAVE_KERNEL_COMPILER_TEMP_FILES=1). */

#include "lanes.h"

/* v clamped to [0, hi], exact inside */
ALWAYS_INLINE lanef al_clamp(lanef v, float hi)
{
    v = 0.5f * (v + LANE_ABS(v));
    lanef d = v - hi;
    return v - 0.5f * (d + LANE_ABS(d));
}

/* bilinear look-up of table entry `e` (0: F, 1: C) at continuous (u, v) */
ALWAYS_INLINE lanef al_fetch(__global const float *tab, lanef u, lanef v, int e)
{
    u = al_clamp(u, AL_NB - 1.001f);
    v = al_clamp(v, AL_NX - 1.001f);
    lanei i = LANE_INT(u), j = LANE_INT(v);
    lanef fu = u - LANE_FLOAT(i), fv = v - LANE_FLOAT(j);
    lanei k = 2 * (i * AL_NX + j) + e;
    lanef p0 = LANE_LOAD(tab, k), p1 = LANE_LOAD(tab, k + 2), p2 = LANE_LOAD(tab, k + 2 * AL_NX), p3 = LANE_LOAD(tab, k + 2 * AL_NX + 2);
    lanef a = p0 + (p1 - p0) * fv, b = p2 + (p3 - p2) * fv;
    return a + (b - a) * fu;
}

/* atan(e), e > 0 (phi = 2 atan(e^x) - pi/2 from the tables' e^x): a polynomial on [0, 1] (1e-5
 * rad), pi/2 - atan(1/e) above; the library's atan is a call per lane in PoCL */
ALWAYS_INLINE lanef al_atan_pos(lanef e)
{
    lanef t = e > 1.0f ? 1.0f / e : e, t2 = t * t;
    lanef a = t * (0.99997726f + t2 * (-0.33262347f + t2 * (0.19354346f + t2 * (-0.11643287f
                                       + t2 * (0.05265332f + t2 * -0.01172120f)))));
    return e > 1.0f ? 1.5707963268f - a : a;
}

ALWAYS_INLINE lanef al_ex(lanef q, lanef R)
{
    lanef t = LANE_SQRT(q * q + R * R);
    return q >= 0.0f ? (q + t) / R : R / (t - q);
}

/* h(x) = p_g(-tanh x) / cosh x from e^x (clamped to [1e-15, 1e15], where h is below 1e-14 of
 * its peak: e^2x stays finite) */
ALWAYS_INLINE lanef al_h(float g, lanef ex)
{
    ex = 1e-15f + al_clamp(ex - 1e-15f, 1e15f);
    lanef e2 = ex * ex, q = 1.0f / (e2 + 1.0f);
    lanef d = 1.0f + g * g + 2.0f * g * (1.0f - 2.0f * q);     /* tanh x = 1 - 2 / (e^2x + 1) */
    return (1.0f - g * g) * 0.1591549431f * ex * q / (d * LANE_SQRT(d));   /* 1 / cosh x = 2 e^x q */
}

/* ln of int_{x0}^{x1} h exp(-beta E_r) dx, E_r = ((1 + r) e^x + (1 - r) e^-x) / 2; xm, em:
 * where E_r is smallest and its value (r < 1; r = 1: -inf and 0); `after`: a value of the
 * caller's to chain the first step to. Where the difference of the cumulative sums would
 * lose its digits the interval is short against the integrand's scale: Simpson's rule in
 * the linear domain, the exponent at the middle factored out, h at the three nodes from the
 * caller (sp: e^x at the middle, its inverse, h at x0, middle, x1; the same for every
 * channel). The vectorised loop evaluates this branch for every pixel, so it has to be cheap:
 * it replaced 2 Gauss-Legendre nodes (5 exponentials, 9 divisions per segment; now 2
 * exponentials per segment; worst in test_table_kernel_matches_the_quadrature_kernel_on_whole_
 * frames, A / A_sc: 4.5e-4 / 1.67e-3 with Simpson, 3.0e-4 / 1.74e-3 with the 2 nodes). */
ALWAYS_INLINE lanef al_segment(__global const float *tab, float r, float xm, float em, lanef beta,
                         lanef lb, lanef x0, lanef x1, lanef ex0, lanef ex1, const lanef *sp, lanef after)
{
    const float sx = (AL_NX - 1) / (AL_X1 - AL_X0);
    lanef u = AFTER((lb - AL_LB0) * ((AL_NB - 1) / (AL_LB1 - AL_LB0)), after);
    lanef v0 = (x0 - AL_X0) * sx;
    lanef v1 = AFTER((x1 - AL_X0) * sx, v0);
    lanef e0 = 0.5f * ((1.0f + r) * ex0 + (1.0f - r) / ex0);
    lanef e1 = 0.5f * ((1.0f + r) * ex1 + (1.0f - r) / AFTER(ex1, e0));
    lanef F0 = al_fetch(tab, u, v0, 0) - beta * (x0 < xm ? e0 : em);
    lanef F1 = al_fetch(tab, u, AFTER(v1, F0), 0) - beta * (x1 < xm ? e1 : em);
    lanef C0 = al_fetch(tab, u, AFTER(v0, F1), 1) - beta * (x0 > xm ? e0 : em);
    lanef C1 = al_fetch(tab, u, AFTER(v1, C0), 1) - beta * (x1 > xm ? e1 : em);
    /* outside the table h ~ 2 p e^{-|x|}: ln F (r = 1, left) and ln C (right) go with slope +-1
     * (r is uniform: the outer choice is not per pixel) */
    F0 += r >= 1.0f ? (x0 < AL_X0 ? x0 - AL_X0 : 0.0f) : 0.0f;
    F1 += r >= 1.0f ? (x1 < AL_X0 ? x1 - AL_X0 : 0.0f) : 0.0f;
    C0 -= x0 > AL_X1 ? x0 - AL_X1 : 0.0f;
    C1 -= x1 > AL_X1 ? x1 - AL_X1 : 0.0f;
    lanef big = F1 < C0 ? F1 : C0, small = F1 < C0 ? F0 : C1;
    lanef tabled = big + lane_log(1.0f - lane_exp(small - big));
    lanef mid = beta * 0.5f * ((1.0f + r) * sp[0] + (1.0f - r) * sp[1]);
    lanef f0 = sp[2] * lane_exp(mid - beta * e0);
    lanef f1 = sp[4] * lane_exp(AFTER(mid - beta * e1, f0));
    lanef direct = -mid + lane_log((x1 - x0) * (1.0f / 6.0f) * (f0 + 4.0f * sp[3] + f1));
    return small - big <= -0.6931472f ? tabled : direct;
}

/* One channel: ln of A (both legs in extinction st) and of A + A_sc (camera leg in
 * absorption sa) per unit of ss I / R, out through ld, lt. The channel's uniform values:
 * r = sa / st, xm = -atanh(r), em = sqrt(1 - r^2), off = its table's offset in floats. */
ALWAYS_INLINE void al_channel(__global const float *tab, float st, float lst, float sa, float r, float xm,
                          float em, int off, lanef R, lanef d1, lanef x0, lanef x1, lanef ex0, lanef ex1, lanef lR,
                          const lanef *sp, lanef after, lanef *ld, lanef *lt)
{
    lanef beta = st * R;
    lanef lb = AFTER(lR + lst, after);       /* ln beta, lst = ln st from the host */
    lb = AL_LB0 + 0.5f * ((lb - AL_LB0) + LANE_ABS(lb - AL_LB0));   /* beta below the table: its first row */
    lanef d = -st * d1 + al_segment(tab, 1.0f, -1e30f, 0.0f, beta, lb, x0, x1, ex0, ex1, sp, lb);
    lanef t = r < 1.0f ? -sa * d1 + al_segment(tab + off, r, xm, em, beta, lb, x0, x1, ex0, ex1, sp, d) : d;
    *ld = beta < AL_BMAX ? d - lR : -1e30f;
    *lt = beta < AL_BMAX ? t - lR : -1e30f;
}

#if LANES == 8
/* pixel_ray (density.h) of pixels i0 .. i0 + 7 of row j, depth dep */
ALWAYS_INLINE float8 al_pixel_ray(const camera_t *c, int i0, int j, float8 dep, float8 *wx, float8 *wy, float8 *wz)
{
    float8 dx = ((float)i0 + (float8)(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f) - c->cx) / c->focal_px;
    float dy = -(j + 0.5f - c->cy) / c->focal_y;
    float8 dlen = LANE_SQRT(dx * dx + dy * dy + 1.0f);
    float8 r = 1.0f / dlen;
    *wx = (c->rot0.x * dx + c->rot0.y * dy - c->rot0.z) * r;
    *wy = (c->rot1.x * dx + c->rot1.y * dy - c->rot1.z) * r;
    *wz = (c->rot2.x * dx + c->rot2.y * dy - c->rot2.z) * r;
    float8 dist = dep * (c->depth_is_z ? dlen : (float8)(1.0f));
    return dist < c->max_depth ? dist : c->max_depth;
}
/* eight pixels of a row; at the row's end the lanes past it read its last pixel and are not
 * stored */
#define AL_PIXELS                                                                              \
    int i = 8 * get_global_id(0), j = get_global_id(1);                                        \
    if (i >= width || j >= height) return;                                                     \
    int idx = j * width + i, whole = i + 8 <= width;                                           \
    int8 lane = (int8)(0, 1, 2, 3, 4, 5, 6, 7), last = (int8)(width - 1 - i);                  \
    float8 dep = whole ? lane_load8(depth + idx) : LANE_LOAD(depth + idx, lane < last ? lane : last); \
    float8 wx, wy, wz;                                                                         \
    float8 D = al_pixel_ray(&cam, i, j, dep, &wx, &wy, &wz);
#define AL_PUT1(L)                                                                             \
    if (whole || i + L < width) {                                                              \
        a_dir[idx + L] = (float4)(d0r.s##L, d1r.s##L, d2r.s##L, 0.0f);                         \
        a_sc[idx + L] = (float4)(s0.s##L, s1.s##L, s2.s##L, wp.s##L);                          \
    }
#define AL_PUT                                                                                 \
    AL_PUT1(0) AL_PUT1(1) AL_PUT1(2) AL_PUT1(3) AL_PUT1(4) AL_PUT1(5) AL_PUT1(6) AL_PUT1(7)
#else
#define AL_PIXELS PIXEL_RAY
#define AL_PUT                                                                                 \
    store4(a_dir, idx, d0r, d1r, d2r, 0.0f);                                                   \
    store4(a_sc, idx, s0, s1, s2, wp);
#endif

/* The per-pixel part the kernels share: ray, d1, R, e^x and x at both ends, ln R. */
#define AL_GEOMETRY                                                                            \
    AL_PIXELS                                                                                  \
    lanef cx = wy * vz - wz * vy;                                                                \
    lanef cy = AFTER(wz * vx - wx * vz, cx);                                                  \
    lanef cz = AFTER(wx * vy - wy * vx, cy);                                                  \
    lanef d1 = AFTER(wx * vx + wy * vy + wz * vz, cz);                                        \
    lanef R02 = cx * cx + cy * cy + cz * cz, R = LANE_SQRT(R02 > rad2 ? R02 : rad2);            \
    lanef ex0 = al_ex(-d1, R);                                                                   \
    lanef ex1 = al_ex(AFTER(D - d1, ex0), R);                                                 \
    lanef x0 = lane_log(ex0);                                                                      \
    lanef x1 = lane_log(AFTER(ex1, x0));                                                        \
    lanef lR = lane_log(AFTER(R, x1));                                                          \
    lanef rg = AL_RADIUS_GAIN(R02, rad2, 2.0f * al_atan_pos(ex0), 2.0f * al_atan_pos(ex1));      \
    /* Simpson's rule on [x0, x1] where a table difference would lose its digits: e^x at the  \
     * middle (sqrt of the ends' product, clamped as al_h does), its inverse, h at the nodes;  \
     * h does not depend on the channel */                                                    \
    lanef sp[5];                                                                                 \
    sp[0] = LANE_SQRT((1e-15f + al_clamp(ex0 - 1e-15f, 1e15f)) * (1e-15f + al_clamp(ex1 - 1e-15f, 1e15f))); \
    sp[1] = 1.0f / sp[0];                                                                      \
    sp[2] = al_h(g, AFTER(ex0, sp[1]));                                                     \
    sp[3] = al_h(g, AFTER(sp[0], sp[2]));                                                   \
    sp[4] = al_h(g, AFTER(ex1, sp[3]));

/* The end the kernels share: the airlight of the three channels from their logs (ld, lt),
 * ln(ss I) per channel (lk), the gain; A_sc spread at the optical depth where the ray passes
 * the light (hf clamp(d1, 0, D)). */
#define AL_STORE                                                                               \
    lanef d0r = rg * lane_exp(lk0 + ld0);                                                          \
    lanef d1r = rg * lane_exp(AFTER(lk1 + ld1, d0r));                                           \
    lanef d2r = rg * lane_exp(AFTER(lk2 + ld2, d1r));                                           \
    lanef t0 = rg * lane_exp(AFTER(lk0 + lt0, d2r));                                            \
    lanef t1 = rg * lane_exp(AFTER(lk1 + lt1, t0));                                             \
    lanef t2 = rg * lane_exp(AFTER(lk2 + lt2, t1));                                             \
    AL_STORE_RGB

/* Grey media: one exponential each for A and A + A_sc, scaled per channel by the host's
 * k_c = exp(lk_c - lkm) <= 1 (lkm the largest lk: nothing overflows that did not before).
 * Each exponential is a dependent step of the chain that keeps LLVM from pairing them,
 * and the chain is the kernel's latency: 2 steps instead of 6 (-15 % of the kernel). */
#define AL_STORE_GREY                                                                          \
    lanef ed = rg * lane_exp(lkm + ld0);                                                           \
    lanef et = rg * lane_exp(AFTER(lkm + lt0, ed));                                             \
    lanef d0r = k0 * ed, d1r = AFTER(k1 * ed, d0r), d2r = AFTER(k2 * ed, d1r);             \
    lanef t0 = AFTER(k0 * et, d2r), t1 = AFTER(k1 * et, t0), t2 = AFTER(k2 * et, t1);   \
    AL_STORE_RGB

#define AL_STORE_RGB                                                                           \
    lanef s0 = t0 - d0r, s1 = AFTER(t1 - d1r, s0), s2 = AFTER(t2 - d2r, s1);               \
    s0 = 0.5f * (s0 + LANE_ABS(s0));                                                             \
    s1 = 0.5f * (s1 + LANE_ABS(s1));                                                             \
    s2 = 0.5f * (s2 + LANE_ABS(s2));                                                             \
    s0 += (gn0 - 1.0f) * (d0r + s0);                                                           \
    s1 = AFTER(s1 + (gn1 - 1.0f) * (d1r + s1), s0);                                         \
    s2 = AFTER(s2 + (gn2 - 1.0f) * (d2r + s2), s1);                                         \
    lanef sstar = hf * (0.5f * (d1 + LANE_ABS(d1)) - 0.5f * ((d1 - D) + LANE_ABS(d1 - D)));          \
    lanef wp = sstar * (LUMA_R * s0 + LUMA_G * s1 + LUMA_B * s2);                             \
    AL_PUT

/* The uniforms both table kernels read by name in the macros above (al_table_t). */
#define AL_UNIFORMS                                                                            \
    const float g = u.g, hf = u.hf, vx = u.vx, vy = u.vy, vz = u.vz, rad2 = u.rad2;            \
    const float gn0 = u.gn[0], gn1 = u.gn[1], gn2 = u.gn[2];

/* Point lights when every density primitive is homogeneous (factor hf): grey media (the three
 * channels share st, sa), integrated once. vx, vy, vz: camera to light (world); rad2: the
 * light's radius squared; lkm: the largest ln(ss I) of the channels (-1e30 for none), k*: each
 * channel's ss I over the largest; gn*: the gain. */
__kernel void airlight_table_grey(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                                  const int width, const int height, const camera_t cam,
                                  __global const float *tab, const al_table_t u)
{
    AL_UNIFORMS
    const float lkm = u.lkm, k0 = u.k[0], k1 = u.k[1], k2 = u.k[2];
    AL_GEOMETRY
    lanef ld0, lt0;
    al_channel(tab, u.st[0], u.lst[0], u.sa[0], u.r[0], u.xm[0], u.em[0], u.off[0], R, d1, x0, x1, ex0, ex1, lR, sp,
               sp[4], &ld0, &lt0);
    AL_STORE_GREY
}

/* The same for media whose channels differ (sea water): three channels, one after another. */
__kernel void airlight_table(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                             const int width, const int height, const camera_t cam,
                             __global const float *tab, const al_table_t u)
{
    AL_UNIFORMS
    const float lk0 = u.lk[0], lk1 = u.lk[1], lk2 = u.lk[2];
    AL_GEOMETRY
    lanef ld0, lt0, ld1, lt1, ld2, lt2;
    al_channel(tab, u.st[0], u.lst[0], u.sa[0], u.r[0], u.xm[0], u.em[0], u.off[0], R, d1, x0, x1, ex0, ex1, lR, sp,
               sp[4], &ld0, &lt0);
    al_channel(tab, u.st[1], u.lst[1], u.sa[1], u.r[1], u.xm[1], u.em[1], u.off[1], R, d1, x0, x1, ex0, ex1, lR, sp,
               lt0, &ld1, &lt1);
    al_channel(tab, u.st[2], u.lst[2], u.sa[2], u.r[2], u.xm[2], u.em[2], u.off[2], R, d1, x0, x1, ex0, ex1, lR, sp,
               lt1, &ld2, &lt2);
    AL_STORE
}

/* Directional lights in homogeneous media: the airlight in closed form (the homogeneous part
 * does not dim a directional light: docs/lights.md). a_sc.w: the luminance-weighted optical
 * depth of its twice-scattered light. */
/* int_0^D e^{-q s} ds and int_0^D s e^{-q s} ds, finite as q -> 0 */
ALWAYS_INLINE float sun_int0(float q, float D)
{
    float qd = q * D;
    return qd > 1e-3f ? one_minus_exp(qd) / q : D * (1.0f - 0.5f * qd);
}

ALWAYS_INLINE float sun_int1(float q, float D)
{
    float qd = q * D;
    return qd > 1e-2f ? (one_minus_exp(qd) - qd * exp_poly(-qd)) / (q * q) : D * D * (0.5f - qd / 3.0f);
}

__kernel void airlight_sun(__global const float *depth, __global float4 *a_dir, __global float4 *a_sc,
                           const int width, const int height, const camera_t cam, const lmedium_t m,
                           const light_t L)
{
    PIXEL_RAY
    float hf = m.homogeneous, gg = m.g;
    float hd = 1.0f + gg * gg - 2.0f * gg * (L.axis.x * wx + L.axis.y * wy + L.axis.z * wz);
    float p = (1.0f - gg * gg) / (12.566370614f * hd * SQRT_(hd));
    /* no loops or arrays: they keep PoCL from vectorising across work-items */
#define SUN_CHANNEL(C, DIR, SC, CEN)                                                    \
    float DIR, SC, CEN;                                                                 \
    {                                                                                   \
        float sa = hf * m.sa.C, st = sa + hf * m.ss.C, k = hf * m.ss.C * p * L.intensity.C; \
        DIR = k * sun_int0(st, D);                                                      \
        SC = k * (sun_int0(sa, D) - sun_int0(st, D));                                   \
        SC = SC > 0.0f ? SC : 0.0f;                                                     \
        CEN = hf * k * (sun_int1(sa, D) - sun_int1(st, D));                             \
    }
    SUN_CHANNEL(x, d0, s0, c0)
    SUN_CHANNEL(y, d1, s1, c1)
    SUN_CHANNEL(z, d2, s2, c2)
#undef SUN_CHANNEL
    float wp = LUMA_R * c0 + LUMA_G * c1 + LUMA_B * c2;
    store4(a_dir, idx, d0, d1, d2, 0.0f);
    store4(a_sc, idx, s0, s1, s2, wp);
}
#endif

/* The lights' twice-scattered part joins the scattered light at level 0 of the colour chain:
 * summed with what is there, log P weighted by luminance, and its per-level shares (apsf)
 * from the table at that log P. (A second chain of its own, like Iser's separated pixels,
 * measured the same on the night scenes with known lights and worse with detected lamps,
 * and cost a second pyramid.) */
#ifdef PSF_APSF
__kernel void airlight_to_chain(__global const float4 *a_sc, __global float4 *chain0, __global float4 *prep0,
                                __global const float *lut, const int n)
{
    int idx = get_global_id(0);
    if (idx >= n) return;
    /* scalar loads and stores, log_pos: PoCL vectorises it (common.h) */
    float ar, ag, ab, aw, cr, cg, cb, cw;
    load4(a_sc, idx, &ar, &ag, &ab, &aw);
    load4(chain0, idx, &cr, &cg, &cb, &cw);
    /* weights of each channel's magnitude: the ground's sources have either sign */
    float ya = light_weight((float3)(ar, ag, ab));
    float yc = light_weight((float3)(cr, cg, cb));
    float pa = ya > 0.0f ? aw / ya : 1e-30f;
    float lpa = log_pos(pa > 1e-30f ? pa : 1e-30f);
    float lp = (yc + ya) > 0.0f ? (yc * cw + ya * lpa) / (yc + ya) : lpa;
    float r = cr + ar, g = cg + ag, b = cb + ab;
    store4(chain0, idx, r, g, b, lp);
    store_prep_apsf(prep0, idx, r, g, b, lp, lut, 0);
}
#endif

/* Lights after the first: their airlight (written to t_dir, t_sc) added to the sums. The
 * airlight kernels never read what they write: a read there keeps PoCL from vectorising. */
__kernel void add_light(__global float4 *a_dir, __global const float4 *t_dir, __global float4 *a_sc,
                        __global const float4 *t_sc, const int n)
{
    int idx = get_global_id(0);
    if (idx >= n) return;
    float a0, a1, a2, a3, b0, b1, b2, b3;
    load4(a_dir, idx, &a0, &a1, &a2, &a3);
    load4(t_dir, idx, &b0, &b1, &b2, &b3);
    store4(a_dir, idx, a0 + b0, a1 + b1, a2 + b2, a3 + b3);
    load4(a_sc, idx, &a0, &a1, &a2, &a3);
    load4(t_sc, idx, &b0, &b1, &b2, &b3);
    store4(a_sc, idx, a0 + b0, a1 + b1, a2 + b2, a3 + b3);
}

/* out += a_dir after the pyramid: the 1/R core of a light stays sharp */
__kernel void add_airlight(__global float4 *out, __global const float4 *a_dir, const int n)
{
    int idx = get_global_id(0);
    if (idx >= n) return;
    float4 o = out[idx];
    out[idx] = (float4)(o.xyz + a_dir[idx].xyz, o.w);
}

/* Detected lamps: their own pixels keep the share `keep` of their scattered light at level 0
 * (the light model carries the rest: frame.scene.share_lamps); what reaches the camera
 * directly stays. idx: the n pixels, keep: their shares (RGB). */
__kernel void keep_sources(__global float4 *chain0, __global float4 *prep0, __global const int *idx,
                           __global const float4 *keep, const int n)
{
    int k = get_global_id(0);
    if (k >= n) return;
    int i = idx[k];
    float3 s = keep[k].xyz;
    chain0[i].xyz *= s;
    prep0[i].xyz *= s;
}
