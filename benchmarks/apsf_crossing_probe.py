"""Probe for issue 8 (not yet part of the table or of any doc): the forward-hemisphere
scattered light at large tau from the sphere-crossing estimator (apsf_mc.simulate_far)
against the point estimator the table is built with (apsf_mc.simulate), two seeds each;
prints, per albedo and tau, the mean energy (relative form, no r_max background), the
seed-to-seed noise of the energy |a/b - 1| / sqrt(2) and of the shape (ring L1 of the
normalised Gaussian weights between the seeds / sqrt(2), as docs/apsf-table.md measures).

    python benchmarks/apsf_crossing_probe.py [g] [crossing photons] [point photons]   # ~20 s

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

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
from fogcli import apsf_mc as mc  # noqa: E402

TAU = np.array([5.0, 7.0, 10.0, 14.0, 20.0, 28.0])
ALB = np.array([0.8, 0.9, 0.95, 0.99])


def run(estimator: str, g: float, photons: int, seed: int, r_max: float = 60.0):
    """(forward energy, Gaussian weights) per (albedo, tau), relative form, no r_max background."""
    sim = mc.simulate_far if estimator == "crossing" else mc.simulate
    t = sim(g, TAU, photons, seed, r_max=r_max, rr_order=int(120 / math.sqrt(1 - g)))
    f, _ = mc.profiles(t, ALB, relative=True, background=False)
    W, E, _ = mc.fit_gaussians(t.th_edges, f)
    return E, W


def main() -> int:
    g = float(sys.argv[1]) if len(sys.argv) > 1 else 0.9
    counts = {"crossing": int(sys.argv[2]) if len(sys.argv) > 2 else 20000,
              "point": int(sys.argv[3]) if len(sys.argv) > 3 else 20000}
    shape = lambda W: W / np.maximum(W.sum(-1, keepdims=True), 1e-300)  # noqa: E731
    print(f"g {g}, tau {TAU.tolist()}; per albedo: mean energy | energy noise | shape noise (ring L1), "
          "seed-to-seed / sqrt(2)")
    for name, n in counts.items():
        t0 = time.time()
        (e1, w1), (e2, w2) = run(name, g, n, 1), run(name, g, n, 2)
        ring = mc.ring_error(mc.theta_edges(), shape(w1), shape(w2)) / math.sqrt(2)
        print(f"{name}: {n} photons, {(time.time() - t0) / 2:.1f} s a run")
        for i, a in enumerate(ALB):
            print(f"  a {a}: " + " ".join(f"{v:.4g}" for v in (e1[i] + e2[i]) / 2)
                  + " | " + " ".join(f"{v:.3f}" for v in np.abs(e1[i] / e2[i] - 1) / math.sqrt(2))
                  + " | " + " ".join(f"{v:.3f}" for v in ring[i]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
