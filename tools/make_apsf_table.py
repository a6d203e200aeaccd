"""Build the multiple-scattering point-spread table src/fogcli/physics/data/apsf.npz with the Monte
Carlo of tools/apsf_mc.py, and write docs/apsf-table.md (every number in it comes from this run).

    PYTHONPATH=src python tools/make_apsf_table.py            # full table + checks, ~20 min on 2 cores
    PYTHONPATH=src python tools/make_apsf_table.py --quick    # 1/20 of the photons, no file

One simulation per g serves every tau (cameras at all distances at once) and every albedo
(absorption applied afterwards from the excess-path histogram). Then, per (g, albedo, tau),
f(theta) is projected on the 31 unit Gaussians in u = tan(theta). Checks, all in the doc:
single scattering against quadrature, MC noise from a second seed, r_max truncation,
interpolation error at off-grid (tau, albedo, g) simulated directly.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
import apsf_mc as mc  # noqa: E402
import apsf_fit as fit
import apsf_crossing as crossing

# 0.15, 0.4, 0.95 and the albedos below 0.3 were added where a study of the earlier 30-tau grid
# (tools/apsf_interpolation.py, removed with that grid; in git history) measured more than
# 1 % interpolation error; tools/apsf_grid_check.py measures this grid
G = np.array([0.0, 0.15, 0.3, 0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.88, 0.9, 0.92, 0.94, 0.95, 0.96])
ALBEDO = np.array([0.02, 0.035, 0.05, 0.075, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.85,
                   0.9, 0.95, 0.98, 0.99, 0.995, 0.999, 1.0])
T_FAR = 0.3                    # entries at tau >= T_FAR come from the sphere-crossing estimator


def tau_grid() -> np.ndarray:
    """The 30 log-spaced taus of the first tables (0.01 to 30, a factor 1.318 a step) stay
    nodes; the step is halved from 0.83 and quartered from 4.3, where the energy ratio bends
    in log tau (tools/apsf_grid_check.py: log ratio linear in log tau at tau >= 5 was
    off by 4.3 % at p90 with the old step, 1.9 % with it halved): 57 taus."""
    lb = np.log(np.geomspace(0.01, 30.0, 30))
    return np.exp(np.concatenate([lb[:17], np.linspace(lb[16], lb[22], 13)[1:], np.linspace(lb[22], lb[29], 29)[1:]]))


TAU = tau_grid()
SEED = 20261201
R_MAX = 2 * TAU[-1]            # photons dropped beyond (their light added in diffusion theory)
SECONDS_PER_G = 75.0           # photon counts are set for about this per g on one core
SECONDS_FAR = 60.0             # the same for the sphere-crossing runs


def photons_for(g: float, scale: float) -> int:
    """Photon count per g for about the same time per g: low g photons diffuse longer
    (measured cost about 0.26 + 0.68 (1 - g)^1.5 ms per photon on this machine's core with
    the weight window and no early roulette)."""
    ms = 0.26 + 0.68 * (1 - g) ** 1.5
    return max(1000, int(round(SECONDS_PER_G * 1e3 / ms * scale, -3)))


def far_photons_for(g: float, scale: float) -> int:
    """Photon count of the sphere-crossing run per g (measured about 0.2 + 0.95 (1 - g)^1.2
    ms per photon with cameras at 40 taus from 1 to 30: every photon diffuses to r_max)."""
    ms = 0.2 + 0.95 * (1 - g) ** 1.2
    return max(1000, int(round(SECONDS_FAR * 1e3 / ms * scale, -3)))


def rr_order_for(g: float) -> int:
    """Russian roulette (keep 1/2) after this many scatterings, a bound on the time of the
    longest diffusers only (the weight window of apsf_mc does the work): forward phases need
    more orders to cross the same distance."""
    return int(120 / math.sqrt(1 - g))


def run_g(g: float, scale: float, seed: int, tau=TAU, r_max=R_MAX) -> list:
    """The tallies of one g: the point estimator for the cameras at tau < T_FAR, the
    sphere-crossing estimator (apsf_crossing.simulate_far) at tau >= T_FAR, where its noise is
    3-20x lower for the same time (tools/apsf_crossing_probe.py; at g 0.9, tau 0.2-3,
    its energy noise is 0.1-2 % with 20000 photons against 0.4-14 % with 60000 point
    photons). Either may be absent when no tau falls in its range."""
    tau = np.asarray(tau, np.float64)
    runs = []
    if (tau < T_FAR).any():
        runs.append(mc.simulate(g, tau[tau < T_FAR], photons_for(g, scale), seed, r_max=r_max,
                                rr_order=rr_order_for(g)))
    if (tau >= T_FAR).any():
        runs.append(crossing.simulate_far(g, tau[tau >= T_FAR], far_photons_for(g, scale), seed, r_max=r_max,
                                    rr_order=rr_order_for(g)))
    return runs


def _timed_run(g: float, scale: float):
    t0 = time.time()
    return run_g(g, scale, SEED), time.time() - t0


def _reduced(g: float, scale: float, seed: int, tau, albedo) -> dict:
    return reduce_runs(run_g(g, scale, seed, tau=tau), albedo)


def reduce_runs(runs: list, albedo=ALBEDO) -> dict:
    """reduce_tally of each estimator's run, joined along tau (ascending: point, then crossing)."""
    parts = [reduce_tally(t, albedo) for t in runs]
    return {k: np.concatenate([p[k] for p in parts], axis=1) for k in parts[0]}


