"""The multiple-scattering point spread (`render.psf: apsf`).

`data/apsf.npz` (made by `tools/make_apsf_table.py` with `apsf_mc.py`) holds, over a
grid of optical distance tau = ss P, single-scattering albedo a = ss / (sa + ss) and phase
asymmetry g, what an isotropic point source seen through the medium sends to the camera
as scattered light: its energy (relative to the unscattered image of the source) and how
that energy spreads, as weights on 2-D Gaussians of widths `sigma_u` in the image plane
(u = tan of the angle from the source; a pixel r_px from the source is at u = r_px / f_px).

Per image the host turns the table into a small lookup table in log P (one per RGB
channel, since the albedo is per channel) that the kernels read:
  * the energy ratio against the thin-medium form exp(-sa P)(1 - exp(-ss P));
  * per pyramid level k, the fractions of the light still travelling up the pyramid that
    level k keeps sharp, keeps with its half-octave blur, and passes on (the Gaussians of
    the table mapped to the pyramid's widths through f_px: results do not depend on the
    resolution);
  * for the reference, the weight of every table Gaussian;
  * for `emission_profile: lambertian`, the energy weight per view cosine.
"""
from __future__ import annotations

import math
from functools import lru_cache
from importlib import resources

import numpy as np

from fogcli.errors import interrupt_held
from fogcli.physics.glow_depth import NU, receiver_table

NP = 128          # samples of log P in the device lookup table
HEADER = 4        # lp0, 1 / dlp, NP, number of levels (floats)
NC = 16           # samples of the view cosine (emission_profile: lambertian) ...
COS_MIN = 0.05    # ... from here to 1; grazing views clamp here


def read_data(name: str) -> dict:
    """Every array of the shipped table physics/data/<name>.npz. A Ctrl-C is held until the
    file is read and closed, its NpzFile freed too: an interrupt inside NpzFile.__del__ is
    printed and dropped by Python, and the command would go on."""
    def read() -> dict:
        with resources.files("fogcli.physics").joinpath(f"data/{name}.npz").open("rb") as f, np.load(f) as z:
            return {k: np.array(z[k]) for k in z.files}

    with interrupt_held():
        return read()


@lru_cache(maxsize=1)
def load_table() -> dict:
    z = read_data("apsf")
    tab = {k: np.asarray(z[k], np.float64) for k in z if k in
           ("g", "albedo", "tau", "sigma_u", "weights", "energy", "emit_mu_edges", "emit_theta", "ratio")}
    # emit_mu stays float16 as shipped: as float64 it was 19 MB and ~23 ms of every start-up;
    # _slice_ga widens the two g slices it reads (exactly: float16 -> float64)
    tab["emit_mu"] = z["emit_mu"]
    return with_ratios(tab)


def with_ratios(tab: dict) -> dict:
    """Add what is interpolated: the energy over thin_energy (the table's own `ratio`
    where it has one: energy underflows float32 in thick absorbing media, the ratio does
    not) and the normalised weights."""
    if "ratio" not in tab:
        thin = thin_energy(tab["tau"][None, :], tab["albedo"][:, None])
        tab["ratio"] = tab["energy"] / np.maximum(thin, 1e-300)[None]
    tab["ratio"] = np.nan_to_num(tab["ratio"], nan=0.0, posinf=0.0)
    tab["shape"] = tab["weights"] / np.maximum(tab["weights"].sum(-1, keepdims=True), 1e-300)
    return tab


def thin_energy(tau, albedo):
    """exp(-sa P)(1 - exp(-ss P)) in units of the scattering length (tau = ss P)."""
    tau = np.asarray(tau, np.float64)
    albedo = np.asarray(albedo, np.float64)
    sa_p = tau * (1.0 - albedo) / np.maximum(albedo, 1e-12)
    return np.exp(-sa_p) * -np.expm1(-tau)


