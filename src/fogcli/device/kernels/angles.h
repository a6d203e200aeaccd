/* render.spread_space: angles: the map between the image's plane and the plane of angles
 * (kernels/warp.cl says why), for warp.cl and the extension's receivers (pyramid.cl). */
#ifndef FOGCLI_ANGLES_H
#define FOGCLI_ANGLES_H
#define WARP_GEOM const float cx, const float cy, const float fx, const float fy, const float sf, const float sc

/* The image point of the plane of angles' point q, and sin(rho) / rho there (its solid
 * angle over the plane's pixel); rho past 1.55 (no image point): a point far outside. */
inline float2 angles_to_image(float2 q, float cx, float cy, float fx, float fy, float sf, float *jac)
{
    float dx = (q.x - cx) / sf, dy = (q.y - cy) / sf;
    float rho = SQRT_(dx * dx + dy * dy);
    *jac = 1.0f;
    if (rho > 1.55f)
        return (float2)(-1e9f, -1e9f);
    float t = 1.0f;
    if (rho > 1e-4f) {
        t = tan(rho) / rho;
        *jac = sin(rho) / rho;
    }
    return (float2)(cx + fx * dx * t, cy + fy * dy * t);
}

/* The plane of angles' point of the image point p. */
inline float2 image_to_angles(float2 p, float cx, float cy, float fx, float fy, float sf)
{
    float X = (p.x - cx) / fx, Y = (p.y - cy) / fy;
    float r = SQRT_(X * X + Y * Y);
    float t = r > 1e-4f ? atan(r) / r : 1.0f;
    return (float2)(cx + sf * X * t, cy + sf * Y * t);
}
#endif
