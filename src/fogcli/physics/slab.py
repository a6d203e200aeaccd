"""Light of a ground and a sky in a plane-parallel medium: the radiance a camera inside it
receives by scattering, for rays of any elevation and length.

The point spread of a pixel is that of a point in an infinite medium. A ground to the
horizon is not that: it sends its light upwards only, the medium below it is not there to
scatter, and most of it lies outside the frame (under and behind the camera). So the
average ground, and the sky above it, are taken as the two boundaries of a slab: the ground
at height 0 emits radiance 1 upwards (Lambertian, non-reflecting), the sky at optical height
tau_H emits 1 downwards, the medium between has albedo omega and the Henyey-Greenstein
phase function of asymmetry g. The azimuthally symmetric radiative transfer equation

    mu dI/dtau = -I + omega / 2 int p0(mu, mu') I(tau, mu') dmu'

is solved by discrete ordinates (double Gauss, n nodes per hemisphere; Stamnes et al. 1988,
DISORT): I(tau) = sum_j c_j V_j exp(lam_j (tau - ref_j)), each mode referred to the
boundary it decays away from, so nothing overflows in thick slabs. The source function at
any direction follows from the nodes (source-function integration), and the light scattered
towards a camera at optical height tau_h along a ray of elevation cosine mu_v (+ up) and
optical length t_d is, per mode, an exponential integral in closed form:

    S = sum_j c_j psi_j(-mu_v) int_0^t_d exp(lam_j (tau_h + t mu_v - ref_j) - t) dt.

fogcli tabulates S per frame on the device (kernel `slab_table`); `inscatter` here is the
same sum in float64, for tests and oracles.
"""
from __future__ import annotations

import functools
import math

import numpy as np

NODES = 32          # per hemisphere: the in-scattered light within 5e-5 of 64 nodes at g 0.92 (0.5 % at g 0.97)
MU_GRID = 129       # source functions tabulated over mu in [-1, 1] for the device table
LEGENDRE_TOL = 1e-7


def _legendre(mu: np.ndarray, lmax: int) -> np.ndarray:
    """P_l(mu), l = 0..lmax, as (len(mu), lmax + 1)."""
    mu = np.asarray(mu, np.float64)
    out = np.empty((mu.size, lmax + 1))
    out[:, 0] = 1.0
    if lmax:
        out[:, 1] = mu
    for k in range(1, lmax):
        out[:, k + 1] = ((2 * k + 1) * mu * out[:, k] - k * out[:, k - 1]) / (k + 1)
    return out


def phase0(mu: np.ndarray, mu_nodes: np.ndarray, g: float) -> np.ndarray:
    """The Henyey-Greenstein phase function averaged over azimuth, p0(mu, mu'), by its
    Legendre series sum (2l + 1) g^l P_l(mu) P_l(mu') (normalised: 1/2 int p0 dmu' = 1)."""
    lmax = 1 if g <= 0 else int(min(4096, max(8, np.ceil(np.log(LEGENDRE_TOL) / np.log(g)))))
    coef = (2 * np.arange(lmax + 1) + 1) * float(g) ** np.arange(lmax + 1)
    # einsum, not a matmul: a product this size (129 x 154 x 64 at g 0.9) goes to BLAS on
    # threads, which then spin for about 100 ms beside the frame's kernels on the same
    # cores (tests/test_one_process.py)
    return np.einsum("il,jl->ij", _legendre(mu, lmax) * coef, _legendre(mu_nodes, lmax))


@functools.lru_cache(maxsize=16)
def _modes(omega: float, g: float, tau_H: float, n: int = NODES):
    # omega = 1 makes a double zero eigenvalue (a mode linear in tau) that the eigenvector
    # basis misses; 1 - 1e-6 is conservative to 1e-5 over any slab fogcli meets
    omega = min(omega, 1.0 - 1e-6)
    x, w = np.polynomial.legendre.leggauss(n)
    mu_p, w_p = 0.5 * (x + 1.0), 0.5 * w
    mu = np.concatenate([mu_p, -mu_p])
    wt = np.concatenate([w_p, w_p])
    P = phase0(mu, mu, g)
    # renormalised on the nodes: the discrete scattering conserves energy exactly, so a
    # conservative slab between boundaries of radiance 1 holds radiance 1 everywhere
    norm = 0.5 * (P * wt).sum(1, keepdims=True)
    P = P / norm
    M = (-np.eye(2 * n) + 0.5 * omega * P * wt[None, :]) / mu[:, None]
    lam, V = np.linalg.eig(M)
    lam, V = lam.real, V.real
    ref = np.where(lam > 0, tau_H, 0.0)
    A = np.concatenate([V[:n] * np.exp(lam * (0.0 - ref))[None, :],
                        V[n:] * np.exp(np.minimum(lam * (tau_H - ref), 0.0))[None, :]])
    rhs = np.zeros((2 * n, 2))
    rhs[:n, 0] = 1.0          # the ground: radiance 1 upwards at tau = 0
    rhs[n:, 1] = 1.0          # the sky: radiance 1 downwards at tau_H
    c = np.linalg.solve(A, rhs)
    grid = np.linspace(-1.0, 1.0, MU_GRID)
    Pe = phase0(grid, mu, g)
    Pe = Pe / (0.5 * (Pe * wt).sum(1, keepdims=True))
    psi = 0.5 * omega * (Pe * wt[None, :]) @ V          # (MU_GRID, 2n): J_j(mu) per unit c_j
    return lam, ref, psi * c[:, 0][None, :], psi * c[:, 1][None, :], mu, wt, V, c


