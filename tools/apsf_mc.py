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

import numpy as np

# The emission tally: the cosine mu0 between a scored photon's emission direction and the
# source->camera direction, per class of the angle theta at which the camera sees it arrive.
# mu0 bins: 12 equal over [-1, 0.8), then finer towards 1, where forward phases put most of
# the light seen near the source (of 20 equal bins, [0.9, 1] held 78 % at tau 0.5 and was
# scored at 0.95). theta classes: a frame sees the light arriving within its own field of
# view, which leaves a source nearer the camera's direction than the whole hemisphere's does
# (emission.lambert_weight).
MU_EDGES = np.concatenate([np.linspace(-1.0, 0.8, 13), [0.9, 0.95, 0.98, 0.995, 1.0]])
N_MU = len(MU_EDGES) - 1
EMIT_THETA = np.radians([0.0, 3.0, 7.0, 13.0, 21.0, 32.0, 48.0, 90.0])
N_TH = len(EMIT_THETA) - 1


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
    theta bin, excess bin); e[k] (T, N_TH, N_MU, nx): the same for the forward hemisphere per
    class of theta (EMIT_THETA) and bin of the emission cosine (MU_EDGES). `norm` turns sums into f per steradian (before the bin's
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
    """Bin of the emission cosine (against the camera's direction) in MU_EDGES."""
    return np.clip(np.searchsorted(MU_EDGES, mu0, side="right") - 1, 0, N_MU - 1)


def _emit_index(cam: np.ndarray, theta: np.ndarray, mu0: np.ndarray) -> np.ndarray:
    """Flat (camera, theta class, mu0 bin) index of forward-hemisphere scores (theta < pi/2)."""
    ic = np.clip(np.searchsorted(EMIT_THETA, theta, side="right") - 1, 0, N_TH - 1)
    return (cam * N_TH + ic) * N_MU + _mu_bin(mu0)


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


@dataclass
class _Cameras:
    """Where `simulate` scores: cameras at distances tau on the axes (axis, sign), the
    cameras each axis has, the near-camera balls' radii eps, the scoring radius r_cut, the
    ball's estimator, the bins."""
    tau: np.ndarray
    axis_list: list
    axis_cams: list
    eps: np.ndarray
    r_cut: float
    reach2: float
    ball: str
    th_edges: np.ndarray
    x_edges: np.ndarray


def _cameras(tau, axes: int, axes_far, tau_far: float, eps_frac: float, eps_max: float, r_cut: float, ball: str,
             th_edges, x_edges) -> tuple[_Cameras, np.ndarray]:
    """The cameras of `simulate` (all distances on the first `axes` axes, only tau >=
    tau_far on the rest) and how many axes score each distance."""
    nT = len(tau)
    axes_far = axes if axes_far is None else max(axes_far, axes)
    axis_list = [(2, 1.0), (2, -1.0), (0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)][:axes_far]
    far = tau >= tau_far
    axis_cams = [np.arange(nT) if i < axes else np.nonzero(far)[0] for i in range(len(axis_list))]
    eps = np.minimum(eps_frac * tau, eps_max)
    reach2 = (tau.max() + r_cut) ** 2
    return (_Cameras(tau, axis_list, axis_cams, eps, r_cut, reach2, ball, th_edges, x_edges),
            np.where(far, len(axis_list), axes))


def _score_cameras(pos, d, d0, w, length, x2, c: _Cameras, g: float, buf_m: list, buf_e: list, stats: dict) -> int:
    """The point estimator: every vertex within r_cut of a camera scores its next-event
    estimate into the buffers (theta and excess bins; the forward ones by emission cosine
    too). Returns how many scores it added."""
    tau, axis_list, axis_cams, eps, r_cut, reach2, ball = (c.tau, c.axis_list, c.axis_cams, c.eps, c.r_cut,
                                                            c.reach2, c.ball)
    th_edges, x_edges = c.th_edges, c.x_edges
    nb, nx = len(th_edges) - 1, len(x_edges) - 1
    scored = 0
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
        buf_e.append((_emit_index(it[fw], theta[fw], mu0) * nx + ix[fw], val[fw], ex[fw]))
        scored += len(iv)
    return scored


def _survivors(x2, w, length, d0, esc: tuple, order: int, rr_order: int, rr_keep: float, r_max: float, rng,
               stats: dict | None = None):
    """(which photons fly on, their weights): those beyond r_max are dropped (their weight,
    path length and emission z appended to esc), and after rr_order scatterings Russian
    roulette keeps rr_keep of the rest (weight / rr_keep)."""
    keep = x2 < r_max * r_max
    if stats is not None:
        stats["escaped"] += int((~keep).sum())
    esc[0].append(w[~keep])
    esc[1].append(length[~keep])
    esc[2].append(d0[~keep, 2])
    if order == rr_order and rr_keep < 1:
        surv = rng.random(len(w)) < rr_keep
        if stats is not None:
            stats["rouletted"] += int((keep & ~surv).sum())
        keep &= surv
        w = w / rr_keep
    return keep, w


def _weight_window(pos, d, d0, length, w, x2, in_a, axis_list, reg_r2, reg_z, split, rng, stats):
    """The weight window by region (importance 1 near the camera axes, 1/split elsewhere):
    leaving the region, Russian roulette keeps 1/split (weight x split); coming back, the
    photon is split into `split` copies (weight / split). Unbiased; photons that can score
    keep their weight. Returns the photons' arrays and whether each is in the region."""
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
    return pos, d, d0, length, w, x2, in_a


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
    cams_at, n_axes = _cameras(tau, axes, axes_far, tau_far, eps_frac, eps_max, r_cut, ball, th_edges, x_edges)
    axis_list = cams_at.axis_list
    m = [np.zeros(nT * nb * nx) for _ in range(3)]
    e = [np.zeros(nT * N_TH * N_MU * nx) for _ in range(3)]
    rng = np.random.default_rng(seed)
    stats = {"vertices": 0, "pairs": 0, "escaped": 0, "rouletted": 0}
    buf_m, buf_e = [], []
    esc_w, esc_l, esc_mu = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)]   # weight, path length, emission z of photons dropped at r_max
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
            nbuf += _score_cameras(pos, d, d0, w, length, x2, cams_at, g, buf_m, buf_e, stats)
            if nbuf > 3_000_000:       # bincount over the big tally only on large chunks
                flush()
                nbuf = 0
            if max_order is not None and order >= max_order:
                break
            if split > 1:
                pos, d, d0, length, w, x2, in_a = _weight_window(pos, d, d0, length, w, x2, in_a, axis_list, reg_r2,
                                                                 reg_z, split, rng, stats)
            # photons beyond r_max are dropped (see the module docstring for what it costs)
            keep, w = _survivors(x2, w, length, d0, (esc_w, esc_l, esc_mu), order, rr_order, rr_keep, r_max, rng, stats)
            pos, d, d0, length, w = pos[keep], d[keep], d0[keep], length[keep], w[keep]
            in_a = in_a[keep]
            d = rotate(d, hg_sample(rng, g, len(w)), rng)
    flush()
    # f per steradian = sum * 4 pi d^2 / (photons * axes * bin solid angle)
    norm = 4 * math.pi * tau ** 2 / (photons * n_axes)
    return Tally(g, tau, th_edges, x_edges, photons,
                 np.stack([a.reshape(nT, nb, nx) for a in m]),
                 np.stack([a.reshape(nT, N_TH, N_MU, nx) for a in e]), norm, stats,
                 r_max, np.concatenate(esc_w), np.concatenate(esc_l), len(axis_list),
                 np.concatenate(esc_mu))


