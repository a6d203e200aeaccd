"""The shipped APSF grid's interpolation error where it can be measured free of Monte Carlo
noise, with the runtime's scheme (fogcli.physics.apsf._slice_ga: across albedo a natural cubic spline in
q = sqrt((1 - a) / a) of the log ratio and of the shape; linear in g and log tau):

* albedo: one tally serves every albedo, so the grid albedos and the midpoints between them
  come from the same photons (g = 0, 0.5, 0.85, 0.95: the table's own runs, its seed and photons;
  --scale 0.25 takes the first quarter of them);
* tau, from the shipped table itself: its curvature along log tau (curvature_errors);
* g: single scattering by quadrature (exact) at the grid g and the midpoints, tau < 1;
* tau >= 5, albedo and tau: the sphere-crossing estimator (apsf_crossing.simulate_far, the one the
  table uses from tau 0.3 on) with cameras at the grid taus and the geometric midpoints between
  them in one tally, two seeds; the runtime interpolates the log ratio linearly in log tau
  (fogcli.physics.apsf.log_along_tau) and the shape linearly.

    PYTHONPATH=src python tools/apsf_grid_check.py [--doc docs/apsf-table.md]   # ~10 min, 2 cores

It checks the grid make_apsf_table.py ships (an earlier, wider study of the 30-tau grid,
tools/apsf_interpolation.py, is in git history).
"""
from __future__ import annotations

import math
import multiprocessing as mp
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "src"), str(ROOT / "tools")]
import make_apsf_table as M  # noqa: E402
from fogcli.physics import apsf  # noqa: E402
import apsf_fit as fit
import apsf_crossing as crossing

G_CHECK = (0.0, 0.5, 0.85, 0.95)
RANGES = ((0.01, 1.0), (1.0, 5.0), (5.0, 31.0))
FAR_PHOTONS = 60_000      # a g and seed, for the large-tau check (~5 min on 2 cores for the four g, two seeds)


def albedo_run(g: float, scale: float = 1.0):
    runs = M.run_g(g, scale, M.SEED)
    mids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    r = M.reduce_runs(runs, np.concatenate([M.ALBEDO, mids]))
    return g, r["ratio"], r["shape"], runs[0].th_edges


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
        shape_err = lambda s: np.where(ok, fit.ring_error(th_edges, s, sd), np.nan)  # noqa: E731
        return dict(shipped=(energy(ri), shape_err(si)), clipped=(energy(ri), shape_err(clipped)),
                    linear=(energy(ri_lin), shape_err(si_lin)))


def far_run(g: float, photons: int, seed: int = M.SEED):
    """The sphere-crossing estimator (apsf_crossing.simulate_far) at the grid taus >= 5 and the
    geometric midpoints between them, the table's albedos and their midpoints: one tally, so
    every midpoint (in albedo and in tau) comes from the same photons as its neighbours."""
    grid = M.TAU[M.TAU >= 5.0]
    taus = np.sort(np.concatenate([grid, np.sqrt(grid[:-1] * grid[1:])]))
    t = crossing.simulate_far(g, taus, photons, seed, r_max=M.R_MAX, rr_order=M.rr_order_for(g))
    r = M.reduce_tally(t, np.concatenate([M.ALBEDO, 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])]))
    return g, r["ratio"], r["shape"], t.th_edges


def tau_errors(ratio, shape, th_edges):
    """Each odd tau (a geometric midpoint) against the runtime's interpolation between its
    neighbours (log ratio and shape linear in log tau: the ratios' geometric mean and the
    shapes' mean), at the grid albedos: (energy, shape, energy with the ratio itself linear in
    log tau, the scheme before) (A, T)."""
    na = len(M.ALBEDO)
    r, s = ratio[:na], shape[:na]
    ri = np.sqrt(r[:, :-2:2] * r[:, 2::2])
    si = 0.5 * (s[:, :-2:2] + s[:, 2::2])
    rd, sd = r[:, 1::2], s[:, 1::2]
    ok = rd > 1e-250
    with np.errstate(divide="ignore", invalid="ignore"):
        rl = 0.5 * (r[:, :-2:2] + r[:, 2::2])
        return (np.where(ok, np.abs(ri / rd - 1), np.nan), np.where(ok, fit.ring_error(th_edges, si, sd), np.nan),
                np.where(ok, np.abs(rl / rd - 1), np.nan))


def curvature_errors(path=ROOT / "src/fogcli/physics/data/apsf.npz"):
    """The shipped table's own midpoint error along tau, from its curvature: between nodes i and
    i + 1 (log-tau step h) linear interpolation misses by h^2 f'' / 8, f'' the three-node second
    derivative in log tau (of the log ratio; of the shape). A wide stencil on the table's full
    photon count: its noise is about 0.3 of one entry's, where the midpoint check above carries
    the noise of three entries of a smaller run. (energy, shape) (G, A, interior taus)."""
    d = np.load(path)
    x = np.log(d["tau"].astype(np.float64))
    h0, h1 = np.diff(x)[:-1], np.diff(x)[1:]
    c = h1 ** 2 / 8 * 2 / (h0 * h1 * (h0 + h1))

    def miss(f):
        return c * (h0 * f[..., 2:] - (h0 + h1) * f[..., 1:-1] + h1 * f[..., :-2])

    ratio = d["ratio"].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = np.where(ratio > 1e-250, np.log(np.maximum(ratio, 1e-300)), np.nan)
        energy = np.abs(np.expm1(miss(lr)))
        w = d["weights"].astype(np.float64)
        s = w / np.maximum(w.sum(-1, keepdims=True), 1e-300)
        ds = np.moveaxis(miss(np.moveaxis(s, -1, 0)), 0, -1)            # (G, A, T - 2, K)
        sm = s[:, :, 1:-1]
        ok = np.isfinite(energy) & (w[:, :, 1:-1].sum(-1) > 0)     # float32 weights underflow before the ratio
        shape = np.where(ok, fit.ring_error(d["theta_edges"].astype(np.float64), sm + ds, sm), np.nan)
    return energy, shape, d["energy"][:, :, 1:-1].astype(np.float64), d["tau"][1:-1], d["albedo"], d["g"]


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
                f[i, k, :nf] = fit.single_scatter(thc[:nf], tv, g, albedo, n=1000)
        W, E, _ = fit.fit_gaussians(te, f)
        sh = W / np.maximum(W.sum(-1, keepdims=True), 1e-300)
        ei = np.exp(0.5 * (np.log(E[0]) + np.log(E[2])))
        out_e.append(np.abs(ei / E[1] - 1))
        out_s.append(fit.ring_error(th_edges, 0.5 * (sh[0] + sh[2]), sh[1]))
    return np.array(out_e), np.array(out_s)