def modes(omega: float, g: float, tau_H: float):
    """(lam, ref, psi_ground, psi_sky) of the slab: lam and ref (2 NODES,) the modes'
    exponents and reference heights, psi_* (MU_GRID, 2 NODES) their source functions on
    mu = linspace(-1, 1, MU_GRID) for unit ground and unit sky radiance."""
    return _modes(round(float(omega), 7), round(float(g), 7), round(float(tau_H), 5))[:4]


def node_radiance(omega: float, g: float, tau_H: float, tau: float) -> tuple:
    """(mu, weights, radiance from the ground, from the sky) at the quadrature nodes at
    optical height tau: the solution itself, for checks against other solvers."""
    lam, ref, _, _, mu, wt, V, c = _modes(round(float(omega), 7), round(float(g), 7), round(float(tau_H), 5))
    e = np.exp(np.minimum(lam * (tau - ref), 0.0))
    return mu, wt, V @ (c[:, 0] * e), V @ (c[:, 1] * e)


def _integral(lam, ref, tau_h, mu_v, t_d):
    """int_0^t_d exp(lam (tau_h + t mu_v - ref) - t) dt, broadcast over a trailing mode axis."""
    a = 1.0 - lam * mu_v[..., None]
    e0 = lam * (tau_h - ref)
    td = t_d[..., None]
    e1 = np.exp(np.minimum(e0, 0.0))
    e2 = np.exp(np.minimum(e0 - a * td, 0.0))
    small = np.abs(a) < 1e-7
    with np.errstate(invalid="ignore"):     # inf x 0 in the branch np.where drops
        return np.where(small, td * e1, (e1 - e2) / np.where(small, 1.0, a))


def ray_length(tau_h: float, tau_H: float, mu_v: np.ndarray, t_d: np.ndarray) -> np.ndarray:
    """A ray's optical length ended at the ground or the sky, whichever it reaches first."""
    mu_v = np.asarray(mu_v, np.float64)
    with np.errstate(divide="ignore"):
        to_ground = np.where(mu_v < 0, tau_h / np.maximum(-mu_v, 1e-12), np.inf)
        to_sky = np.where(mu_v > 0, (tau_H - tau_h) / np.maximum(mu_v, 1e-12), np.inf)
    return np.minimum(np.asarray(t_d, np.float64), np.minimum(to_ground, to_sky))


def inscatter(omega: float, g: float, tau_h: float, tau_H: float, mu_v, t_d) -> tuple:
    """(from the ground, from the sky): the light scattered towards the camera at optical
    height tau_h along rays of elevation cosine mu_v and optical length t_d, per unit
    radiance of the ground and of the sky; float64, the source functions interpolated
    linearly in mu as the device does."""
    mu_v = np.asarray(mu_v, np.float64)
    t_d = ray_length(tau_h, tau_H, mu_v, np.broadcast_to(np.asarray(t_d, np.float64), mu_v.shape))
    lam, ref, psi_g, psi_s = modes(omega, g, tau_H)
    x = np.clip((1.0 - mu_v.ravel()) * 0.5 * (MU_GRID - 1), 0, MU_GRID - 1)   # at -mu_v: towards the camera
    i0 = np.minimum(x.astype(int), MU_GRID - 2)
    f = (x - i0)[:, None]
    integ = _integral(lam, ref, tau_h, mu_v.ravel(), t_d.ravel())
    out = []
    for psi in (psi_g, psi_s):
        p = psi[i0] * (1 - f) + psi[i0 + 1] * f
        out.append((p * integ).sum(-1).reshape(mu_v.shape))
    return tuple(out)


