"""The Python API, over the same code as the command line.

    import fogcli
    frame = fogcli.read_image("shot.exr")                 # colour, alpha, embedded Z
    depth = fogcli.read_depth("shot_depth.png")           # raw values as stored
    cfg = fogcli.make_config("fog", camera=fogcli.read_camera("intrinsics.json"))
    out = fogcli.apply(frame.rgb, depth, cfg, alpha=frame.alpha)
    fogcli.write_image("shot.fog.exr", out, like=frame)

Errors are ``fogcli.UserError`` (a ValueError) naming the argument or the file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fogcli.io import depth as depth_mod
from fogcli.io.colour import srgb_to_linear
from fogcli.config.model import Config
from fogcli.errors import UserError
from fogcli.physics.limits import check_radiance
from fogcli.io.images import Frame
from fogcli.config.presets import assemble
from fogcli.device.plan import Timings
from fogcli.device.run import run
from fogcli.frame.scene import for_image


def make_config(medium: str | None = None, config: str | None = None, sets=(), camera: dict | None = None,
                **overrides) -> Config:
    """A validated Config: a preset name or medium YAML, a config YAML, ``sets`` as
    "key=value" strings, a camera section (e.g. from read_camera), and keyword overrides
    whose dotted keys are written with '__' (render__kernel=6)."""
    sets = tuple(sets) + tuple(f"{k.replace('__', '.')}={v}" for k, v in overrides.items())
    try:
        return assemble(medium, config, sets, camera_section=camera)
    except UserError as exc:
        raise UserError(str(exc).replace("--set ", "make_config: ")) from None


def read_image(path: str | Path, layer: str | None = None, view: str | None = None) -> Frame:
    """An image file as fogcli reads it: .rgb (h, w, 3) float32 scene-linear, .alpha,
    .depth (an embedded Z channel, raw) and what an EXR output keeps of it."""
    from fogcli.io.images import read_image as _read

    frame = _read(path, layer, view)
    frame.rgb      # made and checked now: a bad file is refused here, as documented
    return frame


def read_depth(path: str | Path) -> np.ndarray:
    """The raw values of a depth file (EXR, TIFF, PNG16, NPY), decoded later by the
    config's camera section."""
    from fogcli.io.images import read_depth as _read

    return _read(path)


def read_camera(path: str | Path) -> dict:
    """Pinhole intrinsics JSON (Open3D, Cityscapes, plain fx/fy/cx/cy) as a camera section
    for make_config(camera=...)."""
    from fogcli.config.intrinsics import load

    return load(path)["camera"]


def write_image(path: str | Path, rgb: np.ndarray, alpha: np.ndarray | None = None, *, like: Frame | None = None,
                aovs: dict | None = None, type: str = "auto", compression: str = "auto", exposure: float = 0.0,
                drop_channels: bool = False) -> None:
    """Write scene-linear rgb (EXR/HDR) or display-referred sRGB (PNG/TIFF/JPEG, after
    `exposure` stops), atomically. With ``like`` (the Frame read), an EXR keeps the input's
    other channels, parts, views, windows, pixel types and compression."""
    from fogcli.io import outputs

    path = Path(path)
    rgb = _float_image(rgb, "rgb", None)[0]
    if like is None:
        h, w = rgb.shape[:2]
        like = Frame(path, rgb, alpha, None, (0, 0), (0, 0, w, h))
    outputs.check_target(path, like.path if like.path != path else None)
    outputs.write(path, rgb, alpha, aovs or {}, like, type, exposure, compression, drop_channels)


