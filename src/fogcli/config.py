"""The config model (SPEC 3): YAML sources merged in order, validated once, typed.

Sources merge preset < --medium file < --config < --set. Every value remembers where it
came from (file and line), so a bad value is reported as ``file:line: key: problem``.
"""
from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from .errors import UserError

# Burt-style filters: binomial rows; 4 taps is Elek's {0.13, 0.37, 0.37, 0.13} unrounded.
FILTERS = {
    2: (0.5, 0.5),
    4: (0.125, 0.375, 0.375, 0.125),
    6: (0.03125, 0.15625, 0.3125, 0.3125, 0.15625, 0.03125),
}
# Calibrated against the reference per filter size: (epsilon, threshold factor); the
# threshold of level k is threshold * c * 2^(k-1) (Elek eq. 7 has 1). docs/calibration.md.
CALIBRATED = {
    "source": {2: (1.5, 1.0), 4: (1.5, 1.0), 6: (1.0, 1.1)},
    "receiver": {2: (2.0, 1.0), 4: (2.0, 1.0), 6: (2.0, 1.0)},
}
_INTERP_VAR = {"linear-bilinear": 1.0 / 6.0, "linear-bicubic": 1.0 / 3.0, "cubic-bicubic": 1.0 / 3.0}


def c_theory(kernel: int, interpolation: str, fetch: str) -> float:
    """Blur of level k in level-0 pixels is c 2^k (SPEC 4.5). Each reduce adds the filter's
    variance at the level's pixel size (sum -> 4^k var_h / 3); a fetch adds the variance of
    the interpolation kernel at level k (tent 1/6, cubic B-spline 1/3); the source collapse
    interpolates once per level on the way up (sum -> 4^k 4 v / 3)."""
    taps = FILTERS[kernel]
    x = [i - (len(taps) - 1) / 2 for i in range(len(taps))]
    var_h = sum(t * xi * xi for t, xi in zip(taps, x))
    v = _INTERP_VAR[interpolation]
    return math.sqrt(var_h / 3 + (4 * v / 3 if fetch == "source" else v))


VISIBILITY_CONTRAST = 3.912  # -ln(0.02): Koschmieder's 2 % contrast threshold


