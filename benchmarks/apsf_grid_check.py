"""The shipped APSF grid's interpolation error where it can be measured free of Monte Carlo
noise, with the runtime's scheme (fogcli.apsf: log ratio and shape linear in
q = sqrt((1 - a) / a) across albedo, linear in g, log tau):

* albedo: one tally serves every albedo, so the grid albedos and the midpoints between them
  come from the same photons (g = 0, 0.5, 0.85, 0.95, the table's seed, 1/4 of its photons);
* g: single scattering by quadrature (exact) at the grid g and the midpoints, tau < 1.

    PYTHONPATH=src python benchmarks/apsf_grid_check.py [--doc docs/apsf-table.md]   # ~5 min, 2 cores

benchmarks/apsf_interpolation.py is the full study (tau, seeds, other schemes) on the grid it
was run with; this script checks the grid make_apsf_table.py ships now.
"""
from __future__ import annotations

import math
import multiprocessing as mp
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "benchmarks")]
import make_apsf_table as M  # noqa: E402
from fogcli import apsf_mc as mc  # noqa: E402

G_CHECK = (0.0, 0.5, 0.85, 0.95)
RANGES = ((0.01, 1.0), (1.0, 5.0), (5.0, 31.0))


def q(a):
    return np.sqrt((1 - np.asarray(a, np.float64)) / np.asarray(a, np.float64))


def ring_l1(wa, wb, A):
    ra, rb = wa @ A.T, wb @ A.T
    return np.abs(ra - rb).sum(-1) / np.maximum(rb.sum(-1), 1e-300)


def albedo_run(g: float):
    t = M.run_g(g, M.photons_for(g, 0.25), M.SEED)
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    r = M.reduce_tally(t, np.concatenate([M.ALBEDO, mids]))
    return g, r["ratio"], r["shape"], t.th_edges


def rings(th_edges):
    _, u = mc.kernel_bins(th_edges, np.zeros(len(th_edges) - 1))
    return np.diff(mc.gaussian_cdf(u), axis=0)


def albedo_errors(ratio, shape, A):
    na = len(M.ALBEDO)
    rg, rd, sg, sd = ratio[:na], ratio[na:], shape[:na], shape[na:]
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    t = ((q(mids) - q(M.ALBEDO[:-1])) / (q(M.ALBEDO[1:]) - q(M.ALBEDO[:-1])))[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        ri = np.exp((1 - t) * np.log(rg[:-1]) + t * np.log(rg[1:]))
        e = np.where(rd > 1e-250, np.abs(ri / rd - 1), np.nan)
    si = (1 - t[..., None]) * sg[:-1] + t[..., None] * sg[1:]
    s = np.where(rd > 1e-250, ring_l1(si, sd, A), np.nan)
    return e, s, mids


def g_errors(A, th_edges, taus=(0.03, 0.1, 0.3, 0.7), albedo=1.0):
    te = np.asarray(th_edges, np.float64)
    nf = int(np.searchsorted(te, math.pi / 2 + 1e-12))
    thc = np.sqrt(te[:-1] * te[1:])
    thc[0] = te[1] / 2
    out_e, out_s = [], []
    for g0, g1 in zip(M.G[:-1], M.G[1:]):
        gs = (g0, 0.5 * (g0 + g1), g1)
        f = np.zeros((3, len(taus), len(te) - 1))
        for i, g in enumerate(gs):
            for k, tv in enumerate(taus):
                f[i, k, :nf] = mc.single_scatter(thc[:nf], tv, g, albedo, n=1000)
        W, E, _ = mc.fit_gaussians(te, f)
        sh = W / np.maximum(W.sum(-1, keepdims=True), 1e-300)
        ei = np.exp(0.5 * (np.log(E[0]) + np.log(E[2])))
        out_e.append(np.abs(ei / E[1] - 1))
        out_s.append(ring_l1(0.5 * (sh[0] + sh[2]), sh[1], A))
    return np.array(out_e), np.array(out_s)


def fmt(x):
    x = np.asarray(x)[np.isfinite(x)]
    return f"{100 * np.percentile(x, 90):.2f} / {100 * x.max():.2f}" if x.size else "-"


def main() -> int:
    import argparse
    import io
    from contextlib import redirect_stdout

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--doc", help="write the block between the grid-check markers of this doc")
    args = ap.parse_args()
    buf = io.StringIO()
    with redirect_stdout(buf):
        report()
    text = buf.getvalue()
    print(text)
    if args.doc:
        from docblock import write_block

        begin, end = "<!-- grid-check -->", "<!-- /grid-check -->"
        block = (f"{begin}\n## Interpolation error of the shipped grid\n\nWritten by `PYTHONPATH=src python "
                 f"benchmarks/apsf_grid_check.py --doc docs/apsf-table.md`.\n\n{text.strip()}\n{end}")
        write_block(Path(args.doc), begin, end, block, new_doc="")
    return 0


def report() -> None:
    with mp.get_context("spawn").Pool(2) as pool:
        runs = pool.map(albedo_run, G_CHECK)
    A = rings(runs[0][3])
    print(f"grid: {len(M.G)} g x {len(M.ALBEDO)} albedos x {len(M.TAU)} tau; "
          "p90 / max in %, tau [0.01, 1) | [1, 5) | [5, 30]\n")
    print("| albedo midpoints (same tally) | energy | shape |\n|---|---|---|")
    E, S = [], []
    for g, ratio, shape, _ in runs:
        e, s, mids = albedo_errors(ratio, shape, A)
        E.append(e)
        S.append(s)
    E, S = np.stack(E), np.stack(S)           # (g, mids, tau)
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    for name, sel in (("all albedos", mids > 0), ("albedo < 0.3", mids < 0.3), ("albedo 0.3-0.8", (mids >= 0.3) & (mids < 0.8)),
                      ("albedo >= 0.8", mids >= 0.8)):
        cells = []
        for lo, hi in RANGES:
            tsel = (M.TAU >= lo) & (M.TAU < hi)
            cells.append((fmt(E[:, sel][:, :, tsel]), fmt(S[:, sel][:, :, tsel])))
        print(f"| {name} | " + " \\| ".join(c[0] for c in cells) + " | " + " \\| ".join(c[1] for c in cells) + " |")
    ge, gs = g_errors(A, runs[0][3])
    print("\n| g midpoints, single scattering (exact), tau 0.03-0.7 | energy | shape |\n|---|---|---|")
    print(f"| every interval of G | {fmt(ge)} | {fmt(gs)} |")
    worst = int(np.nanargmax(gs.max(-1)))
    print(f"| worst interval {M.G[worst]:g}-{M.G[worst + 1]:g} | {fmt(ge[worst])} | {fmt(gs[worst])} |")


if __name__ == "__main__":
    sys.exit(main())
