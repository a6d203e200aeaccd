"""The screen-space reference (docs/conventions.md, The reference) on the device.

psf gaussian: binned in sigma. Bins form a geometric ladder s0 * RATIO^b; a pixel's energy
is split between the two bins around its sigma (linear in log sigma).
tests/test_reference.py holds the binned form to within 1 % relative L1 of the
brute-force definition (`brute_force`).
psf apsf: the table's kernel is already a sum of Gaussians (physics/apsf.py); one separable pass
per Gaussian, each pixel weighted by its own share of it: exact to the table."""
from __future__ import annotations

import math

import numpy as np

from fogcli.device.border_size import (EDGE_BAND_LOGP, border_band, border_margin, edge_band_bytes, edge_entries,
                                       open_border)
from fogcli.device.plan import REFERENCE_BUFFERS, defines
from fogcli.physics.apsf import load_table
from fogcli.physics.apsf_lut import lut_offsets

S0 = 0.25                 # px; sharper spreads stay (nearly) delta-like
RATIO = 2.0 ** (1.0 / 6.0)


def _bins_needed(sigma: np.ndarray) -> list[int]:
    u = np.maximum(np.log(np.maximum(sigma, 1e-30) / S0) / math.log(RATIO), 0.0)
    lo = np.unique(np.floor(u).astype(np.int64))
    return [int(b) for b in np.union1d(lo, lo + 1)]


class _Blur:
    """Buffers and the separable Gaussian pass shared by both point spreads."""

    def __init__(self, plan, t, smax: float):
        rt, cl = plan.rt, plan.rt.cl
        self.plan, self.t, self.q = plan, t, rt.queue
        self.prog = rt.program("reference", **_defines(plan))
        w, h, n = plan.w, plan.h, plan.w * plan.h
        mf = cl.mem_flags
        for b in REFERENCE_BUFFERS:      # declared with the plan's (check_memory)
            setattr(self, b.name, cl.Buffer(rt.ctx, mf.READ_WRITE, b.bytes(n, n, plan.features, h)))
        t.add("reference", cl.enqueue_fill_buffer(self.q, self.acc, np.float32(0), 0, self.acc.size))
        rmax = int(math.ceil(4.0 * max(smax, S0) * RATIO)) + 1
        self.taps = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * (rmax + 1))
        self.nx = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * w)
        self.ny = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * h)
        self.open = np.int32(open_border(plan.cfg))
        self.margin = border_margin(plan.cfg, w, h)
        self.band = border_band(plan.cfg, w, h)
        # the continued edge (extend): its entries, then the top and bottom ones blurred along the row
        self.prof = cl.Buffer(rt.ctx, mf.READ_WRITE, edge_band_bytes(w, h) if any(self.margin) else 16)

    def norms(self, sigma: float) -> int:
        """Taps and the 1-D normalisations of a Gaussian of `sigma`; returns its reach."""
        p, rt, t = self.plan, self.plan.rt, self.t
        R = int(math.ceil(4.0 * sigma))
        t.add("reference", self.prog.ref_taps(self.q, *rt.nd(R + 1), taps=self.taps, sigma=np.float32(sigma), R=np.int32(R)))
        t.add("reference",
              self.prog.ref_norm1d(self.q, *rt.nd(p.w), taps=self.taps, R=np.int32(R), n=np.int32(p.w), norm=self.nx,
                                   open_border=self.open))
        t.add("reference",
              self.prog.ref_norm1d(self.q, *rt.nd(p.h), taps=self.taps, R=np.int32(R), n=np.int32(p.h), norm=self.ny,
                                   open_border=self.open))
        return R

    def profiles(self, j: int) -> None:
        """render.border: extend: Gaussian j's sources past the edge (ref_edge_profiles)."""
        p, rt = self.plan, self.plan.rt
        if any(self.margin):
            self.t.add("reference",
                       self.prog.ref_edge_profiles(self.q, *rt.nd(edge_entries(p.w, p.h)), scat0=p.chain, lut=p.lut,
                                                   width=np.int32(p.w), height=np.int32(p.h), j=np.int32(j),
                                                   norm_x=self.nx, norm_y=self.ny, kx=np.int32(self.band[0]),
                                                   ky=np.int32(self.band[1]), gate=np.float32(EDGE_BAND_LOGP),
                                                   prof=self.prof))

    def blur_add(self, R: int) -> None:
        """acc += the Gaussian blur of src (taps beyond the image reach nothing: capped), with
        the continued edge's (profiles) when the border is extend."""
        p, rt, t = self.plan, self.plan.rt, self.t
        mx, my = self.margin
        R = np.int32(min(R, max(p.w + mx, p.h + my)))
        w, h = np.int32(p.w), np.int32(p.h)
        t.add("reference",
              self.prog.ref_rows(self.q, *rt.nd(p.w, p.h), src=self.src, width=w, height=h, taps=self.taps, R=R,
                                 margin=np.int32(mx), prof=self.prof, dst=self.tmp))
        if my:
            t.add("reference", self.prog.ref_profile_rows(self.q, *rt.nd(p.w, 2), prof=self.prof, width=w, height=h,
                                                          taps=self.taps, R=R, mx=np.int32(mx)))
        t.add("reference",
              self.prog.ref_cols_acc(self.q, *rt.nd(p.w, p.h), src=self.tmp, width=w, height=h, taps=self.taps, R=R,
                                     margin=np.int32(my), prof=self.prof, acc_img=self.acc))