def thin(tau, albedo):
    return np.exp(-np.outer((1 - albedo) / albedo, tau)) * -np.expm1(-tau)[None, :]


def reduce_tally(t: mc.Tally, albedo=ALBEDO) -> dict:
    """Everything the table stores for one g: ratio-space fit (no underflow), then scaled."""
    f_rel, em_rel = fit.profiles(t, albedo, relative=True)
    W, E_rel, err = fit.fit_gaussians(t.th_edges, f_rel)
    dom = 2 * math.pi * (np.cos(t.th_edges[:-1]) - np.cos(t.th_edges[1:]))
    att = np.exp(-np.outer((1 - albedo) / albedo, t.tau))             # exp(-sa d)
    em_sum = em_rel.sum((-2, -1), keepdims=True)
    return dict(
        weights=W * att[..., None], energy=E_rel * att, ratio=E_rel / -np.expm1(-t.tau)[None, :],
        energy_sphere=(f_rel * dom).sum(-1) * att, profile=f_rel * att[..., None],
        emit_mu=em_rel / np.where(em_sum > 0, em_sum, 1.0), fit_error=err,
        shape=W / np.maximum(W.sum(-1, keepdims=True), 1e-300), f_rel=f_rel)


def bracket(grid, x):
    x = min(max(x, grid[0]), grid[-1])
    i = int(np.clip(np.searchsorted(grid, x) - 1, 0, len(grid) - 2))
    return i, (x - grid[i]) / (grid[i + 1] - grid[i])


def interp(tab: dict, g: float, a: float, tau: float):
    """(ratio, shape) at an off-grid point by the runtime's lookup (fogcli.physics.apsf.spread)."""
    from fogcli.physics import apsf

    ratio, shape = apsf.spread(tab, g, a, np.array([tau]))
    return float(ratio[0]), shape[0]


def ring_l1(th_edges, sa, sb):
    """Relative L1 of the ring energies of two normalised weight sets."""
    return fit.ring_error(th_edges, sa, sb)


def pct(x, q):
    """Percentile over the entries that are numbers (a ratio that underflows float32 on both
    seeds, albedo 0.02 at large tau, gives 0 / 0)."""
    return float(np.nanpercentile(np.asarray(x, np.float64).ravel(), q))


