"""Probe for issue 8 that chose the table's estimators (make_apsf_table.T_FAR): the
forward-hemisphere scattered light at large tau from the sphere-crossing estimator
(apsf_crossing.simulate_far) against the point estimator (apsf_mc.simulate), two seeds each;
prints, per albedo and tau, the mean energy (relative form, no r_max background), the
seed-to-seed noise of the energy |a/b - 1| / sqrt(2) and of the shape (ring L1 of the
normalised Gaussian weights between the seeds / sqrt(2), as docs/apsf-table.md measures).

    python tools/apsf_crossing_probe.py [g] [crossing photons] [point photons]   # ~20 s
    python tools/apsf_crossing_probe.py --tau-step                                # ~3.5 min, 2 cores

--tau-step: how fine the table's tau grid must be beyond 5. One tally (crossing estimator, g 0,
0.5, 0.85, 0.95, 60000 photons, two seeds, their mean) with cameras at the grid taus >= 5 and
at the quarter points between them (geometric), reduced like the table (make_apsf_table's
reduce_tally): the error of interpolating a midpoint from its neighbours with the grid step
and with the step halved, the ratio linear in log tau (the scheme before) or its log (shipped),
and the shape;
albedo >= 0.8; the seeds' difference at the midpoints is the noise.

Session 12, g 0.9, tau 5-28, albedo 0.8-0.99, Intel Xeon (2 cores): crossing, 20000 photons,
3.4 s a run: energy 0.1-2.9 %, shape 0.5-4.9 %; point, 100000 photons, 6.8 s a run: energy
1.3-60 %, shape 8-84 % (its heavy tail also makes its mean unreliable beyond tau ~7). Not
yet done: the table built from it at large tau (its small-angle bins get few crossings)."""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path[:0] = [str(Path(__file__).resolve().parents[1] / d) for d in ("src", "tools")]
import apsf_mc as mc  # noqa: E402
import apsf_fit as fit
import apsf_crossing as crossing

TAU = np.array([5.0, 7.0, 10.0, 14.0, 20.0, 28.0])
ALB = np.array([0.8, 0.9, 0.95, 0.99])


def run(estimator: str, g: float, photons: int, seed: int, r_max: float = 60.0):
    """(forward energy, Gaussian weights) per (albedo, tau), relative form, no r_max background."""
    sim = crossing.simulate_far if estimator == "crossing" else mc.simulate
    t = sim(g, TAU, photons, seed, r_max=r_max, rr_order=int(120 / math.sqrt(1 - g)))
    f, _ = fit.profiles(t, ALB, relative=True, background=False)
    W, E, _ = fit.fit_gaussians(t.th_edges, f)
    return E, W


def tau_step_run(g: float, seed: int, photons: int = 60000):
    import make_apsf_table as M

    grid = M.TAU[M.TAU >= 5.0]
    fine = np.exp(np.linspace(np.log(grid[0]), np.log(grid[-1]), 4 * (len(grid) - 1) + 1))
    t = crossing.simulate_far(g, fine, photons, seed, r_max=M.R_MAX, rr_order=M.rr_order_for(g))
    r = M.reduce_tally(t, M.ALBEDO)
    return r["ratio"], r["shape"], t.th_edges


def tau_step() -> int:
    import multiprocessing as mp

    import make_apsf_table as M
    from apsf_grid_check import tau_errors

    with mp.get_context("spawn").Pool(2) as pool:
        res = pool.starmap(tau_step_run, [(g, M.SEED + k) for g in (0.0, 0.5, 0.85, 0.95) for k in (0, 1)])
    keep = M.ALBEDO >= 0.8
    pct = lambda x: f"{100 * np.nanpercentile(np.concatenate(x), 90):.2f} / {100 * np.nanmax(np.concatenate(x)):.2f}"  # noqa: E731
    print("tau >= 5, albedo >= 0.8, p90 / max in %: energy (ratio linear in log tau, the scheme before) | "
          "energy (log ratio linear in log tau, shipped) | shape | noise of the midpoints' energy")
    for step, name in ((2, "grid step"), (1, "step halved")):
        e_lin, e_log, e_sh, noise = [], [], [], []
        for a, b in zip(res[::2], res[1::2]):
            # this grid's nodes and midpoints alternating, as apsf_grid_check.tau_errors takes them
            r, s, th = 0.5 * (a[0] + b[0])[:, ::step], 0.5 * (a[1] + b[1])[:, ::step], a[2]
            log, shp, lin = tau_errors(r, s, th)
            e_lin.append(lin[keep].ravel())
            e_log.append(log[keep].ravel())
            e_sh.append(shp[keep].ravel())
            with np.errstate(divide="ignore", invalid="ignore"):
                noise.append((np.abs(a[0] - b[0]) / (a[0] + b[0]))[:, ::step][:, 1::2][keep].ravel())
        print(f"{name}: {pct(e_lin)} | {pct(e_log)} | {pct(e_sh)} | {pct(noise)}")
    return 0


def main() -> int:
    if sys.argv[1:2] == ["--tau-step"]:
        return tau_step()
    g = float(sys.argv[1]) if len(sys.argv) > 1 else 0.9
    counts = {"crossing": int(sys.argv[2]) if len(sys.argv) > 2 else 20000,
              "point": int(sys.argv[3]) if len(sys.argv) > 3 else 20000}
    shape = lambda W: W / np.maximum(W.sum(-1, keepdims=True), 1e-300)  # noqa: E731
    print(f"g {g}, tau {TAU.tolist()}; per albedo: mean energy | energy noise | shape noise (ring L1), "
          "seed-to-seed / sqrt(2)")
    for name, n in counts.items():
        t0 = time.time()
        (e1, w1), (e2, w2) = run(name, g, n, 1), run(name, g, n, 2)
        ring = fit.ring_error(mc.theta_edges(), shape(w1), shape(w2)) / math.sqrt(2)
        print(f"{name}: {n} photons, {(time.time() - t0) / 2:.1f} s a run")
        for i, a in enumerate(ALB):
            print(f"  a {a}: " + " ".join(f"{v:.4g}" for v in (e1[i] + e2[i]) / 2)
                  + " | " + " ".join(f"{v:.3f}" for v in np.abs(e1[i] / e2[i] - 1) / math.sqrt(2))
                  + " | " + " ".join(f"{v:.3f}" for v in ring[i]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
