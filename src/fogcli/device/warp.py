"""render.spread_space: angles (kernels/warp.cl): the source collapse's levels K and up in a
plane of angles. The reduce makes level K in the image's plane and warp_chain moves it over;
the levels above follow there; the collapse makes level K there and unwarp brings it back for
the levels below. The receivers' level K moves with it (warp_receivers). The scratch is the
plan's half-octave image (source_bufs), free between the stages that use it."""
from __future__ import annotations

import numpy as np

from fogcli.device.plan import Timings


def _geometry(plan) -> tuple[int, int, int, int, dict]:
    """(level, its offset, width, height, the kernels' WARP_GEOM arguments)."""
    k, s, cx, cy, fx, fy = plan.warp
    o, w, h, _ = (int(v) for v in plan.lv[k])
    f32 = np.float32
    return k, o, w, h, dict(cx=f32(cx), cy=f32(cy), fx=f32(fx), fy=f32(fy), sf=f32(s * fx), sc=f32(2 ** k))


def warp_chain(plan, t: Timings, chain, prep, scratch) -> None:
    """Level K of the colour chain (just reduced) into the plane of angles, with its prep."""
    k, o, w, h, geom = _geometry(plan)
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_level"], w, h, chain=chain, off=np.int32(o), w=np.int32(w),
                                      h=np.int32(h), out=scratch, **geom))
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_store"], w, h, chain=chain, prep=prep, off=np.int32(o),
                                      w=np.int32(w), h=np.int32(h), src=scratch, lut=plan.lut, level=np.int32(k)))


def warp_receivers(plan, t: Timings) -> None:
    """Level K of the receivers' log P into the plane of angles (the levels above are made
    from it there)."""
    k, o, w, h, geom = _geometry(plan)
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_receivers"], w, h, rd=plan.rdepth, off=np.int32(o),
                                      w=np.int32(w), h=np.int32(h), out=plan.image, **geom))
    t.add("pyramid", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.rdepth, plan.image, byte_count=4 * w * h,
                                             src_offset=0, dst_offset=4 * o))


def unwarp(plan, t: Timings, chain, scratch) -> None:
    """Level K of the collapsed chain back into the image's plane, in place."""
    k, o, w, h, geom = _geometry(plan)
    t.add("composite", plan.rt.launch2d(plan.k_warp["unwarp_level"], w, h, chain=chain, off=np.int32(o),
                                        w=np.int32(w), h=np.int32(h), out=scratch, **geom))
    t.add("composite", plan.rt.cl.enqueue_copy(plan.rt.queue, chain, scratch, byte_count=16 * w * h,
                                               src_offset=0, dst_offset=16 * o))


def ext_receiver_args(plan) -> dict:
    """receiver_depth_ext's arguments for the main plan's level the extension reads: whether
    it lies in the plane of angles, and where that is."""
    if plan.warp is None or plan._ext_level < plan.warp[0]:
        z = np.float32(0)
        return dict(warped=np.int32(0), cx=z, cy=z, fx=np.float32(1), fy=np.float32(1), sf=np.float32(1),
                    sc=np.float32(1))
    _, _, _, _, geom = _geometry(plan)
    return dict(warped=np.int32(1), **dict(geom, sc=np.float32(2 ** plan._ext_level)))
