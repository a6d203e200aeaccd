"""kernels/preprocess.cl and density.cl: the frame uploaded, the optical depth of the
non-homogeneous media, the point-spread table of this medium, and preprocess (Elek eq. 1-3
per pixel: direct light, scattered light and its spread at level 0)."""
from __future__ import annotations

import numpy as np

from fogcli.device import ground
from fogcli.device.noise import noise_args, noise_grid, p_samples
from fogcli.device.border_size import open_border
from fogcli.device.plan import LIGHT_SHARE, Timings, halo_depth
from fogcli.device.pyramid import receiver_depth
from fogcli.device.structs import camera_struct, medium_struct, primitive_launches
from fogcli.physics.apsf_lut import build_lut
from fogcli.physics.limits import check_radiance


def pack_rgba(dst: np.ndarray, rgb: np.ndarray, alpha: np.ndarray | None) -> None:
    """dst (h, w, 4) float32 = rgb (any float type and strides) and alpha (1 where None),
    written in place. A float32 frame in one block goes through OpenCV's 3 -> 4 channel
    conversion (alpha 1), 1.8 ms at 2 MPx where numpy's interleaving copy took 20 (AMD EPYC;
    a seventh of fogcli.apply's time); the rest (half EXR columns, views) numpy's way."""
    if rgb.dtype == np.float32 and rgb.flags.c_contiguous and dst.flags.c_contiguous and dst.flags.writeable:
        import cv2

        if cv2.cvtColor(rgb, cv2.COLOR_RGB2RGBA, dst=dst) is dst:
            if alpha is not None:
                dst[:, :, 3] = alpha
            return
    dst[:, :, :3] = rgb
    dst[:, :, 3] = 1.0 if alpha is None else alpha


# view_cosines: a pixel nearer or farther than both neighbours along an axis, by steps
# steeper than this many times the lateral spacing (79 degrees from facing the camera), is
# narrower than the step (kernels/preprocess.cl isolated)
ISOLATED_STEEP = 5.0