def reference_into(plan, t) -> None:
    rt, q = plan.rt, plan.rt.queue
    w, h, n = plan.w, plan.h, plan.w * plan.h
    if plan.apsf:
        sigmas = load_table()["sigma_u"] * plan.cfg.camera.focal(w) * plan.cfg.render.spread_scale
        off = lut_offsets(len(plan.sizes) - 1, len(sigmas))
        shape = plan.lut_host[off["shape"]:off["lambert"]].reshape(len(sigmas), -1)
        blur = _Blur(plan, t, float(sigmas.max()))
        for j, sj in enumerate(sigmas):
            if shape[j].max() <= 0.0:
                continue   # no pixel of this medium has light in this Gaussian
            R = blur.norms(float(sj) if sj >= S0 else 1e-3)   # sharper than S0: a delta
            t.add("reference",
                  blur.prog.ref_apsf_source(q, *rt.nd(w, h), scat0=plan.chain, lut=plan.lut, width=np.int32(w),
                                            height=np.int32(h), j=np.int32(j), norm_x=blur.nx, norm_y=blur.ny,
                                            src=blur.src))
            blur.profiles(j)
            blur.blur_add(R)
    else:
        sigma = plan.download(plan.spread, 1, t)   # glue: which bins exist decides the work
        blur = _Blur(plan, t, float(sigma.max()))
        for b in _bins_needed(sigma):
            R = blur.norms(S0 * RATIO ** b)
            t.add("reference",
                  blur.prog.ref_bin_source(q, *rt.nd(w, h), scat0=plan.chain, spread0=plan.spread, width=np.int32(w),
                                           height=np.int32(h), s0=np.float32(S0),
                                           log_ratio=np.float32(math.log(RATIO)), b=np.int32(b), norm_x=blur.nx,
                                           norm_y=blur.ny, src=blur.src))
            blur.blur_add(R)
    t.add("reference",
          blur.prog.ref_finish(q, *rt.nd(n), direct=plan.direct, medium_term=plan.medium, acc_img=blur.acc,
                               n=np.int32(n), add_medium=np.int32(plan.split_medium), out=plan.out,
                               want_aov=np.int32(bool(plan.aovs)), level_aov=plan.level_aov,
                               scattered_aov=plan.scat_aov))


def brute_force(plan, t) -> np.ndarray:
    """O(N^2) definition of the Gaussian reference blur of L_sc (small images only): (h, w, 3)."""
    rt, cl, q = plan.rt, plan.rt.cl, plan.rt.queue
    w, h, n = plan.w, plan.h, plan.w * plan.h
    prog = rt.program("reference", **_defines(plan))
    norm = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 4 * n)
    out = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 16 * n)
    t.add("reference",
          prog.ref_brute_norm(q, *rt.nd(w, h), spread0=plan.spread, width=np.int32(w), height=np.int32(h), norm=norm,
                              open_border=np.int32(open_border(plan.cfg))))
    t.add("reference",
          prog.ref_brute(q, *rt.nd(w, h), scat0=plan.chain, spread0=plan.spread, norm=norm, width=np.int32(w),
                         height=np.int32(h), out=out))
    return plan.download(out, 4, t)[:, :, :3]


def _defines(plan):
    return defines(plan.cfg)
