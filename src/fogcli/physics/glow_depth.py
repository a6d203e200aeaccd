"""Where along a receiver's ray a source's glow scatters (`render.halo_depth: receiver`).

The point spread gives a pixel at angle theta from a source the light scattered into its
ray over the whole ray. A pixel whose surface is nearer than the source ends its ray
before part of that scattering: a ground a few metres away below a lamp at fifteen, a
pole in front of a sign. In forward-scattering media much of the glow seen near a source
scatters close to the camera (the small scattering angle there outweighs the nearness of
the source), so how much a nearer surface keeps depends on theta and on the medium.

`depth_cdf` is that share in single scattering: the light of a matte source facing the
camera (intensity max(0, mu0) against the line to the camera), seen at angle theta from
it at distance D, that scatters nearer than u D along the ray, normalised to 1 at u = 1
(the source's own surface keeps all of it). Against the Monte Carlo of the table (a tally of
where the last scattering lies, session 41 scratch, g 0.85) it is within ~0.1 up to tau 2
and keeps less than multiple scattering does beyond (more of that light scatters near the
camera). `receiver_table` samples it for the pyramid: per level at that level's angle.
"""
from __future__ import annotations

import math

import numpy as np

NU = 17            # samples of u = receiver depth / source depth over [0, 1] (1 beyond)
N_PSI = 256        # quadrature nodes along the ray


def depth_cdf(theta: float, tau: np.ndarray, g: float, u: np.ndarray) -> np.ndarray:
    """(len(tau), len(u)): the share of the single-scattered light seen at angle theta from a
    facing matte source at optical distance tau (extinction) that scatters at ray distance
    below u times the source's, over the share below the source's own (u = 1).
    The integral along the ray on nodes t = D cos(theta) + b tan(psi), b = D sin(theta), even
    in psi (they crowd where the ray passes the source, at any theta), with evenly spaced
    ones added for the stretch near the camera, which the psi nodes leave sparse at small
    theta; trapezoids in t. exp(-(rho + t - D)) <= 1 keeps it finite at any tau."""
    tau = np.atleast_1d(np.asarray(tau, np.float64))[:, None]
    theta = min(max(theta, 1e-6), 0.5 * math.pi - 1e-6)
    s, c = math.sin(theta), math.cos(theta)
    psi0 = math.atan2(-c, s)
    psi = psi0 + (np.arange(N_PSI) + 0.5) / N_PSI * (0.5 * math.pi - psi0)
    tr = np.unique(np.concatenate([[0.0], c + s * np.tan(psi[:-1]), np.linspace(0.0, 2.0, N_PSI // 2)]))   # t / D
    xz = 1.0 - tr * c                                   # the point's distance towards the camera / D
    rho = np.sqrt((tr * s) ** 2 + xz ** 2)              # / D
    cs = (tr * s * -s + xz * c) / rho                   # cosine of the scattering angle
    phase = (1 - g * g) / (1 + g * g - 2 * g * cs) ** 1.5
    f = phase * np.maximum(xz / rho, 0.0) / rho ** 2 * np.exp(-tau * (rho + tr - 1.0))
    cum = np.concatenate([np.zeros((len(tau), 1)), np.cumsum(0.5 * (f[:, 1:] + f[:, :-1]) * np.diff(tr), -1)], -1)
    return np.clip(_along(tr, cum, np.minimum(u, 1.0)) / np.maximum(_along(tr, cum, np.ones(1)), 1e-300), 0.0, 1.0)


def _along(x: np.ndarray, rows: np.ndarray, at: np.ndarray) -> np.ndarray:
    """np.interp of every row of `rows` (over the increasing x) at `at`, 0 left of x."""
    at = np.asarray(at, np.float64)
    i = np.clip(np.searchsorted(x, at) - 1, 0, len(x) - 2)
    t = np.clip((at - x[i]) / (x[i + 1] - x[i]), 0.0, 1.0)
    v = rows[:, i] * (1 - t) + rows[:, i + 1] * t
    return np.where(at < x[0], 0.0, v)


def receiver_table(sigma_t: float, g: float, P: np.ndarray, level_theta: np.ndarray) -> np.ndarray:
    """(levels, len(P), NU) float64: depth_cdf per pyramid level (its angle level_theta[k]) at
    the source distances P, on u = 0, 1 / (NU - 1), ..., 1. A level's light all lands at
    about its own angle, so one angle per level."""
    u = np.linspace(0.0, 1.0, NU)
    return np.stack([depth_cdf(th, sigma_t * P, g, u) for th in level_theta])