def _lines(depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 16 rows and the 16 columns (as rows) across the frame that staircase and
    depth_noise read."""
    d = np.asarray(depth)
    h, w = d.shape[:2]
    return d[h // 32::max(1, h // 16)], d[:, w // 32::max(1, w // 16)].T


def _blocks_along(lines: np.ndarray) -> tuple[int, int | None]:
    """(block size, phase) along the lines (staircase): the phase is the position, modulo the
    size, where 60 % of the runs start (a regular grid), None where they do not."""
    change = lines[:, 1:] != lines[:, :-1]
    if change.size == 0 or np.count_nonzero(change) > 0.7 * change.size:
        return 1, None
    rows, cols = np.nonzero(change)
    runs = np.diff(cols)[rows[1:] == rows[:-1]]
    hist = np.bincount(runs[runs <= 8], minlength=9)
    k = int(hist.argmax())
    if not (k >= 2 and hist[k] >= 0.6 * hist.sum() and hist[k] * k >= 0.25 * lines.size):
        return 1, None
    starts = np.bincount((cols + 1) % k, minlength=k)
    return k, int(starts.argmax()) if starts.max() >= 0.6 * starts.sum() else None


def depth_blocks(depth: np.ndarray) -> tuple[tuple[int, int], tuple[int, int, int, int] | None]:
    """(staircase(depth), block_grid(depth)) from one reading of the lines."""
    (kx, px), (ky, py) = (_blocks_along(lines) for lines in _lines(depth))
    regular = kx * ky > 1 and (kx == 1 or px is not None) and (ky == 1 or py is not None)
    return (kx, ky), ((kx, ky, px or 0, py or 0) if regular else None)


def staircase(depth: np.ndarray) -> tuple[int, int]:
    """(columns, rows) of the blocks of equal depth that nearest-neighbour upsampling leaves
    (a sensor's depth map enlarged elsewhere: 2 x 2 at twice its size), 1 where there are
    none. From the lengths of the runs of equal values along 16 rows (columns) across the frame: a
    block size when it is at least 60 % of the runs of 1-8 pixels (a quantised sensor's
    flats have every length; sky and walls at one depth have longer runs) and its runs
    cover a quarter of the lines (not a few windows on a fronto wall). A map where
    most neighbours differ is none early. 0.05-0.2 ms at 2 MPx (every 8th row: 5 ms)."""
    return depth_blocks(depth)[0]


def block_grid(depth: np.ndarray) -> tuple[int, int, int, int] | None:
    """(kx, ky, px, py): the staircase's blocks and where their grid starts (a block's first
    column is px modulo kx), when the depth is one (larger than 1 along an axis) on a
    regular grid; else None."""
    return depth_blocks(depth)[1]


# A depth whose noise (relative to the depth) times the focal length in pixels reaches this
# is smoothed for the view cosines (smooth_depth): their one-pixel slopes are then off by
# 0.35 and more (a surface at 45 degrees has 1). Renders and quantised depths in
# tools/normals_robustness.py measure 0.001-0.05 (a street's curvature), 0.5 % sensor noise
# at 222 px 1.1, the TUM Kinect frame 0.9
NOISY_SLOPE = 0.25
# ... over as many pixels as bring the slopes' noise to this (0.03-0.1 tried on
# tools/normals_robustness.py's noisy renders: smaller smooths away street walls' edges,
# larger leaves the skyline's far ground noisy)
SMOOTHED_SLOPE = 0.07
# the radius's cost: ~50 ms per pass at 2 MPx at 8 (docs/physics.md)
SMOOTH_RADIUS_MAX = 8


def depth_noise(depth: np.ndarray, steps: tuple[int, int] = (1, 1)) -> float:
    """The depth's noise relative to itself (a standard deviation), from the second
    differences over the staircase's steps along 16 rows and 16 columns: per line the root
    mean square of the smallest 90 % (depth edges are the rest) over 0.623 (what a Gaussian
    keeps of it so) and 6 (white noise's second difference has 6 times its variance); the
    median over the lines (some lines are mostly edges); the smaller of rows' and columns'
    (a surface's curvature, a ground's depth down a column, is not noise). A sensor's
    quantised flats count: their steps are its noise."""
    found = []
    for lines, k in zip(_lines(depth), steps):
        if lines.shape[1] < 2 * k + 10:
            continue
        mid = lines[:, k:-k]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            r = np.abs((lines[:, :-2 * k] - 2.0 * mid + lines[:, 2 * k:]) / mid).astype(np.float64)
        per_line = []
        for row in r:
            row = row[np.isfinite(row)]
            if row.size >= 10:
                kept = np.partition(row, int(0.9 * row.size))[:int(0.9 * row.size)]
                per_line.append(np.sqrt(np.mean(np.square(kept)) / 0.623 / 6.0))
        if per_line:
            found.append(float(np.median(per_line)))
    return min(found, default=0.0)


def depth_smoothing(noise: float, focal: float) -> tuple[int, float] | None:
    """(radius, tau) of smooth_depth for a depth of this noise, None when it needs none.
    A one-pixel slope's error is noise x focal x sqrt(2); the difference of two box means of
    (2r + 1)^2 pixels one pixel apart has (2r + 1)^1.5 times less, brought to SMOOTHED_SLOPE.
    tau = 5 noise: a noisy neighbour of the same surface is within it (a difference of two
    is 3.5 of its standard deviations), a depth edge of more is not averaged over."""
    if noise * focal < NOISY_SLOPE:
        return None
    side = (np.sqrt(2.0) * noise * focal / SMOOTHED_SLOPE) ** (2.0 / 3.0)
    return int(np.clip(np.ceil((side - 1.0) / 2.0), 1, SMOOTH_RADIUS_MAX)), float(5.0 * noise)


def _upload_depth(plan, depth: np.ndarray, t: Timings) -> None:
    """The depth copied (after the image) and refined on the device: realigned where it was
    enlarged by nearest neighbour, its edges moved to where the light is (light_share);
    while that runs, what the host reads of it for the view cosines (only they use it):
    its staircase and whether it is smoothed for them."""
    steps, plan.grid = depth_blocks(depth)
    t.add_copy("upload", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.depth, np.ascontiguousarray(depth, np.float32)))
    if plan.grid is not None:
        realign(plan, t)
    light_share(plan, t)
    plan.smoothing = depth_smoothing(depth_noise(depth, steps), plan.cfg.camera.focal(plan.w)) \
        if plan.lambert else None
    # a grid's depth is realigned (smooth between the blocks) before the cosines read it
    plan.steps = steps if plan.lambert and plan.grid is None else (1, 1)


def upload(plan, rgba: np.ndarray, depth: np.ndarray, t: Timings) -> None:
    t.add_copy("upload", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.image, np.ascontiguousarray(rgba, np.float32)))
    _upload_depth(plan, depth, t)
    plan.ground = ground.find(plan.cfg, plan.w, plan.h, rgba, depth, plan.grid)


def upload_rgb(plan, rgb: np.ndarray, alpha, depth: np.ndarray, t: Timings) -> None:
    """The frame's RGBA assembled straight in the image buffer, mapped (on a CPU device
    its own memory: no copy after the assembly, which a host array and upload() needed;
    upload 8.3-9.1 -> 1.7 ms at 2 MPx), and the depth copied."""
    cl, q = plan.rt.cl, plan.rt.queue
    rgba, ev = cl.enqueue_map_buffer(q, plan.image, cl.map_flags.WRITE_INVALIDATE_REGION, 0,
                                     (plan.h, plan.w, 4), np.float32)
    t.add("upload", ev)
    ev.wait()
    pack_rgba(rgba, rgb, alpha)
    try:       # here, where the colour is float32 and in one block (a half EXR's is not before)
        check_radiance(rgba, "colour")
    finally:
        t.add("upload", rgba.base.release(q))
    del rgba
    _upload_depth(plan, depth, t)
    plan.ground = ground.find(plan.cfg, plan.w, plan.h, rgb, depth, plan.grid)


def optical_depth(plan, t: Timings, depth=None, out=None) -> None:
    """P of the non-homogeneous primitives, summed into the spread buffer (level 0),
    which preprocess reads before it writes the spread there."""
    cam = camera_struct(plan.cfg, plan.w, plan.h)
    launches = primitive_launches(plan.cfg)
    noise = noise_args(plan)
    frame = dict(depth=plan.depth if depth is None else depth, width=np.int32(plan.w), height=np.int32(plan.h), cam=cam)
    if noise is not None:          # the samples of render.noise_stride first, then every pixel
        st, cw, ch = noise_grid(plan)
        grid = dict(stride=np.int32(st), cw=np.int32(cw), ch=np.int32(ch))
        samples = p_samples(plan, cw * ch)
        t.add("preprocess", plan.k_density.p_noise_samples(plan.rt.queue, *plan.rt.nd(cw, ch), **frame, S=samples,
                                                           **noise, **grid))
        launches.append(("p_noise", dict(**noise, S=samples, **grid)))
    for k, (name, args) in enumerate(launches):
        t.add("preprocess", getattr(plan.k_density, name)(
            plan.rt.queue, *plan.rt.nd(plan.w, plan.h), **frame, P=plan.spread if out is None else out, **args,
            accumulate=np.int32(k > 0)))


def coverage(plan, t: Timings, empty_depth: float) -> None:
    """Output alpha of an input with alpha: the medium in front of each pixel's uncovered
    part (kernel `coverage`). Two planes more, only for heterogeneous media."""
    cl, q, n = plan.rt.cl, plan.rt.queue, plan.w * plan.h
    ms = medium_struct(plan.cfg, plan.w, plan.h)
    p_empty = plan.spread        # not read unless has_p
    if int(ms["has_p"]):
        mf = cl.mem_flags
        d_empty = cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 4 * n)
        p_empty = cl.Buffer(plan.rt.ctx, mf.READ_WRITE, 4 * n)
        cl.enqueue_fill_buffer(q, d_empty, np.float32(empty_depth), 0, 4 * n)
        optical_depth(plan, t, d_empty, p_empty)
    t.add("preprocess",
          plan.k_pre_prog.coverage(q, *plan.rt.nd(plan.w, plan.h), direct=plan.direct, P_empty=p_empty,
                                   has_p=ms["has_p"], width=np.int32(plan.w), height=np.int32(plan.h), m=ms,
                                   empty_depth=np.float32(min(empty_depth, 3e38)), lut=plan.lut))


def upload_lut(plan, t: Timings, table: dict | None = None) -> np.ndarray | None:
    """The apsf lookup table of this medium, focal length and pyramid (apsf_lut.build_lut);
    rebuilt only when one of them changes."""
    if not plan.apsf:
        return None
    m, r = plan.cfg.medium, plan.cfg.render
    frame = (plan.w, plan.h) if open_border(plan.cfg) else None
    focal, c = plan.cfg.camera.focal(plan.w), r.resolved()[0]
    key = (m.absorption, m.scattering, m.asymmetry, focal, r.spread_scale, c, id(table), frame, plan.w, plan.h,
           halo_depth(plan.cfg), r.emission_profile, plan.warp)
    if key != plan._lut_key:
        plan.lut_host = build_lut(m.absorption, m.scattering, m.asymmetry, focal, r.spread_scale,
                                  len(plan.sizes) - 1, c, 2.0 * plan.half_step(), table, frame, (plan.w, plan.h),
                                  halo_depth(plan.cfg), r.emission_profile == "lambertian",
                                  None if plan.warp is None else (plan.warp[1], plan.warp[0]))
        t.add("upload", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.lut, plan.lut_host))
        plan._lut_key = key
    return plan.lut_host


def view_cosines(plan, t: Timings) -> None:
    """The view cosine of every pixel into `cosines` (emission_profile lambertian), from
    the depth, or from the depth smoothed for them (plan.smoothing: into `chain`, which
    preprocess writes next)."""
    whole, checked = plan.k_pre_whole, plan.k_pre_prog
    depth = plan.depth
    cam = camera_struct(plan.cfg, plan.w, plan.h)
    lx, ly = plan.rt.local2d
    if plan.smoothing is not None:     # x into `cosines`, y into `chain`
        r, tau = plan.smoothing
        nx, ny = (plan.w - 2 * r) // lx * lx, (plan.h - 2 * r) // ly * ly
        for src, dst, along_y, inner, region in (
                (plan.depth, plan.cosines, 0, whole.smooth_depth_x_inner, (r, r + nx, 0, plan.h // ly * ly)),
                (plan.cosines, plan.chain, 1, whole.smooth_depth_y_inner, (0, plan.w // lx * lx, r, r + ny))):
            plan.launch_inner(t, "preprocess", region if region[1] > region[0] and region[3] > region[2] else None,
                              inner, (whole.smooth_depth, checked.smooth_depth), plan.w, plan.h,
                              dict(src=src, dst=dst, width=np.int32(plan.w), height=np.int32(plan.h),
                                   along_y=np.int32(along_y), radius=np.int32(r), tau=np.float32(tau), cam=cam))
        depth = plan.chain
    # the interior: pixels whose four neighbours are in the image
    sx, sy = plan.steps
    nx, ny = (plan.w - 2 * sx) // lx * lx, (plan.h - 2 * sy) // ly * ly
    plan.launch_inner(t, "preprocess", (sx, sx + nx, sy, sy + ny) if nx > 0 and ny > 0 else None,
                      whole.view_cosines_inner, (whole.view_cosines, checked.view_cosines), plan.w, plan.h,
                      dict(depth=depth, cosv=plan.cosines, width=np.int32(plan.w), height=np.int32(plan.h),
                           cam=cam, sx=np.int32(sx), sy=np.int32(sy), steep=np.float32(ISOLATED_STEEP)))


# realign_blocks: a depth edge is where the 3 x 3 blocks' depths span more than 1 + this, and
# the own block's second difference exceeds this much of its depth
REALIGN_TOL = 0.05


def realign(plan, t: Timings) -> None:
    """A nearest-neighbour-enlarged depth's edges moved to the colour's and its surfaces
    made smooth between the blocks (kernel realign_blocks, through `chain`), for the view
    cosines and the rest."""
    kx, ky, px, py = plan.grid
    whole, checked = plan.k_pre_whole, plan.k_pre_prog
    t.add("preprocess", plan.rt.launch2d(
        (whole.realign_blocks, checked.realign_blocks), plan.w, plan.h, depth=plan.depth, image=plan.image,
        out=plan.chain, width=np.int32(plan.w), height=np.int32(plan.h), kx=np.int32(kx), ky=np.int32(ky),
        px=np.int32(px), py=np.int32(py), tol=np.float32(REALIGN_TOL)))
    t.add("preprocess", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.depth, plan.chain, byte_count=4 * plan.w * plan.h))


def light_share(plan, t: Timings) -> None:
    """A pixel at a depth edge whose light is mostly that of a nearer or a farther, brighter
    surface takes its depth (kernels/light_share.h: each row's least and largest depth into
    `chain`, those within the radius into `direct`, the depth over them into `chain`; copied
    back)."""
    whole, checked = plan.k_pre_whole, plan.k_pre_prog
    r, (lx, ly) = LIGHT_SHARE["radius"], plan.rt.local2d
    frame = dict(width=np.int32(plan.w), height=np.int32(plan.h))
    nx, ny = (plan.w - 2 * r) // lx * lx, (plan.h - 2 * r) // ly * ly
    plan.launch_inner(t, "preprocess", (r, r + nx, 0, plan.h // ly * ly) if nx > 0 and plan.h >= ly else None,
                      whole.light_share_rows_inner, (whole.light_share_rows, checked.light_share_rows),
                      plan.w, plan.h, dict(depth=plan.depth, rowext=plan.chain, **frame))
    plan.launch_inner(t, "preprocess", (0, plan.w // lx * lx, r, r + ny) if ny > 0 and plan.w >= lx else None,
                      whole.light_share_cols_inner, (whole.light_share_cols, checked.light_share_cols),
                      plan.w, plan.h, dict(rowext=plan.chain, ext=plan.direct, **frame))
    t.add("preprocess", plan.rt.launch1d((whole.light_share_pick, checked.light_share_pick), -(-plan.w * plan.h // 8),
                                         depth=plan.depth, image=plan.image, ext=plan.direct, out=plan.chain, **frame))
    t.add("preprocess", plan.rt.cl.enqueue_copy(plan.rt.queue, plan.depth, plan.chain, byte_count=4 * plan.w * plan.h))


def preprocess(plan, t: Timings) -> None:
    eps = plan.cfg.render.resolved()[1]
    if plan.lambert:
        view_cosines(plan, t)
    upload_lut(plan, t)
    optical_depth(plan, t)
    if plan.ground is not None:
        ground.table(plan, plan.ground, t)
    whole, checked = ground.programs(plan)
    t.add("preprocess",
          plan.rt.launch2d((whole.preprocess, checked.preprocess), plan.w, plan.h, image=plan.image, depth=plan.depth,
                           direct=plan.direct, scat0=plan.chain, spread0=plan.spread, medium_term=plan.medium,
                           transmittance=plan.trans, width=np.int32(plan.w), height=np.int32(plan.h),
                           m=medium_struct(plan.cfg, plan.w, plan.h), prep0=plan.prep,
                           thresh1=np.float32(plan.threshold(1)), eps=np.float32(eps), sep_chain0=plan.chain2,
                           sep_prep0=plan.prep2, sep_par=plan.sep_params(), lut=plan.lut, cosines=plan.cosines,
                           ground_table=plan.ground_table[0] if plan.ground is not None else plan.lut,
                           **ground.kernel_args(plan.ground)))
    if plan.features.recv:      # from level 0's own log P, before lights join it
        receiver_depth(plan, t)
