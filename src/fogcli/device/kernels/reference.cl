/* The screen-space reference (Elek sec. 3.3): every pixel spreads its L_sc with its
 * point-spread kernel, truncated at R = ceil(4 sigma). Closed border: each kernel is
 * normalised over the in-image pixels it reaches, so no scattered energy leaves the frame;
 * open: normalised over the whole plane, so what falls outside is lost. extend: open, with
 * the frame's edge continued `margin` pixels past each side as sources, as the pyramid
 * continues it (edge_bands.h), the world a photograph goes on showing.
 *
 * psf gaussian, binned form: sigma is split between two neighbouring bins of a geometric
 * ladder (linear weights in log sigma); each bin is a separable Gaussian whose per-pixel
 * normalisation is the product of two 1-D sums. psf apsf: the kernel is the table's sum
 * of Gaussians, one pass per Gaussian with each pixel's own weight (ref_apsf_source).
 * `ref_brute` is the O(N^2) definition of the Gaussian, kept to validate the binned form. */
#include "common.h"
#include "edge_bands.h"

/* taps[r] = exp(-r^2 / (2 sigma^2)), r = 0..R */
__kernel void ref_taps(__global float *taps, const float sigma, const int R)
{
    int r = get_global_id(0);
    if (r > R) return;
    taps[r] = exp(-(float)(r * r) / (2.0f * sigma * sigma));
}

/* norm[x] = sum of taps reaching in-image positions from x along an axis of length n
 * (closed border), or of all taps (open border) */
__kernel void ref_norm1d(__global const float *taps, const int R, const int n,
                         __global float *norm, const int open_border)
{
    int x = get_global_id(0);
    if (x >= n) return;
    float s = 0.0f;
    int lo = open_border ? -R : max(-R, -x), hi = open_border ? R : min(R, n - 1 - x);
    for (int d = lo; d <= hi; ++d) s += taps[abs(d)];
    norm[x] = s;
}

#ifdef PSF_APSF
/* Gaussian j of the table: a pixel's L_sc times its own weight (from log P in .w of the
 * colour chain, per channel), divided by the kernel's normalisation n */
inline float4 apsf_source(float4 v, __global const float *lut, const int j, const float n)
{
    int nlev = (int)lut[3];
    return (float4)(lut_at(lut, lut_shape(nlev, j, 0), v.w) * v.x / n,
                    lut_at(lut, lut_shape(nlev, j, 1), v.w) * v.y / n,
                    lut_at(lut, lut_shape(nlev, j, 2), v.w) * v.z / n, 0.0f);
}

__kernel void ref_apsf_source(__global const float4 *scat0, __global const float *lut,
                              const int width, const int height, const int j,
                              __global const float *norm_x, __global const float *norm_y,
                              __global float4 *src)
{
    int i = get_global_id(0), y = get_global_id(1);
    if (i >= width || y >= height) return;
    int idx = y * width + i;
    src[idx] = apsf_source(scat0[idx], lut, j, norm_x[i] * norm_y[y]);
}

/* render.border: extend: Gaussian j's sources past the edge, entry by entry (edge_bands.h):
 * the mean of ref_apsf_source's value over the band's pixels on the end pixel's surface */
__kernel void ref_edge_profiles(__global const float4 *scat0, __global const float *lut,
                                const int width, const int height, const int j,
                                __global const float *norm_x, __global const float *norm_y,
                                const int kx, const int ky, const float gate, __global float4 *prof)
{
    int i = get_global_id(0);
    if (i >= edge_entries(width, height)) return;
    int xa, xb, ya, yb, ex, ey;
    edge_band(i, width, height, kx, ky, &xa, &xb, &ya, &yb, &ex, &ey);
    float lp_end = scat0[ey * width + ex].w;
    float4 s = (float4)(0.0f);
    float n = 0.0f;
    for (int y = ya; y < yb; ++y)
        for (int x = xa; x < xb; ++x) {
            float4 v = scat0[y * width + x];
            if (fabs(v.w - lp_end) > gate) continue;
            s += apsf_source(v, lut, j, norm_x[x] * norm_y[y]);
            n += 1.0f;
        }
    prof[i] = s / n;
}
#endif

/* Hat weight of pixel spread in bin b (u = log(sigma/s0)/log(ratio)), divided by the
 * 2-D normalisation: the bin's source image. */
__kernel void ref_bin_source(__global const float4 *scat0, __global const float *spread0,
                             const int width, const int height, const float s0,
                             const float log_ratio, const int b,
                             __global const float *norm_x, __global const float *norm_y,
                             __global float4 *src)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int idx = j * width + i;
    float u = log(fmax(spread0[idx], 1e-30f) / s0) / log_ratio;
    float w = fmax(0.0f, 1.0f - fabs(u - (float)b));
    /* bin 0 also holds everything sharper than s0 (those stay delta-like) */
    if (b == 0 && u < 0.0f) w = 1.0f;
    float4 v = scat0[idx];
    src[idx] = (float4)(w * v.xyz / (norm_x[i] * norm_y[j]), 0.0f);
}

