/* render.border: extend: what the frame's edge continues as (included by pyramid.cl, inside
 * its PSF_APSF part: it needs light_weight from common.h) */
#ifndef EDGE_BANDS_H
#define EDGE_BANDS_H

/* render.border: extend. What the frame's edge continues as (device/plan.py edge_band_bytes):
 * for each row's left and right end, each column's top and bottom end and each corner, the
 * mean over the band of kx columns (ky rows; kx x ky at a corner) next to it of a source's
 * terms as a reduce sums them: colour and luminance x log P, then luminance and log P.
 * Entry i takes bands[2 i] and bands[2 i + 1]: left rows 0..h-1, right rows h..2h-1, top
 * columns 2h.., bottom columns 2h+w.., corners 2h+2w.. (top-left, top-right, bottom-left,
 * bottom-right). With pixel separation (sep0: render.separation) a pixel is the sum of its
 * two parts, so that the band does not depend on it. One pixel's texture, a glyph's stroke or a window's frame cut at the edge,
 * is not the surface's; the band's mean is a better guess of what lies past it. */
__kernel void edge_bands(__global const float4 *chain0, __global const float4 *sep0, const int with_sep,
                         const int w, const int h, const int kx, const int ky, __global float4 *bands)
{
    int i = get_global_id(0);
    if (i >= 2 * (w + h) + 4) return;
    int xa, xb, ya, yb;
    if (i < 2 * h) {
        int right = i >= h;
        ya = i - (right ? h : 0);
        yb = ya + 1;
        xa = right ? w - kx : 0;
        xb = right ? w : kx;
    } else if (i < 2 * h + 2 * w) {
        int bottom = i >= 2 * h + w;
        xa = i - 2 * h - (bottom ? w : 0);
        xb = xa + 1;
        ya = bottom ? h - ky : 0;
        yb = bottom ? h : ky;
    } else {
        int c = i - 2 * h - 2 * w, right = c & 1, bottom = c >> 1;
        xa = right ? w - kx : 0;
        xb = right ? w : kx;
        ya = bottom ? h - ky : 0;
        yb = bottom ? h : ky;
    }
    float3 c = (float3)(0.0f);
    float yw = 0.0f, ys = 0.0f, lw = 0.0f;
    for (int y = ya; y < yb; ++y)
        for (int x = xa; x < xb; ++x) {
            float4 v = chain0[y * w + x];
            if (with_sep) v.xyz += sep0[y * w + x].xyz;   /* the whole pixel, separated or not */
            float yl = light_weight(v.xyz);
            c += v.xyz;
            yw += yl * v.w;
            ys += yl;
            lw += v.w;
        }
    float inv = 1.0f / (float)((xb - xa) * (yb - ya));
    bands[2 * i] = (float4)(c * inv, yw * inv);
    bands[2 * i + 1] = (float4)(ys * inv, lw * inv, 0.0f, 0.0f);
}

#endif
