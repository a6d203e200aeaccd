"""Interpolation error of the APSF table (src/fogcli/data/apsf.npz), separated from the
Monte Carlo noise, per dimension (albedo, tau, g) and tau range.

    PYTHONPATH=src python benchmarks/apsf_interpolation.py --jobs 2 --doc docs/apsf-table.md
    PYTHONPATH=src python benchmarks/apsf_interpolation.py --analyse-only --doc docs/apsf-table.md

Runs are cached one file each in --cache (default /tmp/apsf_interpolation) and skipped when
present, so a cut-short run can be resumed; --analyse-only renders from whatever is cached
(the report says which runs it used). Cost: 24 MC runs of photons_for(g, 1) photons (the
tau runs score 59 cameras, ~1.6x the table's 75 s per g), an estimated ~45 CPU-min on an
idle core, i.e. ~25 min wall with --jobs 2; plus ~1-2 min for the single-scattering quadrature and the
NNLS reductions. Measured 2026-12-02 (Intel Xeon 2.3 GHz, 2 cores shared with other jobs'
test runs, so each run took 1.5-4x longer than on an idle core): the 24 runs took 36 min wall
(85-466 s each; the g runs in a second process with --part g), the analysis ~1 min more.

What is measured (energy: relative error of the interpolated `ratio`; shape: ring_l1 between
interpolated and direct normalised weights):

* albedo: absorption is applied after the run, so one tally serves every albedo. Each run is
  reduced (`reduce_tally`) at the grid albedos AND at 1/4, 1/2, 3/4 of every albedo interval;
  interpolated-vs-direct then share every photon and differ only by the interpolation (plus
  the NNLS projection of each entry). Checked on 3 seeds: the seed-to-seed spread of the
  error is reported. Interpolation variables compared: linear in a (the runtime's), linear in
  s = (1 - a) / a (absorption per scattering length, the exponent of exp(-s l)) or in sqrt(s)
  (diffusion's attenuation exponent), on the ratio or on log(ratio); the shape on the
  normalised weights, or on ratio * shape (energy weighted) renormalised. Also: the error if
  every albedo interval were halved (its midpoint taken as a node).
* tau: runs with cameras at TAU and at the geometric midpoints (the random stream does not
  depend on the camera list, so the seed-SEED run reproduces the table at the grid taus; this
  is verified), 3 seeds. (a) statistical: per seed the midpoint error from the same run; the
  bias is the mean over seeds, its uncertainty the seed spread / sqrt(n). (b) smoothness: a
  smoothing spline in log tau (residuals at the seed-to-seed noise level) through the seed
  mean of each (g, albedo) row; the midpoint error of linear interpolation of that spline.
  Assumes the truth is no rougher than the smoothest curve the noise allows.
* g: direct runs at interval midpoints of G with the table's seed (correlated photons with the
  table's own runs at both ends) and, for some, another seed; the table at the two ends from
  apsf.npz. The correlation is judged by comparing the same-seed and other-seed errors.
* single scattering by quadrature (`single_scatter`, deterministic): the first order on G and
  its midpoints x TAU and its midpoints, fitted like the table; its g and tau interpolation
  errors are exact (representative of the table at tau < 1 only).
"""
from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import pickle
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "benchmarks"))
import make_apsf_table as M  # noqa: E402
from fogcli import apsf_mc as mc  # noqa: E402

TAU_MID = np.sqrt(M.TAU[:-1] * M.TAU[1:])
TAU2 = np.sort(np.concatenate([M.TAU, TAU_MID]))          # grid at even, midpoints at odd index
FRACS = (0.25, 0.5, 0.75)
A_IN = np.array([a0 + f * (a1 - a0) for a0, a1 in zip(M.ALBEDO[:-1], M.ALBEDO[1:]) for f in FRACS])
ALB2 = np.concatenate([M.ALBEDO, A_IN])                     # grid first, then interior points
G_TAU = (0.0, 0.7, 0.85, 0.92, 0.96)                        # albedo + tau runs
N_SEEDS = 3
RANGES = ((0.0, 1.0), (1.0, 5.0), (5.0, 31.0))
BEGIN, END = "<!-- interpolation -->", "<!-- /interpolation -->"


def job(spec):
    """One MC run, reduced to ratio and shape. spec = (kind, g, seed, scale)."""
    kind, g, seed, scale = spec
    n = M.photons_for(g, scale)
    t0 = time.time()
    if kind == "tau":
        t = M.run_g(g, n, seed, tau=TAU2)
        r = M.reduce_tally(t, ALB2)
    else:
        t = M.run_g(g, n, seed)
        r = M.reduce_tally(t, M.ALBEDO)
    return dict(kind=kind, g=g, seed=seed, photons=n, secs=time.time() - t0,
                ratio=r["ratio"], shape=r["shape"], th_edges=t.th_edges)


def all_specs(scale: float, part: str = "all") -> list:
    """Every run, in the order of their value for the report (what a cut-short run keeps)."""
    tau = [("tau", g, M.SEED + s, scale) for s in range(N_SEEDS) for g in G_TAU]
    g_order = [(0.65, 0), (0.93, 0), (0.65, 1), (0.15, 0), (0.865, 0), (0.93, 1), (0.4, 0),
               (0.775, 0), (0.15, 1)]
    gg = [("g", g, M.SEED + s, scale) for g, s in g_order]
    return {"tau": tau, "g": gg, "all": tau[:len(G_TAU)] + gg + tau[len(G_TAU):]}[part]


def run_all(cache: Path, scale: float, jobs: int, part: str = "all") -> None:
    cache.mkdir(parents=True, exist_ok=True)
    specs = all_specs(scale, part)
    todo = [s for s in specs if not (cache / fname(s)).exists()]
    print(f"{len(todo)} runs to do of {len(specs)}", flush=True)
    t0 = time.time()
    with mp.get_context("spawn").Pool(jobs) as pool:
        for res in pool.imap_unordered(job, todo):
            spec = (res["kind"], res["g"], res["seed"], scale)
            with open(cache / fname(spec), "wb") as fh:
                pickle.dump(res, fh)
            print(f"{fname(spec)}: {res['photons']} photons {res['secs']:.0f} s "
                  f"(elapsed {time.time() - t0:.0f} s)", flush=True)


