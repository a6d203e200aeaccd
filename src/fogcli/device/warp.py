"""render.spread_space: angles (kernels/warp.cl): the source collapse's levels K and up in a
plane of angles. The reduce makes level K in the image's plane and warp_chain moves it over;
the levels above follow there; the collapse makes level K there and unwarp brings it back for
the levels below. The receivers' level K moves with it (warp_receivers). The scratch is the
plan's half-octave image (source_bufs), free between the stages that use it. Where each pixel
samples is computed here once per camera and size (maps; physics/apsf.py: plane_to_image,
image_to_plane, the one definition of the plane)."""
from __future__ import annotations

import numpy as np

from fogcli.device.plan import Timings
from fogcli.physics.apsf import image_to_plane, plane_to_image


def map_arrays(geom, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """For level K (w x h) of the plane of angles geom: to_image (h, w, 4) float32, where each
    plane pixel lies on the image's level (index space), sin(rho) / rho there, and 1 where
    that is on the frame (else 0); to_plane (h, w, 2), where each image pixel of the level
    lies on the plane's (index space)."""
    sc = 2.0 ** geom[0]
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    px, py, jac, ok = plane_to_image((x + 0.5) * sc, (y + 0.5) * sc, geom)
    u, v = px / sc - 0.5, py / sc - 0.5
    inside = ok & (u >= -0.5) & (v >= -0.5) & (u <= w - 0.5) & (v <= h - 0.5)
    to_image = np.stack([np.where(ok, u, -1.0), np.where(ok, v, -1.0), jac, inside.astype(np.float64)], -1)
    qx, qy = image_to_plane((x + 0.5) * sc, (y + 0.5) * sc, geom)
    to_plane = np.stack([qx / sc - 0.5, qy / sc - 0.5], -1)
    return to_image.astype(np.float32), to_plane.astype(np.float32)


def maps(plan):
    """The device copies of map_arrays for this frame's camera: (to_image, to_plane) buffers,
    made again only when the plane changes."""
    _, _, w, h = _level(plan)
    if getattr(plan, "_warp_maps", None) is None or plan._warp_maps[0] != plan.warp:   # a plan keeps its size
        cl = plan.rt.cl
        mf = cl.mem_flags
        a, b = map_arrays(plan.warp, w, h)
        plan._warp_maps = (plan.warp, cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a),
                           cl.Buffer(plan.rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=b))
    return plan._warp_maps[1], plan._warp_maps[2]


def _level(plan) -> tuple[int, int, int, int]:
    k = plan.warp[0]
    o, w, h, _ = (int(v) for v in plan.lv[k])
    return k, o, w, h


def warp_chain(plan, t: Timings, chain, prep, scratch) -> None:
    """Level K of the colour chain (just reduced) into the plane of angles, with its prep."""
    k, o, w, h = _level(plan)
    to_image, _ = maps(plan)
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_level"], w, h, chain=chain, off=np.int32(o), w=np.int32(w),
                                      h=np.int32(h), out=scratch, to_image=to_image))
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_store"], w, h, chain=chain, prep=prep, off=np.int32(o),
                                      w=np.int32(w), h=np.int32(h), src=scratch, lut=plan.lut, level=np.int32(k)))


def warp_receivers(plan, t: Timings) -> None:
    """Level K of the receivers' log P into the plane of angles (the levels above are made
    from it there)."""
    k, o, w, h = _level(plan)
    to_image, _ = maps(plan)
    t.add("pyramid", plan.rt.launch2d(plan.k_warp["warp_receivers"], w, h, rd=plan.rdepth, off=np.int32(o),
                                      w=np.int32(w), h=np.int32(h), out=plan.image, to_image=to_image))
    t.add("pyramid", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.rdepth, plan.image, byte_count=4 * w * h,
                                             src_offset=0, dst_offset=4 * o))


def unwarp(plan, t: Timings, chain, scratch) -> None:
    """Level K of the collapsed chain back into the image's plane, in place."""
    k, o, w, h = _level(plan)
    _, to_plane = maps(plan)
    t.add("composite", plan.rt.launch2d(plan.k_warp["unwarp_level"], w, h, chain=chain, off=np.int32(o),
                                        w=np.int32(w), h=np.int32(h), out=scratch, to_plane=to_plane))
    t.add("composite", plan.rt.cl.enqueue_copy(plan.rt.queue, chain, scratch, byte_count=16 * w * h,
                                               src_offset=0, dst_offset=16 * o))


def ext_receiver_args(plan) -> dict:
    """receiver_depth_ext's arguments for the main plan's level the extension reads: whether
    it lies in the plane of angles, and where each of its pixels lies there (the level is
    K: the extension joins at or below it)."""
    if plan.warp is None or plan._ext_level < plan.warp[0]:
        return dict(warped=np.int32(0), to_plane=plan.lut)      # not read
    return dict(warped=np.int32(1), to_plane=maps(plan)[1])
