/* Reading the slab's table (device/ground.py, kernel slab_table in ground.cl): the light a
 * ground and a sky scatter towards the camera, over mu_v and u = 1 - exp(-t), SLAB_MU x
 * SLAB_NU float4 (RGB). Included by preprocess.cl when built with PRE_GROUND. */
#ifndef FOGCLI_SLAB_H
#define FOGCLI_SLAB_H
#include "common.h"

/* bilinear in (mu_v, u) of channel c; ternaries and casts only (common.h: PoCL inlines no
 * fmin / fabs, and a call keeps the kernel from being vectorised) */
ALWAYS_INLINE float slab_light(__global const float4 *tab, float mu, float u, int c)
{
    float x = clampf_((mu + 1.0f) * 0.5f * (float)(SLAB_MU - 1), 0.0f, (float)(SLAB_MU - 1) - 1e-3f);
    float y = clampf_(u * (float)(SLAB_NU - 1), 0.0f, (float)(SLAB_NU - 1) - 1e-3f);
    int ix = (int)x, iy = (int)y;
    float fx = x - (float)ix, fy = y - (float)iy;
    __global const float *t = (__global const float *)tab;
    int o = (iy * SLAB_MU + ix) * 4 + c;
    float a = t[o], b = t[o + 4], d = t[o + 4 * SLAB_MU], e = t[o + 4 * SLAB_MU + 4];
    return (a + (b - a) * fx) * (1.0f - fy) + (d + (e - d) * fx) * fy;
}

/* the same for the three channels at one u (a grey medium) */
ALWAYS_INLINE void slab_light3(__global const float4 *tab, float mu, float u, float *r, float *g, float *b)
{
    float x = clampf_((mu + 1.0f) * 0.5f * (float)(SLAB_MU - 1), 0.0f, (float)(SLAB_MU - 1) - 1e-3f);
    float y = clampf_(u * (float)(SLAB_NU - 1), 0.0f, (float)(SLAB_NU - 1) - 1e-3f);
    int ix = (int)x, iy = (int)y;
    float fx = x - (float)ix, fy = y - (float)iy;
    float w00 = (1.0f - fx) * (1.0f - fy), w01 = fx * (1.0f - fy), w10 = (1.0f - fx) * fy, w11 = fx * fy;
    __global const float *t = (__global const float *)tab + (iy * SLAB_MU + ix) * 4;
    __global const float *t1 = t + 4 * SLAB_MU;
    *r = w00 * t[0] + w01 * t[4] + w10 * t1[0] + w11 * t1[4];
    *g = w00 * t[1] + w01 * t[5] + w10 * t1[1] + w11 * t1[5];
    *b = w00 * t[2] + w01 * t[6] + w10 * t1[2] + w11 * t1[6];
}

#endif
