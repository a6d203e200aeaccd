/* The tabulated point spread on the device (render.psf: apsf); included by common.h, whose
 * helpers (log_pos, clampf_, LUT sizes) it uses. */
/* render.psf: apsf. The host's table in log P (physics/apsf.py, build_lut): a header (log P of the
 * first sample, samples per unit log P, APSF_NP, number of levels), then per level and
 * channel the shares passed up and kept half-blurred, the energy ratio per channel, and
 * the weight of each tabulated Gaussian per channel (reference). */
#ifdef PSF_APSF
/* log P's position in the table's samples, before clamping to [0, LUT_U_MAX] (float or
 * float8: reduce_lanes.cl reads it lane by lane) */
#define LUT_U(lut, lp) (((lp) - (lut)[0]) * (lut)[1])
#define LUT_U_MAX ((float)APSF_NP - 1.001f)
/* sample index and fraction of log P in the table: once per pixel, shared by every read */
inline int lut_pos(__global const float *lut, float lp, float *f)
{
    float u = clampf_(LUT_U(lut, lp), 0.0f, LUT_U_MAX);
    int i = (int)u;
    *f = u - (float)i;
    return i;
}
inline float lut_get(__global const float *lut, int base, int i, float f)
{
    float v = lut[base + i];
    return v + (lut[base + i + 1] - v) * f;
}
inline float lut_at(__global const float *lut, int base, float lp)
{
    float f;
    int i = lut_pos(lut, lp, &f);
    return lut_get(lut, base, i, f);
}
/* A grey medium (-D MEDIUM_GREY: the same absorption and scattering in R, G, B) has three
 * equal rows per table entry: every channel reads channel 0's, so the compiler keeps one
 * gather where there were three */
#ifdef MEDIUM_GREY
#define LUT_CH(c) 0
#else
#define LUT_CH(c) (c)
#endif
inline int lut_updown(int k, int ch, int q) { return 4 + ((k * 3 + LUT_CH(ch)) * 2 + q) * APSF_NP; }
inline int lut_ratio(int nlev, int ch) { return 4 + nlev * 6 * APSF_NP + LUT_CH(ch) * APSF_NP; }
inline int lut_shape(int nlev, int j, int ch) { return 4 + nlev * 6 * APSF_NP + 3 * APSF_NP + (j * 3 + LUT_CH(ch)) * APSF_NP; }
/* after the Gaussians' weights: the Lambertian weight per view cosine, then the receiver
 * weight per level (apsf.lut_offsets "lambert", "recv") */
inline int lut_lambert(int nlev) { return lut_shape(nlev, APSF_J, 0); }
inline int lut_recv(int nlev) { return lut_lambert(nlev) + APSF_NC * 3 * APSF_NP; }

#ifdef EMISSION_LAMBERT
/* Lambertian over isotropic scattered energy at the view cosine cosv, times the energy
 * ratio (one table: apsf.build_lut), per channel, at the log-P sample (li, lf) of lut_pos:
 * bilinear in (cosine, log P) */
inline float lambert_ch(__global const float *lut, int base, int li, float lf, float f)
{
    float a = lut_get(lut, base, li, lf);
    return a + (lut_get(lut, base + 3 * APSF_NP, li, lf) - a) * f;
}
inline void lambert_at(__global const float *lut, int nlev, int li, float lf, float cosv,
                       float *w0, float *w1, float *w2)
{
    float u = clampf_((cosv - APSF_COS_MIN) / (1.0f - APSF_COS_MIN) * (float)(APSF_NC - 1), 0.0f,
                      (float)APSF_NC - 1.001f);
    int ci = (int)u;
    float f = u - (float)ci;
    int base = lut_lambert(nlev) + ci * 3 * APSF_NP;
    *w0 = lambert_ch(lut, base, li, lf, f);
    *w1 = lambert_ch(lut, base + LUT_CH(1) * APSF_NP, li, lf, f);
    *w2 = lambert_ch(lut, base + LUT_CH(2) * APSF_NP, li, lf, f);
}
#endif

#ifdef RECEIVER_DEPTH
/* render.halo_depth: receiver. Of the light `level` keeps for a receiver whose surface is at
 * log P lr (the level's mean over its footprint), from sources at log P lp (the level's
 * light-weighted one), the share that scatters nearer than that surface: the host's
 * glow_depth.receiver_table after the Lambertian weights, per level, bilinear in (log P,
 * u = P_r / P over [0, 1]; beyond 1 all of it) */
ALWAYS_INLINE float recv_weight(__global const float *lut, int level, float lp, float lr)
{
    float f;
    int li = lut_pos(lut, lp, &f);
    float u = clampf_(exp_poly(lr - lp), 0.0f, 1.0f) * (float)(APSF_NU - 1);
    int ui = mini_((int)u, APSF_NU - 2);
    float uf = u - (float)ui;
    int base = lut_recv((int)lut[3]) + (level * APSF_NP + li) * APSF_NU + ui;
    float a = lut[base] + (lut[base + 1] - lut[base]) * uf;
    float b = lut[base + APSF_NU] + (lut[base + APSF_NU + 1] - lut[base + APSF_NU]) * uf;
    return a + (b - a) * f;
}
#endif

/* The share of the thin-medium form's scattered energy each channel keeps at the log-P
 * sample (li, lf) of lut_pos: the table's energy ratio (lower where long multiply scattered
 * paths absorb more), times the Lambertian weight at view cosine cosv with
 * emission_profile: lambertian (VIEW_COS reads the cosine only then). */
inline void apsf_energy(__global const float *lut, int nlev, int li, float lf, float cosv,
                        float *e0, float *e1, float *e2)
{
#ifdef EMISSION_LAMBERT
    lambert_at(lut, nlev, li, lf, cosv, e0, e1, e2);
#else
    *e0 = lut_get(lut, lut_ratio(nlev, 0), li, lf);
    *e1 = lut_get(lut, lut_ratio(nlev, 1), li, lf);
    *e2 = lut_get(lut, lut_ratio(nlev, 2), li, lf);
#endif
}
#ifdef EMISSION_LAMBERT
#define VIEW_COS(cosines, idx) ((cosines)[idx])
#else
#define VIEW_COS(cosines, idx) 1.0f
#endif

/* prep of level k for apsf: each channel's share passed on to level k+1, and log P */
inline void store_prep_apsf(__global float4 *buf, int idx, float r, float g, float b, float lp,
                            __global const float *lut, int k)
{
    float f;
    int i = lut_pos(lut, lp, &f);
    store4(buf, idx, lut_get(lut, lut_updown(k, 0, 0), i, f) * r, lut_get(lut, lut_updown(k, 1, 0), i, f) * g,
           lut_get(lut, lut_updown(k, 2, 0), i, f) * b, lp);
}
#endif