def _float_image(image, name: str, colour: str | None) -> tuple[np.ndarray, np.ndarray | None]:
    """(rgb, alpha from a 4th channel) as float32 scene-linear; integer images only with an
    explicit colour= ('srgb' or 'linear', scaled by the type's maximum)."""
    a = np.asarray(image)
    if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
        raise UserError(f"{name}: expected an (h, w, 3) or (h, w, 4) array, got shape {a.shape}")
    if np.issubdtype(a.dtype, np.integer) or a.dtype == bool:
        if colour not in ("srgb", "linear"):
            raise UserError(f"{name}: {a.dtype} pixels are display values, not radiance; convert them to "
                            "float scene-linear, or pass colour='srgb' (or 'linear') to convert here")
        top = float(np.iinfo(a.dtype).max) if a.dtype != bool else 1.0
        a = a.astype(np.float32) / np.float32(top)
        if colour == "srgb":
            a = np.concatenate([srgb_to_linear(np.ascontiguousarray(a[:, :, :3])), a[:, :, 3:]], axis=2)
    elif not np.issubdtype(a.dtype, np.floating):
        raise UserError(f"{name}: expected float scene-linear pixels, got dtype {a.dtype}")
    elif colour == "srgb":
        a = np.concatenate([srgb_to_linear(np.ascontiguousarray(a[:, :, :3], np.float32)), a[:, :, 3:]], axis=2)
    with np.errstate(invalid="ignore", over="ignore"):
        a = a.astype(np.float32, copy=False)
    rgb = np.ascontiguousarray(a[:, :, :3])
    check_radiance(rgb, name)       # NaN, infinite, beyond what the float32 kernels carry
    alpha = np.ascontiguousarray(np.clip(np.nan_to_num(a[:, :, 3], nan=1.0), 0, 1)) if a.shape[2] == 4 else None
    return rgb, alpha


def apply(image: np.ndarray, depth: np.ndarray, config: Config | str | None = None, *,
          alpha: np.ndarray | None = None, colour: str | None = None, aovs=(), device: str | None = None,
          timings: Timings | None = None, return_aovs: bool = False):
    """Add the medium to a scene-linear image.

    image: (h, w, 3) or (h, w, 4) float scene-linear radiance (premultiplied with its alpha);
    integer images need colour='srgb' or 'linear'. depth: raw depth values as stored
    (decoded by the config's camera section: depth_scale, encoding, z / distance / disparity
    / inverse; +inf is sky; NaN, <= 0 and zero disparity are holes), at the image's size or a
    smaller one of the same aspect. alpha: (h, w) coverage in [0, 1]; pixels with alpha 0 are
    empty and look at camera.empty_depth. config: a Config, a preset name or None (fog).
    Returns (h, w, 3) float32, or (h, w, 4) with the output alpha when the input had one;
    with return_aovs, (image, {aov channel: plane}).
    """
    if colour not in (None, "srgb", "linear"):
        raise UserError(f"colour: expected 'srgb', 'linear' or None, got {colour!r}")
    if not isinstance(config, Config):
        try:
            cfg = assemble(config)
        except UserError as exc:
            raise UserError(str(exc).replace("--medium ", "config: ")) from None
    else:
        cfg = config
    img, a4 = _float_image(image, "image", colour)
    if alpha is None:
        alpha = a4
    elif np.shape(alpha) != img.shape[:2]:
        raise UserError(f"alpha: expected shape {img.shape[:2]}, got {np.shape(alpha)}")
    else:
        alpha = np.ascontiguousarray(np.clip(np.nan_to_num(np.asarray(alpha, np.float32), nan=1.0), 0, 1))
    d = np.asarray(depth)
    if d.ndim == 3 and d.shape[2] == 1:
        d = d[:, :, 0]
    if d.ndim != 2 or not (np.issubdtype(d.dtype, np.number) or d.dtype == bool):
        raise UserError(f"depth: expected an (h, w) numeric array, got shape {d.shape} {d.dtype}")
    dm, rep = depth_mod.metric_depth(d, img, cfg.camera, "depth", alpha)
    if rep.notes:
        import warnings

        for n in rep.notes:
            warnings.warn(n, UserWarning, stacklevel=2)
    notes: list = []
    frame_cfg, lamp_pixels = for_image(img, dm, cfg, report=notes)
    out, a_out, planes = run(img, dm, frame_cfg, alpha=alpha, aovs=aovs, device=device, timings=timings,
                             lamp_pixels=lamp_pixels)
    if notes:
        import warnings

        for n in notes:
            warnings.warn(n, UserWarning, stacklevel=2)
    from fogcli.frame.job import grid_luminance, medium_warning

    hidden = medium_warning(grid_luminance(img), out, cfg, dm)
    if hidden:
        import warnings

        warnings.warn(hidden, UserWarning, stacklevel=2)
    if a_out is not None:
        out = np.concatenate([out, a_out[:, :, None]], axis=2)
    return (out, planes) if return_aovs else out