def single_scatter_rows(th_edges, scale: float) -> list:
    """(g, albedo, tau, MC / quadrature) of the single-scattered energy over the whole sphere,
    each tau with the estimator its table entry comes from and the table's r_max (a smaller
    one drops photons whose first flight passes it and adds their diffusion light, which is
    not single scattering)."""
    rows = []
    ks = [int(np.argmin(np.abs(TAU - v))) for v in (0.01, 0.091, 0.83, 4.34)]
    dom = 2 * math.pi * (np.cos(th_edges[:-1]) - np.cos(th_edges[1:]))
    thc = np.sqrt(th_edges[:-1] * th_edges[1:])
    thc[0] = th_edges[1] / 2
    for g in (0.0, 0.9):
        for k in ks:
            sim = mc.simulate if TAU[k] < T_FAR else crossing.simulate_far
            t = sim(g, TAU[k:k + 1], int(100_000 * max(scale, 0.2)), SEED + 7, max_order=1, r_max=R_MAX)
            f, _ = fit.profiles(t, [1.0, 0.3])
            for i, a in enumerate((1.0, 0.3)):
                q = fit.single_scatter(thc, TAU[k], g, a, n=2000) @ dom
                rows.append((g, a, TAU[k], f[i, 0] @ dom / q))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1/20 of the photons; writes nothing")
    ap.add_argument("--jobs", type=int, default=2, help="processes for the table's runs (one per g)")
    ap.add_argument("--out", default=str(ROOT / "src/fogcli/physics/data/apsf.npz"))
    ap.add_argument("--doc", default=str(ROOT / "docs/apsf-table.md"))
    ap.add_argument("--scale", type=float, default=None, help=argparse.SUPPRESS)   # smoke runs
    ap.add_argument("--doc-only", action="store_true", help="re-render the doc from /tmp/apsf_checks.pkl")
    ap.add_argument("--before", default=None, help="checks pickle of a previous run: its noise table is shown too")
    args = ap.parse_args(argv)
    if args.doc_only:
        import pickle
        with open("/tmp/apsf_checks.pkl", "rb") as fh:
            write_doc(pickle.load(fh), args.doc)
        return 0
    scale = args.scale or (0.05 if args.quick else 1.0)
    args.quick = args.quick or scale < 1
    t_start = time.time()

    # ---- the table ----
    res, tallies, photons, secs = {}, {}, [], []
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        runs = {g: pool.submit(_timed_run, g, scale) for g in G}
        for g in G:
            t, sec = runs[g].result()
            secs.append(sec)
            res[g] = reduce_runs(t)
            tallies[g] = t
            photons.append((photons_for(g, scale), far_photons_for(g, scale)))
            print(f"g={g:.2f}: {photons[-1]} photons (point, crossing), {secs[-1]:.0f} s, {t[0].stats}", flush=True)
    t_table = time.time() - t_start
    stack = {k: np.stack([res[g][k] for g in G]) for k in res[G[0]]}
    th_edges = tallies[G[0]][0].th_edges
    tab = dict(g=G, albedo=ALBEDO, tau=TAU, ratio=stack["ratio"], shape=stack["shape"])

    # ---- write ----
    if not args.quick:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        f32 = np.float32
        # uncompressed: every fogcli process loads the table, and inflating its 4.4 MB cost
        # ~40 ms of each start-up (1.1 MB more in the package)
        np.savez(
            out, g=G.astype(f32), albedo=ALBEDO.astype(f32), tau=TAU.astype(f32),
            sigma_u=fit.SIGMA_U.astype(f32), weights=stack["weights"].astype(f32),
            energy=stack["energy"].astype(f32), energy_sphere=stack["energy_sphere"].astype(f32),
            ratio=stack["ratio"].astype(f32), theta_edges=th_edges.astype(f32), t_far=np.float32(T_FAR),
            # half precision (3 significant digits, ample for a weight's average): 4.8 MB
            emit_mu=stack["emit_mu"].astype(np.float16), emit_mu_edges=mc.MU_EDGES.astype(f32),
            emit_theta=mc.EMIT_THETA.astype(f32),
            photons=np.array(photons, np.int64), seed=np.int64(SEED),
            fit_error=stack["fit_error"].astype(f32), r_max=np.float32(R_MAX),
            rr_order=np.array([rr_order_for(g) for g in G], np.int64))
        print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB)")


    # ---- checks ----
    # the runs of checks 2 and 4 go to the pool while check 1 runs here
    noise_g = (0.0, 0.8, 0.96)
    g_off = (0.65, 0.87)
    a_off = np.array([0.15, 0.45, 0.75, 0.875, 0.925, 0.97, 0.997])
    tau_off = np.sqrt(TAU[:-1] * TAU[1:])[1::3]
    pool = ProcessPoolExecutor(max_workers=args.jobs, mp_context=multiprocessing.get_context("spawn"))
    noise_runs = {g: pool.submit(_reduced, g, scale, SEED + 1, TAU, ALBEDO) for g in noise_g}
    off_runs = {g: pool.submit(_reduced, g, scale, SEED + 3, tau_off, a_off) for g in g_off}
    # 1. single scattering against quadrature (estimator check, independent of the table), each
    #    tau with the estimator its table entry comes from
    ss_rows = single_scatter_rows(th_edges, scale)
    print(f"single-scattering check done {time.time() - t_start:.0f} s", flush=True)
    # 2. MC noise: a second seed, same photons
    noise = {}
    for g in noise_g:
        r2 = noise_runs[g].result()
        r1 = res[g]
        de = np.abs(r2["ratio"] / r1["ratio"] - 1)
        dl = ring_l1(th_edges, r2["shape"], r1["shape"])
        noise[g] = (de, dl)
        print(f"noise g={g}: done {time.time() - t_start:.0f} s", flush=True)
    # 3. truncation: share of the energy that is the diffusion tail of the photons dropped at
    #    r_max (from the table's own runs): the truncation error is a fraction of this
    trunc = []
    for g in (0.0, 0.9, 0.96):
        a3 = [1.0, 0.999, 0.99, 0.9]
        dom = 2 * math.pi * (np.cos(th_edges[:-1]) - np.cos(th_edges[1:]))
        e_no = np.concatenate([fit.profiles(t, a3, relative=True, background=False)[0] @ dom for t in tallies[g]], 1)
        e_bg = np.concatenate([fit.profiles(t, a3, relative=True, background=True)[0] @ dom for t in tallies[g]], 1)
        trunc.append((g, a3, 1 - e_no / np.maximum(e_bg, 1e-300)))
    # 4. interpolation at off-grid points, simulated directly
    interp_rows = []
    for g in g_off:
        r = off_runs[g].result()
        for i, a in enumerate(a_off):
            for k, tv in enumerate(tau_off):
                ri, si = interp(tab, g, a, tv)
                e_err = ri / r["ratio"][i, k] - 1
                s_err = float(ring_l1(th_edges, si[None], r["shape"][i, k][None])[0])
                interp_rows.append((g, a, tv, e_err, s_err))
        print(f"interp g={g}: done {time.time() - t_start:.0f} s", flush=True)
    pool.shutdown()
    t_total = time.time() - t_start

    # ---- doc ----
    if args.before:
        import pickle
        with open(args.before, "rb") as fh:
            old = pickle.load(fh)
        noise_before = dict(noise=old["noise"], photons=old["photons"], t_table=old["t_table"],
                            secs=old["secs"])
    else:
        noise_before = None
    ctx = dict(stack=stack, photons=photons, secs=secs, t_table=t_table, t_total=t_total, jobs=args.jobs,
               noise_before=noise_before,
               ss_rows=ss_rows, noise=noise, noise_g=noise_g, th_edges=th_edges, g_off=g_off,
               a_off=a_off, tau_off=tau_off, interp_rows=interp_rows, trunc=trunc, quick=args.quick)
    import pickle
    with open("/tmp/apsf_checks.pkl", "wb") as fh:
        pickle.dump(ctx, fh)
    write_doc(ctx, None if args.quick else args.doc)
    return 0


