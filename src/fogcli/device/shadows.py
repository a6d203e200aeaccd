"""kernels/shadows.cl: screen-space shadows of the lights, marched per pixel or along the
epipolar lines through the light's image (Intel's epipolar sampling)."""
from __future__ import annotations

import math

import numpy as np

from fogcli.config.model import Config
from fogcli.device.geometry import placed, rotation
from fogcli.device.plan import Timings
from fogcli.device.structs import SH_BINS


DENSE_PX = 64.0      # the epipolar samples' dense zone around the light's image, at most (pixels)


def epipolar_layout(cfg: Config, light, width: int, height: int, slices: int, step: int) -> tuple:
    """The samples of render.lights.method: epipolar (kernels/shadows.cl): (ex, ey) the light's
    image (its antipode for a light behind the camera; 1e4 pixels out along the epipolar lines
    when they are nearly parallel), the slices' angles a0 + k da, k < ns, the samples' radii
    (r0 + m h1 below rb, rb + (m - m1) h2 beyond; m < nm), whether the slices go all round
    (the image holds e) and whether e is the light's own image (in front of the camera)."""
    cam = cfg.camera.for_size(width, height)
    f, fy = cam.focal(width), cam.focal_y(width)
    cx, cy = cam.centre(width, height)
    pos, axis = placed(cfg, light)
    v = np.asarray(axis if light.type == "directional" else np.asarray(pos) - np.asarray(cfg.camera.position), float)
    x, y, z = rotation(cfg.camera.yaw, cfg.camera.pitch, cfg.camera.roll).T @ v
    g = np.array([f * x, -fy * y])          # the lines' direction where they are parallel
    far = 1e4
    if abs(z) * far > np.hypot(*g):
        e = np.array([cx + f * x / -z, cy - fy * y / -z])
    else:
        e = np.array([cx, cy]) - far * g / max(np.hypot(*g), 1e-30)
    corners = np.array([[0, 0], [width, 0], [0, height], [width, height]], float) - e
    r_max = float(np.hypot(corners[:, 0], corners[:, 1]).max())
    inside = 0 <= e[0] <= width and 0 <= e[1] <= height
    if inside:
        a0, span, r0, full = -math.pi, 2 * math.pi, 0.0, True
    else:
        mid = math.atan2(cy - e[1], cx - e[0])
        d = (np.arctan2(corners[:, 1], corners[:, 0]) - mid + math.pi) % (2 * math.pi) - math.pi
        a0, span, full = mid + float(d.min()), float(d.max() - d.min()), False
        r0 = float(np.hypot(max(0 - e[0], 0, e[0] - width), max(0 - e[1], 0, e[1] - height)))
    # at most two slices per border pixel, and `step` at most 1/16 of the longer side: small
    # images keep their accuracy (64 x 48 at step 16: up to 10 % from the march) and do not
    # get more samples than pixels
    ns = int(min(slices, 2 * (width + height)))
    step = max(2, min(step, round(max(width, height) / 16)))
    da = span / ns if full else span / max(ns - 1, 1)
    # four times as dense near the light's image, where the shares change fastest: within 15 %
    # of the image's longer side (Intel's sample: 0.3 NDC) and at most DENSE_PX (at 1920 x 1080
    # the error against the march is 0.23 % with 64 or 128 px, 0.20 % with 288 px, 1.6 % with
    # none; 64 px instead of 288 saves a third of the samples; small images need their 15 %:
    # at 256 x 192, 38 px, 0.95 %, and 13 px, 2.0 %)
    h1 = step / 4.0
    m1 = int(math.ceil(max(min(0.15 * max(width, height), DENSE_PX) - r0, 0.0) / h1))
    rb = r0 + m1 * h1
    nm = m1 + int(math.ceil(max(r_max - rb, 0.0) / step)) + 2
    front = bool(z < 0 and abs(z) * far > np.hypot(*g))      # e is the light's own image
    return float(e[0]), float(e[1]), a0, da, r0, rb, h1, float(step), m1, nm, ns, full, front


def epipolar(plan, t: Timings, k, dst: dict, shade: dict, light) -> None:
    """render.lights.method: epipolar (kernels/shadows.cl): each slice through the light's
    image walked once into a 1D shadow map with min/max trees (epi_maps), the shares at
    samples on the slices read from them (epi_samples), then every pixel from its four
    samples (epi_unwarp), or marched (epi_march: the pixels epi_unwarp flagged).
    plan.epi_marched[0]: how many pixels were marched themselves (tools/shadows.py). dst:
    the airlight's buffers (a_dir, a_sc); shade: the shadow kernels' light and medium
    arguments (lights.airlight)."""
    cl, q = plan.rt.cl, plan.rt.queue
    sh = plan.cfg.render.lights
    ex, ey, a0, da, r0, rb, h1, h2, m1, nm, ns, full, front = epipolar_layout(plan.cfg, light, plan.w, plan.h,
                                                                              sh.slices, sh.step)
    # the samples' shares, the slices' maps (min and max trees) and ranges, the marched-pixel
    # counter: kept while big enough (fresh buffers cost their pages' zeroing every frame)
    if plan._epi is None or plan._epi[0] < nm * ns or plan._epi[1] < ns:
        mf = cl.mem_flags
        B = lambda nbytes: cl.Buffer(plan.rt.ctx, mf.READ_WRITE, nbytes)  # noqa: E731
        plan._epi = (nm * ns, ns, B(16 * nm * ns), B(16 * nm * ns), B(16 * SH_BINS * ns), B(16 * ns), B(4))
    sh_a, sh_t, maps, ranges, counter = plan._epi[2:]
    plan.epi_marched = np.zeros(1, np.int32)
    cl.enqueue_fill_buffer(q, counter, np.int32(0), 0, 4)
    f = np.float32
    slices = dict(ex=f(ex), ey=f(ey), a0=f(a0), da=f(da), ns=np.int32(ns))
    lay = dict(slices, r0=f(r0), rb=f(rb), h1=f(h1), h2=f(h2), m1=np.int32(m1), nm=np.int32(nm))
    frame = dict(depth=plan.depth, width=np.int32(plan.w), height=np.int32(plan.h))
    inside = front and full         # the lines reach the light's image inside the frame
    t.add("shadows", k.epi_maps(q, *plan.rt.nd(ns), **frame, maps=maps, ranges=ranges, cam=shade["cam"], L=shade["L"],
                                thickness=shade["thickness"], **slices, off=np.int32(not inside)))
    t.add("shadows", k.epi_samples(q, *plan.rt.nd(nm, ns), **frame, sh_a=sh_a, sh_t=sh_t, **shade, **lay, maps=maps,
                                   ranges=ranges))
    t.add("shadows", k.epi_unwarp(q, *plan.rt.nd(-(-plan.w // plan.lanes), plan.h), **frame, **dst, sh_a=sh_a,
                                  sh_t=sh_t, cam=shade["cam"], **lay, full_circle=np.int32(full), march=plan.epi_flags))
    t.add("shadows", k.epi_march(q, *plan.rt.nd(plan.w, plan.h), **frame, **dst, **shade, march=plan.epi_flags,
                                 marched=counter))
    cl.enqueue_copy(q, plan.epi_marched, counter, is_blocking=False)     # read with the download
