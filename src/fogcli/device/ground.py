"""`render.ground`: the ground and the sky of a frame as the boundaries of a slab of medium
(physics/slab.py, physics/ground.py). At upload the ground is looked for in a sample of the
depth; when there is one, the slab's in-scattered light is tabulated on the device (kernel
slab_table) and preprocess, built with PRE_GROUND, adds it to each pixel and takes the
ground's and the sky's mean colour out of their pixels' point-spread sources: the slab
carries the mean, the point spread only what differs from it."""
from __future__ import annotations

import numpy as np

from fogcli.device.plan import Timings, defines
from fogcli.device.geometry import rotation
from fogcli.physics import dome
from fogcli.physics import ground as gmod
from fogcli.physics import pixel_rays
from fogcli.physics import slab

NU = 32      # table entries over u = 1 - exp(-t) of the ray's optical length (129 x 32: within 0.1 % on average of a 1025 x 257 table)


def wanted(cfg) -> bool:
    """The slab assumes one homogeneous medium. `medium.ambient` is the user's own model of
    the light around (a uniform one): with it the slab, which would count the sky twice,
    stays out."""
    m = cfg.medium
    return (cfg.render.ground == "auto" and not m.heterogeneous and m.homogeneous > 0
            and not (m.ambient == "auto" or any(m.ambient)))


def find(cfg, width: int, height: int, colour: np.ndarray, depth: np.ndarray,
         grid: tuple | None = None) -> gmod.Ground | None:
    """The ground of the frame (colour (h, w, >= 3), depth raw as the camera says) from
    its sample, or None. grid: the depth's blocks when it was enlarged by nearest neighbour
    (preprocess.block_grid: kx, ky, px, py); a block's depth is then taken along the ray
    through its centre (a sensor's pixel centre), not the sample pixel's own: on a grazing
    ground a ray one row off moves the point by a row's height, and the plane fitted to a
    sample on one parity of rows tilted (ground-fog with the depth 2 x 2: 0.005 rad, the camera
    2 % low)."""
    if not wanted(cfg):
        return None
    cam = cfg.camera
    cols, rows = gmod.sample_grid(width, height)
    f, fy = cam.focal(width), cam.focal_y(width)
    cx, cy = cam.centre(width, height)
    rot = rotation(cam.yaw, cam.pitch, cam.roll)
    rc, rr = cols, rows
    if grid is not None:
        kx, ky, px, py = grid
        rc = px + (np.floor((cols - px) / kx) + 0.5) * kx - 0.5
        rr = py + (np.floor((rows - py) / ky) + 0.5) * ky - 0.5
    dirs = gmod.rays(rc, rr, f, fy, cx, cy, rot)
    raw = np.asarray(depth)[rows, cols].astype(np.float64)     # the sample first: the frame is 2 MPx
    if cam.depth != "distance":
        raw = raw * pixel_rays.length(pixel_rays.directions(rc, rr, f, fy, cx, cy))
    # directions in world orientation: camera.pitch and roll say where up is
    m = cfg.medium
    ext = float(np.mean(np.asarray(m.absorption) + np.asarray(m.scattering))) * m.homogeneous
    return gmod.find(raw, dirs, np.asarray(colour)[rows, cols, :3], cam.max_depth, f, ext)


def table(plan, g: gmod.Ground, t: Timings) -> None:
    """The slab's light per (mu_v, u) into plan.ground_table[0] (float4: RGB) for ground g."""
    cfg, rt = plan.cfg, plan.rt
    m = cfg.medium
    sa = np.asarray(m.absorption, np.float64) * m.homogeneous
    ss = np.asarray(m.scattering, np.float64) * m.homogeneous
    st = sa + ss
    d = defines(cfg)
    grey = "MEDIUM_GREY" in d          # the preprocess build's own test: one u for R, G, B
    albedo = [ss[c] / x if x > 0 else 0.0 for c, x in enumerate(st)]
    # the slab's optical thickness per channel, once: a dome's is a bisection (slab.sky_height)
    thick = [slab.sky_height(x, g.height, g.sky_distance, g.dome, albedo[c], m.asymmetry) for c, x in enumerate(st)]
    psi, lam, ref = [], [], []
    for c in range(1 if grey else 3):
        l_, r_, pg, ps = slab.modes(albedo[c], m.asymmetry, thick[c])
        # grey: the ground's and the sky's unit rows, mixed by the kernel; else mixed here
        psi += [pg, ps] if grey else [g.colour[c] * pg + g.sky_colour[c] * ps]
        lam.append(l_)
        ref.append(r_)
    psi = np.ascontiguousarray(np.stack(psi), np.float32)
    lam = np.ascontiguousarray(np.stack(lam), np.float32)
    ref = np.ascontiguousarray(np.stack(ref), np.float32)
    nm = lam.shape[1]
    cl, mf = rt.cl, rt.cl.mem_flags
    bufs = [cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (psi, lam, ref)]
    tau_h = np.array([*(st * g.height), 0.0], np.float32)
    tau_H = np.array([*thick, 0.0], np.float32)
    if plan.ground_table is None:      # the table, and the optical lengths of its u nodes
        u = np.arange(NU) / (NU - 1.0)
        with np.errstate(divide="ignore"):
            t_nodes = np.where(u < 1.0, -np.log(np.maximum(1.0 - u, 1e-300)), np.inf).astype(np.float32)
        plan.ground_table = (cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * slab.MU_GRID * NU),
                             cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=t_nodes))
    k = rt.program("ground", **d).slab_table
    t.add("preprocess", k(rt.queue, (slab.MU_GRID, NU), None, psi=bufs[0], lam=bufs[1], ref=bufs[2],
                          tau_h4=tau_h, tau_H4=tau_H, t_nodes=plan.ground_table[1], nmu=np.int32(slab.MU_GRID), nu=np.int32(NU),
                          nm=np.int32(nm), grey=np.int32(grey), gcol=np.array([*g.colour, 0.0], np.float32),
                          scol=np.array([*g.sky_colour, 0.0], np.float32), out=plan.ground_table[0]))
    if g.dome and dome.matters(st * g.sky_distance):
        dome_light(plan, g, st[:1] if grey else st, albedo[:1] if grey else albedo, thick, d, t)


