"""What `fogcli tune` holds between the page's requests: the image named on the command
line read once, a reduced copy for previews while a slider moves, the config the page
builds on the preset, and the full-size frame rendered as `fogcli apply` renders it (the
same stages of frame.job), which Save writes beside the YAML that reproduces it."""
from __future__ import annotations

import math
import shlex
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogcli.config import yaml_source as S
from fogcli.config.model import Config
from fogcli.config.presets import DEFAULT_MEDIUM, given_data, medium_data, presets, visibility_m
from fogcli.config.validate import build
from fogcli.device.plan import Timings
from fogcli.errors import UserError
from fogcli.frame.job import Job, compute, load, store
from fogcli.frame.scene import median_depth
from fogcli.io import outputs
from fogcli.io.colour import srgb_codes
from fogcli.physics import pixel_rays
from fogcli.physics.luminance import luminance
from fogcli.tune.quick_look import reduced, render
from fogcli.tune.saved_yaml import commented_yaml, prune

PREVIEW_PIXELS = 500_000        # the preview's size while a slider moves (issue 42: 0.5 MPx)
SHOWN = ("output", "input", "scattered", "airlight")
# what the page may change: the look of the medium and its lights; the camera (how the depth
# is read), the output and the limits stay as the command line gave them
PAGE_SECTIONS = ("medium", "lights", "render")


@dataclass
class Rendered:
    """One result the page shows: float colour planes by name (SHOWN), at one size."""
    size: str
    planes: dict
    key: str                # the config it was made with (its canonical JSON)
    ms: float
    cfg: Config


