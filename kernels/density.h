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
    float4 n;           /* exponential: unit direction; .w = factor exp(-b <c - o, n>) */
    float4 o;           /* exponential: offset; sphere: centre */
} density_t;

/* e^y to ~2e-7 relative: 2^n from the exponent bits, 2^f (|f| <= 1/2) by its Taylor series
 * to degree 7; 0 below e^-87, inf above e^88. Straight arithmetic that PoCL vectorises,
 * where exp() is a per-lane library call (2 of them cost 70 % of this stage). */
inline float exp_poly(float y)
{
    /* ternaries and casts only: PoCL does not inline clamp / rint / fabs / dot either */
    float z = y * 1.44269504f;
    z = z < -127.0f ? -127.0f : (z > 128.0f ? 128.0f : z);
    int ni = (int)(z + (z >= 0.0f ? 0.5f : -0.5f));
    float g = (z - (float)ni) * 0.69314718f;
    float p = 1.0f + g * (1.0f + g * (0.5f + g * (1.0f / 6.0f + g * (1.0f / 24.0f
              + g * (1.0f / 120.0f + g * (1.0f / 720.0f + g * (1.0f / 5040.0f)))))));
    return z <= -127.0f ? 0.0f : p * as_float((ni + 127) << 23);
}

inline float dot3(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

/* rho' exp(-b <x - o, n>) from t = 0 to D along c + t w:
 * rho' exp(-b h0) D (e^x - 1) / x with h0 = <c - o, n>, x = -b D <w, n>. rho' exp(-b h0)
 * is the same for every pixel and comes from the host in n.w. The printed form divides
 * (1 - exp(..)) by b <w, n>, two tiny numbers for grazing rays; here |x| < 1e-2 takes the
 * series (error < 1e-10) and otherwise (e^x - 1) / x loses at most 2e-7 / 1e-2 relative. */
inline float exponential_p(density_t d, float3 w, float D)
{
    float x = -d.falloff * D * dot3(w, d.n.xyz);
    float series = 1.0f + x * (0.5f + x * (1.0f / 6.0f + x * (1.0f / 24.0f)));
    float direct = (exp_poly(x) - 1.0f) / x;
    return d.n.w * D * ((x < 1e-2f && x > -1e-2f) ? series : direct);
}

/* rho' (1 - |x - o|^2 / R^2) inside the sphere. With u = t + <w, c - o> (the ray parameter
 * from the point closest to the centre), |x - o|^2 = u^2 + p^2, p the distance of the line
 * from the centre, so the integrand is (s^2 - u^2) / R^2, s^2 = R^2 - p^2, over
 * [u1, u2] = the chord clipped to [0, D]. p^2 comes from the perpendicular component, not
 * from B^2 - C, which cancels for spheres far from the camera. */
inline float sphere_p(density_t d, float3 c, float3 w, float D)
{
    float3 co = c - d.o.xyz;
    float B = dot3(w, co);
    float3 perp = co - B * w;
    float R2 = d.radius * d.radius;
    float s2 = R2 - dot3(perp, perp);
    if (s2 <= 0.0f) return 0.0f;
    float s = sqrt(s2);
    float u1 = B > -s ? B : -s, u2 = D + B < s ? D + B : s;   /* t in [0, D] <=> u in [B, D + B] */
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
        else if (d.type == DENSITY_EXPONENTIAL) P += exponential_p(d, w, D);
        else P += sphere_p(d, c, w, D);
    }
    return P;
}

#endif