def _float4(v) -> np.ndarray:
    """1 to 4 channel values as a kernel's float4 (zeros after them)."""
    return np.array([*v, *[0.0] * (4 - len(v))], np.float32)


def dome_light(plan, g: gmod.Ground, st: np.ndarray, albedo: list, thick: list, d: dict, t: Timings) -> None:
    """Adds a dome's first-order light in place of the slab's plane's (physics/dome.py) to
    plan.ground_table[0]: per channel of st (one in a grey medium) its extinction, albedo and
    slab thickness; d the plan's defines (table has them)."""
    rt, cl = plan.rt, plan.rt.cl
    mf = cl.mem_flags
    nch = len(st)
    tau_h = _float4(st * g.height)
    tau_R = _float4(st * g.sky_distance)
    tau_P = _float4([thick[c] - st[c] * g.height for c in range(nch)])
    cos = np.ascontiguousarray(dome.hg_cosines(plan.cfg.medium.asymmetry), np.float32)
    sin = np.ascontiguousarray(dome.azimuth_sines(), np.float32)
    bufs = [cl.Buffer(rt.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (cos, sin)]
    cells = cl.Buffer(rt.ctx, mf.READ_WRITE, 16 * slab.MU_GRID * dome.NS)
    prog = rt.program("dome", **d)
    t.add("preprocess", prog.dome_cells(rt.queue, (slab.MU_GRID, dome.NS), None, cosines=bufs[0], nth=np.int32(cos.size),
                                        sines=bufs[1], nph=np.int32(sin.size), tau_h4=tau_h, tau_R4=tau_R, tau_P4=tau_P,
                                        nmu=np.int32(slab.MU_GRID), ns=np.int32(dome.NS), nch=np.int32(nch), out=cells))
    t.add("preprocess", prog.dome_add(rt.queue, (slab.MU_GRID, NU), None, cells=cells, t_nodes=plan.ground_table[1],
                                      tau_h4=tau_h, tau_R4=tau_R, tau_P4=tau_P, alb4=_float4(albedo), scol=_float4(g.sky_colour),
                                      nmu=np.int32(slab.MU_GRID), nu=np.int32(NU), ns=np.int32(dome.NS), nch=np.int32(nch),
                                      table=plan.ground_table[0]))


def programs(plan):
    """preprocess's (whole, checked) programs for the frame: with PRE_GROUND when it has a
    ground (built once per process, on the first frame that has one)."""
    if plan.ground is None:
        return plan.k_pre_whole, plan.k_pre_prog
    d = dict(plan.pre_defines, PRE_GROUND=1, SLAB_MU=slab.MU_GRID, SLAB_NU=NU,
             GROUND_TOL_H=f"{gmod.TOL_HEIGHT!r}f", GROUND_TOL_D=f"{gmod.TOL_DIST!r}f",
             GROUND_TOL_PX=f"{gmod.TOL_PIXELS!r}f")
    return plan.rt.program("preprocess", WHOLE_GROUPS=1, **d), plan.rt.program("preprocess", **d)


def kernel_args(g: gmod.Ground | None) -> dict:
    """preprocess's ground arguments (placeholders without a ground)."""
    if g is None:
        z = np.zeros(4, np.float32)
        return dict(gplane=z, gcolour=z, scolour=z)
    return dict(gplane=np.array([*g.normal, g.height], np.float32),
                gcolour=np.array([*g.colour, 0.0], np.float32),
                scolour=np.array([*g.sky_colour, min(g.sky_from, 3e38)], np.float32))