class Session:
    def __init__(self, image: str, depth: str | None = None, medium: str | None = None,
                 config_file: str | None = None, camera_file: str | None = None, device: str | None = None,
                 sets=()):
        self.image = Path(image)
        self.depth = depth
        self.config_file, self.camera_file, self.device = config_file, camera_file, device
        self.medium_file = medium if medium and medium not in presets() else None
        self.preset = medium or DEFAULT_MEDIUM
        self.given = given_data(config_file, camera_file)          # refused here when bad
        for item in sets:            # --set: kept in the saved YAML like a --config file's keys
            self.given = S.merge(self.given, S.parse_set(item, {}))
        self.overrides: dict = {}
        self._presets: dict = {}
        self.timings = Timings()
        stem = self.image.name.rsplit(".", 1)[0]
        self.yaml_path = self.image.with_name(f"{stem}.tune.yaml")
        self.output_path = self.image.with_name(f"{stem}.fog{outputs.default_ext(self.image)}")
        self.lock = threading.Lock()     # one render at a time: they share the device's plans
        cfg = self.config()
        st = load(self._job(), cfg)       # the frame as apply reads it: colour, cleaned metric depth
        self._reduce(st, st.cfg or cfg)
        self.full: Rendered | None = None
        self.preview: Rendered | None = None
        self._full_staged = None

    # ------------------------------------------------------------------ config
    def choices(self) -> list[str]:
        return list(presets()) + ([self.medium_file] if self.medium_file else [])

    def set_preset(self, name: str) -> None:
        if name not in self.choices():
            raise UserError(f"preset: expected one of {', '.join(self.choices())}, got {name!r}")
        self.preset = name
        self.overrides = {k: v for k, v in self.overrides.items() if k == "lights"}

    def data(self, overrides: dict | None = None) -> dict:
        """The config's data: the preset, then what the command line's files and the page
        add (what the saved YAML gives with the preset: saved() keeps it so)."""
        page = self.overrides if overrides is None else overrides
        _sections(page)
        return S.merge(self._preset_data(), S.merge(self.given, page))

    def _preset_data(self) -> dict:
        """The preset's data, read once a preset (a slider's every move builds on it)."""
        if self.preset not in self._presets:
            self._presets[self.preset] = medium_data(self.preset, {})
        return self._presets[self.preset]

    def saved(self, overrides: dict) -> dict:
        """What the YAML holds: the command line's --config and --camera with the page's
        changes, less what the preset already says (kept where dropping it would change
        the config)."""
        _sections(overrides)
        full = S.merge(self.given, overrides)
        base = self._preset_data()
        pruned = prune(full, base)
        if pruned != full and self._build(S.merge(base, pruned)) != self._build(S.merge(base, full)):
            return full
        return pruned

    def config(self, overrides: dict | None = None) -> Config:
        return self._build(self.data(overrides))

    @staticmethod
    def _build(data: dict) -> Config:
        import yaml

        # through YAML text as the saved file will be read: the same numbers, the same types
        return build(yaml.safe_load(yaml.safe_dump(data, sort_keys=False)), {})

    # ------------------------------------------------------------------ renders
    def _job(self) -> Job:
        return Job(str(self.image), str(self.output_path), self.depth,
                   protected=tuple(p for p in (self.config_file, self.camera_file, self.medium_file) if p))

    def _reduce(self, st, cfg: Config) -> None:
        """The frame at full size and reduced to PREVIEW_PIXELS for previews."""
        frame = st.frame
        rgb = np.asarray(frame.rgb, np.float32)
        h, w = frame.shape
        self.width, self.height = w, h
        s = min(1.0, math.sqrt(PREVIEW_PIXELS / (w * h)))
        self.big = reduced(rgb, st.depth, frame.alpha, cfg.camera, w, h)
        self.small = reduced(rgb, st.depth, frame.alpha, cfg.camera, max(1, round(w * s)), max(1, round(h * s)))
        self.median = median_depth(st.depth, cfg.camera.max_depth)
        self.hdr = not frame.display_referred
        self.mean_luminance = float(luminance(self.small.rgb).mean())

    def render(self, overrides: dict, size: str, aovs: bool = False) -> Rendered:
        """The frame with the page's config: 'preview' (reduced; with the scattered and
        airlight AOVs when asked: they cost downloads) or 'full' (apply's stages)."""
        cfg = self.config(overrides)
        key = cfg.model_dump_json()
        with self.lock:
            t0 = time.perf_counter()
            if size == "full":
                planes = self._render_full(cfg)
            else:
                planes = self._render_preview(cfg, aovs)
            r = Rendered(size, planes, key, (time.perf_counter() - t0) * 1e3, cfg)
            self.overrides = overrides
            if size == "full":
                self.full = r
            else:
                self.preview = r
            return r

    def _render_preview(self, cfg: Config, aovs: bool) -> dict:
        out, planes, _ = render(self.small, cfg, ("scattered", "airlight") if aovs else (), self.device, self.timings)
        return {"output": out, "input": self.small.rgb, **_rgb_planes(planes)}

    def _render_full(self, cfg: Config) -> dict:
        """apply's stages on the file as read again (compute consumes the frame it uploads);
        the AOVs come from a second run, so that the frame kept for Save is apply's own."""
        st = compute(load(self._job(), cfg), cfg, device=self.device, timings=Timings())
        self._full_staged = (st, cfg)
        return {"output": st.rgb, "input": self.big.rgb}

    def aovs(self, size: str) -> dict:
        """The planes of the last frame of that size with its scattered and airlight AOVs,
        made on demand (the page's AOV view) by a run with the same config."""
        r = self.full if size == "full" else self.preview
        if r is None:
            raise UserError(f"no {size} frame rendered yet")
        with self.lock:
            if "scattered" not in r.planes:
                look = self.big if size == "full" else self.small
                _, planes, _ = render(look, r.cfg, ("scattered", "airlight"), self.device)
                r.planes.update(_rgb_planes(planes))
        return r.planes

    # ------------------------------------------------------------------ the page's other asks
    def light_at(self, x: float, y: float) -> dict:
        """A point light at the full frame's pixel (x, y), at that pixel's depth, bright
        enough to be seen against the frame."""
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise UserError(f"pixel ({x:g}, {y:g}): outside the {self.width}x{self.height} frame")
        cam = self.big.camera.for_size(self.width, self.height)
        d = float(self.big.depth[int(y), int(x)])
        d = min(d, cam.max_depth, 4.0 * self.median) if math.isfinite(d) else 4.0 * self.median
        ray = pixel_rays.directions(np.array(x - 0.5), np.array(y - 0.5), cam.focal(self.width),
                                    cam.focal_y(self.width), *cam.centre(self.width, self.height))
        pos = ray * d if cam.depth == "z" else ray / pixel_rays.length(ray) * d
        level = max(self.mean_luminance, 1e-3) * 20.0 * d * d
        return {"type": "point", "position": [round(float(v), 4) for v in pos],
                "intensity": [float(f"{level:.3g}")] * 3}

    def pixel(self, x: float, y: float) -> dict:
        """The depth and colours of the full frame's pixel (x, y): input, and the last
        result (full size where made, else the preview's)."""
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise UserError(f"pixel ({x:g}, {y:g}): outside the {self.width}x{self.height} frame")
        xi, yi = int(x), int(y)
        out = {"x": xi, "y": yi, "depth": float(self.big.depth[yi, xi]),
               "input": [float(v) for v in self.big.rgb[yi, xi]]}
        r = self.full if self.full is not None and self.full.key == self.config().model_dump_json() else self.preview
        if r is not None:
            p = r.planes["output"]
            ph, pw = p.shape[:2]
            out["output"] = [float(v) for v in p[min(ph - 1, yi * ph // self.height), min(pw - 1, xi * pw // self.width)]]
            out["of"] = r.size
        return out

    def state(self) -> dict:
        """What the page starts from: the presets, the frame, and the config's values for
        the controls (the effective visibility as a share of the median depth)."""
        cfg = self.config()
        m = cfg.medium
        vis = m.visibility if isinstance(m.visibility, str) else f"{visibility_m(m) / self.median * 100:.4g}%"
        m = m.for_depth(self.median)        # the coefficients this frame gets
        ext = [a + s for a, s in zip(m.absorption, m.scattering)]
        return {
            "presets": self.choices(), "preset": self.preset, "overrides": self.overrides,
            "width": self.width, "height": self.height,
            "preview": list(self.small.rgb.shape[1::-1]), "hdr": self.hdr,
            "median_depth": self.median, "visibility": vis,
            "albedo": (sum(m.scattering) / sum(ext)) if sum(ext) > 0 else 0.0,
            "absorption": list(m.absorption), "scattering": list(m.scattering),
            "asymmetry": m.asymmetry, "ambient": m.ambient if m.ambient == "auto" else list(m.ambient),
            "border": cfg.render.border, "density": [d.model_dump(mode="json") for d in m.density],
            "lights": [x.model_dump(mode="json", exclude_defaults=True) | {"type": x.type} for x in cfg.lights],
            "files": {"yaml": str(self.yaml_path), "output": str(self.output_path)},
        }

    def save(self, overrides: dict) -> dict:
        """The YAML (what differs from the preset, with comments) and the full-size frame,
        written as `fogcli apply` with that YAML writes it; the command that does."""
        cfg = self.config(overrides)
        data = self.saved(overrides)
        text = commented_yaml(data, self.preset, self.image.name)
        outputs.atomic_write(self.yaml_path, lambda tmp: Path(tmp).write_text(text))
        if self.full is None or self.full.key != cfg.model_dump_json() or self._full_staged is None:
            self.render(overrides, "full")
        st, used = self._full_staged
        st.planes = {}
        store(st, used)
        return {"yaml": str(self.yaml_path), "output": str(self.output_path), "command": self.command()}

    def command(self, output: str | None = None) -> str:
        parts = ["fogcli", "apply", str(self.image)]
        if self.depth:
            parts += ["--depth", self.depth]
        parts += ["--medium", self.preset]     # the YAML holds --config's and --camera's values too
        parts += ["--config", str(self.yaml_path), "-o", output or str(self.output_path)]
        return shlex.join(parts)


def _sections(overrides: dict) -> None:
    for k in overrides:
        if k not in PAGE_SECTIONS:
            raise UserError(f"{k}: the page changes only {', '.join(PAGE_SECTIONS)}")


def _rgb_planes(planes: dict) -> dict:
    return {name: np.dstack([planes[f"{name}.{c}"] for c in "RGB"]) for name in ("scattered", "airlight")
            if f"{name}.R" in planes}


# sRGB's 8-bit code of each 16-bit linear value: the page's frames through a table (a
# power per channel cost 25 ms of a 0.5 MPx preview's 40 ms encoding)
_STEPS = 65535
_SRGB8 = srgb_codes(np.arange(_STEPS + 1, dtype=np.float32) / _STEPS)


def encode(rgb: np.ndarray, exposure: float, quality: int) -> bytes:
    """Scene-linear colour as a JPEG for the page: the exposure, then sRGB (linear_to_srgb,
    at 16-bit steps of the linear value)."""
    import cv2

    scaled = np.multiply(rgb[:, :, ::-1], np.float32(2.0 ** exposure * _STEPS), dtype=np.float32)
    idx = np.clip(scaled, 0, _STEPS, out=scaled).astype(np.uint16)
    q = _SRGB8[idx]
    ok, buf = cv2.imencode(".jpg", q, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise UserError("cannot encode the preview")
    return buf.tobytes()
