/* A sky dome's first-order light in place of the slab's plane's (physics/dome.py, whose
 * `table` is the oracle), added to the slab's table (ground.cl) over mu_v and
 * u = 1 - exp(-t). Two passes: dome_cells, the difference J_dome - J_plane at the middles
 * of ns cells along each view (ns rows of nmu), then dome_add, each table entry's integral
 * over the cells up to its length, exact in exp(-s). Built with the plan's defines. */
#include "common.h"

/* edge k of ns cells along a view (dome.cell_edges): it ends at the ground (below the
 * horizon) or at the dome; ns / 2 cells up to where it crosses the plane, ns / 2 past it */
ALWAYS_INLINE float dome_edge(float mu, float tau_h, float tau_R, float tau_P, int k, int ns)
{
    float to_ground = mu < 0.0f ? tau_h / -mu : INFINITY;
    float L = to_ground < tau_R ? to_ground : tau_R;
    float cross = mu > 0.0f ? tau_P / mu : INFINITY;
    int mid = ns / 2;
    if (!(cross < L))
        return L * (float)k / (float)ns;
    return k <= mid ? cross * (float)k / (float)mid : cross + (L - cross) * (float)(k - mid) / (float)(ns - mid);
}

/* One (mu_v row i, cell k) per work-item; per channel c < nch (1 in a grey medium):
 * tau_h, tau_R, tau_P the camera's height, the dome's radius and the plane's height above
 * the camera, optical. cosines: the nth HG-stratified cosines around the view (dome.hg_cosines),
 * sines: the sines of nph azimuths (dome.azimuth_sines). out: (ns rows of nmu) float4, J per channel. Ternaries, SQRT_ and exp_poly:
 * the direction loop vectorises across work-items. */
__kernel void dome_cells(__global const float *cosines, const int nth, __global const float *sines, const int nph,
                         const float4 tau_h4, const float4 tau_R4, const float4 tau_P4,
                         const int nmu, const int ns, const int nch, __global float4 *out)
{
    int i = get_global_id(0), k = get_global_id(1);
    if (i >= nmu || k >= ns) return;
    float mu = -1.0f + 2.0f * (float)i / (float)(nmu - 1);
    float sv = SQRT_(clampf_(1.0f - mu * mu, 0.0f, 1.0f));
    float th[3] = {tau_h4.x, tau_h4.y, tau_h4.z}, tR[3] = {tau_R4.x, tau_R4.y, tau_R4.z};
    float tP[3] = {tau_P4.x, tau_P4.y, tau_P4.z};
    float J[3] = {0.0f, 0.0f, 0.0f};
    for (int c = 0; c < nch; ++c) {
        float s = 0.5f * (dome_edge(mu, th[c], tR[c], tP[c], k, ns) + dome_edge(mu, th[c], tR[c], tP[c], k + 1, ns));
        float z = s * mu, R2 = tR[c] * tR[c];
        float acc = 0.0f;
        for (int a = 0; a < nth; ++a) {
            float ct = cosines[a];
            float st = SQRT_(clampf_(1.0f - ct * ct, 0.0f, 1.0f));
            /* x . omega = s ct: the dome's distance along omega from x = s v */
            float D = -s * ct + SQRT_(clampf_(R2 - s * s * (1.0f - ct * ct), 0.0f, INFINITY));
            float e_dome = exp_poly(-D);
            for (int b = 0; b < nph; ++b) {
                float up = ct * mu - st * sines[b] * sv;          /* omega's up component */
                float dome = z + D * up >= -th[c] ? e_dome : 0.0f;
                int lit = up > 0.0f && z < tP[c];
                float plane = lit ? exp_poly(-(tP[c] - z) / (lit ? up : 1.0f)) : 0.0f;
                acc += dome - plane;
            }
        }
        J[c] = acc / (float)(nth * nph);
    }
    /* by its floats: Oclgrind's uninitialised-value check cannot follow a vector literal */
    __global float *o = (__global float *)out + 4 * (k * nmu + i);
    o[0] = J[0]; o[1] = J[1]; o[2] = J[2]; o[3] = 0.0f;
}

/* One table entry (mu_v row i, u node j) per work-item: adds scol_c albedo_c times the
 * integral over the cells of J exp(-s) up to t_nodes[j] to channel c of
 * the slab's table; a grey medium's one channel gives all three. */
__kernel void dome_add(__global const float4 *cells, __global const float *t_nodes,
                       const float4 tau_h4, const float4 tau_R4, const float4 tau_P4, const float4 alb4, const float4 scol,
                       const int nmu, const int nu, const int ns, const int nch, __global float4 *table)
{
    int i = get_global_id(0), j = get_global_id(1);
    if (i >= nmu || j >= nu) return;
    float mu = -1.0f + 2.0f * (float)i / (float)(nmu - 1);
    float th[3] = {tau_h4.x, tau_h4.y, tau_h4.z}, tR[3] = {tau_R4.x, tau_R4.y, tau_R4.z};
    float tP[3] = {tau_P4.x, tau_P4.y, tau_P4.z};
    float alb[3] = {alb4.x, alb4.y, alb4.z}, col[3] = {scol.x, scol.y, scol.z};
    __global const float *cf = (__global const float *)cells;
    float S[3] = {0.0f, 0.0f, 0.0f};
    for (int c = 0; c < nch; ++c) {
        float T = t_nodes[j], acc = 0.0f;
        /* each edge once: a cell's far edge is the next one's near edge */
        float e_lo = exp_poly(-(0.0f < T ? 0.0f : T));
        for (int k = 0; k < ns; ++k) {
            float hi = dome_edge(mu, th[c], tR[c], tP[c], k + 1, ns);
            float e_hi = exp_poly(-(hi < T ? hi : T));
            acc += cf[4 * (k * nmu + i) + c] * (e_lo - e_hi);
            e_lo = e_hi;
        }
        S[c] = alb[c] * acc;
    }
    if (nch == 1)
        S[1] = S[2] = S[0];
    __global float *o = (__global float *)table + 4 * (j * nmu + i);
    o[0] += col[0] * S[0];
    o[1] += col[1] * S[1];
    o[2] += col[2] * S[2];
}
