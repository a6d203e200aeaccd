"""kernels/pyramid.cl: the pyramid's reduce (Elek eq. 5-7), and the source collapse's
half-octave split and collapse of levels K-1 .. 1."""
from __future__ import annotations

import numpy as np

from fogcli.device.plan import Timings
from fogcli.device.warp import unwarp, warp_chain, warp_receivers
from fogcli.physics.calibration import FILTERS

LANES_MIN_WIDTH = 64    # reduce_source_lanes on levels at least this wide (pyramid.reduce)


def reduce_region(sw: int, sh: int, dw: int, dh: int, taps: int, margin: int, local: tuple) -> tuple | None:
    """The destination pixels (x0, x1, y0, y1) of a reduce from a sw x sh level to dw x dh that
    reduce_source_inner takes, on whole work-groups: every tap inside the source level and at
    least `margin` pixels from its edges (apsf: where the conservation factors are 1)."""
    out = []
    for s, d, l in ((sw, dw, local[0]), (sh, dh, local[1])):
        lo = -(-(margin + taps // 2 - 1) // 2)                  # 2 x - taps / 2 + 1 >= margin
        hi = min(d - 1, (s - margin - taps + taps // 2 - 1) // 2)   # 2 x - taps / 2 + 1 + taps <= s - margin
        n = (hi + 1 - lo) // l * l
        if n <= 0:
            return None
        out += [lo, lo + n]
    return tuple(out)


def reduce(plan, t: Timings, masked: bool, second: bool = False) -> None:
    eps = plan.cfg.render.resolved()[1]
    q = plan.rt.queue
    chain, scratch, prep = plan.source_bufs(second)
    warp_k = None if plan.warp is None else plan.warp[0]      # the plane of angles: apsf source collapse only
    if plan.source:
        taps = len(FILTERS[plan.cfg.render.kernel])
        for k in range(1, len(plan.sizes)):
            (so, sw, sh, _), (do, dw, dh, _) = plan.lv[k - 1], plan.lv[k]
            args = dict(chain=chain, prep=prep, src_off=np.int32(so), sw=np.int32(sw), sh=np.int32(sh),
                        dst_off=np.int32(do), dw=np.int32(dw), dh=np.int32(dh),
                        thresh_next=np.float32(plan.threshold(k + 1)), eps=np.float32(eps), lut=plan.lut,
                        level=np.int32(k), edge=plan.edge, edge_off=np.int32(plan.edge_off[k]), cons=plan.cons,
                        cons_off=np.int32(plan.cons_off[k]))
            # on an 8-wide CPU without AVX-512 LLVM leaves the interior kernel scalar (its
            # strided and table reads), and the per-pixel kernel is the faster scalar code
            # (tools/avx2/run.sh); for apsf the interior is written on float8 there
            # (reduce_lanes: level 1 of 2 MPx ~10 -> ~4 ms on an AMD EPYC), below the top level,
            # whose kept share reads the border's; and on levels at least LANES_MIN_WIDTH wide:
            # on a narrower one its five launches cost the host more than they save the device
            margin = taps // 2 if plan.apsf else 0
            if plan.k_reduce_lanes is not None and k < len(plan.sizes) - 1 and dw >= LANES_MIN_WIDTH:
                reduce_lanes(plan, t, args, reduce_region(int(sw), int(sh), int(dw), int(dh), taps, margin, (8, 1)))
            else:
                region = reduce_region(int(sw), int(sh), int(dw), int(dh), taps, margin,
                                       plan.rt.local2d) if plan.lanes == 1 else None
                plan.launch_inner(t, "pyramid", region, plan.k_reduce_inner, (plan.k_reduce_src,) * 2,
                                  int(dw), int(dh), args, corner_args=True)
            if k == warp_k:
                warp_chain(plan, t, chain, prep, scratch)
        return
    spread = plan.spread2 if second else plan.spread
    for k in range(1, len(plan.sizes)):
        (so, sw, sh, _), (do, dw, dh, _) = plan.lv[k - 1], plan.lv[k]
        t.add("pyramid",
              plan.k_reduce(q, *plan.rt.nd(dw, dh), chain=chain, spread_chain=spread, src_off=np.int32(so),
                            sw=np.int32(sw), sh=np.int32(sh), dst_off=np.int32(do), dw=np.int32(dw), dh=np.int32(dh),
                            thresh=np.float32(plan.threshold(k)), eps=np.float32(eps), masked=np.int32(masked)))


def reduce_lanes(plan, t: Timings, args: dict, region: tuple | None) -> None:
    """A level of the apsf source reduce through reduce_source_lanes (kernels/reduce_lanes.cl:
    eight pixels a work-item, for CPUs with 8-wide SIMD) on `region`, whose width is a
    multiple of 8, and reduce_level_source on the strips around it."""
    dw, dh = int(args["dw"]), int(args["dh"])
    if region is None:
        t.add("pyramid", plan.rt.launch2d((plan.k_reduce_src,) * 2, dw, dh, **args))
        return
    x0, x1, y0, y1 = region
    n8, ny = (x1 - x0) // 8, y1 - y0
    t.add("pyramid", plan.k_reduce_lanes(
        plan.rt.queue, *plan.rt.nd(n8, ny), chain=args["chain"], prep=args["prep"], src_off=args["src_off"],
        sw=args["sw"], dst_off=args["dst_off"], dw=args["dw"], lut=args["lut"], level=args["level"],
        px0=np.int32(x0), py0=np.int32(y0), n8=np.int32(n8), ny=np.int32(ny)))
    t.add("pyramid", plan.rt.launch_strips(plan.k_reduce_src, dw, dh, region, **args))


def receiver_depth(plan, t: Timings, from_rd0: bool = False) -> None:
    """render.halo_depth: receiver: levels 1 .. K of the receivers' mean log P (rdepth), level 1
    from the colour chain's level 0, whose .w is each pixel's log P until lights join it
    (preprocess runs this); from_rd0: from level 0 of rdepth itself (the extension plan's,
    border.extend)."""
    for k in range(1, len(plan.sizes)):
        (so, sw, sh, _), (do, dw, dh, _) = plan.lv[k - 1], plan.lv[k]
        src, src_off, stride = (plan.chain, 3, 4) if k == 1 and not from_rd0 else (plan.rdepth, int(so), 1)
        t.add("pyramid", plan.rt.launch2d(plan.k_recv_depth, int(dw), int(dh), src=src, src_off=np.int32(src_off),
                                          stride=np.int32(stride), sw=np.int32(sw), sh=np.int32(sh), rd=plan.rdepth,
                                          dst_off=np.int32(do), dw=np.int32(dw), dh=np.int32(dh)))
        if plan.warp is not None and k == plan.warp[0]:
            warp_receivers(plan, t)


def split(plan, t: Timings, k: int, chain, out) -> None:
    """Half-octave shares of level k of `chain` into `out` (level-0 sized scratch)."""
    o, w, h, _ = (int(v) for v in plan.lv[k])
    t.add("composite", plan.rt.launch2d(
        plan.k_split, w, h, chain=chain, off=np.int32(o), h=np.int32(h), half_img=out,
        thresh=np.float32(plan.threshold(k + 1)), eps=np.float32(plan.cfg.render.resolved()[1]), lut=plan.lut,
        level=np.int32(k), w=np.int32(w), edge=plan.edge, edge_off=np.int32(plan.edge_off[k])))


def collapse(plan, t: Timings, second: bool = False, ext: bool = False) -> None:
    """Source collapse of levels K-1 .. 1, in place over the colour chain (level 0 is
    fused into composite_source). The input buffer, free after preprocess, is the
    scratch for the half-octave shares. ext: the extension plan's light (`extend`, run
    first) joins at its level."""
    a = plan.half_step()
    chain, half, prep = plan.source_bufs(second)
    top = len(plan.sizes) - 1
    if plan.features.recv and top > 0:
        o, w, h, _ = (int(v) for v in plan.lv[top])
        t.add("composite", plan.rt.launch2d(plan.k_recv_top, w, h, chain=chain, off=np.int32(o), w=np.int32(w),
                                            h=np.int32(h), rd=plan.rdepth, rd_off=np.int32(o), lut=plan.lut,
                                            level=np.int32(top)))
    if ext and plan._ext_level == top:
        inject(plan, t)
    for k in range(top - 1, 0, -1):
        (o, w, h, _), (uo, uw, uh, _) = plan.lv[k], plan.lv[k + 1]
        split(plan, t, k, chain, half)
        args = dict(chain=chain, off=np.int32(o), w=np.int32(w), h=np.int32(h), half_img=half, up_off=np.int32(uo),
                    uw=np.int32(uw), uh=np.int32(uh), a=np.float32(a), prep=prep, edge=plan.edge,
                    edge_off=np.int32(plan.edge_off[k]), cons=plan.cons, cons_up=np.int32(plan.cons_off[k + 1]),
                    lut=plan.lut, rd=plan.rdepth, rd_off=np.int32(o), level=np.int32(k))
        plan.launch_pairs(t, plan._pairs[k], plan.k_collapse_pairs, plan.k_collapse, w, h, args, chain, k + 1)
        if plan.warp is not None and k == plan.warp[0]:
            unwarp(plan, t, chain, half)
        if ext and k == plan._ext_level:
            inject(plan, t)


def inject(plan, t: Timings) -> None:
    o, w, h, _ = (int(v) for v in plan.lv[plan._ext_level])
    pw, ox, oy = plan._ext_geom
    t.add("composite",
          plan.k_border_inject(plan.rt.queue, *plan.rt.nd(w, h), chain=plan.chain, off=np.int32(o), w=np.int32(w),
                               h=np.int32(h), ext=plan._ext.out, pw=pw, ox=ox, oy=oy))
