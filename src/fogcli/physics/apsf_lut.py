"""The device's lookup table of the tabulated point spread (render.psf: apsf), in log P: the
pyramid's shares per level, the energy ratio, the Gaussians' weights (reference), the
Lambertian weight per view cosine and the receiver weight per level (physics/apsf.py says
what each is)."""
from __future__ import annotations

import math

import numpy as np

from fogcli.physics.apsf import (HEADER, NP, fractions, in_frame, load_table, p_range, slot_widths, spread,
                                 theta_plane, to_slots)
from fogcli.physics.emission import COS_MIN, NC, lambert_shape, theta_seen
from fogcli.physics.glow_depth import NU, receiver_table


def build_lut(sa, ss, g: float, focal_px: float, spread_scale: float, levels: int, c: float,
              half_var: float, tab: dict | None = None, frame: tuple[int, int] | None = None,
              size: tuple[int, int] | None = None, halo_depth: bool = False, lambertian: bool = False,
              warp: tuple[float, int] | None = None) -> np.ndarray:
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
    the channels); without, ones.
    warp: (s, K) with render.spread_space: angles: levels K and above spread over a plane of
    angles at s focal_px pixels a radian (theta_plane: the Gaussians laid out there); None:
    every level in the image's pixels, focal_px a radian (the pinhole's scale at the
    principal point)."""
    tab = load_table() if tab is None else tab
    lp0, lp1 = p_range(ss, tab)
    P = np.exp(np.linspace(lp0, lp1, NP))
    J = len(tab["sigma_u"])
    # widths in radians: the Gaussians', and the slots' through each level's pixels a radian
    slots = slot_widths(levels, c, half_var)
    per_rad = np.full(len(slots), float(focal_px))
    e, sigma = np.ones(J), tab["sigma_u"]
    if warp is not None:
        per_rad[2 * warp[1]:] *= warp[0]
        e, sigma = theta_plane(tab["sigma_u"] * spread_scale)   # the widths the light spreads with
    else:
        sigma = sigma * spread_scale
    slots = slots / per_rad
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
        if lambertian and "emit_mu" in tab:
            sh, lw = lambert_shape(tab, g, a, ss[ch] * P, sh, cos_grid, seen)
            lambert[:, ch, :] = lw.T
        if warp is not None:           # the plane of angles holds more than the sphere: e >= 1
            gain = sh @ e
            gain = np.where(gain > 0, gain, 1.0)     # no light spread (a thick absorbing channel): as it is
            sh = sh * e / gain[:, None]
            r = r * gain
        v = to_slots(sh, sigma, slots)
        up, half = fractions(v, levels)
        if frame is not None:
            wide = sigma > slots[-1]
            top_px = per_rad[-1]
            keep = in_frame(sigma[wide] * top_px, *frame) / in_frame(np.array([slots[-1] * top_px]), *frame)[0]
            lost = (sh[:, wide] * (1.0 - np.minimum(keep, 1.0))).sum(-1)
            top = np.maximum(v[:, -1], 1e-30)
            up[:, levels] = np.clip(lost / top, 0.0, 1.0)
        updown[:, ch, 0, :] = up.T
        updown[:, ch, 1, :] = half.T
        ratio[ch] = r
        shape[:, ch, :] = sh.T
    recv = np.ones((levels + 1, NP, NU))
    if halo_depth:
        s_k = np.array([math.sqrt(max(slots[2 * k], 1e-3 / focal_px) * slots[min(2 * k + 1, len(slots) - 1)])
                        for k in range(levels + 1)])
        theta = 1.2533 * s_k / max(spread_scale, 1e-30)     # a 2-D Gaussian's mean radius
        recv = receiver_table(float(np.mean(np.asarray(sa) + np.asarray(ss))), g, P, theta)
    head = np.array([lp0, (NP - 1) / (lp1 - lp0), NP, levels + 1])
    # the Lambertian weight times the ratio, which the kernels interpolate as one table where
    # they need both: 4 table reads a pixel fewer than the two apart (gathers, on AVX2)
    return np.concatenate([head, updown.ravel(), ratio.ravel(), shape.ravel(),
                           (lambert * ratio[None]).ravel(), recv.ravel()]).astype(np.float32)


def lut_offsets(levels: int, J: int) -> dict:
    """Float offsets of the parts of build_lut's table (the kernels compute the same)."""
    up = HEADER
    ratio = up + (levels + 1) * 3 * 2 * NP
    shape = ratio + 3 * NP
    lambert = shape + J * 3 * NP
    recv = lambert + NC * 3 * NP
    return {"updown": up, "ratio": ratio, "shape": shape, "lambert": lambert, "recv": recv,
            "end": recv + (levels + 1) * NP * NU}
