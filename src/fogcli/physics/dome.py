"""A sky dome's first-order light, in place of the slab's plane's.

The slab (physics/slab.py) stands for a sky dome (a sky the depth map shows at one distance
all round, physics/ground.Ground.dome) by a plane above the camera (slab.sky_height). A
plane sends its unscattered light from above; a dome from every side, and most from near
the horizon, where a plane's light has the longest way to come. A forward phase function
scatters that light into a level view, which a plane of the same irradiance sends little of
(`skyline-haze`, docs/physics.md). So the dome's once-scattered light replaces the plane's:

    dS(mu_v, t) = albedo int_0^min(t, L) exp(-s) [J_dome(x(s)) - J_plane(x(s))] ds,
    J(x) = int p(omega . v) / (4 pi) vis(x, omega) exp(-D(x, omega)) d omega,

optical units, the camera at the dome's centre tau_h above a black ground, the view v of
elevation sine mu_v, x = s v; D the optical distance from x to the dome along omega (to the
plane: (tau_P - z) / omega_up), vis whether it gets there above the ground (the plane: from
above only). L: where the view ray meets the ground or the dome. Higher orders stay the
slab's: its plane is placed so that the dome's diffuse light comes through
(slab.diffusion_height).

The direction integral is a mean over HG-stratified directions around v (NTH cosines from
the phase function's inverse CDF, hg_cosines, times NPH azimuths, azimuth_sines); along the
ray, NS cells of constant J (two runs of them where the view crosses the plane, past which
J_plane is 0), exp(-s) integrated exactly over each. The device (kernels/dome.cl) gets the same
cosines and sines from here; `table` is its float64 oracle.
"""
from __future__ import annotations

import numpy as np

NTH = 32      # HG-stratified cosines around the view
NPH = 16      # azimuths (over a half turn: azimuth_sines)
NS = 32       # cells along the ray (cell_edges)
MIN_LIGHT = 1e-5    # the dome's unscattered light exp(-tau_R) below this in every channel: no term


def matters(tau_R) -> bool:
    """Whether any channel's dome (optical radius tau_R, array) is near enough to count."""
    return bool(np.any(np.exp(-np.asarray(tau_R, np.float64)) >= MIN_LIGHT))


def hg_cosine(g: float, xi: np.ndarray) -> np.ndarray:
    """cos theta of the Henyey-Greenstein phase function at probabilities xi in [0, 1) (its
    inverse CDF): uniform xi give its scattering angles."""
    xi = np.asarray(xi, np.float64)
    if abs(g) < 1e-6:
        return 1.0 - 2.0 * xi
    return (1.0 + g * g - ((1.0 - g * g) / (1.0 - g + 2.0 * g * xi)) ** 2) / (2.0 * g)


def hg_cosines(g: float, n: int = NTH) -> np.ndarray:
    """cos theta at the centres of n equal strata of probability: a mean over them (and
    uniform azimuths) is the integral with the phase function's weight."""
    return hg_cosine(g, (np.arange(n) + 0.5) / n)


def azimuth_sines(n: int = NPH) -> np.ndarray:
    """sin phi at the centres of n equal azimuth strata around the view, over a half turn:
    only sin phi enters (the up component), and phi and pi - phi share it."""
    return np.sin(((np.arange(n) + 0.5) / n - 0.5) * np.pi)


def ray_end(mu: np.ndarray, tau_h: float, tau_R: float) -> np.ndarray:
    """Where a view ray of elevation sine mu ends: at the ground, or at the dome."""
    mu = np.asarray(mu, np.float64)
    with np.errstate(divide="ignore"):
        to_ground = np.where(mu < 0.0, tau_h / np.maximum(-mu, 1e-30), np.inf)
    return np.minimum(to_ground, tau_R)


def difference(g: float, tau_h: float, tau_R: float, tau_P: float, mu: np.ndarray, s: np.ndarray) -> np.ndarray:
    """J_dome - J_plane at points s along views of elevation sine mu (broadcast), per unit
    sky radiance, the same directions as the device."""
    mu, s = np.broadcast_arrays(np.asarray(mu, np.float64), np.asarray(s, np.float64))
    ct = hg_cosines(g)[:, None]
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    sphi = azimuth_sines()[None, :]
    out = np.empty(mu.shape)
    for idx in np.ndindex(mu.shape):
        m, x = mu[idx], s[idx]
        sv = np.sqrt(max(1.0 - m * m, 0.0))
        up = ct * m - st * sphi * sv            # omega's up component; x . omega = x ct
        z = x * m
        D = -x * ct + np.sqrt(np.maximum(tau_R * tau_R - x * x * (1.0 - ct * ct), 0.0))
        dome = np.where(z + D * up >= -tau_h, np.exp(-D), 0.0)
        lit = (up > 0.0) & (z < tau_P)
        plane = np.where(lit, np.exp(-np.where(lit, (tau_P - z) / np.where(lit, up, 1.0), 0.0)), 0.0)
        out[idx] = (dome - plane).mean()
    return out


def cell_edges(mu: np.ndarray, tau_h: float, tau_R: float, tau_P: float) -> np.ndarray:
    """(NS + 1, len(mu)) edges of the cells along each view: NS / 2 up to where it crosses
    the plane (J_plane drops to 0 there) and NS / 2 on from there to its end; NS over the
    whole when it does not cross."""
    mu = np.asarray(mu, np.float64)
    L = ray_end(mu, tau_h, tau_R)
    with np.errstate(divide="ignore"):
        cross = np.where(mu > 0.0, tau_P / np.maximum(mu, 1e-30), np.inf)
    split = cross < L
    c = np.where(split, cross, L)
    half = NS // 2
    k = np.arange(NS + 1)[:, None]
    first = np.where(k <= half, c * k / half, c + (L - c) * (k - half) / (NS - half))
    return np.where(split, first, L * k / NS)


def table(albedo: float, g: float, tau_h: float, tau_R: float, tau_P: float, mu: np.ndarray,
          t: np.ndarray) -> np.ndarray:
    """dS at views mu (nmu,) and optical lengths t (nu,; inf: to the end), (nu, nmu): J at
    each cell's middle (cell_edges), exp(-s) integrated exactly over the cell up to t."""
    mu = np.asarray(mu, np.float64)
    e = cell_edges(mu, tau_h, tau_R, tau_P)
    J = difference(g, tau_h, tau_R, tau_P, mu[None, :], 0.5 * (e[1:] + e[:-1]))       # (NS, nmu)
    out = np.empty((len(t), len(mu)))
    for j, tj in enumerate(np.asarray(t, np.float64)):
        lo = np.minimum(e[:-1], tj)
        hi = np.minimum(e[1:], tj)
        out[j] = albedo * (J * (np.exp(-lo) - np.exp(-hi))).sum(0)
    return out
