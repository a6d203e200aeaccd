"""Small numpy oracles of every kernel: loops written for reading, not for speed."""
from __future__ import annotations

import math

import numpy as np

import oracles_warp
from fogcli.device.border_size import EDGE_BAND_LOGP
from fogcli.physics.luminance import luminance


def spread_w(s, sa, ss, g):
    """Elek eq. 2 as printed (s > 0)."""
    s = np.asarray(s, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = 2 * sa / (3 * s) + 4 / (s ** 3 * ss * (1 - g))
        w = np.sqrt(0.5 / inner)
    return np.where(s > 0, w, 0.0)


def preprocess(img, depth, sa, ss, g, focal, scale=1.0, density=1.0, depth_scale=1.0,
               max_depth=1000.0, z=True, paper=False, emission=(0, 0, 0), ambient=(0, 0, 0),
               focal_y=None, centre=None):
    h, w = depth.shape
    cx, cy = centre if centre is not None else (w / 2, h / 2)
    fy = focal_y or focal
    sa, ss = np.asarray(sa, float), np.asarray(ss, float)
    st = sa + ss
    jj, ii = np.mgrid[0:h, 0:w] + 0.5
    dist = depth.astype(np.float64) * depth_scale
    if z:
        dist = dist * np.sqrt(((ii - cx) / focal) ** 2 + ((jj - cy) / fy) ** 2 + 1)
    dist = np.minimum(dist, max_depth)
    P = density * dist
    L = img[:, :, :3].astype(np.float64)
    at = np.exp(-st * P[..., None]) * L
    sc = np.exp(-sa * P[..., None]) * (1 - np.exp(-ss * P[..., None])) * L
    W = spread_w(P, sa.mean(), ss.mean(), g)
    if paper:
        sigma = scale * W * w / 1280
    else:
        sigma = np.where(dist > 0, scale * W / np.maximum(dist, 1e-30) * focal, 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        em = np.where(st > 0, (1 - np.exp(-st * P[..., None])) / st, P[..., None]) * np.asarray(emission)
        amb = np.where(st > 0, ss / st * (1 - np.exp(-st * P[..., None])), 0) * np.asarray(ambient)
    return at, sc, sigma, em + amb, P


def smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


def _window(y: int, x: int, n: int, h: int, w: int):
    """(ty, sy, tx, sx): the taps of an n-tap filter of a 2x reduction at destination (y, x)
    and their source pixels inside an h x w level."""
    for ty in range(n):
        sy = 2 * y - n // 2 + 1 + ty
        if not 0 <= sy < h:
            continue
        for tx in range(n):
            sx = 2 * x - n // 2 + 1 + tx
            if 0 <= sx < w:
                yield ty, sy, tx, sx


def reduce_level(src, spread, taps, thresh, eps, masked=True, source_weights=False):
    """One pyramid level: src (h, w, 4) with W in [..., 3], spread (h, w). Elek eq. 8
    weights W by the luminance of level k-1; source weights take the geometric mean
    weighted by the masked luminance."""
    h, w = spread.shape
    n = len(taps)
    dh, dw = (h + 1) // 2, (w + 1) // 2
    out = np.zeros((dh, dw, 4))
    sout = np.zeros((dh, dw))
    for y in range(dh):
        for x in range(dw):
            c = np.zeros(3)
            gsum = ssum = yw = ysum = wsum = 0.0
            cnt = 0
            for ty, sy, tx, sx in _window(y, x, n, h, w):
                v = src[sy, sx]
                wg = taps[tx] * taps[ty]
                m = smoothstep(thresh, (1 + eps) * thresh, v[3]) if masked else 1.0
                c += wg * m * v[:3]
                gsum += wg
                ssum += wg * spread[sy, sx]
                lum = luminance(np.abs(m * v[:3] if source_weights else v[:3]))   # light_weight
                yw += lum * (math.log(max(v[3], 1e-6)) if source_weights else v[3])
                ysum += lum
                wsum += math.log(max(v[3], 1e-6)) if source_weights else v[3]
                cnt += 1
            out[y, x, :3] = c / gsum
            out[y, x, 3] = yw / ysum if ysum > 1e-30 else wsum / cnt
            if source_weights:
                out[y, x, 3] = math.exp(out[y, x, 3])   # geometric mean, weighted or not
            sout[y, x] = ssum / gsum
    return out, sout


def _bspline(f):
    return np.array([(1 - f) ** 3, 3 * f ** 3 - 6 * f ** 2 + 4, -3 * f ** 3 + 3 * f ** 2 + 3 * f + 1, f ** 3]) / 6


def sample(img, x, y, cubic):
    """Clamp-to-edge bilinear or cubic B-spline (16 taps) at index-space (x, y)."""
    h, w = img.shape[:2]
    cx = lambda i: min(max(i, 0), w - 1)  # noqa: E731
    cy = lambda j: min(max(j, 0), h - 1)  # noqa: E731
    if not cubic:
        x = min(max(x, 0.0), w - 1.0)
        y = min(max(y, 0.0), h - 1.0)
        x0, y0 = int(math.floor(x)), int(math.floor(y))
        fx, fy = x - x0, y - y0
        a = img[y0, x0] * (1 - fx) + img[y0, cx(x0 + 1)] * fx
        b = img[cy(y0 + 1), x0] * (1 - fx) + img[cy(y0 + 1), cx(x0 + 1)] * fx
        return a * (1 - fy) + b * fy
    ix, iy = math.floor(x), math.floor(y)
    wx, wy = _bspline(x - ix), _bspline(y - iy)
    acc = 0.0
    for b in range(4):
        for a in range(4):
            acc = acc + wx[a] * wy[b] * img[cy(iy - 1 + b), cx(ix - 1 + a)]
    return acc


def keep(I, x, y, T, eps, a):
    """What level k keeps at (x, y): below T / sqrt(2) as is, between T / sqrt(2) and T
    blurred by (a, 1 - 2a, a) in both axes (clamp-to-edge), above T passed on."""
    h, w = I.shape[:2]
    th = T / math.sqrt(2)
    g = {-1: a, 0: 1 - 2 * a, 1: a}
    acc = np.zeros(3)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            v = I[min(max(y + dy, 0), h - 1), min(max(x + dx, 0), w - 1)]
            m = smoothstep(T, (1 + eps) * T, v[3])
            mh = max(m, smoothstep(th, (1 + eps) * th, v[3]))
            acc += g[dx] * g[dy] * (mh - m) * v[:3]
            if dx == 0 and dy == 0:
                acc += (1 - mh) * v[:3]
    return acc


def collapse(levels, taps_c, eps, cubic, thr=1.0, a=0.0):
    """E_K = I^[K], E_k = keep_k(I^[k]) + up(E_{k+1}), over a list of (h, w, 4) levels."""
    I = [lv.astype(np.float64) for lv in levels]
    E = I[-1].copy()
    for k in range(len(I) - 2, -1, -1):
        T = thr * taps_c * 2.0 ** k
        h, w = I[k].shape[:2]
        Ek = np.zeros((h, w, 4))
        for y in range(h):
            for x in range(w):
                up = sample(E, (x + 0.5) * 0.5 - 0.5, (y + 0.5) * 0.5 - 0.5, cubic)
                Ek[y, x, :3] = keep(I[k], x, y, T, eps, a) + up[:3]
        E = Ek
    return E


def reference(sc, sigma):
    """Brute-force screen-space reference: Gaussian per source pixel, truncated at
    ceil(4 sigma), normalised over the in-image pixels."""
    h, w = sigma.shape
    out = np.zeros((h, w, 3))
    for j in range(h):
        for i in range(w):
            s = sigma[j, i]
            if s <= 0:
                out[j, i] += sc[j, i]
                continue
            R = int(math.ceil(4 * s))
            xs = np.arange(max(0, i - R), min(w, i + R + 1))
            ys = np.arange(max(0, j - R), min(h, j + R + 1))
            gx = np.exp(-((xs - i) ** 2) / (2 * s * s))
            gy = np.exp(-((ys - j) ** 2) / (2 * s * s))
            k = np.outer(gy, gx)
            out[ys[0]:ys[-1] + 1, xs[0]:xs[-1] + 1] += k[:, :, None] * sc[j, i] / k.sum()
    return out


# ----------------------------------------------------------------------------- apsf

def lut_at(lut, base, lp):
    """Linear lookup in the host's apsf table (fogcli.physics.apsf_lut.build_lut) at log P."""
    n = int(lut[2])
    u = np.clip((lp - lut[0]) * lut[1], 0.0, n - 1.001)
    i = np.floor(u).astype(np.int64)
    f = u - i
    return lut[base + i] * (1 - f) + lut[base + i + 1] * f


def _updown(k, c, q, n):
    return 4 + ((k * 3 + c) * 2 + q) * n


def apsf_shares(lut, k, lp, rgb, q):
    """Per channel, the share of rgb that level k passes on (q 0) or half-blurs (q 1)."""
    n = int(lut[2])
    return np.stack([lut_at(lut, _updown(k, c, q, n), lp) * rgb[..., c] for c in range(3)], axis=-1)


def _src_share(n_src, n_dst, taps):
    """Per source pixel along an axis: the share of its filter weights landing on the
    n_dst outputs (1/2 away from the edges)."""
    T = len(taps)
    got = np.zeros(n_src)
    for x in range(n_dst):
        for t in range(T):
            s = 2 * x - T // 2 + 1 + t
            if 0 <= s < n_src:
                got[s] += taps[t]
    return got


def apsf_reduce(prep, taps, open_border):
    """One level of the apsf chain from the level below's prep (passed colour, log P): the
    filtered colour, every source's taps scaled to hand on exactly its energy, and the log
    P weighted by the luminance of what moves up."""
    h, w = prep.shape[:2]
    n = len(taps)
    dh, dw = (h + 1) // 2, (w + 1) // 2
    fx = 0.5 / _src_share(w, dw, taps)
    fy = 0.5 / _src_share(h, dh, taps)
    col = np.zeros((dh, dw, 3))
    lp = np.zeros((dh, dw))
    for y in range(dh):
        for x in range(dw):
            c = np.zeros(3)
            gsum = yw = ysum = lsum = 0.0
            cnt = 0
            for ty, sy, tx, sx in _window(y, x, n, h, w):
                v = prep[sy, sx]
                wg = taps[tx] * taps[ty] * fx[sx] * fy[sy]
                c += wg * v[:3]
                gsum += wg
                lum = luminance(np.abs(v[:3]))   # light_weight: a ground's sources have either sign
                yw += lum * v[3]
                ysum += lum
                lsum += v[3]
                cnt += 1
            col[y, x] = c
            lp[y, x] = yw / ysum if ysum > 1e-30 else lsum / cnt
    return col, lp


def _blur3(img, a):
    h, w = img.shape[:2]
    g = {-1: a, 0: 1 - 2 * a, 1: a}
    out = np.zeros_like(img)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            ys = np.clip(np.arange(h) + dy, 0, h - 1)
            xs = np.clip(np.arange(w) + dx, 0, w - 1)
            out += g[dx] * g[dy] * img[ys][:, xs]
    return out


def _frame_share(n, n0, scale, sigma):
    """Share along one axis of a Gaussian centred on each of n level pixels (level-0 centre
    scale (x + 0.5)) that lands in [0, n0]."""
    if sigma <= 0:
        return np.ones(n)
    x0 = scale * (np.arange(n) + 0.5)
    k = 1 / (math.sqrt(2) * sigma)
    return np.array([0.5 * (math.erf((n0 - v) * k) + math.erf(v * k)) for v in x0])


def receiver_depths(lp0, levels, warp=None):
    """render.halo_depth: receiver: per level the receivers' mean log P, each level the 2 x 2
    mean of the one below (clamped at the edge); level 0 each pixel's own. warp: the plan's
    plane of angles (render.spread_space: angles): its level moved there, the ones above made
    from it."""
    out = [np.asarray(lp0, np.float64)]
    for k in range(1, levels + 1):
        r = out[-1]
        h, w = r.shape
        y0, x0 = np.arange((h + 1) // 2) * 2, np.arange((w + 1) // 2) * 2
        y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
        out.append(0.25 * (r[y0][:, x0] + r[y0][:, x1] + r[y1][:, x0] + r[y1][:, x1]))
        if warp is not None and k == warp[0]:
            out[-1] = oracles_warp.warp_receivers(out[-1], k, warp)
    return out


def recv_weight(lut, base, level, lp, lr, nu):
    """The share a receiver at log P lr keeps of level `level`'s light from sources at log P
    lp: the table at `base` (apsf_lut.lut_offsets "recv"), bilinear in (log P, u = P_r / P)."""
    n = int(lut[2])
    t = np.clip((lp - lut[0]) * lut[1], 0.0, n - 1.001)
    i = np.floor(t).astype(np.int64)
    f = t - i
    u = np.clip(np.exp(lr - lp), 0.0, 1.0) * (nu - 1)
    ui = np.minimum(u.astype(np.int64), nu - 2)
    uf = u - ui
    at = lambda ii, uu: lut[base + (level * n + ii) * nu + uu]  # noqa: E731
    a = at(i, ui) * (1 - uf) + at(i, ui + 1) * uf
    b = at(i + 1, ui) * (1 - uf) + at(i + 1, ui + 1) * uf
    return a * (1 - f) + b * f


def apsf_collapse(sc, lp0, lut, levels, taps, cubic, a, open_border=False, slots=None, recv=None, warp=None):
    """The whole apsf source collapse from level 0 (scattered colour, log P): every level
    keeps its sharp and half-blurred shares and passes the rest up. The chain itself is
    closed; with the open border each level's kept light is scaled by the frame share of
    its slot's Gaussian (slots: the slot widths, apsf.slot_widths). recv: (table offset, NU)
    of render.halo_depth: receiver: levels 1 .. K keep their light times recv_weight.
    warp: the plan's plane of angles (render.spread_space: angles): its level moved there
    once reduced (oracles_warp), and back once collapsed."""
    H0, W0 = sc.shape[:2]
    cols, lps, preps = [sc.astype(np.float64)], [lp0.astype(np.float64)], []
    for k in range(levels + 1):
        p = apsf_shares(lut, k, lps[k], cols[k], 0)
        preps.append(np.concatenate([p, lps[k][..., None]], axis=-1))
        if k < levels:
            c, lp = apsf_reduce(preps[k], taps, False)
            if warp is not None and k + 1 == warp[0]:
                c, lp = oracles_warp.warp_level(c, lp, k + 1, warp)
            cols.append(c)
            lps.append(lp)

    def share(k, half):
        h, w = cols[k].shape[:2]
        sg = slots[min(2 * k + half, len(slots) - 1)] if half == 0 or 2 * k + 1 < len(slots) else slots[2 * k]
        return np.outer(_frame_share(h, H0, 2.0 ** k, sg), _frame_share(w, W0, 2.0 ** k, sg))[..., None]

    E = cols[levels] - preps[levels][..., :3] if levels > 0 else cols[0]   # the top's `up`: lost
    if open_border and levels > 0:
        E = E * share(levels, 0)
    rds = receiver_depths(lp0, levels, warp) if recv else None

    def weight(k):
        return recv_weight(lut, recv[0], k, lps[k], rds[k], recv[1])[..., None] if recv and k > 0 else 1.0
    E = E * weight(levels)
    for k in range(levels - 1, -1, -1):
        half = apsf_shares(lut, k, lps[k], cols[k], 1)
        if open_border:
            hs = half * share(k, 1)
            keep = _blur3(hs, a) + (cols[k] - preps[k][..., :3] - half) * share(k, 0)
        else:
            keep = _blur3(half, a) + cols[k] - preps[k][..., :3] - half
        E = keep * weight(k) + _up2_conserving(E, keep.shape[0], keep.shape[1], cubic, open_border)
        if warp is not None and k == warp[0]:
            E = oracles_warp.unwarp_level(E, k, warp)
    return E


def _up2_conserving(E, h, w, cubic, open_border=False):
    """Factor-2 up-sampling to (h, w): the B-spline (or tent) weights of an output centre,
    clamp-to-edge (zero outside with the open border), and each input pixel's weights
    scaled so that they sum to 2 per axis over the outputs (it hands on exactly its energy)."""
    def weights(n_out, n_in):
        M = np.zeros((n_out, n_in))
        for y in range(n_out):
            src = (y + 0.5) * 0.5 - 0.5
            i0 = math.floor(src)
            f = src - i0
            ws = _bspline(f) if cubic else np.array([1 - f, f])
            first = i0 - 1 if cubic else i0
            for t, wt in enumerate(ws):
                if open_border and not 0 <= first + t < n_in:
                    continue   # open: zero outside
                M[y, min(max(first + t, 0), n_in - 1)] += wt
        return M * (2.0 / np.maximum(M.sum(axis=0), 1e-12))[None, :]
    My, Mx = weights(h, E.shape[0]), weights(w, E.shape[1])
    return np.einsum("yi,xj,ijc->yxc", My, Mx, E)


def shadow_fraction(ray_len, f, light, directional=False, radius=0.05, thickness=1.0, sa=0.01, ss=0.1, g=0.85,
                    n=128, steps=1000, reach=80.0, pixels=None):
    """Lit share of each pixel's airlight integrand under the screen-space occluder model of
    kernels/shadows.cl, by brute force: every cell's segment to the light (point: camera-frame
    position; directional: unit direction towards it, for `reach` metres) marched in 3-D in
    `steps` points, each point tested at its nearest pixel: blocked when z(q) + b < z(x) <
    z(q) + thickness (depth along the view axis), b = min(max(0.05, 0.01 z(q)), thickness / 4),
    and (points) the surface there is farther than max(0.05, 2 % of the light's distance,
    2 radii) from the light. Camera at the origin looking down -z, principal point at the centre;
    homogeneous medium. Cells: n uniform in phi (points, s = d1 + R tan phi) or in s
    (directional), visibility at their middles. pixels: the (j, i) to do (default all)."""
    h, w = ray_len.shape
    cx, cy = w / 2, h / 2
    L = np.asarray(light, float)
    st = sa + ss
    bl = max(0.05, 0.02 * np.linalg.norm(L), 2 * radius)
    out = np.full((h, w), np.nan)
    for j, i in pixels if pixels is not None else np.ndindex(h, w):
        d = np.array([(i + 0.5 - cx) / f, -(j + 0.5 - cy) / f, -1.0])
        d /= np.linalg.norm(d)
        D = ray_len[j, i]
        if directional:
            s = (np.arange(n) + 0.5) * D / n
            y = s[:, None] * d
            ends = y + reach * L            # far enough to leave the scene's depths
            wgt = np.exp(-st * s)
        else:
            d1 = d @ L
            R = math.hypot(np.linalg.norm(L - d1 * d), radius)
            phi = math.atan2(-d1, R) + (np.arange(n) + 0.5) * (math.atan2(D - d1, R) - math.atan2(-d1, R)) / n
            s = d1 + R * np.tan(phi)
            y = s[:, None] * d
            ends = np.broadcast_to(L, y.shape)
            wgt = (1 - g * g) / (1 + g * g + 2 * g * np.sin(phi)) ** 1.5 * np.exp(-st * s - st * R / np.cos(phi))
        u = (np.arange(steps) + 0.5) / steps
        x = y[:, None, :] + u[None, :, None] * (ends - y)[:, None, :]
        zc = -x[..., 2]
        front = zc > 1e-9
        zs = np.where(front, zc, 1.0)
        qx, qy = cx + f * x[..., 0] / zs, cy - f * x[..., 1] / zs
        inside = front & (qx >= 0) & (qy >= 0) & (qx < w) & (qy < h)
        qi, qj = np.clip(qx.astype(int), 0, w - 1), np.clip(qy.astype(int), 0, h - 1)
        Dq = ray_len[qj, qi]
        zq = Dq / np.sqrt(((qi + 0.5 - cx) / f) ** 2 + ((qj + 0.5 - cy) / f) ** 2 + 1.0)
        b = np.minimum(np.maximum(0.05, 0.01 * zq), 0.25 * thickness)
        blocked = inside & (zc > zq + b) & (zc < zq + thickness)
        if not directional:
            t = np.linalg.norm(x, axis=-1)
            blocked &= np.linalg.norm(x / t[..., None] * Dq[..., None] - L, axis=-1) >= bl
        out[j, i] = wgt[~blocked.any(axis=1)].sum() / wgt.sum()
    return out


# -- optical depth of the density primitives (dicts as in the config), by quadrature

GL12_NODES, GL12_WEIGHTS = np.polynomial.legendre.leggauss(12)


def primitive_density(x, prims):
    rho = np.zeros(x.shape[:-1])
    for p in prims:
        if p["type"] == "homogeneous":
            rho += p["factor"]
        elif p["type"] == "exponential":
            n = np.array(p["direction"], float)
            n /= np.linalg.norm(n)
            rho += p["factor"] * np.exp(-p["falloff"] * ((x - np.array(p["offset"])) @ n))
        else:
            r2 = ((x - np.array(p["center"])) ** 2).sum(-1)
            rho += p["factor"] * np.maximum(0.0, 1 - r2 / p["radius"] ** 2)
    return rho


def optical_depth_quadrature(c, w, D, prims):
    """Composite Gauss-Legendre on [0, D], split where the ray enters/leaves a sphere (the
    printed quadratic, in float64) and into 256 equal pieces."""
    cuts = {0.0, D}
    for p in prims:
        if p["type"] == "sphere":
            co = c - np.array(p["center"])
            B, C = w @ co, co @ co - p["radius"] ** 2
            if B * B - C > 0:
                for t in (-B - math.sqrt(B * B - C), -B + math.sqrt(B * B - C)):
                    if 0 < t < D:
                        cuts.add(t)
    cuts = sorted(cuts)
    total = 0.0
    for a, b in zip(cuts[:-1], cuts[1:]):
        edges = np.linspace(a, b, 257)
        mid, half = (edges[:-1] + edges[1:]) / 2, (edges[1:] - edges[:-1]) / 2
        t = (mid[:, None] + half[:, None] * GL12_NODES[None, :]).ravel()
        wts = (half[:, None] * GL12_WEIGHTS[None, :]).ravel()
        total += (wts * primitive_density(c + t[:, None] * w, prims)).sum()
    return total


def smooth_depth(depth, along_y: bool, radius: int, tau: float, far) -> np.ndarray:
    """kernels/preprocess.cl smooth_depth in float64: along one axis, each pixel's depth
    replaced by the value at it of a line fitted to the run of neighbours (its mean when the
    run is radius pixels or fewer; up to radius on
    each side) whose every step is this pixel's slope within 2 tau z and whose offset from
    the slope's line is within tau z (1 + o / 2); the slope is the central difference where
    the two one-sided steps agree within tau z, else the smaller step. far (h, w): the
    depth at which each pixel's ray reaches max_depth; a pixel there or past it (the sky)
    is not smoothed, and a neighbour there or past the centre's is not taken."""
    z = np.asarray(depth, np.float64)
    far = np.asarray(far, np.float64)
    if along_y:
        return smooth_depth(z.T, False, radius, tau, far.T).T
    out = z.copy()
    h, w = z.shape
    for j in range(h):
        for i in range(w):
            zc = z[j, i]
            if not zc < far[j, i]:
                continue
            lim = tau * zc
            ef = z[j, min(i + 1, w - 1)] - zc
            eb = zc - z[j, max(i - 1, 0)]
            c = 0.5 * (ef + eb) if abs(ef - eb) <= lim else (ef if abs(ef) < abs(eb) else eb)
            offs, vals = [0.0], [0.0]
            for side in (-1, 1):
                prev = 0.0
                for o in range(1, radius + 1):
                    k = i + side * o
                    if not 0 <= k < w or not z[j, k] < far[j, i]:
                        break
                    zn = z[j, k] - zc
                    if not (abs(zn - prev - side * c) <= 2 * lim and abs(zn - o * side * c) <= lim * (1 + 0.5 * o)):
                        break
                    offs.append(side * o)
                    vals.append(zn)
                    prev = zn
            o, v = np.array(offs), np.array(vals)
            a = np.polyfit(o, v, 1)[1] if len(o) > radius else np.mean(v)
            out[j, i] = zc + a
    return out


def realign_blocks(depth, rgb, kx: int, ky: int, px: int, py: int, tol: float) -> np.ndarray:
    """kernels/preprocess.cl realign_blocks in float64: where the 3 x 3 blocks of the grid
    (kx x ky, starting at px, py) around a pixel span more than 1 + tol in depth and its own
    block's second difference of 1 / depth along x or y (a block past the frame continuing
    the ramp in 1 / depth) exceeds tol of its 1 / depth, the pixel takes a block by its colour
    (_pick_by_colour), whose surface is carried on to it (_extend); elsewhere its depth is linear
    in 1 / depth between its block's centre and the nearer neighbours' along x and y."""
    z = np.asarray(depth, np.float64)
    img = np.asarray(rgb, np.float64)[..., :3]
    h, w = z.shape
    out = z.copy()

    def anchor(bj, bi):
        return z[min(max(bj * ky + py, 0), h - 1), min(max(bi * kx + px, 0), w - 1)]

    for j in range(h):
        for i in range(w):
            bi, bj = (i - px) // kx, (j - py) // ky
            d = np.array([[anchor(bj + dj, bi + di) for di in (-1, 0, 1)] for dj in (-1, 0, 1)])
            lo, hi = min(d.min(), z[j, i]), max(d.max(), z[j, i])
            c = d[1, 1]
            inside = lambda a, b: _block_inside(bi + b - 1, kx, px, w) and _block_inside(bj + a - 1, ky, py, h)  # noqa: E731
            xl, xr, yu, yd = not inside(1, 0), not inside(1, 2), not inside(0, 1), not inside(2, 1)
            # 1 / depth of the neighbours; past the frame, continued in 1 / depth
            left = 2 / c - 1 / d[1, 2] if xl else 1 / d[1, 0]
            right = 2 / c - 1 / d[1, 0] if xr else 1 / d[1, 2]
            up = 2 / c - 1 / d[2, 1] if yu else 1 / d[0, 1]
            down = 2 / c - 1 / d[0, 1] if yd else 1 / d[2, 1]
            cx, cy = abs(left - 2 / c + right), abs(up - 2 / c + down)
            if xl or xr:        # about the inner neighbour: the continued ramp is a plane
                o = 1 if xl else -1
                cx = abs(1 / c - 2 / d[1, 1 + o] + 1 / anchor(bj, bi + 2 * o))
            if yu or yd:
                o = 1 if yu else -1
                cy = abs(1 / c - 2 / d[1 + o, 1] + 1 / anchor(bj + 2 * o, bi))
            curve = max(cx, cy)
            fx = (i - bi * kx - px + 0.5) / kx - 0.5      # from the own block's centre, in blocks
            fy = (j - bj * ky - py + 0.5) / ky - 0.5
            if not (hi > lo * (1 + tol) and curve > tol / c):
                # a surface: linear in 1 / depth from the own block's centre toward the nearer
                # neighbour's along each axis
                nx, ny = (left if fx < 0 else right), (up if fy < 0 else down)
                with np.errstate(divide="ignore", invalid="ignore"):
                    zz = 1.0 / (1.0 / z[j, i] + abs(fx) * (nx - 1.0 / c) + abs(fy) * (ny - 1.0 / c))
                out[j, i] = zz if 0 < zz < np.inf else z[j, i]
                continue
            (dj, di), mid = _pick_by_colour(img, img[j, i], d, bi, bj, kx, ky, px, py)
            out[j, i] = _extend(d, dj, di, mid, fx - di, fy - dj, inside)
    return out


def _block_inside(b: int, k: int, p: int, n: int) -> bool:
    """Block b of a grid of k pixels starting at p has a pixel in 0 .. n - 1."""
    return b * k + p + k > 0 and b * k + p < n


def _extend(d, dj, di, mid, fx, fy, inside):
    """The chosen block (dj, di of the 3 x 3) carried on to the pixel (fx, fy blocks from its
    centre), linear in 1 / depth along each axis with the slope toward a neighbour block of
    the same surface (in the frame: inside(a, b), on its side of mid, 1 / depth within a
    factor 2 of it; the one away from the pixel first)."""
    ib = 1.0 / d[dj + 1, di + 1]
    near = ib > mid
    q = ib
    for f, axis in ((fx, 1), (fy, 0)):
        for step in ((-1, 1) if f >= 0 else (1, -1)):
            a, b = (dj + 1, di + 1 + step) if axis else (dj + 1 + step, di + 1)
            if not (0 <= a <= 2 and 0 <= b <= 2) or not inside(a, b):
                continue
            inn = 1.0 / d[a, b]
            if (inn > mid) == near and abs(inn - ib) <= 0.5 * ib:
                q += f * (inn - ib) * step
                break
    with np.errstate(divide="ignore"):
        z = 1.0 / q
    return z if 0 < z < np.inf else d[dj + 1, di + 1]


# kernels/preprocess.cl realign_blocks' constants
PURE_TOL, SINGLE_TOL, PAIR_SLACK = 0.2, 0.1, 0.02


def _pick_by_colour(img, p, d, bi, bj, kx, ky, px, py):
    """realign_blocks at an edge: which of the 3 x 3 blocks ((dj, di), and the middle of their
    1 / depth range) gives the pixel of colour p its depth. A block is
    pure where each of its pixels is within PURE_TOL (relative L1) of its mean. The nearest
    pure block if within SINGLE_TOL; else, if both the blocks nearer than the middle of their
    1 / depth range and the farther ones hold a pure block, the pixel as a mix
    a c_near + (1 - a) c_far of a pure pair (a in [0, 1]; relative L1 residual; among pairs
    within PAIR_SLACK of the best, the one with an end nearest the pixel): the nearer's depth
    where a >= 1/2, else the farther's; else the nearest block (own block ahead by 1e-3)."""
    h, w = img.shape[:2]
    means, deps, pure, own_k, where = [], [], [], -1, []
    for dj in (-1, 0, 1):
        for di in (-1, 0, 1):
            x0, y0 = (bi + di) * kx + px, (bj + dj) * ky + py
            block = img[max(y0, 0):min(y0 + ky, h), max(x0, 0):min(x0 + kx, w)]
            if block.size:
                q = block.reshape(-1, 3)
                m = q.mean(0)
                own_k = len(deps) if di == dj == 0 else own_k
                where.append((dj, di))
                means.append(m)
                deps.append(d[dj + 1, di + 1])
                pure.append((np.abs(q - m).sum(1) / (np.abs(q).sum(1) + np.abs(m).sum() + 1e-6)).max() <= PURE_TOL)
    pn = np.abs(p).sum() + 1e-6
    dist = np.array([np.abs(p - m).sum() / (pn + np.abs(m).sum()) for m in means])
    dist = dist - 1e-3 * (np.arange(len(deps)) == own_k)        # the own block wins a tie
    pure = np.array(pure)
    inv = 1.0 / np.array(deps)
    mid = 0.5 * (inv.min() + inv.max())
    if pure.any() and dist[pure].min() <= SINGLE_TOL:
        return where[int(np.argmin(np.where(pure, dist, np.inf)))], mid
    near, far = np.flatnonzero((inv > mid) & pure), np.flatnonzero((inv <= mid) & pure)
    if not (near.size and far.size):
        return where[int(np.argmin(dist))], mid
    pairs = []
    for k in near:
        for m in far:
            seg = means[k] - means[m]
            s2 = float(seg @ seg)
            a = float(np.clip((p - means[m]) @ seg / s2, 0.0, 1.0)) if s2 > 1e-12 else 1.0
            res = np.abs(p - means[m] - a * seg).sum() / pn
            end = min(np.abs(p - means[k]).sum(), np.abs(p - means[m]).sum()) / pn
            pairs.append((res, end, where[k] if a >= 0.5 else where[m]))
    bound = min(x[0] for x in pairs) + PAIR_SLACK
    return min((x for x in pairs if x[0] <= bound), key=lambda x: x[1])[2], mid


def slab_table(ground, sa, ss, g, nmu: int, nu: int) -> np.ndarray:
    """device/ground.table's (nu, nmu, 3): the slab's light (physics/slab.inscatter, float64)
    at mu_v = linspace(-1, 1, nmu) and optical length -ln(1 - u), u = linspace(0, 1, nu),
    weighted by the ground's and the sky's colours; a dome's first-order light in place of
    the plane's (physics/dome.table) where it counts."""
    from fogcli.physics import dome, slab

    mu = np.linspace(-1.0, 1.0, nmu)[None, :] * np.ones((nu, 1))
    u = np.linspace(0.0, 1.0, nu)
    with np.errstate(divide="ignore"):
        t = np.where(u < 1.0, -np.log1p(-np.minimum(u, 1.0 - 1e-300)), np.inf)[:, None] * np.ones((1, nmu))
    out = np.empty((nu, nmu, 3))
    for c in range(3):
        st = sa[c] + ss[c]
        tH = slab.sky_height(st, ground.height, ground.sky_distance, ground.dome, ss[c] / st, g)
        a, b = slab.inscatter(ss[c] / st, g, st * ground.height, tH, mu, t * 1.0)
        out[..., c] = ground.colour[c] * a + ground.sky_colour[c] * b
        if ground.dome and dome.matters(st * ground.sky_distance):      # as device/ground.table
            th = st * ground.height
            out[..., c] += ground.sky_colour[c] * dome.table(ss[c] / st, g, th, st * ground.sky_distance,
                                                             tH - th, mu[0], t[:, 0])
    return out


def slab_lookup(tab: np.ndarray, mu: np.ndarray, u: np.ndarray) -> np.ndarray:
    """preprocess's slab_light: tab (nu, nmu) bilinear at (mu, u)."""
    nu, nmu = tab.shape
    x = np.clip((mu + 1.0) * 0.5 * (nmu - 1), 0, nmu - 1 - 1e-3)
    y = np.clip(u * (nu - 1), 0, nu - 1 - 1e-3)
    ix, iy = x.astype(int), y.astype(int)
    fx, fy = x - ix, y - iy
    a, b = tab[iy, ix], tab[iy, ix + 1]
    d, e = tab[iy + 1, ix], tab[iy + 1, ix + 1]
    return (a + (b - a) * fx) * (1 - fy) + (d + (e - d) * fx) * fy


def light_share_depth(depth, rgb, radius: int, nearer: float, same: float, far_radius: int,
                      far_cover: float) -> np.ndarray:
    """kernels/light_share.h: a pixel within `radius` of a nearer surface (depth below `nearer`
    of its own, the pixel opposite in the frame and on its own surface) whose luminance,
    read as a c_near + (1 - a) c_far (c_near the brightest nearer pixel, first in row order;
    c_far the darkest of its own surface's, depth within `same`), is more than half the
    nearer surface's light takes that pixel's depth; likewise within `far_radius` of a
    farther surface (`nearer` of its depth above the own), when the pixel is no brighter
    than that surface's brightest and b >= far_cover; where both would, the larger part.
    Edge pixels repeat past the frame."""
    z = np.asarray(depth, np.float64)
    lum = luminance(np.asarray(rgb, np.float64))
    h, w = z.shape
    zp, yp = np.pad(z, radius, mode="edge"), np.pad(lum, radius, mode="edge")
    zo = np.pad(z, radius, constant_values=np.nan)       # an opposite pixel past the edge is none
    near_y, near_z, far_y = np.zeros((h, w)), z.copy(), np.full((h, w), np.inf)
    back_y, back_z = np.zeros((h, w)), z.copy()
    with np.errstate(invalid="ignore"):
        for dj in range(-radius, radius + 1):
            for di in range(-radius, radius + 1):
                zn = zp[radius + dj:radius + dj + h, radius + di:radius + di + w]
                yn = yp[radius + dj:radius + dj + h, radius + di:radius + di + w]
                zm = zo[radius - dj:radius - dj + h, radius - di:radius - di + w]
                across = (zm >= (1 - same) * z) & (zm <= (1 + same) * z)
                take = (zn < nearer * z) & across & (yn > near_y)
                near_y, near_z = np.where(take, yn, near_y), np.where(take, zn, near_z)
                back = (max(abs(di), abs(dj)) <= far_radius) & (nearer * zn > z) & across & (yn > back_y)
                back_y, back_z = np.where(back, yn, back_y), np.where(back, zn, back_z)
                own = (zn >= (1 - same) * z) & (zn <= (1 + same) * z)
                far_y = np.where(own, np.minimum(far_y, yn), far_y)
        span, span_b = near_y - far_y, back_y - far_y
        a = np.minimum(np.where(span > 0, (lum - far_y) / np.where(span > 0, span, 1.0), 0.0), 1.0)
        b = np.where(span_b > 0, (lum - far_y) / np.where(span_b > 0, span_b, 1.0), 0.0)
        part = np.where(span > 0, a * near_y, 0.0)
        part_b = np.where((span_b > 0) & (lum <= back_y) & (b >= far_cover), b * back_y, 0.0)
        pick = np.where(part >= part_b, near_z, back_z)
        return np.where(np.maximum(part, part_b) > 0.5 * lum, pick, z)


def continue_edges(a, mx: int, my: int, kx: int, ky: int, lp=None, gate: float | None = None):
    """render.border: extend as padding (kernels/edge_bands.h: edge_bands, ref_edge_profiles):
    `a` (h, w, ...) continued mx columns and my rows past each side. A row's left part is the
    mean of its kx pixels next to the edge, a column's top part the mean of its ky, a corner
    the kx x ky block's; with `lp` (h, w: log P) only the pixels whose log P is within `gate`
    (border_size.EDGE_BAND_LOGP) of the end pixel's count."""
    a = np.asarray(a, np.float64)
    h, w = a.shape[:2]
    lp = np.zeros((h, w)) if lp is None else np.asarray(lp, np.float64)
    gate = EDGE_BAND_LOGP if gate is None else gate

    def mean(ys, xs, ye, xe):
        block, keep = a[ys, xs], np.abs(lp[ys, xs] - lp[ye, xe]) <= gate
        return block[keep].mean(0)

    out = np.zeros((h + 2 * my, w + 2 * mx) + a.shape[2:])
    out[my:my + h, mx:mx + w] = a
    for j in range(h):
        out[my + j, :mx] = mean(j, np.s_[:kx], j, 0)
        out[my + j, mx + w:] = mean(j, np.s_[w - kx:], j, w - 1)
    for i in range(w):
        out[:my, mx + i] = mean(np.s_[:ky], i, 0, i)
        out[my + h:, mx + i] = mean(np.s_[h - ky:], i, h - 1, i)
    for ys, ye, ro in ((np.s_[:ky], 0, np.s_[:my]), (np.s_[h - ky:], h - 1, np.s_[my + h:])):
        for xs, xe, co in ((np.s_[:kx], 0, np.s_[:mx]), (np.s_[w - kx:], w - 1, np.s_[mx + w:])):
            out[ro, co] = mean(ys, xs, ye, xe)
    return out
