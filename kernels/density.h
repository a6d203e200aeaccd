/* Analytic optical depth P = integral of the density along a camera ray (Iser 4.3,
 * SPEC 4.1): a sum of primitives. Written for float32 accuracy (~1e-6 relative) in the
 * cases where the printed closed forms cancel: grazing exponential rays and far spheres. */
#ifndef FOGCLI_DENSITY_H
#define FOGCLI_DENSITY_H

#define DENSITY_HOMOGENEOUS 0
#define DENSITY_EXPONENTIAL 1
#define DENSITY_SPHERE 2

typedef struct {
    int type;
    float factor;
    float falloff;      /* exponential: b */
    float radius;       /* sphere: R */
    float4 n;           /* exponential: unit direction */
    float4 o;           /* exponential: offset; sphere: centre */
} density_t;

/* e^y to ~2e-7 relative: 2^n from the exponent bits, 2^f (|f| <= 1/2) by its Taylor series
 * to degree 7; 0 below e^-87, inf above e^88. Straight arithmetic that PoCL vectorises,
 * where exp() is a per-lane library call (2 of them cost 70 % of this stage). */
inline float exp_poly(float y)
{
    float z = clamp(y * 1.44269504f, -127.0f, 128.0f);
    float n = rint(z);
    float g = (z - n) * 0.69314718f;
    float p = 1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6.0f + g * (1.0f / 24.0f
              + g * (1.0f / 120.0f + g * (1.0f / 720.0f + g * (1.0f / 5040.0f)))))));
    return z <= -127.0f ? 0.0f : p * as_float(((int)n + 127) << 23);
}

/* rho' exp(-b <x - o, n>) from t = 0 to D along c + t w:
 * rho' D exp(-b h0) (e^x - 1) / x with h0 = <c - o, n>, x = -b D <w, n>. The printed form
 * divides (1 - exp(..)) by b <w, n>, two tiny numbers for grazing rays; here |x| < 1e-2 takes
 * the series (error < 1e-10) and otherwise (e^(x - b h0) - e^(-b h0)) / x loses at most
 * 4e-7 / 1e-2 relative. No expm1, log or exp library calls: PoCL runs them per lane. */
inline float exponential_p(density_t d, float3 c, float3 w, float D)
{
    float bh = -d.falloff * dot(c - d.o.xyz, d.n.xyz);
    float x = -d.falloff * D * dot(w, d.n.xyz);
    float e0 = exp_poly(bh);
    float series = e0 * (1.0f + x * (0.5f + x * (1.0f / 6.0f + x * (1.0f / 24.0f))));
    float direct = (exp_poly(bh + x) - e0) / x;
    return d.factor * D * (fabs(x) < 1e-2f ? series : direct);
}

/* rho' (1 - |x - o|^2 / R^2) inside the sphere. With u = t + <w, c - o> (the ray parameter
 * from the point closest to the centre), |x - o|^2 = u^2 + p^2, p the distance of the line
 * from the centre, so the integrand is (s^2 - u^2) / R^2, s^2 = R^2 - p^2, over
 * [u1, u2] = the chord clipped to [0, D]. p^2 comes from the perpendicular component, not
 * from B^2 - C, which cancels for spheres far from the camera. */
inline float sphere_p(density_t d, float3 c, float3 w, float D)
{
    float3 co = c - d.o.xyz;
    float B = dot(w, co);
    float3 perp = co - B * w;
    float R2 = d.radius * d.radius;
    float s2 = R2 - dot(perp, perp);
    if (s2 <= 0.0f) return 0.0f;
    float s = sqrt(s2);
    float u1 = fmax(-s, B), u2 = fmin(s, D + B);   /* t in [0, D]  <=>  u in [B, D + B] */
    if (u2 <= u1) return 0.0f;
    float du = u2 - u1;
    return d.factor / R2 * du * (s2 - (u2 * u2 + u1 * u2 + u1 * u1) / 3.0f);
}

inline float optical_depth(__constant const density_t *dens, int n, float3 c, float3 w, float D)
{
    float P = 0.0f;
    for (int k = 0; k < n; ++k) {
        density_t d = dens[k];
        if (d.type == DENSITY_HOMOGENEOUS) P += d.factor * D;
        else if (d.type == DENSITY_EXPONENTIAL) P += exponential_p(d, c, w, D);
        else P += sphere_p(d, c, w, D);
    }
    return P;
}

#endif
