"""The multiple-scattering point spread (`render.psf: apsf`).

`data/apsf.npz` (made by `tools/make_apsf_table.py` with `apsf_mc.py`) holds, over a
grid of optical distance tau = ss P, single-scattering albedo a = ss / (sa + ss) and phase
asymmetry g, what an isotropic point source seen through the medium sends to the camera
as scattered light: its energy (relative to the unscattered image of the source) and how
that energy spreads, as weights on 2-D Gaussians of widths `sigma_u` in the image plane
(u = tan of the angle from the source; a pixel r_px from the source is at u = r_px / f_px).

Per image the host turns the table into a small lookup table in log P (one per RGB
channel, since the albedo is per channel) that the kernels read (apsf_lut.build_lut):
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

NP = 128          # samples of log P in the device lookup table
HEADER = 4        # lp0, 1 / dlp, NP, number of levels (floats)


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


THETA_FIT = 1.0   # radians: the angles over which theta_plane matches each Gaussian


@lru_cache(maxsize=4)
def _theta_plane(sigma_u: tuple) -> tuple[np.ndarray, np.ndarray]:
    out_e, out_s = [], []
    for sg in sigma_u:
        th = np.linspace(0.0, min(THETA_FIT, 6.0 * sg), 400)[1:]
        y = np.exp(-0.5 * (np.tan(th) / sg) ** 2) / np.cos(th) ** 3         # over its value at theta 0
        wgt = y * th                                                         # what a ring of pixels holds
        x = th * th
        ly = np.log(np.maximum(y, 1e-300))
        xm, ym = (wgt * x).sum() / wgt.sum(), (wgt * ly).sum() / wgt.sum()
        a = -(wgt * (x - xm) * (ly - ym)).sum() / (wgt * (x - xm) ** 2).sum()   # exp(-a theta^2)
        if a <= 1.0 / (2.0 * sg * sg):      # no narrower than in u: flatter is the horizon's 1 / cos^3
            out_s.append(sg)
            out_e.append(1.0)
            continue
        st2 = 1.0 / (2.0 * a)
        out_s.append(math.sqrt(st2))
        out_e.append(math.exp(ym + a * xm) * st2 / (sg * sg))               # the line's density at theta 0
    return np.array(out_e), np.array(out_s)


def theta_plane(sigma_u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e, sigma_theta) per table Gaussian for a plane of angles (`render.spread_space:
    angles`): a Gaussian of std sigma_u in the plane u = tan theta is the radiance
    G(tan theta) / cos^3 theta per steradian; laid out over theta as distance it is replaced
    by the Gaussian of std sigma_theta and sum e (over that plane's pixels) whose logarithm
    is the least-squares line in theta^2 through the profile's, over the angles a frame shows
    (THETA_FIT), each angle counted by the light a ring there holds. Narrow Gaussians stay
    as they are (e 1). A sum of the table's Gaussians does not do much better (tried, session
    42): near the source the profile is flatter than any Gaussian, and where sigma_u > 0.58 it
    rises away from the source (1 / cos^3 outgrows the Gaussian), which none of them does;
    those keep their width and their density at the source (e 1)."""
    return _theta_plane(tuple(float(v) for v in sigma_u))


def warp_scale(width: int, height: int, fx: float, fy: float, cx: float, cy: float, s_max: float) -> float:
    """Pixels per radian over fx of the plane of angles the pyramid spreads in from level
    WARP_LEVEL up (render.spread_space: angles): the largest at which every edge of the frame
    stays inside the level's grid (a point at angle rho from the principal point lies s fx rho
    from it; the frame's edges are nearest the principal point along the axes), below 1 where
    fy < fx, and at most s_max (warp_cap: the slots' blurs must grow with the level)."""
    s = s_max
    for ext, f in ((width - cx, fx), (cx, fx), (height - cy, fy), (cy, fy)):
        if ext > 0:
            s = min(s, ext / (fx * math.atan(ext / f)))
    return s


def plane_to_image(qx, qy, geom) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """render.spread_space: angles. The image points (px, py, level-0 pixels) of points of the
    plane of angles, sin(rho) / rho there (a plane pixel's solid angle over its area at the
    axis) and where an image point exists (rho <= 1.55: in front of the camera, off the
    horizon). The plane: a direction at angle rho from the optical axis lies s fx rho from
    the principal point, along its own azimuth (azimuthal equidistant); geom is (K, s, cx, cy,
    fx, fy) (device/plan.warp_geometry)."""
    _, s, cx, cy, fx, fy = geom
    dx, dy = (np.asarray(qx, np.float64) - cx) / (s * fx), (np.asarray(qy, np.float64) - cy) / (s * fx)
    rho = np.hypot(dx, dy)
    ok = rho <= 1.55
    r = np.where(ok, rho, 1.0)
    t = np.where(r > 1e-6, np.tan(r) / np.maximum(r, 1e-300), 1.0)
    jac = np.where(ok & (r > 1e-6), np.sin(r) / np.maximum(r, 1e-300), 1.0)
    return cx + fx * dx * t, cy + fy * dy * t, jac, ok


def image_to_plane(px, py, geom) -> tuple[np.ndarray, np.ndarray]:
    """The plane of angles' points (plane_to_image) of image points."""
    _, s, cx, cy, fx, fy = geom
    X, Y = (np.asarray(px, np.float64) - cx) / fx, (np.asarray(py, np.float64) - cy) / fy
    r = np.hypot(X, Y)
    t = np.where(r > 1e-6, np.arctan(r) / np.maximum(r, 1e-300), 1.0)
    return cx + s * fx * X * t, cy + s * fx * Y * t


def warp_cap(c: float, half_var: float, k: int) -> float:
    """The largest scale of the plane of angles at which level k's sharp slot, s times fewer
    of its pixels a radian, stays wider than level k-1's half-blurred one (slot_widths):
    to_slots needs the slots in order. About 1.7 at the default c; a
    lens wider than ~125 degrees on a near-square frame reaches it, and its frame then
    fills less of the grid."""
    w = slot_widths(k, c, half_var)
    return 0.98 * float(w[2 * k] / w[2 * k - 1])


def slot_widths(levels: int, c: float, half_var: float) -> np.ndarray:
    """Blur (std-dev, level-0 px) of what the source collapse leaves at each slot: level k
    sharp (c 2^k; 0 at level 0, which is not filtered) and level k with its half-octave
    3x3 blur (variance half_var in level-k pixels, added). The two bilinear resamplings of
    render.spread_space: angles are left out: near the principal point they hardly blur
    (there the plane of angles is the image's, to a few percent), and counted as the
    average over the sub-pixel phase (1/6 level-3 pixel^2 each) they put more light near the
    sources than the exact angular sum does (tests/test_spread_space.py)."""
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