def single_share(tau) -> np.ndarray:
    """Of the light a point source loses to scattering on its way to the camera, the share
    that scattered once: tau e^-tau / (1 - e^-tau) (tau = ss P; at small angles every order
    travels about the camera's distance, so the orders are Poisson in tau). 1 at tau 0,
    0.58 at 1, 0.015 at 5."""
    tau = np.maximum(np.asarray(tau, np.float64), 1e-12)
    return tau * np.exp(-tau) / -np.expm1(-tau)


def _bracket(grid: np.ndarray, x: float) -> tuple[int, float]:
    """Index i and weight t of x between grid[i] and grid[i+1], clamped to the grid."""
    x = min(max(x, grid[0]), grid[-1])
    i = int(np.clip(np.searchsorted(grid, x) - 1, 0, len(grid) - 2))
    return i, (x - grid[i]) / (grid[i + 1] - grid[i])


def _absorption_q(albedo):
    """sqrt(s), s = (1 - a) / a the absorption per scattering length: in diffusion the light
    falls off like exp(-d sqrt(3 (1 - g) s)), so the table is close to linear in it."""
    a = np.asarray(albedo, np.float64)
    return np.sqrt((1.0 - a) / a)


def albedo_weights(grid: np.ndarray, albedo: float) -> np.ndarray:
    """Weights w over the albedo grid such that w @ values is the natural cubic spline in
    q = sqrt((1 - a) / a) through the values, at albedo (clamped to the grid). A spline is
    linear in the values, so one weight vector serves every g, tau and Gaussian."""
    x = _absorption_q(np.asarray(grid, np.float64))[::-1]          # ascending in q
    n = len(x)
    h = np.diff(x)
    # second derivatives m = Minv @ y (natural: m = 0 at both ends)
    T = np.diag(2.0 * (h[:-1] + h[1:])) + np.diag(h[1:-1], 1) + np.diag(h[1:-1], -1)
    D = np.zeros((n - 2, n))
    i = np.arange(n - 2)
    D[i, i], D[i, i + 1], D[i, i + 2] = 6.0 / h[:-1], -6.0 / h[:-1] - 6.0 / h[1:], 6.0 / h[1:]
    Minv = np.zeros((n, n))
    Minv[1:-1] = np.linalg.solve(T, D)
    q = float(np.clip(_absorption_q(min(max(albedo, grid[0]), grid[-1])), x[0], x[-1]))
    k = int(np.clip(np.searchsorted(x, q) - 1, 0, n - 2))
    t = (q - x[k]) / h[k]
    w = h[k] ** 2 / 6.0 * (((1 - t) ** 3 - (1 - t)) * Minv[k] + (t ** 3 - t) * Minv[k + 1])
    w[k] += 1 - t
    w[k + 1] += t
    return w[::-1]


def _slice_ga(tab: dict, key: str, g: float, albedo: float) -> np.ndarray:
    """tab[key] interpolated at (g, albedo): an array over tau (and more). Linear in g; across
    albedo a natural cubic spline in sqrt((1 - a) / a) (albedo_weights), the energy ratio as
    its logarithm, distributions (shape, emit_mu) kept non-negative (_non_negative). Measured
    free of the Monte Carlo noise by tools/apsf_grid_check.py (docs/apsf-table.md,
    Interpolation error of the shipped grid): below tau 5 the energy is within 0.5 % at every
    albedo midpoint (linear in q: 2.3 %); the shape's ring L1 p90 0.2 % (linear: 0.4 %), worst
    3.1 % (linear: 1.6 %) where the non-negative fits of neighbouring entries put the light in
    different Gaussians."""
    ig, tg = _bracket(tab["g"], g)
    w = albedo_weights(tab["albedo"], albedo)
    v = tab[key]
    if key == "ratio":
        v = np.log(np.maximum(v, 1e-300))
    out = (1 - tg) * np.tensordot(w, v[ig], axes=(0, 0)) + tg * np.tensordot(w, v[ig + 1], axes=(0, 0))
    if key == "ratio":
        return np.exp(out)
    return _non_negative(out) if key in ("shape", "emit_mu") else out


