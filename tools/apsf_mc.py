"""Monte Carlo angular point spread (APSF) of an isotropic point source in fog (numpy only).

Geometry and units. Infinite homogeneous medium, Henyey-Greenstein phase (asymmetry g),
lengths in scattering mean free paths (ss = 1, so the scattering optical distance tau is the
distance d), absorption sa = (1 - a) / a. An isotropic source at the origin; cameras on
coordinate axes at distances d = tau, each looking at the source. f(theta) is the scattered
radiance (unscattered light excluded) the camera sees at angle theta from the source,
divided by I / d^2 (I = source intensity per steradian); its integral over solid angle is
the `energy` (relative to the unscattered image of the source with its exp(-(ss+sa) d)
taken out: a source of solid angle W and radiance L gives L W f(theta)).

Estimator. Free paths are sampled with ss only; absorption is never simulated. Every path
that reaches a camera is weighted afterwards by exp(-sa l), l = its total length (source ->
vertices -> camera), so one run serves every albedo: the tally is a histogram over the
*excess* length x = l - d >= 0 (absorption weight exp(-sa d) exp(-sa x)), with the first
three moments of x per bin, from which exp(-sa x) is averaged over the bin (cumulant
expansion, clipped to the bin's range).
At every scattering vertex a point (next-event) estimator sends w p_HG(mu) exp(-r) / r^2 to
each camera (r: vertex-camera distance, mu: cosine between the incoming direction and the
direction to the camera), binned by the angle between (vertex - camera) and
(source - camera). The source is isotropic and the medium homogeneous, so the same photons
serve every camera distance and every axis (cameras on +z and -z by default: the two see
anti-correlated halves of each photon's vertices, which halves the variance at no cost in
propagation).

Near the camera 1/r^2 has infinite variance. Inside a ball of radius eps(d) around the
camera a vertex at distance r is scored as if it were at r' = eps (r / eps)^3 along the same
direction, with 1/r^2 replaced by 3 / eps^2: for a vertex density that is uniform across the
ball r' is uniform on [0, eps], so per direction the ball gives int_0^eps exp(-(1 + sa) r') dr',
exactly the point estimator's int_0^eps exp(-(1 + sa) r) dr (r' is used in exp(-r) and in
the path length, so every albedo is exact). The older variant (3 / eps^2 exp(-r) with the true
r) was low by ~ eps / 4 of the ball's share (1.5-2 % at eps = 0.3). What is left is a density
gradient across the ball: a linear gradient changes no total (its odd part averages out); it
moves ~ (1/4) eps |grad n| / n of the ball's share of the light between directions (the ball's
share along a ray is ~ 1 - exp(-eps)). eps = min(0.1 d, 0.6): at d >= 6, where eps = 0.6, the
field varies on the scale of the transport length (>~ 3 mfp for g <= 0.5 at a >= 0.9, more
for forward phases), i.e. ~ 0.6 / 4 / 3 * 0.45 ~ 2 % moved in angle in the worst case,
nothing in total; at small d the single scattering checks against quadrature (tests, docs)
bound it.

Truncation. Without absorption photons never die. A photon is dropped when it is further
than `r_max` from the source. The light of the dropped photons is not lost: `profiles` adds
it as an isotropic radiance from diffusion theory (shell theorem for the Yukawa kernel,
each dropped photon weighted by exp(-sa l) at the drop). Without that tail the loss would be
a fraction ~ d / r_max of the fluence at a = 1 and ~exp(-(r_max - d) / L_diff) of that with
absorption; `make_apsf_table.py` reports the tail's share, which bounds the error of this
approximation. Pairs with vertex-camera distance beyond `r_cut` = 8 are not scored: the last
free path of a scattered photon exceeds r_cut with probability exp(-r_cut) = 3e-4, the
order of the light dropped (in units of the thin-medium energy exp(-sa d)(1 - exp(-d)) the
unscattered-from-far part is at most ~ d exp(-d) exp(-r_cut)).

Weight window. Vertices farther than r_cut from every camera score nothing, and at large tau
most of a diffusing photon's scatterings happen there. The space is split into the region
R within r_cut + `margin` of the camera axes (|coordinate along the axis| < max tau + r_cut +
margin) and the rest: a photon leaving R is kept with probability 1 / `split` (weight x
split); a photon coming back into R is split into `split` copies (weight / split each).
Unbiased (importance ratios exact); photons near the cameras keep their weight (the older
order-based roulette, keep 1/10 after 30 / sqrt(1 - g) scatterings, put weight-10 photons
next to the far cameras, the main source of the large-tau noise), and the time saved outside
R pays for the photons kept inside. The margin keeps a photon entering R from scoring with
its large weight (it would have to fly > margin mfp unscattered to reach scoring distance).
After `rr_order` scatterings Russian roulette keeps a photon with probability `rr_keep`
(weight 1 / rr_keep): unbiased, a bound on the time of the very long diffusers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

J = 31
SIGMA_U = 2.0 ** (-14 + np.arange(J) / 2.0)           # Gaussian widths in u = tan(theta)
N_MU = 20                                              # emission-cosine bins over [-1, 1]
# Neighbouring half-octave Gaussians are nearly interchangeable, so the plain NNLS fit is
# sparse and picks different ones at neighbouring albedos: interpolating such weights mixes
# two different kernels (up to 3 % ring error at albedo midpoints, tau 1-5). A small
# penalty on the weights' second difference makes them a smooth function of the profile:
# 0.5 % there, for < 0.01 more fit error on noise-free profiles (docs/apsf-table.md).
FIT_SMOOTH = 0.03


def theta_edges(theta0: float = 2e-5, per_octave: int = 6, back_bins: int = 9) -> np.ndarray:
    """0, then log-spaced from theta0 to pi/2 (the forward hemisphere, where the fine
    structure is), then `back_bins` equal bins to pi (only counted in energy_sphere)."""
    n = int(math.ceil(math.log2((math.pi / 2) / theta0) * per_octave))
    fwd = np.geomspace(theta0, math.pi / 2, n + 1)
    back = np.linspace(math.pi / 2, math.pi, back_bins + 1)[1:]
    return np.concatenate([[0.0], fwd, back])


def excess_edges(x0: float = 1e-6, x1: float = 1e4, per_decade: int = 24) -> np.ndarray:
    """Bins of the excess path x = l - d: [0, x0), then log-spaced; the last is open."""
    n = int(round(math.log10(x1 / x0) * per_decade))
    return np.concatenate([[0.0], np.geomspace(x0, x1, n + 1)])


def hg_phase(mu, g):
    """Henyey-Greenstein phase function per steradian."""
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)


def hg_sample(rng, g, n):
    """Cosines of the scattering angle drawn from HG."""
    xi = rng.random(n)
    if abs(g) < 1e-6:
        return 2 * xi - 1
    s = (1 - g * g) / (1 - g + 2 * g * xi)
    return np.clip((1 + g * g - s * s) / (2 * g), -1.0, 1.0)


def rotate(d, mu, rng):
    """New unit directions at cosine mu from d, with a uniform azimuth."""
    phi = 2 * math.pi * rng.random(len(mu))
    st = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    cp, sp = np.cos(phi), np.sin(phi)
    # an orthonormal frame (t1, t2) around d, stable for d near +-z
    a = np.where(np.abs(d[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    t1 = np.cross(a, d)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(d, t1)
    out = mu[:, None] * d + (st * cp)[:, None] * t1 + (st * sp)[:, None] * t2
    return out / np.linalg.norm(out, axis=1, keepdims=True)


# Importance sampling (weights carried by the photon, so every tally stays unbiased; each
# weight is bounded by 1 / the share of the unbiased component, so no tally can blow up):
# * the emission direction, 1/3 isotropic and 2/3 around +-z (1 - |cos| log-uniform on
#   [T0, 1]): for forward phases the light seen near the source left it within ~(1 - g) rad
#   of the camera's direction, a fraction ~(1 - g)^2 / 4 of an isotropic source;
# * the first free path, 1/2 exponential and 1/2 log-uniform on [S0, S1]: at tau = 0.01 the
#   vertices that matter are within ~tau of the source, a fraction ~tau of exponential paths.
C_ISO, T0 = 1.0 / 3.0, 1e-7
C_EXP, S0, S1 = 0.5, 1e-5, 60.0


def emission(rng, n):
    """Unit directions and weights (1/(4 pi)) / pdf."""
    lt = math.log(1.0 / T0)
    cone = rng.random(n) >= C_ISO
    mu = 2 * rng.random(n) - 1
    t = T0 * np.exp(lt * rng.random(n))                      # 1 - |mu| in the cone part
    sgn = np.where(rng.random(n) < 0.5, -1.0, 1.0)
    mu = np.where(cone, sgn * (1 - t), mu)
    t_all = 1 - np.abs(mu)
    w = 1.0 / (C_ISO + (1 - C_ISO) * (t_all >= T0) / (np.maximum(t_all, T0) * lt))
    phi = 2 * math.pi * rng.random(n)
    s = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    return np.stack([s * np.cos(phi), s * np.sin(phi), mu], 1), w


def first_step(rng, n):
    """First free paths and weights exp(-s) / pdf(s)."""
    ls = math.log(S1 / S0)
    s = np.where(rng.random(n) < C_EXP, -np.log1p(-rng.random(n)), S0 * np.exp(ls * rng.random(n)))
    inside = (s >= S0) & (s <= S1)
    pdf = C_EXP * np.exp(-s) + (1 - C_EXP) * inside / (s * ls)
    return s, np.exp(-s) / pdf


@dataclass
class Tally:
    """Raw sums of one run. m[k] (T, nb, nx): sum over scores of w x^k per (camera distance,
    theta bin, excess bin); e[k] (T, N_MU, nx): the same for the forward hemisphere per bin
    of the emission cosine. `norm` turns sums into f per steradian (before the bin's
    solid angle)."""
    g: float
    tau: np.ndarray
    th_edges: np.ndarray
    x_edges: np.ndarray
    photons: int
    m: np.ndarray
    e: np.ndarray
    norm: np.ndarray
    stats: dict = field(default_factory=dict)
    r_max: float = np.inf
    esc_w: np.ndarray = field(default_factory=lambda: np.zeros(0))
    esc_l: np.ndarray = field(default_factory=lambda: np.zeros(0))
    axes: int = 2
    esc_mu: np.ndarray = field(default_factory=lambda: np.zeros(0))


def _excess_bin(ex: np.ndarray, x_edges: np.ndarray) -> np.ndarray:
    """Bin of each excess path in excess_edges: [0, x0), then log-spaced; the last is open."""
    nx = len(x_edges) - 1
    lx0, lx1 = math.log(x_edges[1]), math.log(x_edges[-1])
    x_scale = (nx - 1) / (lx1 - lx0)
    return np.where(ex < x_edges[1], 0,
                    np.clip(np.floor((np.log(np.maximum(ex, 1e-300)) - lx0) * x_scale) + 1, 1, nx - 1)).astype(np.int64)


def _theta_bin(theta: np.ndarray, th_edges: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(th_edges, theta, side="right") - 1, 0, len(th_edges) - 2)


def _mu_bin(mu0: np.ndarray) -> np.ndarray:
    """Bin of the emission cosine (against the camera's direction) among N_MU over [-1, 1]."""
    return np.clip(((mu0 + 1) * (N_MU / 2)).astype(np.int64), 0, N_MU - 1)


def _add_scores(pairs) -> None:
    """Each buffer's scores (index, value, excess path) into its tally's sums of value x
    excess^k, k = 0, 1, 2 (the moments absorption_factor reads); the buffers are emptied."""
    for buf, acc in pairs:
        if buf:
            idx, val, ex = (np.concatenate(c) for c in zip(*buf))
            vx = val * ex
            for k, wk in enumerate((val, vx, vx * ex)):
                acc[k] += np.bincount(idx, wk, minlength=len(acc[k]))
            buf.clear()


def simulate(g: float, tau, photons: int, seed: int, *, axes: int = 2, r_max: float | None = None,
             r_cut: float = 8.0, rr_order: int = 30, rr_keep: float = 0.5, max_order: int | None = None,
             eps_frac: float = 0.1, eps_max: float = 0.6, batch: int = 50_000, th_edges=None, x_edges=None,
             ball: str = "line", axes_far: int | None = None, tau_far: float = 1.0,
             split: int = 10, margin: float = 4.0) -> Tally:
    """Run `photons` photons for asymmetry g and score cameras at distances `tau` on
    `axes` axes (1: +z, 2: +-z, 3..6: +-z, +-x, +-y; with axes_far > axes the extra axes
    score only the cameras at tau >= tau_far). max_order limits the scattering orders
    scored (1 = single scattering, for checks against quadrature).
    ball: "line" (default) maps r -> eps (r / eps)^3 inside the near-camera ball (exact for a
    uniform vertex density, exponentials and absorption included), "avg" the older 3 / eps^2
    with the true r in exp(-r) (biased low by ~ eps / 4 of the ball's share).
    split: weight window by region (see the module docstring); 1 switches it off.
    The previous estimator is ball="avg", r_cut=12, eps_frac=0.05, eps_max=0.3, split=1,
    rr_keep=0.1."""
    tau = np.asarray(tau, np.float64)
    th_edges = theta_edges() if th_edges is None else th_edges
    x_edges = excess_edges() if x_edges is None else x_edges
    r_max = float(3 * tau.max()) if r_max is None else r_max
    nT, nb, nx = len(tau), len(th_edges) - 1, len(x_edges) - 1
    axes_far = axes if axes_far is None else max(axes_far, axes)
    axis_list = [(2, 1.0), (2, -1.0), (0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)][:axes_far]
    far = tau >= tau_far
    # cameras scored per axis: all distances on the first `axes`, only tau >= tau_far on the rest
    axis_cams = [np.arange(nT) if i < axes else np.nonzero(far)[0] for i in range(len(axis_list))]
    n_axes = np.where(far, len(axis_list), axes)
    eps = np.minimum(eps_frac * tau, eps_max)
    m = [np.zeros(nT * nb * nx) for _ in range(3)]
    e = [np.zeros(nT * N_MU * nx) for _ in range(3)]
    rng = np.random.default_rng(seed)
    stats = {"vertices": 0, "pairs": 0, "escaped": 0, "rouletted": 0}
    buf_m, buf_e = [], []
    esc_w, esc_l, esc_mu = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)]   # weight, path length, emission z of photons dropped at r_max
    reach2 = (tau.max() + r_cut) ** 2
    reg_r2, reg_z = (r_cut + margin) ** 2, tau.max() + r_cut + margin   # the scoring region (split)
    nbuf = 0

    def flush():
        _add_scores(((buf_m, m), (buf_e, e)))

    done = 0
    while done < photons:
        n = min(batch, photons - done)
        done += n
        # emission: isotropic source, sampled preferentially towards the +-z cameras
        d, w = emission(rng, n)
        d0 = d.copy()                                  # kept for the emit_mu tally
        pos = np.zeros((n, 3))
        length = np.zeros(n)
        first = True
        order = 0
        in_a = np.ones(n, bool)                        # the source is in the region that scores
        while len(w):
            if first:
                step, wf = first_step(rng, len(w))
                w = w * wf
                first = False
            else:
                step = -np.log1p(-rng.random(len(w)))
            pos += step[:, None] * d
            length += step
            order += 1
            stats["vertices"] += len(w)
            x2 = np.einsum("ij,ij->i", pos, pos)
            near = np.nonzero(x2 < reach2)[0]          # vertices within r_cut of some camera
            dx = np.einsum("ij,ij->i", pos[near], d[near])
            for (ax, sgn), cams in zip(axis_list, axis_cams):
                # camera at sgn * tau along axis ax: everything reduces to the vertex's
                # component xe along the axis and its distance from the axis
                xe = sgn * pos[near, ax]
                de = sgn * d[near, ax]
                tc = tau[cams]
                r2 = x2[near, None] - 2 * xe[:, None] * tc[None, :] + tc[None, :] ** 2
                iv, it = np.nonzero(r2 < r_cut * r_cut)
                if not len(iv):
                    continue
                r = np.sqrt(r2[iv, it])
                it = cams[it]
                stats["pairs"] += len(iv)
                dd = tau[it]
                along = dd - xe[iv]                           # component towards the source
                gv = near[iv]                                 # global photon index
                perp = np.sqrt(np.maximum(x2[gv] - xe[iv] ** 2, 0.0))
                theta = np.arctan2(perp, along)
                cmu = (dd * de[iv] - dx[iv]) / np.maximum(r, 1e-300)
                ep = eps[it]
                inb = r <= ep
                if ball == "line":
                    # inside the ball: r -> eps (r / eps)^3, uniform on [0, eps] for a uniform
                    # vertex density, used in exp(-r) and in the path length (absorption)
                    rl = np.where(inb, ep * (r / np.where(inb, ep, 1.0)) ** 3, r)
                else:
                    rl = r
                att = np.where(inb, 3.0 / (ep * ep), 1.0 / np.maximum(r * r, 1e-300)) * np.exp(-rl)
                val = w[gv] * hg_phase(cmu, g) * att
                ex = np.maximum(length[gv] + rl - dd, 0.0)
                ix = _excess_bin(ex, x_edges)
                ib = _theta_bin(theta, th_edges)
                buf_m.append(((it * nb + ib) * nx + ix, val, ex))
                fw = theta < math.pi / 2
                mu0 = sgn * d0[gv[fw], ax]
                im = _mu_bin(mu0)
                buf_e.append(((it[fw] * N_MU + im) * nx + ix[fw], val[fw], ex[fw]))
                nbuf += len(iv)
            if nbuf > 3_000_000:       # bincount over the big tally only on large chunks
                flush()
                nbuf = 0
            if max_order is not None and order >= max_order:
                break
            if split > 1:
                # weight window by region (importance 1 near the camera axes, 1/split
                # elsewhere): leaving the region, Russian roulette keeps 1/split (weight
                # x split); coming back, the photon is split into `split` copies (weight
                # / split). Unbiased; photons that can score keep their weight.
                now_a = np.zeros(len(w), bool)
                for ax, _ in axis_list[::2] if len(axis_list) > 1 else axis_list:
                    pa2 = x2 - pos[:, ax] ** 2
                    now_a |= (pa2 < reg_r2) & (np.abs(pos[:, ax]) < reg_z)
                leave = in_a & ~now_a
                back = ~in_a & now_a
                dead = leave & (rng.random(len(w)) >= 1.0 / split)
                w = np.where(leave, w * split, w)
                w = np.where(back, w / split, w)
                stats["rouletted"] += int(dead.sum())
                stats["split"] = stats.get("split", 0) + int(back.sum())
                rep = np.where(dead, 0, np.where(back, split, 1))
                if rep.sum() != len(w) or dead.any():
                    ii = np.repeat(np.arange(len(w)), rep)
                    pos, d, d0, length, w, x2 = pos[ii], d[ii], d0[ii], length[ii], w[ii], x2[ii]
                    now_a = now_a[ii]
                in_a = now_a
            # photons beyond r_max are dropped (see the module docstring for what it costs)
            keep = x2 < r_max * r_max
            stats["escaped"] += int((~keep).sum())
            esc_w.append(w[~keep])
            esc_l.append(length[~keep])
            esc_mu.append(d0[~keep, 2])
            if order == rr_order and rr_keep < 1:
                surv = rng.random(len(w)) < rr_keep
                stats["rouletted"] += int((keep & ~surv).sum())
                keep &= surv
                w = w / rr_keep
            pos, d, d0, length, w = pos[keep], d[keep], d0[keep], length[keep], w[keep]
            in_a = in_a[keep]
            d = rotate(d, hg_sample(rng, g, len(w)), rng)
    flush()
    # f per steradian = sum * 4 pi d^2 / (photons * axes * bin solid angle)
    norm = 4 * math.pi * tau ** 2 / (photons * n_axes)
    return Tally(g, tau, th_edges, x_edges, photons,
                 np.stack([a.reshape(nT, nb, nx) for a in m]),
                 np.stack([a.reshape(nT, N_MU, nx) for a in e]), norm, stats,
                 r_max, np.concatenate(esc_w), np.concatenate(esc_l), len(axis_list),
                 np.concatenate(esc_mu))


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
    e = [np.zeros(nT * N_MU * nx) for _ in range(3)]
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
                    ib = _theta_bin(np.arccos(cm), th_edges)
                    kk = order_k[ks]
                    buf_m.append(((kk * nb + ib) * nx + ix, val, ex))
                    fw = cm > 0
                    mu0 = np.einsum("ij,ij->i", d0[hit[fw]], p[fw]) / R[fw]     # emission against the camera's direction
                    im = _mu_bin(mu0)
                    buf_e.append(((kk[fw] * N_MU + im) * nx + ix[fw], val[fw], ex[fw]))
            if max_order is not None and order >= max_order:
                break
            pos += step[:, None] * d
            length += step
            order += 1
            keep = np.einsum("ij,ij->i", pos, pos) < r_max * r_max
            esc_w.append(w[~keep])
            esc_l.append(length[~keep])
            esc_mu.append(d0[~keep, 2])
            if order == rr_order and rr_keep < 1:
                keep &= rng.random(len(w)) < rr_keep
                w = w / rr_keep
            pos, d, d0, length, w = pos[keep], d[keep], d0[keep], length[keep], w[keep]
            d = rotate(d, hg_sample(rng, g, len(w)), rng)
        _add_scores(((buf_m, m), (buf_e, e)))
    # per photon of unit power the crossings sum to 4 pi d^2 L dOmega, and f = L 4 pi d^2
    return Tally(g, tau, th_edges, x_edges, photons, np.stack([a.reshape(nT, nb, nx) for a in m]),
                 np.stack([a.reshape(nT, N_MU, nx) for a in e]), np.full(nT, 1.0 / photons), {"estimator": "crossing"},
                 r_max, np.concatenate(esc_w), np.concatenate(esc_l), 1, np.concatenate(esc_mu))


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
    """f(theta) per steradian (A, T, nb) and the forward-hemisphere energy per emission
    cosine bin (A, T, N_MU), for each albedo. relative=False includes the factor
    exp(-sa d) of the shortest path; relative=True leaves it out (no underflow at large
    sa d; multiply by exp(-sa d) to get f).
    background: add the light of the photons dropped at r_max, in diffusion theory
    (`shell_fluence`, weighted by each photon's exp(-sa l) at the drop): an isotropic
    radiance phi / (4 pi) at the camera, i.e. f_bg = d^2 phi / N per steradian."""
    albedo = np.atleast_1d(np.asarray(albedo, np.float64))
    dom = 2 * math.pi * (np.cos(t.th_edges[:-1]) - np.cos(t.th_edges[1:]))
    f = np.empty((len(albedo), len(t.tau), len(dom)))
    em = np.empty((len(albedo), len(t.tau), N_MU))
    for i, a in enumerate(albedo):
        sa = (1 - a) / a
        shift = 0.0 if relative else 1.0
        base = np.exp(-sa * t.tau * shift)[:, None] * t.norm[:, None]
        f[i] = absorption_factor(t, sa, t.m) * base / dom
        em[i] = absorption_factor(t, sa, t.e) * base
        if background and len(t.esc_w):
            # exp(-sa l) relative to exp(-sa d) per camera (l >= r_max > d: no overflow)
            wl = t.esc_w[None, :] * np.exp(-sa * (t.esc_l[None, :] - t.tau[:, None] * (1 - shift)))
            fbg = t.tau ** 2 / t.photons * wl.sum(1) * shell_fluence(t.tau, t.r_max, sa, t.g)
            f[i] += fbg[:, None]
            # its forward half, split by emission cosine (cameras on +z and -z: both signs)
            h = np.zeros((len(t.tau), N_MU))
            for sgn in (1.0, -1.0):
                im = _mu_bin(sgn * t.esc_mu)
                for k in range(len(t.tau)):
                    h[k] += np.bincount(im, wl[k], minlength=N_MU)
            h /= np.maximum(h.sum(1, keepdims=True), 1e-300)
            em[i] += 2 * math.pi * fbg[:, None] * h
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