def fname(spec) -> str:
    kind, g, seed, scale = spec
    return f"{kind}_g{g:g}_s{seed}_x{scale:g}.pkl"



# ---------------------------------------------------------------- analysis helpers

def pct(x, q):
    x = np.asarray(x, np.float64).ravel()
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if len(x) else float("nan")


def stats3(x):
    return pct(x, 50), pct(x, 90), pct(x, 100)


def ring_matrix(th_edges):
    _, u = mc.kernel_bins(th_edges, np.zeros(len(th_edges) - 1))
    return np.diff(mc.gaussian_cdf(u), axis=0)                 # (rings, J)


def l1(ra, rb):
    return np.abs(ra - rb).sum(-1) / np.maximum(rb.sum(-1), 1e-300)


def s_of(a):
    return (1 - np.asarray(a, np.float64)) / np.asarray(a, np.float64)


def load(cache: Path, scale: float) -> dict:
    runs = {}
    for p in sorted(cache.glob(f"*_x{scale:g}.pkl")):
        with open(p, "rb") as fh:
            r = pickle.load(fh)
        runs[(r["kind"], float(r["g"]), int(r["seed"]))] = r
    return runs


def in_range(tau, lo, hi):
    return (tau >= lo) & (tau < hi)


# ---------------------------------------------------------------- albedo

def albedo_weights(var: str):
    """(i0, t) per interior albedo point: the bracketing grid index and the weight in var."""
    i0 = np.repeat(np.arange(len(M.ALBEDO) - 1), len(FRACS))
    a0, a1 = M.ALBEDO[i0], M.ALBEDO[i0 + 1]
    f = {"a": lambda a: a, "s": s_of, "r": lambda a: np.sqrt(s_of(a))}[var]
    return i0, (f(A_IN) - f(a0)) / (f(a1) - f(a0))


