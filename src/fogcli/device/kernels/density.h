/* Analytic optical depth P = integral of the density along a camera ray (Iser 4.3,
 * docs/conventions.md, Geometry): a sum of primitives. Written for float32 accuracy (~1e-6 relative) in the
 * cases where the printed closed forms cancel: grazing exponential rays and far spheres.
 * Scalar arithmetic throughout: PoCL vectorises a kernel across work-items only when it
 * calls no builtin and does no float3 arithmetic (tools/pocl_vectorisation.py). */
#ifndef FOGCLI_DENSITY_H
#define FOGCLI_DENSITY_H

#include "common.h"

/* The camera of docs/conventions.md, Geometry as the ray kernels need it. */
typedef struct {
    float4 pos;                 /* camera position, world */
    float4 rot0, rot1, rot2;    /* rows of R = Ry(yaw) Rx(pitch) Rz(roll) */
    float focal_px;             /* horizontal focal length, pixels */
    float focal_y;              /* vertical */
    float cx, cy;               /* principal point, pixels from the top-left corner */
    float max_depth;
    int depth_is_z;
} camera_t;

/* Unit world-space ray (wx, wy, wz) of pixel (i, j) and its length D (docs/conventions.md, Geometry): metric
 * z-depth is converted to distance, +inf (sky) and anything beyond max_depth clamp to
 * max_depth. */
inline float pixel_ray(const camera_t *c, int i, int j, float metric,
                       float *wx, float *wy, float *wz)
{
    float dx = (i + 0.5f - c->cx) / c->focal_px;
    float dy = -(j + 0.5f - c->cy) / c->focal_y;
    float dlen = SQRT_(dx * dx + dy * dy + 1.0f);
    float r = 1.0f / dlen;
    *wx = (c->rot0.x * dx + c->rot0.y * dy - c->rot0.z) * r;
    *wy = (c->rot1.x * dx + c->rot1.y * dy - c->rot1.z) * r;
    *wz = (c->rot2.x * dx + c->rot2.y * dy - c->rot2.z) * r;
    float dist = metric * (c->depth_is_z ? dlen : 1.0f);
    return dist < c->max_depth ? dist : c->max_depth;   /* inf compares fine; NaN is filled upstream */
}

/* The opening of a per-pixel kernel over a width x height frame of metric `depth` seen by
 * the camera `cam`: the pixel (i, j) and its index idx (work-items past the frame return),
 * its ray's unit direction (wx, wy, wz) and length D to the surface. */
#define PIXEL_RAY                                                                              \
    int i = get_global_id(0), j = get_global_id(1);                                            \
    if (i >= width || j >= height) return;                                                     \
    int idx = j * width + i;                                                                   \
    float wx, wy, wz;                                                                          \
    float D = pixel_ray(&cam, i, j, depth[idx], &wx, &wy, &wz);
/* The same for the cw x ch samples of render.noise_stride (every `stride`-th pixel of every
 * `stride`-th row, and the last ones; grid_at, noise.h): the sample (ci, cj) and its pixel
 * (i, j), the ray's direction and length. */
#define SAMPLE_RAY                                                                             \
    int ci = get_global_id(0), cj = get_global_id(1);                                          \
    if (ci >= cw || cj >= ch) return;                                                          \
    int i = grid_at(ci, stride, width), j = grid_at(cj, stride, height);                       \
    float wx, wy, wz;                                                                          \
    float D = pixel_ray(&cam, i, j, depth[j * width + i], &wx, &wy, &wz);

/* pre exp(-b <x - o, n>) from t = 0 to D along c + t w, with pre = rho' exp(-b <c - o, n>)
 * from the host (the same for every pixel): pre D (e^x - 1) / x, x = -b D <w, n>. The
 * printed form divides (1 - exp(..)) by b <w, n>, two tiny numbers for grazing rays; here
 * |x| < 1e-2 takes the series (error < 1e-10), elsewhere (e^x - 1) / x loses at most
 * 2e-7 / 1e-2 relative. */
inline float exponential_p(float pre, float b, float wn, float D)
{
    float x = -b * D * wn;
    float series = 1.0f + x * (0.5f + x * (1.0f / 6.0f + x * (1.0f / 24.0f)));
    float direct = (exp_poly(x) - 1.0f) / x;
    return pre * D * ((x < 1e-2f && x > -1e-2f) ? series : direct);
}

/* rho' (1 - |x - o|^2 / R^2) inside the sphere. With u = t + <w, c - o> (the ray parameter
 * from the point closest to the centre), |x - o|^2 = u^2 + p^2, p the distance of the line
 * from the centre, so the integrand is (s^2 - u^2) / R^2, s^2 = R^2 - p^2, over
 * [u1, u2] = the chord clipped to [0, D]. p^2 comes from the perpendicular component, not
 * from B^2 - C, which cancels for spheres far from the camera. co = c - o. */
inline float sphere_p(float factor, float R, float cox, float coy, float coz,
                      float wx, float wy, float wz, float D)
{
    float B = wx * cox + wy * coy + wz * coz;
    float px = cox - B * wx, py = coy - B * wy, pz = coz - B * wz;
    float R2 = R * R;
    float s2 = R2 - (px * px + py * py + pz * pz);
    float s = SQRT_(s2 > 0.0f ? s2 : 0.0f);
    float u1 = B > -s ? B : -s, u2 = D + B < s ? D + B : s;   /* t in [0, D] <=> u in [B, D + B] */
    float du = u2 - u1;
    float p = factor / R2 * du * (s2 - (u2 * u2 + u1 * u2 + u1 * u1) / 3.0f);
    return du > 0.0f ? p : 0.0f;   /* a miss (s2 <= 0) gives du <= 0 */
}

#endif
