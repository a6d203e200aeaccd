/* The light of a ground and a sky scattered towards the camera (physics/slab.py): the slab's
 * discrete-ordinates modes summed into a table over the ray's elevation cosine mu_v and
 * u = 1 - exp(-t) of its optical length t, per channel; preprocess reads it (PRE_GROUND).
 * Built with the plan's defines (common.h needs them). */
#include "common.h"

/* One entry (mu_v index i of nmu, u index k of nu) per work-item. psi: per row (nmu rows,
 * nm modes) the modes' source functions at mu = -1 + 2 r / (nmu - 1); grey (one medium in
 * R, G, B): two rows, the ground's and the sky's for radiance 1, mixed by gcol / scol here;
 * else three rows, one per channel, already mixed. lam, ref: per channel (grey: one) the
 * modes' exponents and reference heights; tau_h4, tau_H4 likewise the camera's and the
 * sky's optical heights; t: the optical lengths of the u nodes (inf at u = 1). Ternaries
 * and exp_poly only: the mode loop vectorises across work-items. */
__kernel void slab_table(__global const float *psi, __global const float *lam, __global const float *ref,
                         const float4 tau_h4, const float4 tau_H4, __global const float *t_nodes,
                         const int nmu, const int nu, const int nm,
                         const int grey, const float4 gcol, const float4 scol, __global float4 *out)
{
    int i = get_global_id(0), k = get_global_id(1);
    if (i >= nmu || k >= nu) return;
    float mu = -1.0f + 2.0f * (float)i / (float)(nmu - 1);
    float th[3] = {tau_h4.x, tau_h4.y, tau_h4.z}, tH[3] = {tau_H4.x, tau_H4.y, tau_H4.z};
    float s[3] = {0.0f, 0.0f, 0.0f};
    int rows = grey ? 2 : 3;
    for (int c = 0; c < rows; ++c) {
        int cm = grey ? 0 : c;
        /* the ray ends at the surface (u), at the ground or at the sky */
        float t = t_nodes[k];
        float to_ground = mu < 0.0f ? th[cm] / -mu : INFINITY;
        float to_sky = mu > 0.0f ? (tH[cm] - th[cm]) / mu : INFINITY;
        t = t < to_ground ? t : to_ground;
        t = t < to_sky ? t : to_sky;
        /* light travelling towards the camera goes along -mu_v: row nmu - 1 - i */
        __global const float *p = psi + ((size_t)c * nmu + (nmu - 1 - i)) * nm;
        __global const float *l = lam + cm * nm, *r = ref + cm * nm;
        float acc = 0.0f;
        for (int j = 0; j < nm; ++j) {
            float a = 1.0f - l[j] * mu;
            float e0 = l[j] * (th[cm] - r[j]);      /* <= 0: each mode decays away from ref */
            e0 = e0 < 0.0f ? e0 : 0.0f;
            float x = a * t;
            float e2 = e0 - x;
            e2 = e2 < 0.0f ? e2 : 0.0f;
            float e1 = exp_poly(e0);
            /* int_0^t exp(e0 - a s) ds; its series where a t is small */
            float v = absf_(x) < 1e-3f ? e1 * t * (1.0f - 0.5f * x) : (e1 - exp_poly(e2)) / a;
            acc += p[j] * v;
        }
        s[c] = acc;
    }
    if (grey) {
        float g0 = s[0], s0 = s[1];
        s[0] = gcol.x * g0 + scol.x * s0;
        s[1] = gcol.y * g0 + scol.y * s0;
        s[2] = gcol.z * g0 + scol.z * s0;
    }
    __global float *o = (__global float *)out + 4 * (k * nmu + i);
    o[0] = s[0]; o[1] = s[1]; o[2] = s[2]; o[3] = 0.0f;
}