def _non_negative(w: np.ndarray) -> np.ndarray:
    """A distribution over the last axis with the spline's dips below 0 (the table's weights
    are non-negative fits that switch between neighbouring Gaussians from one albedo to the
    next) taken out of its neighbours: the cumulative sum made monotone from both ends and
    averaged, so the total stays. Clipping at 0 and renormalising instead more than doubled
    the shape's worst interpolation error (tools/apsf_grid_check.py)."""
    c = np.cumsum(w, -1)
    total = c[..., -1:]
    up = np.minimum(np.maximum.accumulate(c, -1), total)
    down = np.maximum(np.minimum.accumulate(c[..., ::-1], -1)[..., ::-1], 0.0)
    c = 0.5 * (up + down)
    return np.diff(c, axis=-1, prepend=0.0)


def spread(tab: dict, g: float, albedo: float, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ratio, shape): the scattered energy over thin_energy, and the normalised weights of
    the table's Gaussians (..., J), at optical distances tau (clamped to the table's range,
    where the shape has settled: the single-scattering shape below, the diffuse one above).
    Interpolated linearly in log tau, albedo and g; the ratio rather than the energy,
    because it varies slowly where the energy itself changes by orders of magnitude, and
    its logarithm along tau (log_along_tau)."""
    ratio = log_along_tau(tab, _slice_ga(tab, "ratio", g, albedo), tau)
    return ratio, _along_tau(tab, _slice_ga(tab, "shape", g, albedo), tau)


def log_along_tau(tab: dict, ratio: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """A positive ratio over tau (T,) at tau, its logarithm linear in log tau: at large tau
    the ratio falls like exp(-c tau) where the light diffuses and is absorbed, which the
    ratio itself follows badly between the grid's taus (tools/apsf_grid_check.py)."""
    lr = np.log(np.maximum(ratio, 1e-300))[:, None]
    return np.exp(_along_tau(tab, lr, tau)[..., 0])


