"""The sphere-crossing estimator of the point spread (simulate_far): the same quantity as
apsf_mc.simulate, for large optical distances (tools/apsf_crossing_probe.py measures it)."""
from __future__ import annotations

import math

import numpy as np

from apsf_mc import (N_MU, N_TH, Tally, _add_scores, _emit_index, _excess_bin, _survivors, _theta_bin, excess_edges,
                     hg_sample, rotate, theta_edges)


def _score_crossings(pos, d, d0, w, length, step, radii, order_k, th_edges, x_edges, buf_m: list, buf_e: list):
    """The crossing estimator's scores of one flight per photon, pos -> pos + step d: every
    sphere of radius in `radii` (ascending; order_k their camera index) it crosses."""
    nb, nx = len(th_edges) - 1, len(x_edges) - 1
    # the spheres this flight crosses, pos -> pos + step d (|pos + t d| = R, 0 < t <= step):
    # inwards every R between the flight's closest point and |pos|, outwards every R
    # between the closest point and the flight's end. Radii sorted, so each range is
    # two searchsorted bounds and the work is per crossing, not per sphere and flight.
    b = np.einsum("ij,ij->i", pos, d)
    c0 = np.einsum("ij,ij->i", pos, pos)
    tc = np.clip(-b, 0.0, step)
    r_min = np.sqrt(np.maximum(c0 + 2 * tc * b + tc * tc, 0.0))
    r_end = np.sqrt(np.maximum(c0 + 2 * step * b + step * step, 0.0))
    lo = np.searchsorted(radii, r_min, "right")
    bounds = ((lo, np.searchsorted(radii, np.sqrt(c0), "left"), -1.0),
              (lo, np.searchsorted(radii, r_end, "right"), 1.0))
    for lo_k, hi_k, sgn in bounds:
        cnt = np.maximum(hi_k - lo_k, 0)
        if not cnt.any():
            continue
        hit = np.repeat(np.arange(len(w)), cnt)
        # lo_k[i], lo_k[i] + 1, ..., hi_k[i] - 1 for each photon i, concatenated
        ks = np.repeat(lo_k - np.cumsum(cnt) + cnt, cnt) + np.arange(cnt.sum())
        R = radii[ks]
        bh = b[hit]
        th = -bh + sgn * np.sqrt(np.maximum(bh * bh - c0[hit] + R * R, 0.0))
        p = pos[hit] + th[:, None] * d[hit]
        cm = np.clip(np.einsum("ij,ij->i", p, d[hit]) / R, -1.0, 1.0)
        val = w[hit] / np.maximum(np.abs(cm), 1e-12)
        ex = np.maximum(length[hit] + th - R, 0.0)
        ix = _excess_bin(ex, x_edges)
        theta = np.arccos(cm)
        ib = _theta_bin(theta, th_edges)
        kk = order_k[ks]
        buf_m.append(((kk * nb + ib) * nx + ix, val, ex))
        fw = cm > 0
        mu0 = np.einsum("ij,ij->i", d0[hit[fw]], p[fw]) / R[fw]     # emission against the camera's direction
        buf_e.append((_emit_index(kk[fw], theta[fw], mu0) * nx + ix[fw], val[fw], ex[fw]))


def simulate_far(g: float, tau, photons: int, seed: int, *, r_max: float | None = None, rr_order: int = 30,
                 rr_keep: float = 0.5, max_order: int | None = None, batch: int = 50_000, th_edges=None,
                 x_edges=None) -> Tally:
    """The same quantity as `simulate` from a sphere-crossing estimator (issue 8's large-tau
    noise; not yet what the table is built from: tools/apsf_crossing_probe.py).

    The medium is infinite and homogeneous and the source isotropic, so the radiance at
    distance d depends on d and on the angle to the radial direction only: the whole sphere
    of radius d is the detector. A photon crossing it with radial cosine mu (its direction
    against the outward normal) scores w / |mu| in the theta = acos(mu) bin (a camera there
    looking at the source sees it at that angle from the source; mu < 0: the back bins),
    with the path length to the crossing in the excess histogram as `simulate` does. The
    flight from the source is not scored (unscattered light is excluded). Emission is
    isotropic, the first flight exponential and there is no weight window: every direction
    is a camera, so none is preferred. Every photon that reaches distance d scores there,
    where the point estimator needs a vertex within r_cut of one of two camera points: at
    tau >= 5, ~100x less variance for the same time (the probe's numbers, session 12).
    Small angles get few crossings (a bin's share of the sphere's directions), and 1/|mu|
    has a logarithmically divergent variance at grazing crossings (the last forward bin).
    max_order: score only the flights after the first max_order scatterings."""
    tau = np.asarray(tau, np.float64)
    th_edges = theta_edges() if th_edges is None else th_edges
    x_edges = excess_edges() if x_edges is None else x_edges
    r_max = float(3 * tau.max()) if r_max is None else r_max
    nT, nb, nx = len(tau), len(th_edges) - 1, len(x_edges) - 1
    order_k = np.argsort(tau, kind="stable")          # sphere radii ascending, and their camera index
    radii = tau[order_k]
    m = [np.zeros(nT * nb * nx) for _ in range(3)]
    e = [np.zeros(nT * N_TH * N_MU * nx) for _ in range(3)]
    rng = np.random.default_rng(seed)
    esc_w, esc_l, esc_mu = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)]
    done = 0
    while done < photons:
        n = min(batch, photons - done)
        done += n
        mu = 2 * rng.random(n) - 1
        phi = 2 * math.pi * rng.random(n)
        st = np.sqrt(1 - mu * mu)
        d = np.stack([st * np.cos(phi), st * np.sin(phi), mu], 1)
        d0 = d.copy()
        pos = np.zeros((n, 3))
        length = np.zeros(n)
        w = np.ones(n)
        order = 0
        buf_m, buf_e = [], []
        while len(w):
            step = -np.log1p(-rng.random(len(w)))
            if order > 0:
                _score_crossings(pos, d, d0, w, length, step, radii, order_k, th_edges, x_edges, buf_m, buf_e)
            if max_order is not None and order >= max_order:
                break
            pos += step[:, None] * d
            length += step
            order += 1
            keep, w = _survivors(np.einsum("ij,ij->i", pos, pos), w, length, d0, (esc_w, esc_l, esc_mu), order, rr_order,
                                 rr_keep, r_max, rng)
            pos, d, d0, length, w = pos[keep], d[keep], d0[keep], length[keep], w[keep]
            d = rotate(d, hg_sample(rng, g, len(w)), rng)
        _add_scores(((buf_m, m), (buf_e, e)))
    # per photon of unit power the crossings sum to 4 pi d^2 L dOmega, and f = L 4 pi d^2
    return Tally(g, tau, th_edges, x_edges, photons, np.stack([a.reshape(nT, nb, nx) for a in m]),
                 np.stack([a.reshape(nT, N_TH, N_MU, nx) for a in e]), np.full(nT, 1.0 / photons), {"estimator": "crossing"},
                 r_max, np.concatenate(esc_w), np.concatenate(esc_l), 1, np.concatenate(esc_mu))