def albedo_errors(run, A):
    """Energy errors {scheme: (interior, T)} and shape L1 {scheme: (interior, T)} at the grid
    taus, interpolated from the grid albedos of the same tally vs direct."""
    na = len(M.ALBEDO)
    r = run["ratio"][:, 0::2]
    sh = run["shape"][:, 0::2]
    rg, rd = r[:na], r[na:]
    shg, shd = sh[:na], sh[na:]
    ok = rd > 1e-250
    rings_d = shd @ A.T
    e, s = {}, {}
    for var in ("a", "s", "r"):
        i0, t = albedo_weights(var)
        t_ = t[:, None]
        lin = (1 - t_) * rg[i0] + t_ * rg[i0 + 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            lg = np.exp((1 - t_) * np.log(rg[i0]) + t_ * np.log(rg[i0 + 1]))
            e[var] = np.where(ok, lin / rd - 1, np.nan)
            e[var + ",log"] = np.where(ok, lg / rd - 1, np.nan)
        t3 = t[:, None, None]
        shl = (1 - t3) * shg[i0] + t3 * shg[i0 + 1]
        s[var] = np.where(ok, l1(shl @ A.T, rings_d), np.nan)
        ew = (1 - t3) * (rg[i0][..., None] * shg[i0]) + t3 * (rg[i0 + 1][..., None] * shg[i0 + 1])
        ew = ew / np.maximum(ew.sum(-1, keepdims=True), 1e-300)
        s[var + ",ew"] = np.where(ok, l1(ew @ A.T, rings_d), np.nan)
    return e, s


def albedo_halved(run):
    """Energy error of log ratio linear in sqrt(s) if every albedo interval were halved (its
    midpoint a grid node): at the 1/4 and 3/4 points, from the same tally. (interior, T), NaN
    at the 1/2 points."""
    na = len(M.ALBEDO)
    r = run["ratio"][:, 0::2]
    rd = r[na:]
    out = np.full(rd.shape, np.nan)
    q = np.sqrt(s_of(ALB2))
    for i in range(na - 1):
        lo, mid, hi = i, na + 3 * i + 1, i + 1
        for k, (n0, n1) in ((0, (lo, mid)), (2, (mid, hi))):
            j = na + 3 * i + k
            t = (q[j] - q[n0]) / (q[n1] - q[n0])
            with np.errstate(divide="ignore", invalid="ignore"):
                ri = np.exp((1 - t) * np.log(r[n0]) + t * np.log(r[n1]))
                out[3 * i + k] = np.where(rd[3 * i + k] > 1e-250, np.abs(ri / rd[3 * i + k] - 1), np.nan)
    return out


# ---------------------------------------------------------------- tau

def tau_errors(run, A):
    """Midpoint errors of linear-in-log-tau interpolation within one run, grid albedos:
    energy (ratio linear, log ratio linear) (18, 29), signed ring differences (18, 29, R)."""
    na = len(M.ALBEDO)
    r = run["ratio"][:na]
    rg0, rg1, rm = r[:, 0:-1:2], r[:, 2::2], r[:, 1::2]
    ok = (rm > 1e-250) & (rg0 > 1e-250) & (rg1 > 1e-250)
    with np.errstate(divide="ignore", invalid="ignore"):
        e_lin = np.where(ok, 0.5 * (rg0 + rg1) / rm - 1, np.nan)
        e_log = np.where(ok, np.sqrt(rg0 * rg1) / rm - 1, np.nan)
    R = run["shape"][:na] @ A.T
    D = 0.5 * (R[:, 0:-1:2] + R[:, 2::2]) - R[:, 1::2]
    return e_lin, e_log, D, ok


def spline_errors(runs_g, A):
    """(b): smoothing spline through the seed mean of each grid-albedo row, in log tau, with
    the seed-to-seed spread / sqrt(n) as the point sigma; midpoint errors of linear
    interpolation of the spline (energy: ratio and log ratio; shape: ring L1)."""
    from scipy.interpolate import UnivariateSpline
    na = len(M.ALBEDO)
    x = np.log(TAU2)
    n = len(runs_g)
    lr = np.log(np.maximum(np.stack([r["ratio"][:na] for r in runs_g]), 1e-300))   # (n, 18, 59)
    rings = np.stack([r["shape"][:na] @ A.T for r in runs_g])                      # (n, 18, 59, R)
    e_lin = np.full((na, len(TAU_MID)), np.nan)
    e_log = np.full_like(e_lin, np.nan)
    s_l1 = np.full_like(e_lin, np.nan)

    xq = np.log(np.sqrt(TAU2[:-1] * TAU2[1:]))                # midpoints of the halved grid
    e_half = np.full((na, len(xq)), np.nan)

    def smooth(y, sig, at=None):
        sig = np.maximum(sig, max(0.3 * float(np.median(sig)), 1e-6))
        sp = UnivariateSpline(x, y, w=1 / sig, k=3, s=len(x))
        return sp(x) if at is None else (sp(x), sp(at))

    for ia in range(na):
        if (lr[:, ia] < -600).any():
            ok_t = ~(lr[:, ia] < -600).any(0)
        else:
            ok_t = np.ones(len(x), bool)
        if ok_t.all():
            ys, yq = smooth(lr[:, ia].mean(0), lr[:, ia].std(0, ddof=1) / math.sqrt(n), xq)
            e_half[ia] = 0.5 * (np.exp(ys[:-1] - yq) + np.exp(ys[1:] - yq)) - 1
            g0, g1, m = ys[0:-1:2], ys[2::2], ys[1::2]
            e_lin[ia] = 0.5 * (np.exp(g0 - m) + np.exp(g1 - m)) - 1
            e_log[ia] = np.exp(0.5 * (g0 + g1) - m) - 1
        rm = rings[:, ia].mean(0)                      # (59, R)
        rs = rings[:, ia].std(0, ddof=1) / math.sqrt(n)
        fit = np.empty_like(rm)
        for j in range(rm.shape[1]):
            if rm[:, j].max() < 1e-12:
                fit[:, j] = rm[:, j]
            else:
                fit[:, j] = smooth(rm[:, j], rs[:, j])
        fit = np.maximum(fit, 0)
        D = 0.5 * (fit[0:-1:2] + fit[2::2]) - fit[1::2]
        s_l1[ia] = np.abs(D).sum(-1) / np.maximum(fit[1::2].sum(-1), 1e-300)
        s_l1[ia, ~(ok_t[0:-1:2] & ok_t[1::2] & ok_t[2::2])] = np.nan
    return e_lin, e_log, s_l1, e_half


# ---------------------------------------------------------------- g

def g_table():
    z = np.load(ROOT / "src/fogcli/data/apsf.npz")
    w = np.asarray(z["weights"], np.float64)
    ws = w.sum(-1)
    return dict(ratio=np.asarray(z["ratio"], np.float64),
                shape=w / np.maximum(ws, 1e-300)[..., None], ok=ws > 1e-30)


def g_errors(tab, run, A, var="g", log=False):
    gm = run["g"]
    i = int(np.searchsorted(M.G, gm) - 1)
    g0, g1 = M.G[i], M.G[i + 1]
    if var == "g":
        t = (gm - g0) / (g1 - g0)
    else:                                   # linear in log(1 - g)
        t = (math.log(1 - gm) - math.log(1 - g0)) / (math.log(1 - g1) - math.log(1 - g0))
    r0, r1 = tab["ratio"][i], tab["ratio"][i + 1]
    rd = run["ratio"]
    ok = tab["ok"][i] & tab["ok"][i + 1] & (rd > 1e-250) & (r0 > 1e-30) & (r1 > 1e-30)
    with np.errstate(divide="ignore", invalid="ignore"):
        ri = np.exp((1 - t) * np.log(r0) + t * np.log(r1)) if log else (1 - t) * r0 + t * r1
        e = np.where(ok, ri / rd - 1, np.nan)
    shi = (1 - t) * tab["shape"][i] + t * tab["shape"][i + 1]
    s = np.where(ok, l1(shi @ A.T, run["shape"] @ A.T), np.nan)
    return e, s, ok




# ---------------------------------------------------------------- single scattering (no noise)

SS_ALB = (1.0, 0.8)


def ss_grid(th_edges, n=1000):
    """Single-scattering ratio and shape by quadrature (`single_scatter`, deterministic) on
    (G and its interval midpoints) x SS_ALB x TAU2: a noise-free function with the structure
    of the table's first order, which is most of the table at small tau."""
    g_all = np.sort(np.concatenate([M.G, 0.5 * (M.G[:-1] + M.G[1:])]))
    te = np.asarray(th_edges, np.float64)
    nf = int(np.searchsorted(te, math.pi / 2 + 1e-12))
    thc = np.sqrt(te[:-1] * te[1:])
    thc[0] = te[1] / 2
    f = np.zeros((len(g_all), len(SS_ALB), len(TAU2), len(te) - 1))
    for ig, g in enumerate(g_all):
        for ia, a in enumerate(SS_ALB):
            for it, tv in enumerate(TAU2):
                f[ig, ia, it, :nf] = mc.single_scatter(thc[:nf], tv, g, a, n=n)
    W, E, _ = mc.fit_gaussians(te, f)
    thin = np.exp(-np.outer(s_of(SS_ALB), TAU2)) * -np.expm1(-TAU2)[None, :]
    return dict(g=g_all, ratio=E / thin[None], shape=W / np.maximum(W.sum(-1, keepdims=True), 1e-300))


def ss_errors(ss, A):
    """Noise-free interpolation errors of the single-scattering part: along g (at grid taus,
    g midpoints from their neighbours, four schemes) and along tau (at grid g, tau midpoints).
    Returns dict of arrays (..., T) for energy and shape."""
    out = {}
    R, S = ss["ratio"], ss["shape"]
    ge, gi = slice(0, None, 2), slice(1, None, 2)                # grid g, midpoint g
    g0, g1, gm = ss["g"][0:-1:2], ss["g"][2::2], ss["g"][1::2]
    for var in ("g", "lg"):
        if var == "g":
            t = (gm - g0) / (g1 - g0)
        else:
            t = (np.log(1 - gm) - np.log(1 - g0)) / (np.log(1 - g1) - np.log(1 - g0))
        t_ = t[:, None, None]
        r0, r1, rd = R[0:-1:2][..., 0::2], R[2::2][..., 0::2], R[gi][..., 0::2]
        out[("g", var, "lin")] = ((1 - t_) * r0 + t_ * r1) / rd - 1
        out[("g", var, "log")] = np.exp((1 - t_) * np.log(r0) + t_ * np.log(r1)) / rd - 1
        t4 = t_[..., None]
        shi = (1 - t4) * S[0:-1:2][..., 0::2, :] + t4 * S[2::2][..., 0::2, :]
        out[("g", var, "shape")] = l1(shi @ A.T, S[gi][..., 0::2, :] @ A.T)
    Rg, Sg = R[ge], S[ge]
    out[("tau", "lin")] = 0.5 * (Rg[..., 0:-1:2] + Rg[..., 2::2]) / Rg[..., 1::2] - 1
    out[("tau", "log")] = np.sqrt(Rg[..., 0:-1:2] * Rg[..., 2::2]) / Rg[..., 1::2] - 1
    shi = 0.5 * (Sg[..., 0:-1:2, :] + Sg[..., 2::2, :])
    out[("tau", "shape")] = l1(shi @ A.T, Sg[..., 1::2, :] @ A.T)
    return out


# ---------------------------------------------------------------- report

def row3(x, fmt="{:.3f}"):
    return " | ".join(fmt.format(v) for v in stats3(x))


def analyse(runs: dict, scale: float, wall: float | None, ssq: dict | None = None) -> str:
    some = next(iter(runs.values()))
    A = ring_matrix(some["th_edges"])
    L = []
    P = L.append
    tau_g = sorted({g for k, g, s in runs if k == "tau"})
    seeds = sorted({s for k, g, s in runs if k == "tau"})
    secs = sum(r["secs"] for r in runs.values())
    P("## Interpolation error, separated from the Monte Carlo noise")
    P("")
    P("Generated by `PYTHONPATH=src python benchmarks/apsf_interpolation.py --jobs 2 --doc docs/apsf-table.md` "
      f"({len(runs)} runs, photons x {scale:g} of the table's, run times summed {secs / 60:.0f} min"
      + (f", {wall / 60:.0f} min wall on 2 cores" if wall else "") + "). "
      "Energy: |interpolated ratio / direct - 1|; shape: ring L1 between the interpolated and the "
      "direct normalised weights (`ring_l1`). Tau ranges: [0.01, 1), [1, 5), [5, 30].")
    P("")

    # ---- albedo
    K = {}                                   # key numbers for the summary at the top
    n_intro = len(L)
    P("### Albedo: one tally, interpolated vs direct")
    P("")
    P(f"Absorption is applied after the run, so every run is reduced at the 18 grid albedos and at "
      f"1/4, 1/2, 3/4 of each interval (51 points) from the same photons: the difference is the "
      f"interpolation (and the NNLS projection of each entry), not MC noise. g = "
      f"{', '.join(f'{g:g}' for g in tau_g)}, seed {M.SEED} (the table's photons), grid taus, "
      "pooled over g. Schemes: variable a (runtime), s = (1 - a) / a or sqrt(s) (diffusion: the "
      "attenuation exponent goes like sqrt(3 (1 - g) s) for small s), on the ratio or on "
      "log(ratio); shape on the normalised weights or energy-weighted (ratio x shape, renormalised).")
    P("")
    ea, sa_, spread_e, spread_s = {}, {}, {}, {}
    per_seed = {}
    for g in tau_g:
        for sd in seeds:
            if ("tau", g, sd) in runs:
                per_seed[(g, sd)] = albedo_errors(runs[("tau", g, sd)], A)
    for sch in ("a", "s", "a,log", "s,log", "r,log"):
        ea[sch] = np.stack([np.abs(per_seed[(g, M.SEED)][0][sch]) for g in tau_g])
    for sch in ("a", "s", "r", "r,ew"):
        sa_[sch] = np.stack([per_seed[(g, M.SEED)][1][sch] for g in tau_g])
    # noise of the albedo error itself: spread over seeds
    for sch in ("a", "r,log"):
        stk = [np.stack([per_seed[(g, sd)][0][sch] for sd in seeds if (g, sd) in per_seed]) for g in tau_g]
        spread_e[sch] = np.stack([x.std(0, ddof=1) if len(x) > 1 else np.full(x.shape[1:], np.nan) for x in stk])
    for sch in ("a", "r"):
        stk = [np.stack([per_seed[(g, sd)][1][sch] for sd in seeds if (g, sd) in per_seed]) for g in tau_g]
        spread_s[sch] = np.stack([x.std(0, ddof=1) if len(x) > 1 else np.full(x.shape[1:], np.nan) for x in stk])
    hi_a = A_IN >= 0.8
    P("| energy scheme | tau range | median | p90 | max | a >= 0.8: p90 | max |")
    P("|---|---|---|---|---|---|---|")
    names = {"a": "ratio linear in a (now)", "s": "ratio linear in s", "a,log": "log ratio linear in a",
             "s,log": "log ratio linear in s", "r,log": "log ratio linear in sqrt(s)"}
    for sch in ("a", "s", "a,log", "s,log", "r,log"):
        for lo, hi in RANGES:
            sel = in_range(M.TAU, lo, hi)
            x = ea[sch][:, :, sel]
            P(f"| {names[sch]} | [{lo:g}, {hi:g}) | {row3(x)} | {pct(x[:, hi_a], 90):.3f} | {pct(x[:, hi_a], 100):.3f} |")
    P("")
    P("| shape scheme | tau range | median | p90 | max | a >= 0.8: p90 | max |")
    P("|---|---|---|---|---|---|---|")
    names = {"a": "weights linear in a (now)", "s": "weights linear in s",
             "r": "weights linear in sqrt(s)", "r,ew": "ratio x weights linear in sqrt(s)"}
    for sch in ("a", "s", "r", "r,ew"):
        for lo, hi in RANGES:
            sel = in_range(M.TAU, lo, hi)
            x = sa_[sch][:, :, sel]
            P(f"| {names[sch]} | [{lo:g}, {hi:g}) | {row3(x)} | {pct(x[:, hi_a], 90):.3f} | {pct(x[:, hi_a], 100):.3f} |")
    P("")
    if len(seeds) > 1:
        P(f"Noise of these errors: standard deviation over the {len(seeds)} seeds of the same point's "
          "error, median / p90 per tau range (energy: now / log ratio in sqrt(s); shape: now / weights in sqrt(s)):")
        P("")
        P("| tau range | energy now | energy log-sqrt(s) | shape now | shape sqrt(s) |")
        P("|---|---|---|---|---|")
        for lo, hi in RANGES:
            sel = in_range(M.TAU, lo, hi)
            c = [f"{pct(d[:, :, sel], 50):.4f} / {pct(d[:, :, sel], 90):.4f}"
                 for d in (spread_e["a"], spread_e["r,log"], spread_s["a"], spread_s["r"])]
            P(f"| [{lo:g}, {hi:g}) | " + " | ".join(c) + " |")
        P("")
    P("Per g, max over the interior albedo points, now -> recommended (energy: log ratio linear in "
      "sqrt(s); shape: weights linear in sqrt(s)):")
    P("")
    P("| g | energy tau < 1 | energy tau 1-5 | energy tau < 5, a >= 0.5 | energy tau >= 5, a >= 0.8 | "
      "shape tau < 1 | shape tau 1-5 | shape tau < 5, a >= 0.5 |")
    P("|---|---|---|---|---|---|---|---|")
    t1, t15, lt5, ge5 = M.TAU < 1, (M.TAU >= 1) & (M.TAU < 5), M.TAU < 5, M.TAU >= 5
    a5, a8 = A_IN >= 0.5, A_IN >= 0.8

    def mx(x, asel, tsel):
        return float(np.nanmax(x[asel][:, tsel]))

    every = np.ones(len(A_IN), bool)
    for ig, g in enumerate(tau_g):
        cells = []
        for d_now, d_new, cuts in ((ea["a"], ea["r,log"], ((every, t1), (every, t15), (a5, lt5), (a8, ge5))),
                                   (sa_["a"], sa_["r"], ((every, t1), (every, t15), (a5, lt5)))):
            for asel, tsel in cuts:
                cells.append(f"{mx(d_now[ig], asel, tsel):.3f} -> {mx(d_new[ig], asel, tsel):.3f}")
        P(f"| {g:g} | " + " | ".join(cells) + " |")
    P("")
    for lo, hi in RANGES:
        sel = in_range(M.TAU, lo, hi)
        for key, d in (("now", ea["a"]), ("new", ea["r,log"])):
            K[("alb", "e", key, lo)] = (pct(d[:, :, sel], 90), pct(d[:, :, sel], 100),
                                       pct(d[:, a8][:, :, sel], 90), pct(d[:, a8][:, :, sel], 100))
        for key, d in (("now", sa_["a"]), ("new", sa_["r"])):
            K[("alb", "s", key, lo)] = (pct(d[:, :, sel], 90), pct(d[:, :, sel], 100),
                                       pct(d[:, a8][:, :, sel], 90), pct(d[:, a8][:, :, sel], 100))
    # per albedo interval (which intervals fail), best scheme
    P("Per albedo interval (max over g, tau < 5, the three interior points), energy now / log ratio "
      "in sqrt(s), shape now / weights in sqrt(s):")
    P("")
    P("| interval | " + " | ".join(f"{M.ALBEDO[i]:g}-{M.ALBEDO[i + 1]:g}" for i in range(len(M.ALBEDO) - 1)) + " |")
    P("|---|" + "---|" * (len(M.ALBEDO) - 1))
    halved = np.stack([albedo_halved(runs[("tau", g, M.SEED)]) for g in tau_g])
    for lab, d in (("energy now", ea["a"]), ("energy log-sqrt(s)", ea["r,log"]),
                   ("energy log-sqrt(s), interval halved", halved), ("shape now", sa_["a"]),
                   ("shape sqrt(s)", sa_["r"])):
        cells = []
        for i in range(len(M.ALBEDO) - 1):
            cells.append(f"{np.nanmax(d[:, 3 * i:3 * i + 3][:, :, lt5]):.3f}")
        P(f"| {lab} | " + " | ".join(cells) + " |")
    P("")

    # ---- tau
    P("### Tau: midpoints in the same runs, several seeds")
    P("")
    rep = []
    tab = np.load(ROOT / "src/fogcli/data/apsf.npz")
    for g in tau_g:
        if ("tau", g, M.SEED) in runs:
            ig = int(np.argmin(np.abs(M.G - g)))
            mine = runs[("tau", g, M.SEED)]["ratio"][:len(M.ALBEDO), 0::2]
            ref = np.asarray(tab["ratio"][ig], np.float64)
            ok = ref > 1e-30
            rep.append(float(np.max(np.abs(mine[ok] / ref[ok] - 1))))
    P(f"Runs with cameras at the 30 grid taus and the 29 geometric midpoints, seeds "
      f"{', '.join(map(str, seeds))}, g = {', '.join(f'{g:g}' for g in tau_g)}, grid albedos. The random "
      f"stream does not depend on the cameras: at the grid taus the seed-{M.SEED} runs reproduce "
      f"apsf.npz to {max(rep):.1e} (max relative difference of the ratio, float32 storage). "
      "(a) Statistical: per seed, interpolated (neighbours' mean, i.e. linear in log tau) vs the "
      "midpoint camera of the same run; the bias is the mean over seeds, se = seed spread / "
      "sqrt(n). Unbiased whatever the noise, but the noise of adjacent cameras is only partly "
      "shared, so the bias estimate carries se. (b) Smoothness: a cubic smoothing spline in "
      "log tau through the seed mean of each row (log ratio; each ring energy for the shape), "
      "chi^2 = number of points with the seed spread / sqrt(n) as sigma; the interpolation error "
      "of that spline at the midpoints. Assumes the truth is as smooth as the smoothest curve "
      "the noise allows; a feature narrower than the grid spacing and hidden by the noise "
      "would be missed.")
    P("")
    have = {g: [sd for sd in seeds if ("tau", g, sd) in runs] for g in tau_g}
    tg2 = [g for g in tau_g if len(have[g]) >= 2] or tau_g
    n = min(len(have[g]) for g in tg2)
    E_lin, E_log, Dd = [], [], []
    for g in tg2:
        per = [tau_errors(runs[("tau", g, sd)], A) for sd in have[g][:n]]
        E_lin.append(np.stack([p[0] for p in per]))
        E_log.append(np.stack([p[1] for p in per]))
        Dd.append(np.stack([p[2] for p in per]))
    E_lin, E_log, Dd = np.stack(E_lin), np.stack(E_log), np.stack(Dd)     # (G, S, 18, 29[, R])
    dd = max(n - 1, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        b_lin, se_lin = E_lin.mean(1), E_lin.std(1, ddof=dd) / math.sqrt(n) if n > 1 else np.nan * E_lin[:, 0]
        b_log, se_log = E_log.mean(1), E_log.std(1, ddof=dd) / math.sqrt(n) if n > 1 else np.nan * E_log[:, 0]
        Db = Dd.mean(1)
        sb = np.abs(Db).sum(-1)                  # the rings of a normalised shape sum to 1
        sse = (Dd.std(1, ddof=dd) / math.sqrt(n)).sum(-1) if n > 1 else np.nan * sb
    s_seed = np.abs(Dd).sum(-1)                                            # per-seed L1 (G, S, 18, 29)
    if n > 1 and tg2 != tau_g:
        P(f"(Runs with several seeds: g = {', '.join(f'{g:g}' for g in tg2)}.)")
        P("")
    P(f"(a) energy, |bias| and se over {n} seeds, all grid albedos and the {len(tg2)} g; "
      "share of points with |bias| > 2 se:")
    P("")
    P("| variable | tau range | \\|bias\\| median | p90 | max | se median | p90 | share > 2 se | single seed \\|e\\| p90 | a >= 0.8: \\|bias\\| p90 | max |")
    P("|---|---|---|---|---|---|---|---|---|---|---|")
    for lab, b, se, E in (("ratio (now)", b_lin, se_lin, E_lin), ("log ratio", b_log, se_log, E_log)):
        for lo, hi in RANGES:
            sel = in_range(TAU_MID, lo, hi)
            bb, ss = np.abs(b[..., sel]), se[..., sel]
            fin = np.isfinite(bb) & np.isfinite(ss)
            share = float(np.mean(bb[fin] > 2 * ss[fin])) if fin.any() else float("nan")
            K[("tau_a", lab, lo)] = (pct(bb, 90), pct(ss, 90), pct(bb[:, M.ALBEDO >= 0.8], 90))
            P(f"| {lab} | [{lo:g}, {hi:g}) | {row3(bb)} | {pct(ss, 50):.3f} | {pct(ss, 90):.3f} | "
              f"{share:.2f} | {pct(np.abs(E[..., sel]), 90):.3f} | {pct(bb[:, M.ALBEDO >= 0.8], 90):.3f} | "
              f"{pct(bb[:, M.ALBEDO >= 0.8], 100):.3f} |")
    P("")
    P("(a) shape: L1 of the seed-mean signed ring difference (bias + noise / sqrt(n)), and the L1 "
      "of the ring-wise se (its noise floor; pure noise would give about 0.8 x that):")
    P("")
    P("| tau range | bias L1 median | p90 | max | se L1 median | p90 | single seed L1 p90 |")
    P("|---|---|---|---|---|---|---|")
    for lo, hi in RANGES:
        sel = in_range(TAU_MID, lo, hi)
        P(f"| [{lo:g}, {hi:g}) | {row3(sb[..., sel])} | {pct(sse[..., sel], 50):.3f} | "
          f"{pct(sse[..., sel], 90):.3f} | {pct(s_seed[..., sel], 90):.3f} |")
    P("")
    if n > 1:
        SP = [spline_errors([runs[("tau", g, sd)] for sd in have[g][:n]], A) for g in tg2]
        se_lin_b = np.stack([x[0] for x in SP])
        se_log_b = np.stack([x[1] for x in SP])
        ss_b = np.stack([x[2] for x in SP])
        eh_b = np.stack([x[3] for x in SP])
        tq = np.sqrt(TAU2[:-1] * TAU2[1:])
        P("(b) smoothing spline, midpoint error of linear interpolation in log tau of the spline:")
        P("")
        P("| tau range | energy: ratio median | p90 | max | log ratio median | p90 | max | shape median | p90 | max |")
        P("|---|---|---|---|---|---|---|---|---|---|")
        for lo, hi in RANGES:
            sel = in_range(TAU_MID, lo, hi)
            P(f"| [{lo:g}, {hi:g}) | {row3(np.abs(se_lin_b[..., sel]))} | {row3(np.abs(se_log_b[..., sel]))} | "
              f"{row3(ss_b[..., sel])} |")
        P("")
        P("(b) for albedo >= 0.8 only; last three columns: the energy (ratio linear in log tau) if the "
          "tau step were halved (59 grid taus), from the same splines:")
        P("")
        P("| tau range | energy: ratio median | p90 | max | log ratio median | p90 | max | shape median | p90 | max "
          "| halved step: energy median | p90 | max |")
        P("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        ha = M.ALBEDO >= 0.8
        for lo, hi in RANGES:
            sel = in_range(TAU_MID, lo, hi)
            selq = in_range(tq, lo, hi)
            K[("tau_half", lo)] = (pct(np.abs(eh_b[:, ha][..., selq]), 90), pct(np.abs(eh_b[:, ha][..., selq]), 100))
            K[("tau_b", lo)] = (pct(np.abs(se_lin_b[:, ha][..., sel]), 90), pct(np.abs(se_lin_b[:, ha][..., sel]), 100),
                                pct(ss_b[:, ha][..., sel], 90), pct(ss_b[:, ha][..., sel], 100),
                                pct(np.abs(se_log_b[:, ha][..., sel]), 90), pct(np.abs(se_log_b[:, ha][..., sel]), 100))
            P(f"| [{lo:g}, {hi:g}) | {row3(np.abs(se_lin_b[:, ha][..., sel]))} | "
              f"{row3(np.abs(se_log_b[:, ha][..., sel]))} | {row3(ss_b[:, ha][..., sel])} | "
              f"{row3(np.abs(eh_b[:, ha][..., selq]))} |")
        P("")

    # ---- single scattering, exact
    if ssq is not None:
        so = ss_errors(ssq, A)
        P("### Single scattering by quadrature: no noise at all")
        P("")
        P("The first scattering order from `single_scatter` (deterministic quadrature, 1000 nodes), "
          "projected on the Gaussians with `fit_gaussians` like the table, on G and its 12 interval "
          f"midpoints x albedo {', '.join(f'{a:g}' for a in SS_ALB)} x the 30 grid taus and their "
          "midpoints. Its interpolation error is computed exactly. It stands for the table where "
          "single scattering is most of the light (tau << 1; at tau 0.1 multiple scattering is already "
          "~10 % of it); beyond tau ~ 1 it is not representative (the single-scattering ratio falls "
          "like exp(-tau), the full ratio grows), so only tau < 1 is shown.")
        P("")
        P("| dimension | scheme | tau range | energy median | p90 | max | shape median | p90 | max |")
        P("|---|---|---|---|---|---|---|---|---|")
        for lo, hi in ((0.0, 0.1), (0.1, 1.0)):
            for lab, sch, ke, ks, tg in (
                    ("g", "ratio linear in g (now)", ("g", "g", "lin"), ("g", "g", "shape"), M.TAU),
                    ("g", "log ratio linear in g", ("g", "g", "log"), None, M.TAU),
                    ("g", "ratio / weights linear in log(1 - g)", ("g", "lg", "lin"), ("g", "lg", "shape"), M.TAU),
                    ("tau", "ratio linear in log tau (now)", ("tau", "lin"), ("tau", "shape"), TAU_MID),
                    ("tau", "log ratio linear in log tau", ("tau", "log"), None, TAU_MID)):
                sel = in_range(tg, lo, hi)
                sh = row3(so[ks][..., sel]) if ks else "- | - | -"
                P(f"| {lab} | {sch} | [{lo:g}, {hi:g}) | {row3(np.abs(so[ke][..., sel]))} | {sh} |")
        P("")
        K["ss"] = (float(np.abs(so[("tau", "lin")][..., TAU_MID < 1]).max()),
                   float(so[("tau", "shape")][..., TAU_MID < 1].max()),
                   float(np.abs(so[("g", "g", "lin")][..., M.TAU < 1]).max()),
                   float(so[("g", "g", "shape")][..., M.TAU < 1].max()))
        worst = np.abs(so[("g", "g", "lin")][..., M.TAU < 1]).max(axis=(1, 2))
        worst_s = so[("g", "g", "shape")][..., M.TAU < 1].max(axis=(1, 2))
        P("Per g interval (tau < 1, max), energy / shape, linear in g: " + "; ".join(
            f"{a:g}-{b:g}: {e:.3f} / {w:.3f}" for a, b, e, w in zip(M.G[:-1], M.G[1:], worst, worst_s)) + ".")
        P("")

    # ---- g
    gm = sorted({g for k, g, s in runs if k == "g"})
    if gm:
        P("### g: direct runs at interval midpoints")
        P("")
        tabg = g_table()
        P(f"Direct runs at g = {', '.join(f'{g:g}' for g in gm)} (midpoints of G intervals) with the "
          f"table's seed {M.SEED} and photon counts, compared with the table interpolated linearly in g "
          "from apsf.npz (grid albedos, grid taus; entries whose float32 weights underflow are left "
          "out). Same seed: the photons start identically (emission, first path, first scattering "
          "draws), so the noise is partly shared with the table's runs at both ends; the rows "
          f"'other seed' (seed {M.SEED + 1}) show the same comparison without that correlation.")
        P("")
        P("| g | seed | tau range | energy median | p90 | max | a >= 0.8: p90 | max | shape median | p90 | max |")
        P("|---|---|---|---|---|---|---|---|---|---|---|")
        for g in gm:
            for sd in (M.SEED, M.SEED + 1):
                if ("g", g, sd) not in runs:
                    continue
                e, s, ok = g_errors(tabg, runs[("g", g, sd)], A)
                for lo, hi in RANGES:
                    sel = in_range(M.TAU, lo, hi)
                    P(f"| {g:g} | {'same' if sd == M.SEED else 'other'} | [{lo:g}, {hi:g}) | "
                      f"{row3(np.abs(e[:, sel]))} | {pct(np.abs(e[M.ALBEDO >= 0.8][:, sel]), 90):.3f} | "
                      f"{pct(np.abs(e[M.ALBEDO >= 0.8][:, sel]), 100):.3f} | {row3(s[:, sel])} |")
        P("")
        both = [g for g in gm if ("g", g, M.SEED) in runs and ("g", g, M.SEED + 1) in runs]
        if both:
            P("Correlation check: the noise of one direct run, |R(seed) / R(other seed) - 1| / sqrt(2) "
              "(energy) and ring L1 / sqrt(2) (shape), against the same-seed interpolation error above; "
              "a same-seed error well below this noise means the shared photons cancel most of it:")
            P("")
            P("| g | tau range | run noise energy median | p90 | same-seed error median | p90 | other-seed median | p90 | run noise shape median | same-seed shape median |")
            P("|---|---|---|---|---|---|---|---|---|---|")
            for g in both:
                r1, r2 = runs[("g", g, M.SEED)], runs[("g", g, M.SEED + 1)]
                with np.errstate(divide="ignore", invalid="ignore"):
                    nz = np.abs(r1["ratio"] / r2["ratio"] - 1) / math.sqrt(2)
                ns = l1(r1["shape"] @ A.T, r2["shape"] @ A.T) / math.sqrt(2)
                e1, s1, ok = g_errors(tabg, r1, A)
                e2, _, _ = g_errors(tabg, r2, A)
                nz = np.where(ok, nz, np.nan)
                ns = np.where(ok, ns, np.nan)
                for lo, hi in RANGES:
                    sel = in_range(M.TAU, lo, hi)
                    P(f"| {g:g} | [{lo:g}, {hi:g}) | {pct(nz[:, sel], 50):.3f} | {pct(nz[:, sel], 90):.3f} | "
                      f"{pct(np.abs(e1[:, sel]), 50):.3f} | {pct(np.abs(e1[:, sel]), 90):.3f} | "
                      f"{pct(np.abs(e2[:, sel]), 50):.3f} | {pct(np.abs(e2[:, sel]), 90):.3f} | "
                      f"{pct(ns[:, sel], 50):.3f} | {pct(s1[:, sel], 50):.3f} |")
            P("")
        P("Same seed, pooled over the midpoints, by interpolation variable (energy p90 / max; shape p90 / max):")
        P("")
        P("| variable | tau range | energy p90 | max | shape p90 | max |")
        P("|---|---|---|---|---|---|")
        for lab, var, lg in (("ratio, g (now)", "g", False), ("ratio, log(1 - g)", "lg", False),
                             ("log ratio, g", "g", True), ("log ratio, log(1 - g)", "lg", True)):
            es, ss = [], []
            for g in gm:
                if ("g", g, M.SEED) in runs:
                    e, s, ok = g_errors(tabg, runs[("g", g, M.SEED)], A, var, lg)
                    es.append(np.abs(e))
                    ss.append(s)
            es, ss = np.stack(es), np.stack(ss)
            for lo, hi in RANGES:
                sel = in_range(M.TAU, lo, hi)
                P(f"| {lab} | [{lo:g}, {hi:g}) | {pct(es[..., sel], 90):.3f} | {pct(es[..., sel], 100):.3f} | "
                  f"{pct(ss[..., sel], 90):.3f} | {pct(ss[..., sel], 100):.3f} |")
        P("")
    # ---- summary, at the top
    S = ["### Summary", ""]
    if ("alb", "e", "now", 0.0) in K:
        f = lambda k: " / ".join(f"{100 * v:.1f}" for v in K[k][:2])          # noqa: E731
        f8 = lambda k: " / ".join(f"{100 * v:.1f}" for v in K[k][2:])         # noqa: E731
        S.append("* Albedo (noise-free, same tally), p90 / max in %, tau < 1 | 1-5 | 5-30: energy now "
                 + " | ".join(f(("alb", "e", "now", lo)) for lo, _ in RANGES) + "; with log(ratio) linear in "
                 "sqrt(s), s = (1 - a) / a: " + " | ".join(f(("alb", "e", "new", lo)) for lo, _ in RANGES)
                 + ". Albedo >= 0.8 only: now " + " | ".join(f8(("alb", "e", "now", lo)) for lo, _ in RANGES)
                 + "; sqrt(s): " + " | ".join(f8(("alb", "e", "new", lo)) for lo, _ in RANGES)
                 + ". Shape now " + " | ".join(f(("alb", "s", "now", lo)) for lo, _ in RANGES)
                 + "; weights linear in sqrt(s) " + " | ".join(f(("alb", "s", "new", lo)) for lo, _ in RANGES)
                 + " (a >= 0.8: " + " | ".join(f8(("alb", "s", "new", lo)) for lo, _ in RANGES) + ").")
    if "ss" in K:
        S.append(f"* Single scattering by quadrature (exact, tau < 1): tau interpolation max {100 * K['ss'][0]:.1f} % "
                 f"energy, {100 * K['ss'][1]:.2f} % shape; g interpolation max {100 * K['ss'][2]:.1f} % energy, "
                 f"{100 * K['ss'][3]:.1f} % shape.")
    if ("tau_b", 0.0) in K:
        S.append("* Tau, smoothing-spline estimate, albedo >= 0.8, tau < 1 | 1-5 | 5-30, in %: energy (ratio "
                 "linear in log tau, now) p90 / max "
                 + " | ".join(" / ".join(f"{100 * v:.1f}" for v in K[("tau_b", lo)][:2]) for lo, _ in RANGES)
                 + "; log ratio linear in log tau "
                 + " | ".join(" / ".join(f"{100 * v:.1f}" for v in K[("tau_b", lo)][4:6]) for lo, _ in RANGES)
                 + "; shape p90 / max "
                 + " | ".join(" / ".join(f"{100 * v:.1f}" for v in K[("tau_b", lo)][2:4]) for lo, _ in RANGES)
                 + "; energy with the tau step halved "
                 + " | ".join(" / ".join(f"{100 * v:.1f}" for v in K[("tau_half", lo)]) for lo, _ in RANGES)
                 + ". Statistical estimate (same-run midpoints), energy |bias| p90 / se p90 in %: "
                 + " | ".join(" / ".join(f"{100 * v:.1f}" for v in K[("tau_a", "ratio (now)", lo)][:2]) for lo, _ in RANGES)
                 + ".")
    S.append("")
    L[n_intro:n_intro] = S
    return "\n".join(L)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="photons x photons_for(g, 1)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", default="/tmp/apsf_interpolation")
    ap.add_argument("--analyse-only", action="store_true")
    ap.add_argument("--doc", default=None)
    ap.add_argument("--part", choices=("all", "tau", "g"), default="all", help="which runs")
    args = ap.parse_args(argv)
    cache = Path(args.cache)
    t0 = time.time()
    if not args.analyse_only:
        run_all(cache, args.scale, args.jobs, args.part)
    wall = time.time() - t0 if not args.analyse_only else None
    print(f"runs {time.time() - t0:.0f} s", flush=True)
    runs = load(cache, args.scale)
    ssf = cache / "single_scatter.pkl"
    if ssf.exists():
        with open(ssf, "rb") as fh:
            ss = pickle.load(fh)
    else:
        t1 = time.time()
        ss = ss_grid(next(iter(runs.values()))["th_edges"])
        print(f"single scattering {time.time() - t1:.0f} s", flush=True)
        with open(ssf, "wb") as fh:
            pickle.dump(ss, fh)
    block = analyse(runs, args.scale, wall, ss)
    print(block)
    if args.doc:
        from docblock import write_block
        write_block(Path(args.doc), BEGIN, END, BEGIN + "\n" + block + "\n" + END)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
