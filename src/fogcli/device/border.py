"""render.border: extend (kernels/pyramid.cl border_sources): the frame's edge continued past
each side, its light spread by a second, smaller plan and added to the main chain's level
ext_level (pyramid.inject)."""
from __future__ import annotations

import numpy as np

from fogcli.device.composite import composite_source
from fogcli.device.border_size import (EDGE_BAND_LOGP, border_band, border_margin, edge_band_bytes, edge_entries,
                                       ext_level)
from fogcli.device.plan import Plan, Timings
from fogcli.device.preprocess import upload_lut
from fogcli.device.pyramid import collapse, receiver_depth, reduce
from fogcli.device.warp import ext_receiver_args


def extend(plan, t: Timings) -> bool:
    """render.border: extend. The frame's edge continued `border_margin` past each side, as
    the mean of the `border_band` next to it:
    those sources' light is spread by a second apsf chain on the padded frame at the
    resolution of level ext_level (3, finer for a narrow margin; their light reaches the
    frame only through blurs of several pixels and more; the open main chain has the
    frame's own); collapse(ext=True) adds it to that level. About 1/16 of the main chain's
    pixels at margin 0.5. Returns whether there is one."""
    mx, my = border_margin(plan.cfg, plan.w, plan.h)
    plan._ext_level = min(ext_level(plan.cfg, plan.w, plan.h), len(plan.sizes) - 1)
    if not (mx or my) or plan._ext_level == 0:
        return False
    s = 2 ** plan._ext_level
    ox, oy = -(-mx // s) * s, -(-my // s) * s
    pw, ph = -(-(plan.w + 2 * ox) // s), -(-(plan.h + 2 * oy) // s)
    main = plan.cfg.camera
    cx, cy = main.centre(plan.w, plan.h)
    cam = main.model_copy(update=dict(focal_px=main.focal(plan.w) / s, focal_px_y=main.focal_y(plan.w) / s,
                                      cx=(cx + ox) / s, cy=(cy + oy) / s, calibrated_size=None))
    render = plan.cfg.render.model_copy(update=dict(border="open", levels="auto",
                                                    separation=plan.cfg.render.separation.model_copy(
                                                        update=dict(enabled=False))))
    cfg = plan.cfg.model_copy(update=dict(camera=cam, render=render, lights=[]))
    if plan._ext is None:
        plan._ext = Plan(plan.rt, pw, ph, cfg)
    ext = plan._ext
    # no direct light of its own: zeros, every frame (its result is written over them)
    for buf in (ext.direct, ext.medium):
        t.add("composite", plan.rt.cl.enqueue_fill_buffer(plan.rt.queue, buf, np.float32(0), 0, buf.size))
    ext.cfg = cfg
    upload_lut(ext, t)
    q, i32 = plan.rt.queue, np.int32
    if plan._edge_bands is None:
        plan._edge_bands = plan.rt.cl.Buffer(plan.rt.ctx, plan.rt.cl.mem_flags.READ_WRITE,
                                             edge_band_bytes(plan.w, plan.h))
    kx, ky = border_band(plan.cfg, plan.w, plan.h)
    t.add("pyramid",
          plan.k_edge_bands(q, *plan.rt.nd(edge_entries(plan.w, plan.h)), chain0=plan.chain,
                            sep0=plan.chain2 if plan.sep else plan.chain, with_sep=i32(bool(plan.sep)), w=i32(plan.w),
                            h=i32(plan.h), kx=i32(kx), ky=i32(ky), gate=np.float32(EDGE_BAND_LOGP),
                            bands=plan._edge_bands))
    t.add("pyramid",
          ext.k_border_src(q, *plan.rt.nd(pw, ph), bands=plan._edge_bands, w=i32(plan.w), h=i32(plan.h), chain=ext.chain,
                           prep=ext.prep, pw=i32(pw), ph=i32(ph), ox=i32(ox), oy=i32(oy), mx=i32(mx), my=i32(my),
                           scale=i32(s), lut=ext.lut))
    if ext.features.recv:
        # its receivers: the main frame's at ext_level, the continued edge's past it (not its
        # own level 0's log P, which lights have joined by now)
        o, mw, mh, _ = (int(v) for v in plan.lv[plan._ext_level])
        t.add("pyramid", plan.rt.launch2d(ext.k_recv_ext, pw, ph, main_rd=plan.rdepth, main_off=i32(o), mw=i32(mw),
                                          mh=i32(mh), rd=ext.rdepth, pw=i32(pw), ph=i32(ph), ox=i32(ox // s),
                                          oy=i32(oy // s), **ext_receiver_args(plan)))
        receiver_depth(ext, t, from_rd0=True)
    reduce(ext, t, masked=True)
    collapse(ext, t)
    composite_source(ext, t)
    plan._ext_geom = (np.int32(pw), np.int32(ox // s), np.int32(oy // s))
    return True