class _Loader(yaml.SafeLoader):
    """YAML with 1.2-style floats, so that 1e9 and 5E-3 are numbers, as users expect."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*\.?[0-9_]*(?:[eE][-+]?[0-9]+)?|\.[0-9_]+(?:[eE][-+]?[0-9]+)?"
               r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))


class _Loc:
    """Where a value came from."""

    def __init__(self, source: str, line: int | None):
        self.source, self.line = source, line

    def __str__(self):
        return f"{self.source}:{self.line}" if self.line else self.source


# ----------------------------------------------------------------------------- loading

# Config files are small: deeper nesting or more nodes (after aliases are expanded) than
# this is an attack or a mistake (billion laughs), refused before it costs time or memory.
MAX_DEPTH, MAX_NODES = 32, 20000
_PLAIN_TAGS = {f"tag:yaml.org,2002:{t}" for t in ("str", "int", "float", "bool", "null", "map", "seq")}


def _screen(text: str, source: str) -> None:
    """Depth, alias expansion and tags checked on the event stream (iterative, so a
    5000-deep flow list cannot exhaust Python's recursion before we refuse it)."""
    depth, anchors, stack = 0, {}, []     # stack: [anchor name, expanded size so far]
    total = 0
    for ev in yaml.parse(text, Loader=_Loader):
        line = ev.start_mark.line + 1
        tag = getattr(ev, "tag", None)
        if tag and tag not in _PLAIN_TAGS and tag not in ("!", "?"):
            raise UserError(f"{source}:{line}: invalid YAML: tag {tag} is not allowed (plain values only)")
        size = 0
        if isinstance(ev, yaml.AliasEvent):
            if ev.anchor not in anchors:
                raise UserError(f"{source}:{line}: invalid YAML: alias *{ev.anchor} is recursive or undefined")
            size = anchors[ev.anchor]
        elif isinstance(ev, yaml.ScalarEvent):
            size = 1
            if ev.anchor:
                anchors[ev.anchor] = 1
        elif isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise UserError(f"{source}:{line}: invalid YAML: nested deeper than {MAX_DEPTH} levels")
            stack.append([ev.anchor, 1])
            continue
        elif isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
            anchor, size = stack.pop()
            if anchor:
                anchors[anchor] = size
        else:
            continue
        if stack:
            stack[-1][1] += size
        total += size if not stack else 0
        if (stack and stack[-1][1] > MAX_NODES) or total > MAX_NODES:
            raise UserError(f"{source}:{line}: invalid YAML: expands to more than {MAX_NODES} values (aliases)")


def _node_to_py(node, source: str, path: str, locs: dict):
    locs[path] = _Loc(source, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        out = {}
        for knode, vnode in node.value:
            key = str(knode.value)
            if key in out:
                raise UserError(f"{source}:{knode.start_mark.line + 1}: {path + '.' if path else ''}{key}: duplicate key")
            out[key] = _node_to_py(vnode, source, f"{path}.{key}" if path else key, locs)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_node_to_py(v, source, f"{path}[{i}]", locs) for i, v in enumerate(node.value)]
    return yaml.load(yaml.serialize(node), Loader=_Loader) if node.tag != "tag:yaml.org,2002:null" else None


def load_yaml(path: str | Path, locs: dict) -> dict:
    """Parse a YAML file into plain data, recording each key's line in ``locs``."""
    p = Path(path)
    if p.exists() and not p.is_file():
        raise UserError(f"{p}: not a regular file, expected a YAML config file")
    if p.is_file() and p.stat().st_size > 1_000_000:
        raise UserError(f"{p}: {p.stat().st_size} bytes; expected a small YAML config file")
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise UserError(f"{p}: config file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{p}: cannot read config file ({exc.__class__.__name__})") from None
    try:
        _screen(text, str(p))
        node = yaml.compose(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        ctx, cmark = getattr(exc, "context", None) or "", getattr(exc, "context_mark", None)
        if cmark is not None and "flow" in ctx:
            # an unclosed [ or {: the parser notices on a later line; point at the bracket
            mark, problem = cmark, f"{ctx[len('while parsing a '):] if ctx.startswith('while parsing a ') else ctx} " \
                f"opened here is not closed ({problem})"
        line = f":{mark.line + 1}" if mark else ""
        raise UserError(f"{p}{line}: invalid YAML: {problem}") from None
    except RecursionError:
        raise UserError(f"{p}: invalid YAML: nested too deeply") from None
    if node is None:
        return {}
    if not isinstance(node, yaml.MappingNode):
        raise UserError(f"{p}:{node.start_mark.line + 1}: expected a mapping of sections (medium, camera, render, output)")
    try:
        return _node_to_py(node, str(p), "", locs)
    except (yaml.YAMLError, ValueError) as exc:   # a scalar YAML cannot convert (4300+ digit integers)
        if isinstance(exc, UserError):
            raise
        raise UserError(f"{p}: invalid YAML value ({str(exc).splitlines()[0][:80]})") from None


def parse_set(item: str, locs: dict) -> dict:
    """``--set render.kernel=6`` -> {'render': {'kernel': 6}}; the value is YAML."""
    if "=" not in item:
        raise UserError(f"--set {item!r}: expected KEY=VALUE, e.g. render.kernel=6")
    key, value = item.split("=", 1)
    parts = key.strip().split(".")
    if not all(parts):
        raise UserError(f"--set {item[:60]!r}: empty key part")
    if len(item) > 10_000:
        raise UserError(f"--set {key[:60]}: value of {len(value)} characters; expected a short YAML value")
    try:
        _screen(value, f"--set {key.strip()}")
        val = yaml.load(value, Loader=_Loader) if value.strip() else None
    except (yaml.YAMLError, ValueError):   # ValueError: an integer of more than 4300 digits
        raise UserError(f"--set {key.strip()}: value is not valid YAML") from None
    out: dict = {}
    cur = out
    for p in parts[:-1]:
        cur = cur.setdefault(p, {})
    cur[parts[-1]] = val
    _record(out, "", _Loc(f"--set {key.strip()}", None), locs)
    return out


def _record(data, path, loc, locs):
    locs[path] = loc
    if isinstance(data, dict):
        for k, v in data.items():
            _record(v, f"{path}.{k}" if path else k, loc, locs)


# Within `medium`, the two ways of giving the coefficients exclude each other: a later
# source that uses one form drops the other form from earlier sources.
_FORM_A = ("absorption", "scattering")
_FORM_B = ("visibility",)


def merge(base: dict, new: dict) -> dict:
    out = dict(base)
    for k, v in new.items():
        if k == "medium" and isinstance(v, dict) and isinstance(out.get(k), dict):
            med = dict(out[k])
            if any(x in v for x in _FORM_A):
                for x in _FORM_B + ("albedo",):
                    med.pop(x, None)
            if any(x in v for x in _FORM_B):
                for x in _FORM_A:
                    med.pop(x, None)
            out[k] = merge(med, {kk: vv for kk, vv in v.items()})
        elif isinstance(v, dict) and isinstance(out.get(k), dict) and k != "density":
            out[k] = merge(out[k], v)
        else:
            out[k] = v
    return out


# ----------------------------------------------------------------------------- model

@dataclass
class Density:
    type: str
    factor: float = 1.0
    falloff: float = 0.0
    direction: tuple = (0.0, 1.0, 0.0)
    offset: tuple = (0.0, 0.0, 0.0)
    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 1.0


@dataclass
class Medium:
    absorption: tuple = (0.0, 0.0, 0.0)
    scattering: tuple = (0.0, 0.0, 0.0)
    asymmetry: float = 0.9
    emission: tuple = (0.0, 0.0, 0.0)
    ambient: tuple | str = (0.0, 0.0, 0.0)   # or "auto": estimated from the image (ambient.py)
    density: list = field(default_factory=lambda: [Density("homogeneous")])


@dataclass
class Camera:
    fov: float = 60.0
    focal_px: float | None = None
    position: tuple = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0
    depth: str = "z"            # z | distance | disparity | inverse
    depth_scale: float | str = "auto"   # metres per stored unit; auto: 0.001 for 16/32-bit integer files (mm), else 1
    max_depth: float = 1000.0
    empty_depth: float = 0.0          # where pixels with alpha 0 look (m): 0 = no medium (the plate behind has its own); inf = open sky
    focal_px_y: float | None = None   # vertical focal length; default = the horizontal one
    cx: float | None = None           # principal point in pixels; default the image centre
    cy: float | None = None
    baseline: float | None = None     # stereo baseline, m (depth: disparity)
    near: float | None = None         # depth: inverse maps the largest value to near ...
    far: float | None = None          # ... and the smallest to far (m)
    encoding: str = "linear"          # linear (value * depth_scale) | cityscapes ((p - 1) / 256, 0 = none)
    calibrated_size: tuple | None = None   # (w, h) the intrinsics are for; other sizes scale them

    def for_size(self, width: int, height: int) -> "Camera":
        """The intrinsics scaled to an image of width x height (calibrated_size)."""
        if self.calibrated_size is None or tuple(self.calibrated_size) == (width, height):
            return self
        import dataclasses

        sx, sy = width / self.calibrated_size[0], height / self.calibrated_size[1]
        f = lambda v, s: None if v is None else v * s  # noqa: E731
        return dataclasses.replace(self, focal_px=f(self.focal_px, sx), focal_px_y=f(self.focal_px_y, sy),
                                   cx=f(self.cx, sx), cy=f(self.cy, sy), calibrated_size=None)

    def focal(self, width: int) -> float:
        if self.focal_px is not None:
            return float(self.focal_px)
        return (width / 2.0) / math.tan(math.radians(self.fov) / 2.0)

    def focal_y(self, width: int) -> float:
        return float(self.focal_px_y) if self.focal_px_y is not None else self.focal(width)

    def centre(self, width: int, height: int) -> tuple[float, float]:
        return (width / 2.0 if self.cx is None else float(self.cx),
                height / 2.0 if self.cy is None else float(self.cy))


@dataclass
class Separation:
    """Defaults calibrated on night scenes for the receiver fetch (Iser's demo values were
    3 / 3 / 200 / 200 / 0.7); docs/calibration-separation.md."""
    enabled: bool = False
    luminance: float = 0.3
    luminance_width: float = 0.3
    depth: float = 1000.0
    depth_width: float = 1000.0
    level: float = 0.9


@dataclass
class Render:
    method: str = "pyramid"
    spread_model: str = "angular"
    spread_scale: float = 1.0
    kernel: int = 4
    interpolation: str = "linear-bicubic"
    c: float | str = "auto"
    epsilon: float | str = "auto"
    threshold: float | str = "auto"
    levels: int | str = "auto"
    fetch: str = "source"
    separation: Separation = field(default_factory=Separation)
    psf: str = "apsf"                 # apsf (radiative transfer, apsf.py) | gaussian (SPEC 4.3)
    border: str = "open"              # open: scattered light leaves the frame | closed: it stays (docs/physics.md)
    emission_profile: str = "lambertian"  # lambertian (normals from the depth map) | isotropic; docs/physics.md

    def resolved(self) -> tuple[float, float, float]:
        """(c, epsilon, threshold) with `auto` replaced by the derived c and the calibrated
        epsilon and threshold."""
        fetch = self.fetch if self.method == "pyramid" else "receiver"   # naive fetches too
        e0, t0 = CALIBRATED[fetch][self.kernel]
        c0 = c_theory(self.kernel, self.interpolation, fetch)
        pick = lambda v, d: d if v == "auto" else float(v)  # noqa: E731
        return pick(self.c, c0), pick(self.epsilon, e0), pick(self.threshold, t0)


@dataclass
class Output:
    exposure: float = 0.0
    type: str = "auto"          # EXR pixel type: auto (the input's; float otherwise) | half | float
    compression: str = "auto"   # EXR: auto (the input's; zip otherwise) | lossless none | rle | zip | zips | piz; lossy pxr24 | b44 | dwaa | dwab


EXR_COMPRESSION = ["none", "rle", "zip", "zips", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"]


@dataclass
class Config:
    medium: Medium = field(default_factory=Medium)
    camera: Camera = field(default_factory=Camera)
    render: Render = field(default_factory=Render)
    output: Output = field(default_factory=Output)


# ----------------------------------------------------------------------------- validation

class _Checker:
    def __init__(self, locs: dict):
        self.locs = locs
        self.problems: list[str] = []

    def fail(self, path: str, msg: str):
        # the line of the key, else of the nearest enclosing key that has one
        loc, up = self.locs.get(path), path
        while loc is None and "." in up:
            up = up.rsplit(".", 1)[0]
            loc = self.locs.get(up)
        where = f"{loc}: " if loc else ""
        self.problems.append(f"{where}{path}: {msg}")

    def keys(self, data: dict, path: str, allowed: dict):
        for k in data:
            if k not in allowed:
                hint = difflib.get_close_matches(str(k), list(allowed), n=1)
                extra = f" (did you mean {hint[0]}?)" if hint else f" (expected one of: {', '.join(allowed)})"
                self.fail(f"{path}.{k}" if path else str(k), f"unknown key{extra}")

    def number(self, v, path, lo=None, hi=None, lo_open=False, hi_open=False, integer=False):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or (integer and not isinstance(v, int)):
            self.fail(path, f"expected {'an integer' if integer else 'a number'}, got {v!r}")
            return None
        v = float(v) if not integer else v
        if not math.isfinite(v):
            self.fail(path, f"expected a finite number, got {v!r}")
            return None
        rng = ""
        if lo is not None and (v < lo or (lo_open and v == lo)):
            rng = "bad"
        if hi is not None and (v > hi or (hi_open and v == hi)):
            rng = "bad"
        if rng:
            lb = "(" if lo_open else "["
            rb = ")" if hi_open else "]"
            self.fail(path, f"expected a value in {lb}{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}{rb}, got {v!r}")
            return None
        return v

    def rgb(self, v, path, lo=0.0):
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            x = self.number(v, path, lo=lo)
            return None if x is None else (x, x, x)
        if isinstance(v, list) and len(v) == 3:
            xs = [self.number(x, f"{path}[{i}]", lo=lo) for i, x in enumerate(v)]
            return None if None in xs else tuple(xs)
        self.fail(path, f"expected a number or a list of 3 numbers (R, G, B), got {v!r}")
        return None

    def vec3(self, v, path):
        if isinstance(v, list) and len(v) == 3:
            xs = [self.number(x, f"{path}[{i}]") for i, x in enumerate(v)]
            return None if None in xs else tuple(xs)
        self.fail(path, f"expected a list of 3 numbers [x, y, z], got {v!r}")
        return None

    def choice(self, v, path, options):
        if v not in options:
            self.fail(path, f"expected one of {', '.join(map(str, options))}, got {v!r}")
            return None
        return v

    def auto_or(self, v, path, **kw):
        if v == "auto":
            return "auto"
        return self.number(v, path, **kw)

    def boolean(self, v, path):
        if not isinstance(v, bool):
            self.fail(path, f"expected true or false, got {v!r}")
            return None
        return v


_MEDIUM_KEYS = dict.fromkeys(["absorption", "scattering", "visibility", "albedo", "asymmetry",
                              "emission", "ambient", "density"])
_DENSITY_KEYS = {
    "homogeneous": ("type", "factor"),
    "exponential": ("type", "factor", "falloff", "direction", "offset"),
    "sphere": ("type", "factor", "center", "radius"),
}
_CAMERA_KEYS = dict.fromkeys(["fov", "focal_px", "position", "yaw", "pitch", "roll", "depth",
                              "depth_scale", "max_depth", "focal_px_y", "cx", "cy", "baseline",
                              "near", "far", "encoding", "calibrated_size", "empty_depth"])
_RENDER_KEYS = dict.fromkeys(["method", "spread_model", "spread_scale", "kernel", "interpolation",
                              "c", "epsilon", "threshold", "levels", "fetch", "separation",
                              "psf", "border", "emission_profile"])
_SEP_KEYS = dict.fromkeys(["enabled", "luminance", "luminance_width", "depth", "depth_width", "level"])
_OUTPUT_KEYS = dict.fromkeys(["exposure", "type", "compression"])
_SECTIONS = {"medium": _MEDIUM_KEYS, "camera": _CAMERA_KEYS, "render": _RENDER_KEYS, "output": _OUTPUT_KEYS}


def _section(ck: _Checker, data: dict, name: str) -> dict:
    sec = data.get(name, {})
    if sec is None:
        return {}
    if not isinstance(sec, dict):
        ck.fail(name, f"expected a mapping, got {sec!r}")
        return {}
    ck.keys(sec, name, _SECTIONS[name])
    return sec


def _medium(ck: _Checker, sec: dict) -> Medium:
    m = Medium()
    if "visibility" in sec and any(k in sec for k in _FORM_A):
        ck.fail("medium.visibility", "give either visibility (+ albedo) or absorption + scattering, not both")
    sa = ck.rgb(sec["absorption"], "medium.absorption") if "absorption" in sec else None
    ss = ck.rgb(sec["scattering"], "medium.scattering") if "scattering" in sec else None
    m.absorption = sa if sa else m.absorption
    m.scattering = ss if ss else m.scattering
    albedo = ck.number(sec["albedo"], "medium.albedo", lo=0.0, hi=1.0) if "albedo" in sec else None
    if "visibility" in sec:
        v = ck.number(sec["visibility"], "medium.visibility", lo=0.0, lo_open=True)
        if v is not None:
            st = VISIBILITY_CONTRAST / v
            a = 0.9 if albedo is None else albedo
            m.absorption, m.scattering = ((1 - a) * st,) * 3, (a * st,) * 3
    elif albedo is not None:
        # albedo alone redistributes the extinction of the coefficients already given
        st = [x + y for x, y in zip(m.absorption, m.scattering)]
        m.absorption = tuple((1 - albedo) * t for t in st)
        m.scattering = tuple(albedo * t for t in st)
    if "asymmetry" in sec:
        g = ck.number(sec["asymmetry"], "medium.asymmetry", lo=0.0, hi=1.0, hi_open=True)
        m.asymmetry = g if g is not None else m.asymmetry
    if sec.get("ambient") == "auto":
        m.ambient = "auto"
    for key in ("emission", "ambient"):
        if key in sec and not (key == "ambient" and sec[key] == "auto"):
            v = ck.rgb(sec[key], f"medium.{key}")
            if v:
                setattr(m, key, v)
    if "density" in sec:
        m.density = _densities(ck, sec["density"])
    return m


def _densities(ck: _Checker, items) -> list:
    if not isinstance(items, list) or not items:
        ck.fail("medium.density", "expected a non-empty list of density primitives")
        return [Density("homogeneous")]
    out = []
    for i, d in enumerate(items):
        path = f"medium.density[{i}]"
        if not isinstance(d, dict) or "type" not in d:
            ck.fail(path, "expected a mapping with a type (homogeneous, exponential, sphere)")
            continue
        t = ck.choice(d["type"], f"{path}.type", list(_DENSITY_KEYS))
        if t is None:
            continue
        ck.keys(d, path, dict.fromkeys(_DENSITY_KEYS[t]))
        prim = Density(t)
        if "factor" in d:
            prim.factor = ck.number(d["factor"], f"{path}.factor", lo=0.0) or 0.0
        if t == "exponential":
            if "falloff" in d:
                prim.falloff = ck.number(d["falloff"], f"{path}.falloff") or 0.0
            if "direction" in d:
                v = ck.vec3(d["direction"], f"{path}.direction")
                if v and math.hypot(*v) == 0.0:
                    ck.fail(f"{path}.direction", "expected a non-zero direction, got [0, 0, 0]")
                elif v:
                    prim.direction = v
            if "offset" in d:
                prim.offset = ck.vec3(d["offset"], f"{path}.offset") or prim.offset
        if t == "sphere":
            if "center" in d:
                prim.center = ck.vec3(d["center"], f"{path}.center") or prim.center
            if "radius" in d:
                prim.radius = ck.number(d["radius"], f"{path}.radius", lo=0.0, lo_open=True) or 1.0
        out.append(prim)
    return out or [Density("homogeneous")]


def _camera(ck: _Checker, sec: dict) -> Camera:
    c = Camera()
    if "fov" in sec:
        c.fov = ck.number(sec["fov"], "camera.fov", lo=0.0, hi=180.0, lo_open=True, hi_open=True) or c.fov
    if "focal_px" in sec:
        c.focal_px = ck.number(sec["focal_px"], "camera.focal_px", lo=0.0, lo_open=True)
    if "position" in sec:
        c.position = ck.vec3(sec["position"], "camera.position") or c.position
    for k in ("yaw", "pitch", "roll"):
        if k in sec:
            v = ck.number(sec[k], f"camera.{k}")
            setattr(c, k, v if v is not None else 0.0)
    if "depth" in sec:
        c.depth = ck.choice(sec["depth"], "camera.depth", ["z", "distance", "disparity", "inverse"]) or c.depth
    if "depth_scale" in sec:
        v = sec["depth_scale"]
        c.depth_scale = "auto" if v == "auto" else (
            ck.number(v, "camera.depth_scale", lo=0.0, lo_open=True) or c.depth_scale)
    if "max_depth" in sec:
        c.max_depth = ck.number(sec["max_depth"], "camera.max_depth", lo=0.0, lo_open=True) or c.max_depth
    if "empty_depth" in sec:
        v = sec["empty_depth"]
        if v in ("inf", "sky") or (isinstance(v, float) and v == math.inf):
            c.empty_depth = math.inf
        else:
            x = ck.number(v, "camera.empty_depth", lo=0.0)
            c.empty_depth = c.empty_depth if x is None else x
    for k in ("focal_px_y", "baseline", "near", "far"):
        if k in sec:
            setattr(c, k, ck.number(sec[k], f"camera.{k}", lo=0.0, lo_open=True))
    for k in ("cx", "cy"):
        if k in sec:
            setattr(c, k, ck.number(sec[k], f"camera.{k}"))
    if "calibrated_size" in sec:
        v = sec["calibrated_size"]
        if (not isinstance(v, list) or len(v) != 2
                or not all(isinstance(x, int) and not isinstance(x, bool) and x > 0 for x in v)):
            ck.fail("camera.calibrated_size", f"expected [width, height] in pixels, got {v!r}")
        else:
            c.calibrated_size = tuple(v)
    if "encoding" in sec:
        c.encoding = ck.choice(sec["encoding"], "camera.encoding", ["linear", "cityscapes"]) or c.encoding
    if c.depth == "disparity" and c.baseline is None:
        ck.fail("camera.baseline", "depth: disparity needs the stereo baseline in metres (depth = baseline * focal_px / disparity)")
    if c.depth == "inverse":
        if c.near is None or c.far is None:
            ck.fail("camera.near" if c.near is None else "camera.far", "depth: inverse needs near and far in metres")
        elif c.near >= c.far:
            ck.fail("camera.near", f"expected near < far, got near {c.near:g}, far {c.far:g}")
    return c


def _render(ck: _Checker, sec: dict) -> Render:
    r = Render()
    choices = {
        "method": ["pyramid", "naive", "reference"],
        "spread_model": ["angular", "paper"],
        "interpolation": ["linear-bilinear", "linear-bicubic", "cubic-bicubic"],
        "fetch": ["source", "receiver"],
        "psf": ["apsf", "gaussian"],
        "border": ["open", "closed"],
        "emission_profile": ["isotropic", "lambertian"],
    }
    for k, opts in choices.items():
        if k in sec:
            setattr(r, k, ck.choice(sec[k], f"render.{k}", opts) or getattr(r, k))
    if "kernel" in sec:
        k = sec["kernel"]
        r.kernel = int(k) if not isinstance(k, bool) and k in (2, 4, 6) else ck.choice(k, "render.kernel", [2, 4, 6]) or r.kernel
    if "spread_scale" in sec:
        r.spread_scale = ck.number(sec["spread_scale"], "render.spread_scale", lo=0.0) or 0.0
    if "c" in sec:
        r.c = ck.auto_or(sec["c"], "render.c", lo=0.0, lo_open=True) or "auto"
    if "epsilon" in sec:
        v = ck.auto_or(sec["epsilon"], "render.epsilon", lo=0.0)
        r.epsilon = "auto" if v is None else v
    if "threshold" in sec:
        r.threshold = ck.auto_or(sec["threshold"], "render.threshold", lo=0.0, lo_open=True) or "auto"
    if "levels" in sec:
        v = sec["levels"]
        r.levels = v if v == "auto" else (ck.number(v, "render.levels", lo=1, hi=24, integer=True) or "auto")
    if "separation" in sec:
        s = sec["separation"]
        if not isinstance(s, dict):
            ck.fail("render.separation", f"expected a mapping, got {s!r}")
        else:
            ck.keys(s, "render.separation", _SEP_KEYS)
            sp = Separation()
            if "enabled" in s:
                sp.enabled = bool(ck.boolean(s["enabled"], "render.separation.enabled"))
            for k in ("luminance", "luminance_width", "depth", "depth_width"):
                if k in s:
                    setattr(sp, k, ck.number(s[k], f"render.separation.{k}", lo=0.0) or 0.0)
            if "level" in s:
                sp.level = ck.number(s["level"], "render.separation.level", lo=0.0, hi=1.0) or 0.0
            r.separation = sp
    if r.method == "naive" or (r.method == "pyramid" and r.fetch == "receiver"):
        # the naive and receiver-fetch composites read one Gaussian level per pixel
        if sec.get("psf") == "apsf":
            ck.fail("render.psf", "apsf needs render.method pyramid (fetch: source) or reference; "
                    "naive and the receiver fetch are Gaussian models (render.psf: gaussian)")
        r.psf = "gaussian"
    if r.psf == "gaussian" and r.emission_profile == "lambertian" and "emission_profile" in sec:
        ck.fail("render.emission_profile", "lambertian weights the tabulated point spread; it needs render.psf: apsf")
    return r


def _output(ck: _Checker, sec: dict) -> Output:
    o = Output()
    if "exposure" in sec:
        o.exposure = ck.number(sec["exposure"], "output.exposure") or 0.0
    if "type" in sec:
        o.type = ck.choice(sec["type"], "output.type", ["auto", "half", "float"]) or o.type
    if "compression" in sec:
        o.compression = ck.choice(sec["compression"], "output.compression", ["auto"] + EXR_COMPRESSION) or o.compression
    return o


def problems_of(data: dict, locs: dict) -> tuple[Config | None, list[str]]:
    ck = _Checker(locs)
    if not isinstance(data, dict):
        return None, ["expected a mapping of sections"]
    ck.keys(data, "", _SECTIONS)
    cfg = Config(
        medium=_medium(ck, _section(ck, data, "medium")),
        camera=_camera(ck, _section(ck, data, "camera")),
        render=_render(ck, _section(ck, data, "render")),
        output=_output(ck, _section(ck, data, "output")),
    )
    return (None if ck.problems else cfg), ck.problems


def build(data: dict, locs: dict) -> Config:
    cfg, problems = problems_of(data, locs)
    if problems:
        more = f" (and {len(problems) - 1} more problem{'s' if len(problems) > 2 else ''})" if len(problems) > 1 else ""
        raise UserError(problems[0] + more)
    return cfg