def write_doc(ctx: dict, doc: str | None) -> None:
    """docs/apsf-table.md from the numbers of one run (printed if doc is None)."""
    stack, photons, secs = ctx["stack"], ctx["photons"], ctx["secs"]
    t_table, t_total, ss_rows, noise = ctx["t_table"], ctx["t_total"], ctx["ss_rows"], ctx["noise"]
    noise_g, th_edges, g_off, a_off = ctx["noise_g"], ctx["th_edges"], ctx["g_off"], ctx["a_off"]
    tau_off, interp_rows, trunc = ctx["tau_off"], ctx["interp_rows"], ctx["trunc"]
    lines = []
    L = lines.append
    L("# Multiple-scattering point spread table (APSF)")
    L("")
    L("Generated by `PYTHONPATH=src python tools/make_apsf_table.py` (this file is its output"
      + (", **--quick run: 1/20 of the photons**" if ctx["quick"] else "") + "). "
      f"Table: {t_table / 60:.1f} min ({ctx.get('jobs', 1)} processes, one g each); with the checks below "
      f"{t_total / 60:.1f} min, on a 2-core machine (numpy).")
    L("")
    L("## What is tabulated")
    L("")
    L("Infinite homogeneous medium, Henyey-Greenstein phase g, albedo a, lengths in scattering "
      "mean free paths (tau = ss d). An isotropic point source, a camera at distance d = tau looking "
      "at it. f(theta) is the scattered radiance at angle theta from the source over I / d^2 "
      "(unscattered light excluded). `energy` = its integral over the forward hemisphere = the "
      "integral over the image plane of K(u) = f cos^3(theta), u = tan(theta); `weights` are its "
      "projection on unit 2-D Gaussians of widths `sigma_u` = 2^(-14 + j/2), j = 0..30 "
      "(non-negative, summing exactly to `energy`). `ratio` (float32, not underflowing) = energy / "
      "(exp(-sa d)(1 - exp(-d))); `energy` and `weights` underflow float32 where sa d > ~85 "
      "(a = 0.02 beyond tau ~ 1.7): use `ratio` there. `emit_mu` (float16): the joint distribution "
      "of the forward-hemisphere energy over the angle theta at which it arrives (classes "
      "`emit_theta`, " + ", ".join(f"{math.degrees(v):g}" for v in mc.EMIT_THETA) + " degrees) and the "
      "cosine between its emission direction and the source->camera direction (bins `emit_mu_edges`: "
      "12 equal over [-1, 0.8], then 0.9, 0.95, 0.98, 0.995, 1); a frame sees only the classes "
      "within its field of view (`emission.lambert_weight`). The raw f(theta) per steradian is not shipped (4 MB; "
      "`reduce_tally` returns it as `profile`).")
    L("")
    L(f"Grid: g = {', '.join(f'{g:g}' for g in G)}; albedo = {', '.join(f'{a:g}' for a in ALBEDO)}; "
      f"tau = {len(TAU)} from {TAU[0]:g} to {TAU[-1]:g}, log-spaced with a factor 1.318 a step up to 0.83, "
      "half that step (in log tau) to 4.3 and a quarter of it to 30 (`tau_grid`).")
    L(f"Photons per g (point estimator, tau < {T_FAR:g} | sphere crossings, tau >= {T_FAR:g}): "
      f"{', '.join(f'{g:g}: {n[0]} | {n[1]}' for g, n in zip(G, photons))} (seed {SEED}); "
      f"time per g {min(secs):.0f}-{max(secs):.0f} s.")
    L("")
    L("## Method (fogcli/apsf_mc.py)")
    L("")
    L("* Free paths sampled with ss only; absorption is a weight exp(-sa l) on the total path l, "
      "applied after the run from a histogram over the excess path l - d (log bins, 24 per decade, "
      "with the first three moments per bin so exp(-sa x) is averaged within a bin): one run per g "
      "serves every albedo.")
    L(f"* Two estimators: below tau {T_FAR:g} the point estimator (this item and the next three), from "
      f"tau {T_FAR:g} on sphere crossings (`apsf_crossing.simulate_far`): the medium is infinite and homogeneous "
      "and the source isotropic, so the whole sphere of radius d is the detector; a photon crossing it with "
      "radial cosine mu scores w / |mu| in the theta = acos(mu) bin. Isotropic emission, exponential first "
      "flight, no weight window; the same excess-path histogram. At tau 0.2-3 its noise is 3-20x below the "
      "point estimator's for the same time, and 10-100x at tau >= 5 (tools/apsf_crossing_probe.py).")
    L("* Point (next-event) estimator at every vertex, w p_HG(mu) exp(-r) / r^2, to cameras at all "
      f"{int((TAU < T_FAR).sum())} distances below {T_FAR:g} on +z and -z at once. Inside a ball of radius eps = min(0.1 d, 0.6) around the "
      "camera a vertex at r is scored as if at r' = eps (r/eps)^3 on the same ray with 1/r^2 -> 3/eps^2 "
      "(r' uniform on [0, eps] for a uniform vertex density: exact per direction, exp(-r) and "
      "absorption included; bounded variance; a density gradient moves ~ eps/4 |grad ln n| of the "
      "ball's share between directions, no total). Pairs farther than 8 mfp are not scored "
      "(last free path > 8: probability 3e-4).")
    L("* Importance sampling with bounded weights: the emission direction (1/3 isotropic, 2/3 "
      "concentrated around +-z) and the first free path (1/2 exponential, 1/2 log-uniform on "
      "[1e-5, 60]) so that small tau and forward phases get photons.")
    L(f"* Truncation: photons are dropped beyond r_max = {R_MAX:g} mfp; their later light is added as "
      "an isotropic radiance from diffusion theory (shell theorem for the Yukawa kernel, each "
      "dropped photon weighted by exp(-sa l)).")
    L("* Weight window by region instead of the older order-based roulette (keep 1/10 after "
      "30 / sqrt(1 - g) scatterings, which put weight-10 photons next to the far cameras: the main "
      "source of the large-tau noise). Region R = within 12 mfp of the camera axis (|z| < 42): a "
      "photon leaving R is kept with probability 1/10 (weight x 10), one coming back is split into "
      "10 copies (weight / 10). Vertices outside R cannot score (> 8 mfp from every camera), so the "
      "photons near the cameras keep their weight and the time saved outside R pays for them. "
      "Unbiased. A last roulette (keep 1/2) after 120 / sqrt(1 - g) scatterings bounds the time.")
    L("* Fit: NNLS on the ring energies (the profile weighted by u du) and the cumulative energy, "
      "with sum(w) = energy imposed exactly, plus a small penalty on the weights' second difference "
      f"across widths (`apsf_mc.FIT_SMOOTH` = {fit.FIT_SMOOTH:g}): neighbouring half-octave Gaussians are "
      "nearly interchangeable, and without it the fit is sparse and picks different ones at neighbouring "
      "albedos, which interpolation then mixes. Light narrower than sigma_0 goes to w_0.")
    L("")
    L("## Estimator check: single scattering against quadrature")
    L("")
    L("Only the first scattering scored, against `apsf_fit.single_scatter` (quadrature along the "
      "view ray), energy over the whole sphere:")
    L("")
    L("| g | albedo | tau | MC / quadrature |")
    L("|---|---|---|---|")
    for g, a, tv, r in ss_rows:
        L(f"| {g:g} | {a:g} | {tv:.3g} | {r:.4f} |")
    L("")
    L("For g = 0 and tau -> 0 the closed form is energy_sphere = (pi^2 / 4) tau "
      f"(table, tau = {TAU[0]:g}, a = 1: {stack['energy_sphere'][0, -1, 0] / (math.pi ** 2 / 4 * TAU[0]):.3f} "
      "of it; the quadrature with the exponentials gives 0.957, the rest is multiple scattering).")
    L("")
    L("## Monte Carlo noise (second seed, same photons)")
    L("")
    L("Relative difference of the energy, and relative L1 between the two ring profiles "
      "(normalised), over all albedos; median / 90th percentile / max:")
    L("")
    L("| g | tau range | energy median | p90 | max | shape L1 median | p90 | max |")
    L("|---|---|---|---|---|---|---|---|")

    def noise_rows(albedos):
        """The table's rows: per g and tau range, the Monte Carlo noise at the albedos chosen."""
        for g in noise_g:
            de, dl = (x[albedos] for x in noise[g])
            for lo, hi in ((0, 1.0), (1.0, 5.0), (5.0, 31)):
                sel = (TAU >= lo) & (TAU < hi)
                L(f"| {g:g} | [{lo:g}, {hi:g}) | {pct(de[:, sel], 50):.3f} | {pct(de[:, sel], 90):.3f} | "
                  f"{pct(de[:, sel], 100):.3f} | {pct(dl[:, sel], 50):.3f} | {pct(dl[:, sel], 90):.3f} | "
                  f"{pct(dl[:, sel], 100):.3f} |")

    noise_rows(slice(None))
    L("")
    e_low = stack["energy"][:, ALBEDO < 0.3][..., TAU >= 5]
    L(f"At tau >= 5 and albedo < 0.3 the scattered light is at most {np.max(e_low):.1g} of the source's "
      "(`energy`), carried by rare photons with short paths: the large relative differences there are "
      "light no image shows.")
    L("")
    L("The same for albedo >= 0.9 only (fog: the light that matters in thick media):")
    L("")
    L("| g | tau range | energy median | p90 | max | shape L1 median | p90 | max |")
    L("|---|---|---|---|---|---|---|---|")
    hia = ALBEDO >= 0.9
    noise_rows(hia)
    L("")
    nb = ctx.get("noise_before")
    if nb:
        L("Before / after: the same two-seed measure of the previous estimator (ball 3/eps^2 with "
          "eps = min(0.05 d, 0.3), r_cut 12, roulette keep 1/10 after 30 / sqrt(1 - g) scatterings, "
          f"no weight window; its table took {nb['t_table'] / 60:.1f} min with photons per g "
          f"{min(nb['photons'])}-{max(nb['photons'])}; this one {t_table / 60:.1f} min with "
          f"{min(photons)}-{max(photons)}). Energy median / p90, shape L1 median / p90, before -> after:")
        L("")
        L("| g | tau range | albedos | energy median | energy p90 | shape median | shape p90 |")
        L("|---|---|---|---|---|---|---|")
        for g in noise_g:
            for aname, asel in (("all", np.ones(len(ALBEDO), bool)), (">= 0.9", hia)):
                for lo, hi in ((0, 1.0), (1.0, 5.0), (5.0, 31)):
                    sel = (TAU >= lo) & (TAU < hi)
                    cells = []
                    for k in (0, 1):
                        for q in (50, 90):
                            b = pct(nb["noise"][g][k][asel][:, sel], q)
                            a_ = pct(noise[g][k][asel][:, sel], q)
                            cells.append(f"{b:.3f} -> {a_:.3f}")
                    L(f"| {g:g} | [{lo:g}, {hi:g}) | {aname} | " + " | ".join(cells) + " |")
        L("")
    L("## Projection on the Gaussians")
    L("")
    fe = stack["fit_error"]
    L("Relative L1 of the ring energies (fit against tallied), over all g and albedos:")
    L("")
    L("| tau range | median | p90 | max |")
    L("|---|---|---|---|")
    for lo, hi in ((0, 0.1), (0.1, 1.0), (1.0, 5.0), (5.0, 31)):
        sel = (TAU >= lo) & (TAU < hi)
        L(f"| [{lo:g}, {hi:g}) | {pct(fe[..., sel], 50):.3f} | {pct(fe[..., sel], 90):.3f} | {pct(fe[..., sel], 100):.3f} |")
    L("")
    L("Part of this is MC noise in the fine rings (the tallied profile is not smooth: the noise "
      "table above bounds it), part is the basis: K(u) = f cos^3(theta) of a broad f falls like "
      "u^-3, a tail no Gaussian of width <= 2 reproduces. Without noise, on single-scattering "
      "profiles from quadrature (`single_scatter`), the projection error alone is:")
    L("")
    te = th_edges.astype(np.float64)
    thc = np.sqrt(te[:-1] * te[1:])
    thc[0] = te[1] / 2
    L("| g | " + " | ".join(f"tau {t:g}" for t in (0.01, 0.3, 3.0)) + " |")
    L("|---|---|---|---|")
    for g in (0.0, 0.5, 0.85, 0.96):
        errs = [fit.fit_gaussians(te, fit.single_scatter(thc, t, g, 1.0, n=1000)[None])[2][0]
                for t in (0.01, 0.3, 3.0)]
        L(f"| {g:g} | " + " | ".join(f"{e:.3f}" for e in errs) + " |")
    L("")
    nf = int(np.searchsorted(te, math.pi / 2 + 1e-12))
    i76 = int(np.searchsorted(te, math.atan(4.0)))
    dom = 2 * math.pi * (np.cos(te[:-1]) - np.cos(te[1:]))
    ring = stack["f_rel"][..., :nf] * dom[:nf]
    far = ring[..., i76:].sum(-1) / np.maximum(ring.sum(-1), 1e-300)
    L(f"Share of the forward energy at u > 4 (theta > {math.degrees(te[i76]):.0f} degrees), where the "
      f"widest Gaussian (sigma 2) has little weight: median {pct(far, 50):.3f}, max {pct(far, 100):.3f} "
      f"over the table; g = 0: median {pct(far[0], 50):.3f}.")
    L("")
    L("## Interpolation error at off-grid points")
    L("")
    L(f"Direct simulations at g = {', '.join(map(str, g_off))}, albedo = {', '.join(f'{a:g}' for a in a_off)}, "
      f"tau = midpoints of every third grid interval ({len(tau_off)} values), compared with the table "
      "interpolated as fogcli does (`fogcli.physics.apsf.spread`: linear in g and log tau, a natural cubic "
      "spline in sqrt((1 - a) / a) across albedo): the energy through `ratio` (energy over "
      "exp(-sa d)(1 - exp(-d))), the shape through the normalised weights. Each direct run has the "
      "MC noise of the table above, so the numbers are an upper bound on the interpolation error "
      "only down to that noise floor.")
    L("")
    L("| g | tau range | energy median | p90 | max | shape L1 median | p90 | max |")
    L("|---|---|---|---|---|---|---|---|")
    ir = np.array(interp_rows)
    for g in g_off:
        for lo, hi in ((0, 1.0), (1.0, 5.0), (5.0, 31)):
            sel = (ir[:, 0] == g) & (ir[:, 2] >= lo) & (ir[:, 2] < hi)
            e, s = np.abs(ir[sel, 3]), ir[sel, 4]
            L(f"| {g:g} | [{lo:g}, {hi:g}) | {pct(e, 50):.3f} | {pct(e, 90):.3f} | {pct(e, 100):.3f} | "
              f"{pct(s, 50):.3f} | {pct(s, 90):.3f} | {pct(s, 100):.3f} |")
    L("")
    L("Per albedo (all tau, both g), max energy error / max shape L1:")
    L("")
    L("| albedo | " + " | ".join(f"{a:g}" for a in a_off) + " |")
    L("|---|" + "---|" * len(a_off))
    L("| energy | " + " | ".join(f"{np.abs(ir[ir[:, 1] == a, 3]).max():.3f}" for a in a_off) + " |")
    L("| shape | " + " | ".join(f"{ir[ir[:, 1] == a, 4].max():.3f}" for a in a_off) + " |")
    L("")
    L("## Energy against the thin-medium form")
    L("")
    L("`ratio` = energy (forward hemisphere) / (exp(-sa d)(1 - exp(-d))):")
    L("")
    show_t = [0, 6, 10, 14, 17, 20, 23, 26, 29]
    L("| g | albedo | " + " | ".join(f"tau {TAU[k]:.3g}" for k in show_t) + " |")
    L("|---|---|" + "---|" * len(show_t))
    for g in (0.0, 0.5, 0.85, 0.9, 0.96):
        ig = int(np.argmin(np.abs(G - g)))
        for a in (1.0, 0.999, 0.9, 0.85, 0.4, 0.1):
            ia = int(np.argmin(np.abs(ALBEDO - a)))
            L(f"| {g:g} | {a:g} | " + " | ".join(f"{stack['ratio'][ig, ia, k]:.3f}" for k in show_t) + " |")
    L("")
    L("The ratio is not ~1 in general: for g = 0 single scattering alone gives (pi^2/4) tau on the "
      "sphere (side- and back-scattered light from the whole medium around the camera), about "
      "half of it in the forward hemisphere. Only for forward phases is it near 1 at small tau "
      "(within a few per cent for g >= 0.9 below tau ~1; 1.0-1.2 for g = 0.85 up to tau ~2.5). "
      "At large tau and a near 1 diffusion makes it grow (fluence ~ 3 (1 - g) tau relative to "
      "I / d^2); for small albedo absorption along the longer scattered paths makes it fall. "
      "Beyond tau ~1 the entries carry the noise of the noise table above.")
    L("")
    L("## Fraction of the forward energy beyond 30 degrees")
    L("")
    th30 = int(np.searchsorted(th_edges, math.radians(30)))
    nf = int(np.searchsorted(th_edges, math.pi / 2 + 1e-12))
    dom = 2 * math.pi * (np.cos(th_edges[:-1]) - np.cos(th_edges[1:]))
    ring = stack["f_rel"][..., :nf] * dom[:nf]
    frac = ring[..., th30:].sum(-1) / np.maximum(ring.sum(-1), 1e-300)
    L(f"(theta edge used: {math.degrees(th_edges[th30]):.1f} degrees)")
    L("")
    show_t2 = [0, 10, 17, 20, 23, 26, 29]
    L("| g | albedo | " + " | ".join(f"tau {TAU[k]:.3g}" for k in show_t2) + " |")
    L("|---|---|" + "---|" * len(show_t2))
    for g in (0.0, 0.85, 0.96):
        ig = int(np.argmin(np.abs(G - g)))
        for a in (1.0, 0.9, 0.4):
            ia = int(np.argmin(np.abs(ALBEDO - a)))
            L(f"| {g:g} | {a:g} | " + " | ".join(f"{frac[ig, ia, k]:.3f}" for k in show_t2) + " |")
    L("")
    L("## Truncation at r_max")
    L("")
    L(f"Share of the energy that is the diffusion-theory "
      f"tail of the photons dropped at r_max = {R_MAX:g} mfp (over the sphere):")
    L("")
    show_t3 = [17, 20, 23, 26, 29]
    L("| g | albedo | " + " | ".join(f"tau {TAU[k]:.3g}" for k in show_t3) + " |")
    L("|---|---|" + "---|" * len(show_t3))
    for g, a3, share in trunc:
        for i, a in enumerate(a3):
            L(f"| {g:g} | {a:g} | " + " | ".join(f"{share[i, k]:.3f}" for k in show_t3) + " |")
    L("")
    L("Without absorption a photon never dies; in diffusion theory the light of photons that have "
      "gone beyond r_max is a fraction d / r_max of the fluence at a = 1 and falls like "
      "exp(-(r_max - d) / L_diff) with absorption, so only a >= 0.99 at large tau depends on the "
      "tail. The table includes the tail.")
    L("")
    L("## Known limits")
    L("")
    ir_ = np.array(interp_rows)
    small = ir_[ir_[:, 2] < 0.3]
    worst = ir_[ir_[:, 2] < 1.0][np.argmax(np.abs(ir_[ir_[:, 2] < 1.0, 3]))]
    big = np.concatenate([noise[g][0][:, TAU >= 5].ravel() for g in noise_g])
    big_hi = np.concatenate([noise[g][0][ALBEDO >= 0.9][:, TAU >= 5].ravel() for g in noise_g])
    L(f"* Below tau {T_FAR:g} the point estimator's variance is heavy-tailed (vertices close to the camera "
      "whose photon heads at it, p_HG up to ~100 per sr for g = 0.96). Example: the worst interpolation point "
      f"below tau 1 (g {worst[0]:g}, a {worst[1]:g}, tau {worst[2]:.3g}: energy {worst[3]:+.2f}, shape L1 "
      f"{worst[4]:.2f}) is, as far as the two seeds tell, noise of the direct run at that point.")
    L(f"* From tau {T_FAR:g} on the sphere-crossing estimator: few crossings land in the narrowest angle bins "
      "(a bin's share of the sphere's directions) and 1/|mu| has a logarithmically divergent variance at grazing "
      "crossings (the last forward bin). Beyond tau 5 the seed-to-seed energy difference is median "
      f"{pct(big, 50):.3f}, p90 {pct(big, 90):.3f} over all albedos and the three g of the noise table "
      f"({pct(big_hi, 50):.3f} / {pct(big_hi, 90):.3f} for albedo >= 0.9); entries whose ratio underflows "
      "float32 (albedo 0.02 at the largest tau: their light is below 1e-38 of the thin-medium form) are left out.")
    L(f"* The direct runs cannot show the 1 % interpolation target: below tau 0.3 the interpolated-vs-direct "
      f"energy differs by median {pct(np.abs(small[:, 3]), 50):.3f}, p90 {pct(np.abs(small[:, 3]), 90):.3f} "
      f"(shape L1 median {pct(small[:, 4], 50):.3f}), the size of the seed-to-seed noise. The "
      "interpolation error proper, free of that noise, is measured by tools/apsf_grid_check.py "
      "(section \"Interpolation error of the shipped grid\"): across albedo from one tally, across g in "
      "single scattering by quadrature, across tau at tau >= 5 from cameras at the grid taus and the midpoints "
      "in one tally.")
    r_ = stack["ratio"][:, ALBEDO >= 0.9]
    spike = r_[..., 1:-1] / np.sqrt(np.maximum(r_[..., :-2] * r_[..., 2:], 1e-300))
    ig_, ia_, it_ = np.unravel_index(np.argmax(np.abs(np.log(np.maximum(spike, 1e-300)))), spike.shape)
    L("* Single events are still visible as spikes along tau: the largest, for albedo >= 0.9, is "
      f"g {G[ig_]:g}, tau {TAU[it_ + 1]:.3g}: ratio {spike[ig_, ia_, it_]:.2f} x the geometric mean of its "
      "two tau neighbours (the same event at every albedo). fogcli interpolates the log ratio linearly "
      "in log tau, so it reaches the output around that distance.")
    L("* Infinite homogeneous medium: no boundaries, no ground.")
    if doc:
        import re

        old = Path(doc).read_text() if Path(doc).exists() else ""
        # the blocks other scripts own (apsf_grid_check.py) stay
        keep = "".join("\n" + m.group(0) + "\n" for m in re.finditer(r"<!-- ([a-z-]+) -->.*?<!-- /\1 -->", old, re.S))
        Path(doc).write_text("\n".join(lines) + "\n" + keep)
    else:
        print("\n".join(lines))
    print(f"total {t_total / 60:.1f} min")


if __name__ == "__main__":
    raise SystemExit(main())