def fmt(x):
    x = np.asarray(x)[np.isfinite(x)]
    pc = lambda v: f"{100 * v:.2f}" if 100 * v < 1000 else f"{100 * v:.1e}"  # noqa: E731
    return f"{pc(np.percentile(x, 90))} / {pc(x.max())}" if x.size else "-"


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
        from docblock import markers, write_block

        begin, end = markers("grid-check")
        block = (f"{begin}\n## Interpolation error of the shipped grid\n\nWritten by `PYTHONPATH=src python "
                 f"tools/apsf_grid_check.py --doc docs/apsf-table.md`.\n\n{text.strip()}\n{end}")
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
    with mp.get_context("spawn").Pool(2) as pool:
        two = pool.starmap(far_run, [(g, FAR_PHOTONS, M.SEED + k) for g in G_CHECK for k in (0, 1)])
    # the two seeds' mean is checked; half their difference at the tau midpoints is its noise
    far = [(a[0], 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2]), a[3]) for a, b in zip(two[::2], two[1::2])]
    with np.errstate(divide="ignore", invalid="ignore"):
        NE = np.stack([np.abs(a[1] - b[1])[:len(M.ALBEDO), 1::2] / (a[1] + b[1])[:len(M.ALBEDO), 1::2]
                       for a, b in zip(two[::2], two[1::2])])
    amids = 0.5 * (M.ALBEDO[:-1] + M.ALBEDO[1:])
    fa = [albedo_errors(ratio[:, ::2], shape[:, ::2], th)["shipped"] for _, ratio, shape, th in far]
    ft = [tau_errors(ratio, shape, th) for _, ratio, shape, th in far]
    FE, FS = np.stack([e for e, _ in fa]), np.stack([s for _, s in fa])     # (g, albedo mids, grid taus >= 5)
    TE, TS, TL = (np.stack([x[i] for x in ft]) for i in range(3))           # (g, grid albedos, tau mids)
    print(f"\n| tau >= 5, sphere-crossing estimator ({FAR_PHOTONS} photons a g, the same photons for a midpoint and "
          "its neighbours; two seeds, their mean checked) | albedo midpoints: energy | shape | tau midpoints: energy | "
          "shape | the same, ratio linear in log tau (the scheme before): energy | noise of the tau midpoints' energy "
          "(se of the mean) |\n|---|---|---|---|---|---|---|")
    for name, am, ag in (("all albedos", amids > 0, M.ALBEDO > 0), ("albedo < 0.3", amids < 0.3, M.ALBEDO < 0.3),
                         ("albedo 0.3-0.8", (amids >= 0.3) & (amids < 0.8), (M.ALBEDO >= 0.3) & (M.ALBEDO < 0.8)),
                         ("albedo >= 0.8", amids >= 0.8, M.ALBEDO >= 0.8)):
        print(f"| {name} | {fmt(FE[:, am])} | {fmt(FS[:, am])} | {fmt(TE[:, ag])} | {fmt(TS[:, ag])} | {fmt(TL[:, ag])} | {fmt(NE[:, ag])} |")
    ce, cs, cen, ctau, calb, cg = curvature_errors()
    far_t = ctau >= 5.0
    print("\n| tau >= 5, the shipped table's curvature (h^2 f''/8 between neighbouring taus, its full photons) | "
          "energy | shape | worst g (energy p90) | energy, weighted by the entries' scattered energy |\n|---|---|---|---|---|")
    for name, am in (("all albedos", calb > 0), ("albedo < 0.3", calb < 0.3), ("albedo 0.3-0.8", (calb >= 0.3) & (calb < 0.8)),
                     ("albedo >= 0.8", calb >= 0.8)):
        E, S, W = ce[:, am][..., far_t], cs[:, am][..., far_t], cen[:, am][..., far_t]
        ok = np.isfinite(E)
        wmean = float((E[ok] * W[ok]).sum() / W[ok].sum())
        p90 = [np.nanpercentile(E[k], 90) if np.isfinite(E[k]).any() else np.nan for k in range(len(cg))]
        kw = int(np.nanargmax(p90))
        print(f"| {name} | {fmt(E)} | {fmt(S)} | g {cg[kw]:g}: {100 * p90[kw]:.2f} | {100 * wmean:.2f} |")
    ge, gs = g_errors(runs[0][3])
    print("\n| g midpoints, single scattering (exact), tau 0.03-0.7 | energy | shape |\n|---|---|---|")
    print(f"| every interval of G | {fmt(ge)} | {fmt(gs)} |")
    worst = int(np.nanargmax(gs.max(-1)))
    print(f"| worst interval {M.G[worst]:g}-{M.G[worst + 1]:g} | {fmt(ge[worst])} | {fmt(gs[worst])} |")


if __name__ == "__main__":
    sys.exit(main())
