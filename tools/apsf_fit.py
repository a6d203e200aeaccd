"""From Monte Carlo tallies (apsf_mc.py) to the point-spread table: tallies merged, the
absorption factor from their path-length moments, profiles per steradian, and the fit of a
profile by half-octave Gaussians; the single-scattering quadrature they are checked against."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from apsf_mc import EMIT_THETA, N_MU, N_TH, Tally, _mu_bin, hg_phase

J = 31


SIGMA_U = 2.0 ** (-14 + np.arange(J) / 2.0)           # Gaussian widths in u = tan(theta)


# Neighbouring half-octave Gaussians are nearly interchangeable, so the plain NNLS fit is
# sparse and picks different ones at neighbouring albedos: interpolating such weights mixes
# two different kernels (up to 3 % ring error at albedo midpoints, tau 1-5). A small
# penalty on the weights' second difference makes them a smooth function of the profile:
# 0.5 % there, for < 0.01 more fit error on noise-free profiles (docs/apsf-table.md).
FIT_SMOOTH = 0.03


def merge(tallies: list[Tally]) -> Tally:
    """Photon-weighted mean of runs with the same grid (e.g. several seeds)."""
    t0 = tallies[0]
    n = sum(t.photons for t in tallies)
    m = sum(t.m * t.photons for t in tallies) / n      # sums scale with photons via norm
    e = sum(t.e * t.photons for t in tallies) / n
    return Tally(t0.g, t0.tau, t0.th_edges, t0.x_edges, n, m, e, t0.norm * t0.photons / n,
                 {}, t0.r_max, np.concatenate([t.esc_w for t in tallies]),
                 np.concatenate([t.esc_l for t in tallies]), t0.axes,
                 np.concatenate([t.esc_mu for t in tallies]))


def absorption_factor(t: Tally, sa: float, moments: np.ndarray) -> np.ndarray:
    """Sum over excess bins of sum(w exp(-sa x)), from the three moments per bin: the mean
    and variance of x in the bin give exp(-sa mean + sa^2 var / 2), clipped to the values
    at the bin's edges so that it cannot leave the bin's range."""
    s0, s1, s2 = moments
    safe = np.where(s0 > 0, s0, 1.0)
    mean = s1 / safe
    var = np.maximum(s2 / safe - mean ** 2, 0.0)
    lo, hi = t.x_edges[:-1], np.append(t.x_edges[1:-1], np.inf)
    if sa == 0:
        return s0.sum(-1)
    fac = np.exp(np.clip(-sa * mean + 0.5 * sa * sa * var, -sa * hi, -sa * lo))
    return (s0 * fac).sum(-1)


def shell_fluence(d, r_max: float, sa: float, g: float):
    """Diffusion theory: fluence at distance d < r_max from the centre of a uniform spherical
    shell of radius r_max emitting one photon (isotropic, then diffusing with absorption):
    the shell theorem for the Yukawa kernel exp(-r/L) / (4 pi D r),
    = sinh(d/L) / (d/L) * exp(-r_max/L) / (4 pi D r_max)."""
    D = 1.0 / (3.0 * (sa + 1.0 - g))
    d = np.asarray(d, np.float64)
    if sa <= 0:
        return np.full_like(d, 1.0 / (4 * math.pi * D * r_max))
    L = math.sqrt(D / sa)
    # sinh(d/L) exp(-R/L) written without overflow
    sh = 0.5 * (np.exp(-(r_max - d) / L) - np.exp(-(r_max + d) / L))
    return sh / (d / L) / (4 * math.pi * D * r_max)


def profiles(t: Tally, albedo, relative: bool = False, background: bool = True):
    """f(theta) per steradian (A, T, nb) and the forward-hemisphere energy per class of theta
    and bin of the emission cosine (A, T, N_TH, N_MU), for each albedo. relative=False includes the factor
    exp(-sa d) of the shortest path; relative=True leaves it out (no underflow at large
    sa d; multiply by exp(-sa d) to get f).
    background: add the light of the photons dropped at r_max, in diffusion theory
    (`shell_fluence`, weighted by each photon's exp(-sa l) at the drop): an isotropic
    radiance phi / (4 pi) at the camera, i.e. f_bg = d^2 phi / N per steradian."""
    albedo = np.atleast_1d(np.asarray(albedo, np.float64))
    dom = 2 * math.pi * (np.cos(t.th_edges[:-1]) - np.cos(t.th_edges[1:]))
    f = np.empty((len(albedo), len(t.tau), len(dom)))
    em = np.empty((len(albedo), len(t.tau), N_TH, N_MU))
    for i, a in enumerate(albedo):
        sa = (1 - a) / a
        shift = 0.0 if relative else 1.0
        base = np.exp(-sa * t.tau * shift)[:, None] * t.norm[:, None]
        f[i] = absorption_factor(t, sa, t.m) * base / dom
        em[i] = absorption_factor(t, sa, t.e) * base[..., None]
        if background and len(t.esc_w):
            # exp(-sa l) relative to exp(-sa d) per camera (l >= r_max > d: no overflow)
            wl = t.esc_w[None, :] * np.exp(-sa * (t.esc_l[None, :] - t.tau[:, None] * (1 - shift)))
            fbg = t.tau ** 2 / t.photons * wl.sum(1) * shell_fluence(t.tau, t.r_max, sa, t.g)
            f[i] += fbg[:, None]
            # its forward half, split by emission cosine (cameras on +z and -z: both signs);
            # isotropic at the camera, so over the theta classes by their solid angles
            h = np.zeros((len(t.tau), N_MU))
            for sgn in (1.0, -1.0):
                im = _mu_bin(sgn * t.esc_mu)
                for k in range(len(t.tau)):
                    h[k] += np.bincount(im, wl[k], minlength=N_MU)
            h /= np.maximum(h.sum(1, keepdims=True), 1e-300)
            dom_c = 2 * math.pi * (np.cos(EMIT_THETA[:-1]) - np.cos(EMIT_THETA[1:]))
            em[i] += fbg[:, None, None] * dom_c[None, :, None] * h[:, None, :]
    return f, em


def kernel_bins(th_edges: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward-hemisphere energy per theta bin (..., nf) = int K(u) d^2u over the bin's ring
    in the u-plane (the same as int f dOmega over the bin), and the u = tan(theta) edges."""
    nf = int(np.searchsorted(th_edges, math.pi / 2 + 1e-12))       # bins below pi/2
    dom = 2 * math.pi * (np.cos(th_edges[:nf]) - np.cos(th_edges[1:nf + 1]))
    u = np.tan(th_edges[:nf + 1])
    u[-1] = np.inf
    return f[..., :nf] * dom, u


def gaussian_cdf(u: np.ndarray, sigma=SIGMA_U) -> np.ndarray:
    """Energy of each unit 2-D Gaussian inside radius u: (len(u), J)."""
    with np.errstate(over="ignore", invalid="ignore"):
        c = -np.expm1(-(u[:, None] ** 2) / (2 * sigma[None, :] ** 2))
    return np.where(np.isinf(u)[:, None], 1.0, c)


def fit_gaussians(th_edges: np.ndarray, f: np.ndarray, sigma=SIGMA_U, smooth: float = FIT_SMOOTH):
    """Non-negative weights of the unit Gaussians reproducing the ring energies of K(u).
    Least squares on the ring energies (the profile weighted by u du, i.e. what a ring of
    pixels receives) plus the cumulative energy, with sum(w) = energy as a heavily weighted
    row and then imposed exactly, plus `smooth` times the second difference of the weights
    across widths (see FIT_SMOOTH). Returns weights (..., J), energy (...), and the error:
    sum over rings |fit - K| / energy."""
    from scipy.optimize import nnls           # scipy is only needed to build the table
    ring, u = kernel_bins(th_edges, f)
    cdf = gaussian_cdf(u, sigma)
    A_ring = np.diff(cdf, axis=0)                                     # (nf, J)
    A_cum = cdf[1:-1]
    D2 = np.diff(np.eye(len(sigma)), n=2, axis=0)
    shp = ring.shape[:-1]
    ring2 = ring.reshape(-1, ring.shape[-1])
    W = np.zeros((len(ring2), len(sigma)))
    err = np.zeros(len(ring2))
    energy = ring2.sum(-1)
    for i, k in enumerate(ring2):
        E = energy[i]
        if not E > 0:
            continue
        b_ring, b_cum = k / E, np.cumsum(k)[:-1] / E
        A = np.vstack([A_ring, 0.5 * A_cum, smooth * D2, 100.0 * np.ones((1, len(sigma)))])
        b = np.concatenate([b_ring, 0.5 * b_cum, np.zeros(len(D2)), [100.0]])
        w, _ = nnls(A, b, maxiter=2000)
        w *= 1.0 / w.sum()
        W[i] = w * E
        err[i] = np.abs(A_ring @ w - b_ring).sum()
    return W.reshape(*shp, len(sigma)), energy.reshape(shp), err.reshape(shp)


def ring_error(th_edges, W_a, W_b) -> np.ndarray:
    """Relative L1 between the ring energies of two weight sets, over the energy of b."""
    _, u = kernel_bins(th_edges, np.zeros(len(th_edges) - 1))
    A = np.diff(gaussian_cdf(u), axis=0)
    ra, rb = W_a @ A.T, W_b @ A.T
    return np.abs(ra - rb).sum(-1) / np.maximum(rb.sum(-1), 1e-300)


@lru_cache(maxsize=4)
def _leggauss(n: int):
    return np.polynomial.legendre.leggauss(n)      # O(n^2) or worse: computed once per n


def single_scatter(theta, d: float, g: float, albedo: float = 1.0, n: int = 4000) -> np.ndarray:
    """Independent check: f(theta) for single scattering by quadrature along the view ray,
    f = d^2 int_0^inf exp(-st (rho + r)) p(mu) / rho^2 dr, with rho the vertex-source
    distance and mu the cosine between the photon's direction (away from the source) and
    the direction to the camera. Substitution r = rho_min * tan(t) resolves the peak."""
    st = 1.0 / albedo
    theta = np.atleast_1d(np.asarray(theta, np.float64))
    # nodes: Gauss-Legendre in an angle variable psi in (0, pi) = angle source-vertex-camera
    # for a ray from the camera at angle theta, rho sin(psi') ... use the geometric angle
    # alpha at the vertex: r = d sin(alpha - theta)/sin(alpha)... simpler: r over a mapped grid
    x, wq = _leggauss(n)
    out = np.empty(len(theta))
    for i, th in enumerate(theta):
        # b = pi - (angle at the vertex between vertex->camera and vertex->source) runs
        # from theta (r = 0) to pi (r = inf); by the sine rule r = d sin(b - theta) / sin b,
        # rho = d sin(theta) / sin b, dr = d sin(theta) / sin^2 b db, and the scattering
        # cosine (source->vertex against vertex->camera) is cos b. Smooth in b.
        b = th + (math.pi - th) * (x + 1) / 2
        jw = wq * (math.pi - th) / 2
        sb = np.sin(b)
        r = d * np.sin(b - th) / sb
        rho = d * math.sin(th) / sb
        dr = d * math.sin(th) / sb ** 2
        out[i] = d * d * np.sum(jw * dr * np.exp(-st * (rho + r)) * hg_phase(np.cos(b), g) / rho ** 2)
    return out
