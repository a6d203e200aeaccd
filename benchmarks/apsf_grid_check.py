"""The shipped APSF grid's interpolation error where it can be measured free of Monte Carlo
noise, with the runtime's scheme (fogcli.apsf._slice_ga: across albedo a natural cubic spline in
q = sqrt((1 - a) / a) of the log ratio and of the shape; linear in g and log tau):

* albedo: one tally serves every albedo, so the grid albedos and the midpoints between them
  come from the same photons (g = 0, 0.5, 0.85, 0.95: the table's own runs, its seed and photons;
  --scale 0.25 takes the first quarter of them);
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
from fogcli import apsf, apsf_mc as mc  # noqa: E402

G_CHECK = (0.0, 0.5, 0.85, 0.95)
RANGES = ((0.01, 1.0), (1.0, 5.0), (5.0, 31.0))


def albedo_run(g: float, scale: float = 1.0):
    t = M.run_g(g, M.photons_for(g, scale), M.SEED)
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    r = M.reduce_tally(t, np.concatenate([M.ALBEDO, mids]))
    return g, r["ratio"], r["shape"], t.th_edges


def albedo_errors(ratio, shape, th_edges):
    """Each midpoint from the grid albedos by the runtime's albedo interpolation; then two
    schemes not shipped: the spline's shape clipped at 0, and linear in q (the one before)."""
    na = len(M.ALBEDO)
    rg, rd, sg, sd = ratio[:na], ratio[na:], shape[:na], shape[na:]
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    tab = dict(g=np.array([0.0, 1.0]), albedo=M.ALBEDO, ratio=np.stack([rg, rg]), shape=np.stack([sg, sg]))
    ri = np.stack([apsf._slice_ga(tab, "ratio", 0.0, a) for a in mids])
    si = np.stack([apsf._slice_ga(tab, "shape", 0.0, a) for a in mids])
    clipped = np.maximum(np.stack([np.tensordot(apsf.albedo_weights(M.ALBEDO, a), sg, axes=(0, 0)) for a in mids]), 0.0)
    clipped /= np.maximum(clipped.sum(-1, keepdims=True), 1e-300)
    q = np.sqrt((1 - M.ALBEDO) / M.ALBEDO)
    t = ((np.sqrt((1 - mids) / mids) - q[:-1]) / (q[1:] - q[:-1]))[:, None]
    ri_lin = np.exp((1 - t) * np.log(np.maximum(rg[:-1], 1e-300)) + t * np.log(np.maximum(rg[1:], 1e-300)))
    si_lin = (1 - t[..., None]) * sg[:-1] + t[..., None] * sg[1:]
    ok = rd > 1e-250
    with np.errstate(divide="ignore", invalid="ignore"):
        energy = lambda r: np.where(ok, np.abs(r / rd - 1), np.nan)  # noqa: E731
        shape_err = lambda s: np.where(ok, mc.ring_error(th_edges, s, sd), np.nan)  # noqa: E731
        return dict(shipped=(energy(ri), shape_err(si)), clipped=(energy(ri), shape_err(clipped)),
                    linear=(energy(ri_lin), shape_err(si_lin)))


def g_errors(th_edges, taus=(0.03, 0.1, 0.3, 0.7), albedo=1.0):
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
        out_s.append(mc.ring_error(th_edges, 0.5 * (sh[0] + sh[2]), sh[1]))
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
    ap.add_argument("--scale", type=float, default=1.0, help="photons, as a share of the table's (1: its own runs)")
    args = ap.parse_args()
    buf = io.StringIO()
    with redirect_stdout(buf):
        report(args.scale)
    text = buf.getvalue()
    print(text)
    if args.doc:
        from docblock import write_block

        begin, end = "<!-- grid-check -->", "<!-- /grid-check -->"
        block = (f"{begin}\n## Interpolation error of the shipped grid\n\nWritten by `PYTHONPATH=src python "
                 f"benchmarks/apsf_grid_check.py --doc docs/apsf-table.md`.\n\n{text.strip()}\n{end}")
        write_block(Path(args.doc), begin, end, block, new_doc="")
    return 0


def cells(X) -> str:
    """p90 / max of X (..., tau) over each tau range, as table cells."""
    return " \\| ".join(fmt(X[..., (M.TAU >= lo) & (M.TAU < hi)]) for lo, hi in RANGES)


def report(scale: float) -> None:
    with mp.get_context("spawn").Pool(2) as pool:
        runs = pool.starmap(albedo_run, [(g, scale) for g in G_CHECK])
    print(f"grid: {len(M.G)} g x {len(M.ALBEDO)} albedos x {len(M.TAU)} tau; photons x {scale:g} of the table's; "
          "p90 / max in %, tau [0.01, 1) | [1, 5) | [5, 30]\n")
    print("| albedo midpoints (same tally) | energy | shape |\n|---|---|---|")
    errs = [albedo_errors(ratio, shape, th) for _, ratio, shape, th in runs]
    E, S = (np.stack([e["shipped"][i] for e in errs]) for i in (0, 1))           # (g, mids, tau)
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    for name, sel in (("all albedos", mids > 0), ("albedo < 0.3", mids < 0.3), ("albedo 0.3-0.8", (mids >= 0.3) & (mids < 0.8)),
                      ("albedo >= 0.8", mids >= 0.8)):
        print(f"| {name} | {cells(E[:, sel])} | {cells(S[:, sel])} |")
    for key, name in (("clipped", "shape clipped at 0 and renormalised"), ("linear", "linear in q (the scheme before)")):
        E2, S2 = (np.stack([e[key][i] for e in errs]) for i in (0, 1))
        print(f"| all albedos, {name}: not shipped | {cells(E2) if key == 'linear' else ''} | {cells(S2)} |")
    ge, gs = g_errors(runs[0][3])
    print("\n| g midpoints, single scattering (exact), tau 0.03-0.7 | energy | shape |\n|---|---|---|")
    print(f"| every interval of G | {fmt(ge)} | {fmt(gs)} |")
    worst = int(np.nanargmax(gs.max(-1)))
    print(f"| worst interval {M.G[worst]:g}-{M.G[worst + 1]:g} | {fmt(ge[worst])} | {fmt(gs[worst])} |")


if __name__ == "__main__":
    sys.exit(main())