def _log_two_e3(x: float) -> float:
    """ln 2 E_3(x), 2 E_3(x) = int_0^1 2 mu exp(-x / mu) dmu: the share of a unit sky's
    unscattered light that reaches a point x optical units below a plane sky (cosine-weighted).
    E_n as Numerical Recipes' expint: the series below 1, the continued fraction (modified
    Lentz) above, in logs where it underflows; scalar steps, no LAPACK (leggauss's eigenvalues
    go to BLAS threads that spin beside the device: tests/test_one_process.py)."""
    n = 3
    if x <= 0.0:
        return 0.0
    if x > 1.0:
        b, c = x + n, 1e300
        d = 1.0 / b
        h = d
        for i in range(1, 500):
            an = -i * (n - 1 + i)
            b += 2.0
            d = 1.0 / (an * d + b)
            c = b + an / c
            h *= c * d
            if abs(c * d - 1.0) < 1e-15:
                break
        return math.log(2.0) - x + math.log(h)
    ans, fact = 1.0 / (n - 1), 1.0
    for i in range(1, 500):
        fact *= -x / i
        if i != n - 1:
            term = -fact / (i - n + 1)
        else:
            term = fact * (-math.log(x) + (-0.5772156649015329 + 1.0 + 0.5))   # psi(3) = -gamma + 1 + 1/2
        ans += term
        if abs(term) < abs(ans) * 1e-16:
            break
    return math.log(2.0 * ans)


def dome_height(tau_R: float) -> float:
    """The optical height above the camera of the slab's sky that stands for a sky dome of
    optical radius tau_R around it: the plane whose unscattered light reaches the camera
    with the dome's irradiance, 2 E_3(tau) = exp(-tau_R) (the dome is tau_R away in every
    direction above, a plane tau / mu along a ray whose elevation has sine mu). It is below
    tau_R: a plane at the dome's distance would be farther than the dome everywhere but
    straight up, and its light would miss a camera under a near dome (`skyline`'s sky at
    150 m: 0.49 of the path tracer's scattered light in haze)."""
    if tau_R <= 0.0:
        return 0.0
    lo, hi = 0.0, float(tau_R)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _log_two_e3(mid) > -tau_R:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def diffusion_height(tau_R: float, albedo: float, g: float) -> float:
    """The optical height above the camera of the plane sky whose diffuse light reaches a
    camera on a dark ground as that of a sky dome of optical radius tau_R does. In the
    diffusion approximation the light decays by kappa = sqrt(3 (1 - albedo)(1 - g albedo))
    per optical unit; near the ground, under a plane at h it grows as kappa z / sinh(kappa h),
    and at the centre of a hemisphere over the ground (its lowest odd mode: the ground dark,
    the dome bright) as kappa z / (2 i_1(kappa tau_R)), i_1 the modified spherical Bessel
    function. So sinh(kappa h) = 2 i_1(kappa tau_R): 2 tau_R / 3 in a conservative medium,
    tau_R - ln(kappa tau_R / 2) / kappa where it absorbs strongly. A dome sends its light
    from every side, a plane from above only, so a thick medium under a dome is as lit as
    under a plane a third nearer (`skyline`, `ground`: docs/physics.md)."""
    k = math.sqrt(3.0 * max(1.0 - albedo, 0.0) * max(1.0 - g * albedo, 0.0))
    x = k * tau_R
    if x < 1e-4:
        return 2.0 * tau_R / 3.0
    if x < 30.0:
        return math.asinh(2.0 * (x * math.cosh(x) - math.sinh(x)) / (x * x)) / k
    return (x + math.log(2.0 * (x - 1.0) / (x * x))) / k      # asinh(y) = ln 2y, 2 i_1 = e^x (x - 1) / x^2


def sky_height(st: float, height: float, sky_distance: float, dome: bool, albedo: float, g: float) -> float:
    """The slab's optical thickness for a medium of extinction st: the camera's height above
    the ground plus the sky's above the camera. A dome's (physics/ground.Ground.dome) stands
    at the nearer of dome_height (the dome's unscattered light, which a thin medium sees)
    and diffusion_height (its diffuse light, which a thick one sees): one plane cannot give
    both, and each is the lower bound of what the camera gets of its part."""
    if not dome:
        return st * (height + sky_distance)
    tau_R = st * sky_distance
    return st * height + min(dome_height(tau_R), diffusion_height(tau_R, albedo, g))