/* margin: sources continue this far past each end (extend) as the pyramid continues them
 * (kernels/edge_bands.h): row j's left and right as prof[j], prof[h + j] (ref_edge_profiles).
 * The column pass reads the top and bottom continuations already blurred along the row
 * (ref_profile_rows), so the result is the open blur of the padded frame. */
__kernel void ref_rows(__global const float4 *src, const int width, const int height,
                       __global const float *taps, const int R, const int margin,
                       __global const float4 *prof, __global float4 *dst)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    __global const float4 *row = src + j * width;
    float4 acc = taps[0] * row[i];
    for (int d = 1; d <= R; ++d) {
        float t = taps[d];
        if (i - d >= -margin) acc += t * (i - d >= 0 ? row[i - d] : prof[j]);
        if (i + d < width + margin) acc += t * (i + d < width ? row[i + d] : prof[height + j]);
    }
    dst[j * width + i] = acc;
}

__kernel void ref_cols_acc(__global const float4 *src, const int width, const int height,
                           __global const float *taps, const int R, const int margin,
                           __global const float4 *prof, __global float4 *acc_img)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    int e = edge_entries(width, height);     /* the blurred top row, then the bottom one */
    float4 acc = taps[0] * src[j * width + i];
    for (int d = 1; d <= R; ++d) {
        float t = taps[d];
        if (j - d >= -margin) acc += t * (j - d >= 0 ? src[(j - d) * width + i] : prof[e + i]);
        if (j + d < height + margin) acc += t * (j + d < height ? src[(j + d) * width + i] : prof[e + width + i]);
    }
    acc_img[j * width + i] += acc;
}

/* The top (b 0) and bottom (b 1) continuations blurred along the row, their corners going on
 * past each end up to mx: into prof after the entries (ref_cols_acc reads them) */
__kernel void ref_profile_rows(__global float4 *prof, const int width, const int height,
                               __global const float *taps, const int R, const int mx)
{
    int i = get_global_id(0), b = get_global_id(1);
    if (i >= width || b > 1) return;
    int row = 2 * height + b * width, corner = 2 * (height + width) + 2 * b;
    float4 acc = taps[0] * prof[row + i];
    for (int d = 1; d <= R; ++d) {
        float t = taps[d];
        if (i - d >= -mx) acc += t * (i - d >= 0 ? prof[row + i - d] : prof[corner]);
        if (i + d < width + mx) acc += t * (i + d < width ? prof[row + i + d] : prof[corner + 1]);
    }
    prof[edge_entries(width, height) + b * width + i] = acc;
}

/* Brute-force definition: pixel y's normalisation, then an all-pairs gather. */
__kernel void ref_brute_norm(__global const float *spread0, const int width,
                             const int height, __global float *norm, const int open_border)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    float s = spread0[j * width + i];
    int R = (int)ceil(4.0f * s);
    float nx = 0.0f, ny = 0.0f;
    for (int d = open_border ? -R : max(-R, -i); d <= (open_border ? R : min(R, width - 1 - i)); ++d)
        nx += exp(-(float)(d * d) / (2.0f * s * s));
    for (int d = open_border ? -R : max(-R, -j); d <= (open_border ? R : min(R, height - 1 - j)); ++d)
        ny += exp(-(float)(d * d) / (2.0f * s * s));
    norm[j * width + i] = s > 0.0f ? nx * ny : 1.0f;
}

__kernel void ref_brute(__global const float4 *scat0, __global const float *spread0,
                        __global const float *norm, const int width, const int height,
                        __global float4 *out)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    float3 acc = (float3)(0.0f);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            int s = y * width + x;
            float sg = spread0[s];
            int dx = i - x, dy = j - y;
            float w;
            if (sg > 0.0f) {
                int R = (int)ceil(4.0f * sg);
                if (abs(dx) > R || abs(dy) > R) continue;
                w = exp(-(float)(dx * dx + dy * dy) / (2.0f * sg * sg));
            } else {
                w = (dx == 0 && dy == 0) ? 1.0f : 0.0f;
            }
            acc += w * scat0[s].xyz / norm[s];
        }
    out[j * width + i] = (float4)(acc, 0.0f);
}

/* out = L_at + L_em + L_amb + the reference blur of L_sc */
__kernel void ref_finish(__global const float4 *direct, __global const float4 *medium_term,
                         __global const float4 *acc_img, const int n, const int add_medium,
                         __global float4 *out,
                         const int want_aov, __global float *level_aov,
                         __global float4 *scattered_aov)
{
    int i = get_global_id(0);
    if (i >= n) return;
    store_out(out, direct, medium_term, add_medium, i, acc_img[i].xyz);
    if (want_aov) {
        level_aov[i] = -1.0f;   /* the reference has no pyramid level */
        scattered_aov[i] = (float4)(acc_img[i].xyz, 0.0f);
    }
}
