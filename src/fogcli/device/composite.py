"""kernels/composite.cl: the pixel's light put together (Elek eq. 8; Iser eq. 4.26-4.28 for
the separated chain), the result mapped or read back, and the AOV planes."""
from __future__ import annotations

import numpy as np

from fogcli.device.plan import Timings
from fogcli.device.pyramid import split


def composite_source(plan, t: Timings, second: bool = False) -> None:
    top = len(plan.sizes) - 1
    chain, half, prep = plan.source_bufs(second)
    if top > 0:
        split(plan, t, 0, chain, half)
    args = dict(direct=plan.direct, medium_term=plan.medium, chain=chain, half_img=half, lv=plan.lv_buf,
                kmax=np.int32(top), c=np.float32(plan.cfg.render.resolved()[0]), a=np.float32(plan.half_step()),
                out=plan.out, level_aov=plan.level_aov, scattered_aov=plan.scat_aov, prep=prep, spread0=plan.spread,
                edge=plan.edge, cons=plan.cons, cons_up=np.int32(plan.cons_off[1]))
    plan.launch_pairs(t, plan._pairs[0], plan.k_comp_pairs[second], plan.k_comp_src[second], plan.w, plan.h,
                       args, chain, 1)


def composite(plan, t: Timings, depth_blur: bool) -> None:
    c, _, _ = plan.cfg.render.resolved()
    t.add("composite",
          plan.k_comp(plan.rt.queue, *plan.rt.nd(plan.w, plan.h), direct=plan.direct, medium_term=plan.medium,
                      chain=plan.chain, spread_chain=plan.spread, lv=plan.lv_buf, kmax=np.int32(len(plan.sizes) - 1),
                      c=np.float32(c), depth_blur=np.int32(depth_blur), add_medium=np.int32(plan.split_medium),
                      out=plan.out, want_aov=np.int32(bool(plan.aovs)), level_aov=plan.level_aov,
                      scattered_aov=plan.scat_aov))


def composite_separated(plan, t: Timings) -> None:
    """Iser eq. 4.26-4.28 on the receiver fetch: level k_ssc = separation.level * K."""
    kmax = len(plan.sizes) - 1
    t.add("composite",
          plan.k_comp_sep(plan.rt.queue, *plan.rt.nd(plan.w, plan.h), chain2=plan.chain2, lv=plan.lv_buf,
                          kmax=np.int32(kmax), c=np.float32(plan.cfg.render.resolved()[0]),
                          k_ssc=np.float32(plan.cfg.render.separation.level * kmax), out=plan.out,
                          want_aov=np.int32(bool(plan.aovs)), scattered_aov=plan.scat_aov))


def map_out(plan, t: Timings) -> np.ndarray:
    """The result buffer mapped for reading (run(mapped=True); unmap releases it)."""
    cl, q = plan.rt.cl, plan.rt.queue
    arr, ev = cl.enqueue_map_buffer(q, plan.out, cl.map_flags.READ, 0, (plan.h, plan.w, 4), np.float32)
    t.add("download", ev)
    ev.wait()
    arr.base._fogcli_queue = q
    return arr


def aov_planes(plan, t: Timings) -> dict:
    if not plan.aovs:
        return {}
    out = {}
    # optical_depth and emission share the medium buffer (P in .w): download it once
    medium = plan.download(plan.medium, 4, t) if {"optical_depth", "emission"} & set(plan.aovs) else None
    rgb_bufs = {"transmittance": plan.trans, "direct": plan.direct, "scattered": plan.scat_aov,
                "airlight": plan.a_dir, "airlight_scattered": plan.a_sc}
    for name in plan.aovs:
        if name == "optical_depth":
            out[name] = medium[:, :, 3]
        elif name == "spread":
            out[name] = plan.download(plan.spread, 1, t)   # level 0 of the spread chain
        elif name == "level":
            out[name] = plan.download(plan.level_aov, 1, t)
        elif name.startswith("airlight") and not plan.cfg.lights:
            out.update({f"{name}.{ch}": np.zeros((plan.h, plan.w), np.float32) for ch in "RGB"})
        else:
            src = medium if name == "emission" else plan.download(rgb_bufs[name], 4, t)
            for i, ch in enumerate("RGB"):
                out[f"{name}.{ch}"] = src[:, :, i]
    return out
