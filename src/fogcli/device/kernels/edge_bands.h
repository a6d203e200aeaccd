/* render.border: extend: what the frame's edge continues as (device/border_size.py). For each
 * row's left and right end, each column's top and bottom end and each corner ("entries": left
 * rows 0..h-1, right rows h..2h-1, top columns 2h.., bottom columns 2h+w.., corners 2h+2w..:
 * top-left, top-right, bottom-left, bottom-right), the mean over the band of kx columns (ky
 * rows; kx x ky at a corner) next to it, of the pixels on the end pixel's surface: log P
 * within `gate` of its (EDGE_BAND_LOGP). One pixel's texture, a glyph's stroke or a window's
 * frame cut at the edge, is not the surface's, and a lamp a few pixels in does not go on past
 * the edge: the surface it hangs on does. Included by pyramid.cl (edge_bands, with
 * PYRAMID_EDGE_BANDS) and reference.cl (ref_edge_profiles): one definition of the band. */
#ifndef EDGE_BANDS_H
#define EDGE_BANDS_H

/* how many entries (device/border_size.py edge_entries); the reference keeps its two blurred
 * rows after them (ref_profile_rows) */
inline int edge_entries(int w, int h) { return 2 * (w + h) + 4; }

/* entry i's band [xa, xb) x [ya, yb) and its end pixel (ex, ey) */
inline void edge_band(int i, int w, int h, int kx, int ky, int *xa, int *xb, int *ya, int *yb, int *ex, int *ey)
{
    int right, bottom;
    if (i < 2 * h) {
        right = i >= h;
        *ya = i - (right ? h : 0);
        *yb = *ya + 1;
        *xa = right ? w - kx : 0;
        *xb = right ? w : kx;
        *ex = right ? w - 1 : 0;
        *ey = *ya;
    } else if (i < 2 * h + 2 * w) {
        bottom = i >= 2 * h + w;
        *xa = i - 2 * h - (bottom ? w : 0);
        *xb = *xa + 1;
        *ya = bottom ? h - ky : 0;
        *yb = bottom ? h : ky;
        *ex = *xa;
        *ey = bottom ? h - 1 : 0;
    } else {
        int c = i - 2 * h - 2 * w;
        right = c & 1;
        bottom = c >> 1;
        *xa = right ? w - kx : 0;
        *xb = right ? w : kx;
        *ya = bottom ? h - ky : 0;
        *yb = bottom ? h : ky;
        *ex = right ? w - 1 : 0;
        *ey = bottom ? h - 1 : 0;
    }
}

#ifdef PYRAMID_EDGE_BANDS
/* The pyramid's extension (border_sources): for each entry the band's mean of a source's terms
 * as a reduce sums them, in bands[2 i] (colour, luminance x log P) and bands[2 i + 1]
 * (luminance, log P). With pixel separation (sep0: render.separation) a pixel is the sum of
 * its two parts, so that the band does not depend on it. */
__kernel void edge_bands(__global const float4 *chain0, __global const float4 *sep0, const int with_sep,
                         const int w, const int h, const int kx, const int ky, const float gate,
                         __global float4 *bands)
{
    int i = get_global_id(0);
    if (i >= edge_entries(w, h)) return;
    int xa, xb, ya, yb, ex, ey;
    edge_band(i, w, h, kx, ky, &xa, &xb, &ya, &yb, &ex, &ey);
    float lp_end = chain0[ey * w + ex].w;
    float3 c = (float3)(0.0f);
    float yw = 0.0f, ys = 0.0f, lw = 0.0f, n = 0.0f;
    for (int y = ya; y < yb; ++y)
        for (int x = xa; x < xb; ++x) {
            float4 v = chain0[y * w + x];
            if (fabs(v.w - lp_end) > gate) continue;
            if (with_sep) v.xyz += sep0[y * w + x].xyz;   /* the whole pixel, separated or not */
            float yl = light_weight(v.xyz);
            c += v.xyz;
            yw += yl * v.w;
            ys += yl;
            lw += v.w;
            n += 1.0f;
        }
    float inv = 1.0f / n;      /* the end pixel is always in */
    bands[2 * i] = (float4)(c * inv, yw * inv);
    bands[2 * i + 1] = (float4)(ys * inv, lw * inv, 0.0f, 0.0f);
}
#endif

#endif