def _along_tau(tab: dict, per_tau: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """per_tau (T, ...) interpolated linearly in log tau at tau, clamped to the grid."""
    tgrid = np.log(tab["tau"])
    lt = np.clip(np.log(np.maximum(np.asarray(tau, np.float64), 1e-300)), tgrid[0], tgrid[-1])
    i = np.clip(np.searchsorted(tgrid, lt) - 1, 0, len(tgrid) - 2)
    t = ((lt - tgrid[i]) / (tgrid[i + 1] - tgrid[i]))[..., None]
    return (1 - t) * per_tau[i] + t * per_tau[i + 1]


def lambert_gain(mu0: np.ndarray, cos_view: np.ndarray) -> np.ndarray:
    """A Lambertian surface's intensity over an isotropic source's (both send the camera the
    same radiance) in the directions at cosine mu0 from the line to the camera, averaged
    over their azimuth, for a normal at cosine cos_view to that line: (len(mu0), len(cos_view)).
    The surface emits max(0, cos_view mu0 + sin_view sqrt(1 - mu0^2) cos(phi)) / cos_view
    times the isotropic source's intensity; the average over phi is closed form."""
    mu = np.asarray(mu0, np.float64)[:, None]
    ct = np.asarray(cos_view, np.float64)[None, :]
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    A = ct * mu
    B = st * np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        phi0 = np.arccos(np.clip(np.where(B > 0, -A / B, np.sign(-A) * 2.0), -1.0, 1.0))
    return (A * phi0 + B * np.sin(phi0)) / np.pi / ct


def lambert_weight(tab: dict, g: float, albedo: float, tau: np.ndarray, cos_view: np.ndarray,
                   seen: np.ndarray | None = None) -> np.ndarray:
    """Scattered energy of a Lambertian emitter over that of the isotropic source the table
    assumes, (len(tau), len(cos_view)). Both send the camera the same radiance; they differ
    in what they emit elsewhere. The table gives, per class of the angle theta at which the
    light reaches the camera (`emit_theta`), the directions in which it left the source
    (cosine mu0 against the line to the camera); the weight averages lambert_gain over them.
    seen: the share of each theta class that lands in the frame (theta_seen); the default
    counts the whole forward hemisphere. Light arriving far from the source left it far
    from the camera's direction, where a surface facing the camera emits little: a frame
    that sees only the near classes sees a larger weight (at tau 2 in fog, 0.90 within 10
    degrees against 0.80 over the hemisphere)."""
    joint = _slice_ga(tab, "emit_mu", g, albedo)                                # (tau grid, C, M)
    em = _along_tau(tab, joint.reshape(len(joint), -1), tau).reshape((-1,) + joint.shape[1:])
    edges = tab["emit_mu_edges"]
    per_class = em @ lambert_gain(0.5 * (edges[:-1] + edges[1:]), cos_view)   # (T, C, V)
    share = em.sum(-1)                                                         # (T, C)
    s = np.ones(share.shape[-1]) if seen is None else np.asarray(seen, np.float64)
    return (per_class * s[None, :, None]).sum(1) / np.maximum(share @ s, 1e-300)[:, None]


def theta_seen(theta_edges: np.ndarray, focal_px: float, width: int, height: int, n: int = 12) -> np.ndarray:
    """Per class of theta (edges in radians), the share of the directions at those angles from
    a source in the frame that land in the frame (by solid angle): rings of sub-angles across
    each class, around sources on an n x n grid over the frame, through the pinhole."""
    sub = 4
    th = np.concatenate([np.linspace(a, b, sub + 2)[1:-1] for a, b in zip(theta_edges[:-1], theta_edges[1:])])
    phi = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
    g = (np.arange(n) + 0.5) / n
    sx, sy = np.meshgrid((g - 0.5) * width, (g - 0.5) * height)
    s = np.stack([sx.ravel(), sy.ravel(), np.full(n * n, focal_px)], -1)
    s /= np.linalg.norm(s, axis=-1, keepdims=True)                             # (S, 3)
    a = np.cross(s, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a, axis=-1, keepdims=True)
    b = np.cross(s, a)
    ring = np.cos(phi)[:, None, None] * a[None] + np.sin(phi)[:, None, None] * b[None]        # (F, S, 3)
    v = np.cos(th)[:, None, None, None] * s[None, None] + np.sin(th)[:, None, None, None] * ring[None]
    z = v[..., 2]
    ok = z > 1e-9
    zs = np.where(ok, z, 1.0)
    inside = ok & (np.abs(v[..., 0] / zs * focal_px) <= width / 2) & (np.abs(v[..., 1] / zs * focal_px) <= height / 2)
    sw = np.sin(th).reshape(-1, sub)
    return (inside.mean(axis=(1, 2)).reshape(-1, sub) * sw).sum(-1) / sw.sum(-1)


def slot_widths(levels: int, c: float, half_var: float) -> np.ndarray:
    """Blur (std-dev, level-0 px) of what the source collapse leaves at each slot: level k
    sharp (c 2^k; 0 at level 0, which is not filtered) and level k with its half-octave
    3x3 blur (variance half_var in level-k pixels, added)."""
    out = []
    for k in range(levels + 1):
        base2 = 0.0 if k == 0 else (c * 2.0 ** k) ** 2
        out += [math.sqrt(base2), math.sqrt(base2 + half_var * 4.0 ** k)]
    return np.array(out[:-1])   # the top level keeps all it gets, sharp


def to_slots(shape: np.ndarray, sigma_px: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """Each Gaussian of width sigma_px split between the two slots around it so that the
    variance is kept; narrower than slot 0 stays there, wider than the top goes to the top."""
    if len(slots) == 1:
        return shape.sum(axis=-1, keepdims=True)
    v2, s2 = sigma_px ** 2, slots ** 2
    j = np.clip(np.searchsorted(s2, v2) - 1, 0, len(slots) - 2)
    t = np.clip((v2 - s2[j]) / np.maximum(s2[j + 1] - s2[j], 1e-30), 0.0, 1.0)
    m = np.zeros((len(sigma_px), len(slots)))
    m[np.arange(len(sigma_px)), j] = 1 - t
    m[np.arange(len(sigma_px)), j + 1] += t
    return shape @ m


def fractions(slot_w: np.ndarray, levels: int) -> tuple[np.ndarray, np.ndarray]:
    """(up, half) per level (..., levels + 1): of what reaches level k, the share passed on
    and the share kept with the half-octave blur; the rest is kept sharp."""
    n = slot_w.shape[-1]
    rem = np.cumsum(slot_w[..., ::-1], axis=-1)[..., ::-1]   # weight of slots >= s
    up = np.zeros(slot_w.shape[:-1] + (levels + 1,))
    half = np.zeros_like(up)
    for k in range(levels + 1):
        r = rem[..., 2 * k]
        safe = np.where(r > 1e-12, r, 1.0)
        if 2 * k + 2 < n:
            up[..., k] = np.where(r > 1e-12, rem[..., 2 * k + 2] / safe, 0.0)
        if 2 * k + 1 < n:
            half[..., k] = np.where(r > 1e-12, slot_w[..., 2 * k + 1] / safe, 0.0)
    return up, half


def p_range(ss, tab: dict) -> tuple[float, float]:
    """log P range covering the table's tau for every scattering channel."""
    ss = [s for s in ss if s > 0]
    if not ss:
        return 0.0, 1.0
    lo = math.log(tab["tau"][0] / max(ss))
    hi = math.log(tab["tau"][-1] / min(ss))
    return lo, max(hi, lo + 1e-3)


def frame_share(x0, n0: int, sigma: float) -> np.ndarray:
    """Along one axis, the share of a Gaussian of `sigma` px centred at x0 (level-0 px)
    that lands in [0, n0]."""
    x0 = np.asarray(x0, np.float64)
    if sigma <= 0:
        return np.ones_like(x0)
    k = 1.0 / (math.sqrt(2.0) * sigma)
    erf = np.vectorize(math.erf, otypes=[float])
    return 0.5 * (erf((n0 - x0) * k) + erf(x0 * k))


def in_frame(sigma: np.ndarray, width: int, height: int) -> np.ndarray:
    """Share of a Gaussian of `sigma` px centred in a width x height frame that lands in it."""
    return np.array([float(frame_share(width / 2, width, s) * frame_share(height / 2, height, s))
                     for s in np.atleast_1d(sigma)])


def build_lut(sa, ss, g: float, focal_px: float, spread_scale: float, levels: int, c: float,
              half_var: float, tab: dict | None = None, frame: tuple[int, int] | None = None,
              size: tuple[int, int] | None = None, halo_depth: bool = False) -> np.ndarray:
    """The device table: header, then up/half per (level, channel), the energy ratio per
    channel, the weight of each table Gaussian per channel (reference), and the Lambertian
    weight per view cosine and channel times the energy ratio. float32.
    frame: (width, height) with the open border. The top level is a single blur about as
    wide as the frame; light of the table's wider Gaussians mostly leaves an open frame,
    so of what reaches the top level only the share that such a Gaussian would leave in
    the frame (centred, against the top level's own width) stays: `up` of the top level
    is the share lost.
    size: (width, height) of the image, whose field of view the Lambertian weight counts
    (theta_seen); None: the whole forward hemisphere.
    halo_depth: per level (its angle) and log P, the share of the light a receiver at u
    times the source's distance keeps (glow_depth.receiver_table, extinction averaged over
    the channels); without, ones."""
    tab = load_table() if tab is None else tab
    lp0, lp1 = p_range(ss, tab)
    P = np.exp(np.linspace(lp0, lp1, NP))
    J = len(tab["sigma_u"])
    sigma_px = tab["sigma_u"] * focal_px * spread_scale
    slots = slot_widths(levels, c, half_var)
    updown = np.zeros((levels + 1, 3, 2, NP))
    ratio = np.zeros((3, NP))
    shape = np.zeros((J, 3, NP))
    lambert = np.ones((NC, 3, NP))
    cos_grid = np.linspace(COS_MIN, 1.0, NC)
    seen = None if size is None or "emit_theta" not in tab else theta_seen(tab["emit_theta"], focal_px, *size)
    for ch in range(3):
        if ss[ch] <= 0:
            continue   # no scattering in this channel: nothing to spread
        a = ss[ch] / (sa[ch] + ss[ch])
        r, sh = spread(tab, g, a, ss[ch] * P)
        v = to_slots(sh, sigma_px, slots)
        up, half = fractions(v, levels)
        if frame is not None:
            wide = sigma_px > slots[-1]
            keep = in_frame(sigma_px[wide], *frame) / in_frame(np.array([slots[-1]]), *frame)[0]
            lost = (sh[:, wide] * (1.0 - np.minimum(keep, 1.0))).sum(-1)
            top = np.maximum(v[:, -1], 1e-30)
            up[:, levels] = np.clip(lost / top, 0.0, 1.0)
        updown[:, ch, 0, :] = up.T
        updown[:, ch, 1, :] = half.T
        ratio[ch] = r
        shape[:, ch, :] = sh.T
        if "emit_mu" in tab:
            lambert[:, ch, :] = lambert_weight(tab, g, a, ss[ch] * P, cos_grid, seen).T
    recv = np.ones((levels + 1, NP, NU))
    if halo_depth:
        s_k = np.array([math.sqrt(max(slots[2 * k], 1e-3) * slots[min(2 * k + 1, len(slots) - 1)])
                        for k in range(levels + 1)])
        theta = 1.2533 * s_k / max(focal_px * spread_scale, 1e-30)     # a 2-D Gaussian's mean radius
        recv = receiver_table(float(np.mean(np.asarray(sa) + np.asarray(ss))), g, P, theta)
    head = np.array([lp0, (NP - 1) / (lp1 - lp0), NP, levels + 1])
    # the Lambertian weight times the ratio, which the kernels interpolate as one table where
    # they need both: 4 table reads a pixel fewer than the two apart (gathers, on AVX2)
    return np.concatenate([head, updown.ravel(), ratio.ravel(), shape.ravel(),
                           (lambert * ratio[None]).ravel(), recv.ravel()]).astype(np.float32)


def edge_tables(sizes: list[tuple[int, int]], c: float, half_var: float) -> tuple[np.ndarray, list[int]]:
    """Open border: per level, the share of a Gaussian of the sharp slot's width, centred
    on each level pixel, that lands in the frame along x (w_k values) and along y (h_k),
    then the same for the half-blurred slot. The kernels multiply the x and y factors.
    Returns the float32 table and each level's offset into it."""
    W, H = sizes[0]
    levels = len(sizes) - 1
    slots = slot_widths(levels, c, half_var)
    parts, offs, o = [], [], 0
    for k, (w, h) in enumerate(sizes):
        sharp = slots[2 * k]
        half = slots[2 * k + 1] if 2 * k + 1 < len(slots) else sharp
        offs.append(o)
        xs, ys = 2.0 ** k * (np.arange(w) + 0.5), 2.0 ** k * (np.arange(h) + 0.5)   # level-0 centres
        for sg in (sharp, half):
            parts += [frame_share(xs, W, sg), frame_share(ys, H, sg)]
        o += 2 * (w + h)
    return np.concatenate(parts).astype(np.float32), offs


UP_TENT = ((0.25, 0.75), (0.75, 0.25))   # (even, odd) output: weights of taps t = 0, 1
UP_BSPLINE = ((0.00260417, 0.31510417, 0.61197917, 0.0703125),
              (0.0703125, 0.61197917, 0.31510417, 0.00260417))


def up2_taps(n_out: int, cubic: bool):
    """(first input index, weights) of the factor-2 up-sampling of every output pixel (the
    fixed-phase taps of up2_fetch4 in kernels/common.h)."""
    for y in range(n_out):
        if cubic:
            yield (y >> 1) - 2 + (y & 1), UP_BSPLINE[y & 1]
        else:
            yield (y >> 1) - 1 + (y & 1), UP_TENT[y & 1]


def conservation_tables(sizes: list[tuple[int, int]], taps, cubic: bool,
                        open_border: bool = False) -> tuple[np.ndarray, list[int]]:
    """Energy-conserving borders for the apsf chain. The plain filters keep a constant
    image constant at the border but not its energy (a bright source near the edge of a
    small level gains up to tens of per cent). Here each SOURCE pixel's weights are
    normalised instead: in the reduce, each level-(k-1) pixel hands on exactly its energy
    (1 / the share of its filter weights that land on level-k pixels), and in the
    up-sampling, each level-k pixel hands level k-1 exactly its energy (taps outside are
    zero, 2 / its weights that land). Per level k >= 1 and axis: the reduce factors of
    level k-1's pixels, then the up-sampling factors of level k's pixels.
    Returns the float32 table and each level's offset (index k; level 0 has none)."""
    taps = np.asarray(taps, np.float64)
    T = len(taps)
    parts, offs, o = [], [0], 0

    # bincount adds in the order of its input, here (output pixel, tap) as a loop over both
    # would: the same sums, in microseconds instead of 60 ms a frame size at 2 MPx
    def reduce_norm(n_src: int, n_dst: int) -> np.ndarray:
        s = 2 * np.arange(n_dst)[:, None] - T // 2 + 1 + np.arange(T)[None, :]
        w = np.broadcast_to(taps, s.shape)
        ok = (s >= 0) & (s < n_src)
        return 0.5 / np.bincount(s[ok], w[ok], minlength=n_src)

    up_w = np.asarray(UP_BSPLINE if cubic else UP_TENT, np.float64)

    def up_norm(n_in: int, n_out: int) -> np.ndarray:
        y = np.arange(n_out)
        j = ((y >> 1) - (2 if cubic else 1) + (y & 1))[:, None] + np.arange(up_w.shape[1])[None, :]
        w = up_w[y & 1]
        ok = (j >= 0) & (j < n_in) if open_border else np.ones(j.shape, bool)
        got = np.bincount(np.clip(j[ok], 0, n_in - 1), w[ok], minlength=n_in)
        return 2.0 / np.maximum(got, 1e-12)

    for k in range(1, len(sizes)):
        (sw, sh), (dw, dh) = sizes[k - 1], sizes[k]
        offs.append(o)
        part = [reduce_norm(sw, dw), reduce_norm(sh, dh), up_norm(dw, sw), up_norm(dh, sh)]
        parts += part
        o += sum(len(p) for p in part)
    return (np.concatenate(parts) if parts else np.zeros(1)).astype(np.float32), offs


def lut_offsets(levels: int, J: int) -> dict:
    """Float offsets of the parts of build_lut's table (the kernels compute the same)."""
    up = HEADER
    ratio = up + (levels + 1) * 3 * 2 * NP
    shape = ratio + 3 * NP
    lambert = shape + J * 3 * NP
    recv = lambert + NC * 3 * NP
    return {"updown": up, "ratio": ratio, "shape": shape, "lambert": lambert, "recv": recv,
            "end": recv + (levels + 1) * NP * NU}
