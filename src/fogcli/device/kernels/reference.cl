/* The screen-space reference (Elek sec. 3.3): every pixel spreads its L_sc with its
 * point-spread kernel, truncated at R = ceil(4 sigma). Closed border: each kernel is
 * normalised over the in-image pixels it reaches, so no scattered energy leaves the frame;
 * open: normalised over the whole plane, so what falls outside is lost. extend: open, with
 * the frame's edge continued `margin` pixels past each side as sources (the blur passes
 * read the mean of the `band` pixels next to the edge there), the world a photograph goes on
 * showing.
 *
 * psf gaussian, binned form: sigma is split between two neighbouring bins of a geometric
 * ladder (linear weights in log sigma); each bin is a separable Gaussian whose per-pixel
 * normalisation is the product of two 1-D sums. psf apsf: the kernel is the table's sum
 * of Gaussians, one pass per Gaussian with each pixel's own weight (ref_apsf_source).
 * `ref_brute` is the O(N^2) definition of the Gaussian, kept to validate the binned form. */
#include "common.h"

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
/* Gaussian j of the table: each pixel's L_sc times its own weight (from log P in .w of
 * the colour chain, per channel), divided by the kernel's normalisation */
__kernel void ref_apsf_source(__global const float4 *scat0, __global const float *lut,
                              const int width, const int height, const int j,
                              __global const float *norm_x, __global const float *norm_y,
                              __global float4 *src)
{
    int i = get_global_id(0), y = get_global_id(1);
    if (i >= width || y >= height) return;
    int idx = y * width + i;
    float4 v = scat0[idx];
    int nlev = (int)lut[3];
    float n = norm_x[i] * norm_y[y];
    src[idx] = (float4)(lut_at(lut, lut_shape(nlev, j, 0), v.w) * v.x / n,
                        lut_at(lut, lut_shape(nlev, j, 1), v.w) * v.y / n,
                        lut_at(lut, lut_shape(nlev, j, 2), v.w) * v.z / n, 0.0f);
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

/* margin: sources continue this far past each end (extend) as the mean of the `band` pixels
 * next to it (kernels/pyramid.cl edge_bands); the column pass reads the row pass's result the
 * same way, so a corner continues as the band x band block's mean, as if the image had been
 * padded so */
inline float4 band_mean(__global const float4 *p, const int stride, const int a, const int band)
{
    float4 s = (float4)(0.0f);
    for (int k = 0; k < band; ++k) s += p[(a + k) * stride];
    return s / (float)band;
}

__kernel void ref_rows(__global const float4 *src, const int width, const int height,
                       __global const float *taps, const int R, const int margin, const int band,
                       __global float4 *dst)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    __global const float4 *row = src + j * width;
    float4 lo = (float4)(0.0f), hi = (float4)(0.0f);
    if (margin > 0) {
        lo = band_mean(row, 1, 0, band);
        hi = band_mean(row, 1, width - band, band);
    }
    float4 acc = taps[0] * row[i];
    for (int d = 1; d <= R; ++d) {
        float t = taps[d];
        if (i - d >= -margin) acc += t * (i - d >= 0 ? row[i - d] : lo);
        if (i + d < width + margin) acc += t * (i + d < width ? row[i + d] : hi);
    }
    dst[j * width + i] = acc;
}

__kernel void ref_cols_acc(__global const float4 *src, const int width, const int height,
                           __global const float *taps, const int R, const int margin, const int band,
                           __global float4 *acc_img)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= width || j >= height) return;
    float4 lo = (float4)(0.0f), hi = (float4)(0.0f);
    if (margin > 0) {
        lo = band_mean(src + i, width, 0, band);
        hi = band_mean(src + i, width, height - band, band);
    }
    float4 acc = taps[0] * src[j * width + i];
    for (int d = 1; d <= R; ++d) {
        float t = taps[d];
        if (j - d >= -margin) acc += t * (j - d >= 0 ? src[(j - d) * width + i] : lo);
        if (j + d < height + margin) acc += t * (j + d < height ? src[(j + d) * width + i] : hi);
    }
    acc_img[j * width + i] += acc;
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
