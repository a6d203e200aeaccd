"""The screen-space reference (SPEC 4.4) on the device, binned in sigma.

Bins form a geometric ladder s0 * RATIO^b; a pixel's energy is split between the two
bins around its sigma (linear in log sigma). tests/test_reference.py holds the binned
form to within 1 % relative L1 of the brute-force definition (`brute_force`)."""
from __future__ import annotations

import math

import numpy as np

S0 = 0.25                 # px; sharper spreads stay (nearly) delta-like
RATIO = 2.0 ** (1.0 / 6.0)


def _bins_needed(sigma: np.ndarray) -> list[int]:
    u = np.maximum(np.log(np.maximum(sigma, 1e-30) / S0) / math.log(RATIO), 0.0)
    lo = np.unique(np.floor(u).astype(np.int64))
    return [int(b) for b in np.union1d(lo, lo + 1)]


def reference_into(plan, t) -> None:
    rt, cl, q = plan.rt, plan.rt.cl, plan.rt.queue
    w, h, n = plan.w, plan.h, plan.w * plan.h
    prog = rt.program("reference", **_defines(plan))
    sigma = plan.download(plan.spread, 1, t)   # glue: which bins exist decides the work
    mf = cl.mem_flags
    src = cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * n)
    tmp = cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * n)
    acc = cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * n)
    t.add("reference", cl.enqueue_fill_buffer(q, acc, np.float32(0), 0, 16 * n))
    smax = float(sigma.max())
    rmax = int(math.ceil(4.0 * max(smax, S0) * RATIO)) + 1
    taps = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * (rmax + 1))
    nx = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * w)
    ny = cl.Buffer(rt.ctx, mf.READ_WRITE, 4 * h)
    for b in _bins_needed(sigma):
        sb = S0 * RATIO ** b
        R = int(math.ceil(4.0 * sb))
        t.add("reference", prog.ref_taps(q, *rt.nd(R + 1), taps, np.float32(sb), np.int32(R)))
        t.add("reference", prog.ref_norm1d(q, *rt.nd(w), taps, np.int32(R), np.int32(w), nx))
        t.add("reference", prog.ref_norm1d(q, *rt.nd(h), taps, np.int32(R), np.int32(h), ny))
        t.add("reference", prog.ref_bin_source(q, *rt.nd(w, h), plan.chain, plan.spread, np.int32(w),
                                               np.int32(h), np.float32(S0), np.float32(math.log(RATIO)),
                                               np.int32(b), nx, ny, src))
        t.add("reference", prog.ref_rows(q, *rt.nd(w, h), src, np.int32(w), np.int32(h), taps, np.int32(R), tmp))
        t.add("reference", prog.ref_cols_acc(q, *rt.nd(w, h), tmp, np.int32(w), np.int32(h), taps, np.int32(R), acc))
    t.add("reference", prog.ref_finish(q, *rt.nd(n), plan.direct, plan.medium, acc, np.int32(n),
                                       np.int32(plan.split_medium), plan.out,
                                       np.int32(bool(plan.aovs)), plan.level_aov, plan.scat_aov))


def brute_force(plan, t) -> np.ndarray:
    """O(N^2) definition of the reference blur of L_sc (small images only): (h, w, 3)."""
    rt, cl, q = plan.rt, plan.rt.cl, plan.rt.queue
    w, h, n = plan.w, plan.h, plan.w * plan.h
    prog = rt.program("reference", **_defines(plan))
    norm = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 4 * n)
    out = cl.Buffer(rt.ctx, cl.mem_flags.READ_WRITE, 16 * n)
    t.add("reference", prog.ref_brute_norm(q, *rt.nd(w, h), plan.spread, np.int32(w), np.int32(h), norm))
    t.add("reference", prog.ref_brute(q, *rt.nd(w, h), plan.chain, plan.spread, norm, np.int32(w), np.int32(h), out))
    return plan.download(out, 4, t)[:, :, :3]


def _defines(plan):
    from .pipeline import defines

    return defines(plan.cfg)
