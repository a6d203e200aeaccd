"""The config model: every key declared once, with its type, range, default and doc (the
docs' key reference is generated from it: tools/make_config_doc.py). Built once from the
merged sources (yaml_source.py) into a frozen object; `auto` values that do not depend on
the image are resolved then. Problems are reported as ``file:line: key: problem``, sorted
by file and line."""
from __future__ import annotations

import math
from typing import Annotated, Literal, Union

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from fogcli.physics.calibration import CALIBRATED, c_theory

VISIBILITY_CONTRAST = 3.912  # -ln(0.02): Koschmieder's 2 % contrast threshold


# ----------------------------------------------------------------------------- value types

# No key means anything beyond this magnitude (a coefficient of 1e15 / m, a position 1e15 m
# away): refusing it keeps float32 kernels and float64 host code from overflowing.
MAX_MAGNITUDE = 1e15


def _num(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a number, got {str(v)[:40]!r}")
    try:
        v = float(v)
    except OverflowError:
        raise ValueError("expected a number, got an integer too large for one") from None
    if not math.isfinite(v):
        raise ValueError(f"expected a finite number, got {v!r}")
    if abs(v) > MAX_MAGNITUDE or 0.0 < abs(v) < 1.0 / MAX_MAGNITUDE ** 2:
        raise ValueError(f"expected 0 or a magnitude between {1 / MAX_MAGNITUDE ** 2:g} and {MAX_MAGNITUDE:g}, got {v:g}")
    return v


def _triple(v, lo=None):
    xs = [v] * 3 if isinstance(v, (int, float)) and not isinstance(v, bool) else v
    if not isinstance(xs, (list, tuple)) or len(xs) != 3:
        raise ValueError(f"expected a number or a list of 3 numbers, got {v!r}")
    out = tuple(_num(x) for x in xs)
    bad = [i for i, x in enumerate(out) if lo is not None and x < lo]
    if bad:
        raise ValueError(f"[{bad[0]}]: expected a value >= {lo:g}, got {out[bad[0]]:g}")
    return out


def _inf_or_num(v):
    return math.inf if v in ("inf", "sky") or (isinstance(v, float) and v == math.inf) else _num(v)


Num = Annotated[float, BeforeValidator(_num)]
RGB = Annotated[tuple[float, float, float], BeforeValidator(lambda v: _triple(v, 0.0))]
Vec3 = Annotated[tuple[float, float, float], BeforeValidator(_triple)]
Auto = Literal["auto"]
Percent = Annotated[str, Field(pattern=r"^\s*\d+(\.\d*)?\s*%\s*$")]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# ----------------------------------------------------------------------------- medium

class Homogeneous(_Model):
    type: Literal["homogeneous"] = Field(description="homogeneous | exponential | sphere | noise")
    factor: Annotated[Num, Field(ge=0)] = Field(1.0, description="density multiplier of the medium's coefficients")


class Exponential(Homogeneous):
    type: Literal["exponential"]  # type: ignore[assignment]
    falloff: Num = Field(0.0, description="1/m: density factor * exp(-falloff * (x - offset) . direction)")
    direction: Vec3 = Field((0.0, 1.0, 0.0), description="direction in which the density falls off (world)")
    offset: Vec3 = Field((0.0, 0.0, 0.0), description="m, world point where the density is factor")

    @model_validator(mode="after")
    def _dir(self):
        if math.hypot(*self.direction) < 1e-9:
            raise ValueError(f"direction: expected a non-zero direction, got {list(self.direction)}")
        return self


class Sphere(Homogeneous):
    type: Literal["sphere"]  # type: ignore[assignment]
    center: Vec3 = Field((0.0, 0.0, 0.0), description="m, world centre of the sphere")
    radius: Annotated[Num, Field(gt=0)] = Field(1.0, description="m: density factor * (1 - r^2 / radius^2) inside")


class Noise(Homogeneous):
    """Fractal value noise (docs/media.md, Noise): factor * max(0, offset + amplitude * fbm(x)),
    fbm in [-1, 1], inside a box or a sphere. No closed form: rays through it are marched."""
    type: Literal["noise"]  # type: ignore[assignment]
    seed: Annotated[int, Field(ge=0, lt=2**31, strict=True)] = Field(0, description="which noise (the same seed, the same smoke)")
    octaves: Annotated[int, Field(ge=1, le=8, strict=True)] = Field(4, description="layers of detail, each half the size")
    scale: Annotated[Num, Field(gt=0)] = Field(1.0, description="m, size of the largest features")
    amplitude: Annotated[Num, Field(ge=0)] = Field(
        2.0, description="density factor * max(0, offset + amplitude * fbm); fbm lies in [-1, 1], its spread about 0.23")
    offset: Num = Field(0.25, description="added to amplitude * fbm: below about -amplitude / 4 most of the box is empty")
    shape: Literal["box", "sphere"] = Field("sphere", description="bounds: box (center, size) | sphere (center, radius)")
    center: Vec3 = Field((0.0, 0.0, 0.0), description="m, world centre of the bounds")
    size: Vec3 = Field((1.0, 1.0, 1.0), description="m, box: edge lengths along the world axes")
    radius: Annotated[Num, Field(gt=0)] = Field(1.0, description="m, sphere: radius")
    edge: Annotated[Num, Field(ge=0)] | Literal["auto"] = Field(
        "auto", description="m, the density fades to 0 over this width inside the bounds; auto: a quarter of the "
        "smallest half-size (0: a hard edge)")
    step: Annotated[Num, Field(gt=0)] | Literal["auto"] = Field(
        "auto", description="m, march step along rays; auto: a quarter of the finest features (at most 512 steps a ray)")

    @model_validator(mode="after")
    def _bounds(self):
        if self.shape == "box" and min(self.size) <= 0:
            raise ValueError(f"size: expected three positive edge lengths, got {list(self.size)}")
        return self

    def edge_m(self) -> float:
        if self.edge != "auto":
            return float(self.edge)
        return 0.25 * (self.radius if self.shape == "sphere" else 0.5 * min(self.size))

    def march_step(self) -> float:
        return self.scale / 2 ** (self.octaves - 1) / 4 if self.step == "auto" else float(self.step)


Density = Annotated[Union[Homogeneous, Exponential, Sphere, Noise], Field(discriminator="type")]


class Medium(_Model):
    absorption: RGB = Field((0.0, 0.0, 0.0), description="sigma_a per RGB, 1/m (a number means grey)")
    scattering: RGB = Field((0.0, 0.0, 0.0), description="sigma_s per RGB, 1/m")
    visibility: Annotated[Num, Field(gt=0)] | Percent | None = Field(
        None, description="m, instead of absorption + scattering: sigma_t = 3.912 / visibility (2 % contrast); "
        "or a share of the frame's median depth ('40%'), which scales the coefficients given")
    albedo: Annotated[Num, Field(ge=0, le=1)] | None = Field(
        None, description="sigma_s / sigma_t with visibility (default 0.9); alone, it redistributes sigma_t")
    asymmetry: Annotated[Num, Field(ge=0, lt=1)] = Field(0.9, description="g of the Henyey-Greenstein phase function")
    emission: RGB = Field((0.0, 0.0, 0.0), description="L_e, light the medium emits per metre")
    ambient: RGB | Auto = Field(
        (0.0, 0.0, 0.0), description="L_a, ambient light the medium scatters; auto: the median colour of the sky or farthest 2 %")
    density: Annotated[list[Density], Field(min_length=1)] = Field(
        [Homogeneous(type="homogeneous")], description="primitives whose densities add up (homogeneous, exponential, sphere, noise)")

    @model_validator(mode="after")
    def _forms(self):
        v, a, given = self.visibility, self.albedo, {"absorption", "scattering"} & self.model_fields_set
        if isinstance(v, float) and given:
            raise ValueError("visibility: give either visibility (+ albedo) or absorption + scattering, not both")
        if isinstance(v, float) or (isinstance(v, str) and not given):    # grey (relative: sigma_t 1 m^-1)
            st, a = (VISIBILITY_CONTRAST / v if isinstance(v, float) else 1.0,) * 3, 0.9 if a is None else a
        elif a is not None:                                                # albedo redistributes sigma_t
            st = [x + y for x, y in zip(self.absorption, self.scattering)]
        else:
            return self
        object.__setattr__(self, "absorption", tuple((1 - a) * t for t in st))   # frozen: set once, here
        object.__setattr__(self, "scattering", tuple(a * t for t in st))
        return self

    @property
    def homogeneous(self) -> float:
        """The summed factor of the homogeneous density primitives."""
        return sum(d.factor for d in self.density if d.type == "homogeneous")

    @property
    def heterogeneous(self) -> bool:
        """A primitive other than a homogeneous one: its optical depth P is found per pixel."""
        return any(d.type != "homogeneous" for d in self.density)

    def for_depth(self, median_depth: float) -> "Medium":
        """A relative visibility ('40%') made metres: the coefficients scaled so that the mean
        extinction gives that visibility at this share of the frame's median depth."""
        if not isinstance(self.visibility, str):
            return self
        v = float(self.visibility.strip().rstrip("%")) / 100.0 * median_depth
        st = sum(a + s for a, s in zip(self.absorption, self.scattering)) / 3.0
        k = VISIBILITY_CONTRAST / v / st if v > 0 and st > 0 else 0.0
        return self.model_copy(update=dict(visibility=v, absorption=tuple(k * a for a in self.absorption),
                                           scattering=tuple(k * s for s in self.scattering)))


# ----------------------------------------------------------------------------- camera

class Camera(_Model):
    fov: Annotated[Num, Field(gt=0, lt=180)] = Field(
        60.0, description="horizontal field of view, degrees (unless focal_px)")
    focal_px: Annotated[Num, Field(gt=0)] | None = Field(None, description="horizontal focal length, pixels")
    focal_px_y: Annotated[Num, Field(gt=0)] | None = Field(
        None, description="vertical focal length, pixels; default: focal_px")
    cx: Num | None = Field(None, description="principal point, pixels from the left edge; default: width / 2")
    cy: Num | None = Field(None, description="principal point, pixels from the top edge; default: height / 2")
    calibrated_size: tuple[Annotated[int, Field(gt=0, strict=True)], Annotated[int, Field(gt=0, strict=True)]] | None = Field(
        None, description="[width, height] the intrinsics are for; other image sizes scale them")
    depth: Literal["z", "distance", "disparity", "inverse"] = Field(
        "z", description="what the depth file holds: z (planar), distance (ray length), disparity, inverse (relative)")
    depth_scale: Annotated[Num, Field(gt=0)] | Auto = Field(
        "auto", description="metres per stored unit; auto: 0.001 for 16/32-bit integer files (millimetres), else 1")
    encoding: Literal["linear", "cityscapes"] = Field(
        "linear", description="linear: value * depth_scale; cityscapes: disparity PNG (p - 1) / 256, 0 = none")
    baseline: Annotated[Num, Field(gt=0)] | None = Field(
        None, description="m, depth: disparity -> z = baseline * focal_px / disparity")
    near: Annotated[Num, Field(gt=0)] | None = Field(
        None, description="m, depth: inverse maps its largest value to near ...")
    far: Annotated[Num, Field(gt=0)] | None = Field(None, description="m, ... and its smallest to far, linear in 1/z")
    max_depth: Annotated[Num, Field(gt=0)] = Field(1000.0, description="m; +inf (sky) and beyond are clamped here")
    empty_depth: Annotated[float, BeforeValidator(_inf_or_num), Field(ge=0)] = Field(
        0.0, description="m, where pixels with alpha 0 look: 0 = no medium (the plate behind carries its own); inf = open sky")
    highlight_gain: Annotated[Num, Field(ge=1, le=1e6)] = Field(
        1.0, description="display-referred images (8/16-bit): the light a lamp clipped at white stands for, in "
        "multiples of white (1: as stored; 50: a lamp that clipped is 50 times white); a lamp is a compact clipped "
        "region at most 1 m across at its depth; its pixels from 80 % of white up ramp towards it")
    highlight_area_gain: Annotated[Num, Field(ge=1, le=1e6)] = Field(
        1.0, description="the same for every other clipped region (sky, lit windows, white walls, a lamp's "
        "reflection): usually a few times white")
    highlight_kelvin: Annotated[Num, Field(ge=1667, le=25000)] | None = Field(
        None, description="the colour temperature of a lamp whose core clipped to white (its hue is lost with "
        "every channel clipped): 2000 sodium, 2700 tungsten, 4000 warm LED; unset: white")
    position: Vec3 = Field((0.0, 0.0, 0.0), description="world position of the camera, m (for the density primitives)")
    yaw: Num = Field(0.0, description="degrees about +Y (positive turns left), then")
    pitch: Num = Field(0.0, description="degrees about +X (positive looks up), then")
    roll: Num = Field(0.0, description="degrees about the view axis")

    @model_validator(mode="after")
    def _depth_needs(self):
        if self.depth == "disparity" and self.baseline is None:
            raise ValueError("baseline: depth: disparity needs the stereo baseline in metres")
        if self.depth == "inverse" and (self.near is None or self.far is None):
            raise ValueError(f"{'near' if self.near is None else 'far'}: depth: inverse needs near and far in metres")
        if self.depth == "inverse" and self.near >= self.far:
            raise ValueError(f"near: expected near < far, got near {self.near:g}, far {self.far:g}")
        return self

    def for_size(self, width: int, height: int) -> "Camera":
        """The intrinsics scaled to an image of width x height (calibrated_size)."""
        if self.calibrated_size is None or tuple(self.calibrated_size) == (width, height):
            return self
        sx, sy = width / self.calibrated_size[0], height / self.calibrated_size[1]
        f = lambda v, s: None if v is None else v * s  # noqa: E731
        return self.model_copy(update=dict(focal_px=f(self.focal_px, sx), focal_px_y=f(self.focal_px_y, sy),
                                           cx=f(self.cx, sx), cy=f(self.cy, sy), calibrated_size=None))

    def focal(self, width: int) -> float:
        return float(self.focal_px) if self.focal_px is not None else (width / 2.0) / math.tan(math.radians(self.fov) / 2.0)

    def focal_y(self, width: int) -> float:
        return float(self.focal_px_y) if self.focal_px_y is not None else self.focal(width)

    def centre(self, width: int, height: int) -> tuple[float, float]:
        return (width / 2.0 if self.cx is None else float(self.cx), height / 2.0 if self.cy is None else float(self.cy))


# ----------------------------------------------------------------------------- lights

def _nonzero(v):
    if math.hypot(*v) < 1e-9:
        raise ValueError("expected a non-zero direction, got [0, 0, 0]")
    return v


Direction = Annotated[Vec3, AfterValidator(_nonzero)]
Frame = Literal["camera", "world"]
_FRAME = "camera: camera space (+X right, +Y up, looking down -Z) | world: placed by camera.position and yaw/pitch/roll"


class PointLight(_Model):
    type: Literal["point"] = Field(description="point | spot | directional")
    position: Vec3 = Field(description="m, where the light is")
    intensity: RGB = Field(description="radiant intensity in image radiance x m^2 (a pixel of radiance L at d m, "
                                       "footprint a m^2 sends L a)")
    radius: Annotated[Num, Field(gt=0)] = Field(0.05, description="m, size of the emitter: a ray closer to the light sees the airlight at this distance, raised towards the centre so that the light's energy stays (finite on the ray through it)")
    frame: Frame = Field("camera", description=_FRAME)


class SpotLight(PointLight):
    type: Literal["spot"]  # type: ignore[assignment]
    direction: Direction = Field(description="axis of the cone, the way the light shines")
    angle: Annotated[Num, Field(gt=0, lt=90)] = Field(30.0, description="degrees from the axis to the cone's edge")
    blend: Annotated[Num, Field(ge=0, le=1)] = Field(0.15, description="soft edge: the share of the angle over which the light fades")


class DirectionalLight(_Model):
    type: Literal["directional"]
    direction: Direction = Field(description="towards the light (the sun)")
    irradiance: RGB = Field(description="irradiance inside the medium, image radiance x sr; the homogeneous part "
                                        "of the medium does not dim it further, the other density primitives do")
    frame: Frame = Field("camera", description=_FRAME)


class AutoLights(_Model):
    type: Literal["auto"]
    threshold: Annotated[Num, Field(gt=0)] | Auto = Field(
        "auto", description="luminance above which pixels are lamp cores; auto: 10x the 99th percentile "
        "(HDR), 0.98 (display-referred images, whose lamps are clipped)")
    min_pixels: Annotated[int, Field(ge=1, strict=True)] = Field(3, description="smallest lamp core, pixels")


Light = Annotated[Union[PointLight, SpotLight, DirectionalLight, AutoLights], Field(discriminator="type")]


class LightsRender(_Model):
    airlight: Literal["quadrature", "pk"] = Field(
        "quadrature", description="quadrature: Gauss-Legendre, any medium and phase | pk: Pradhan & Kumar's "
        "closed form for point lights, isotropic phase, homogeneous media (its error: docs/lights.md)")
    nodes: Annotated[int, Field(ge=4, le=64, strict=True)] = Field(
        16, description="Gauss-Legendre nodes per piece of each ray (accuracy per node count: docs/lights.md); "
        "noise media: midpoint intervals per piece")
    shadows: Literal["none", "screen"] = Field(
        "none", description="screen: the visible surfaces of the depth map shadow the lights (docs/lights.md, Shadows)")
    method: Literal["epipolar", "march"] = Field(
        "epipolar", description="shadows: epipolar (marched at samples on lines through the light's image, "
        "interpolated) | march (every pixel marched: the reference)")
    slices: Annotated[int, Field(ge=16, le=16384, strict=True)] = Field(
        512, description="epipolar: lines through the light's image (at most two per border pixel); more are closer "
        "where a shadow's edge falls between lines, at a cost in proportion (docs/lights.md, Shadows)")
    step: Annotated[int, Field(ge=1, le=64, strict=True)] = Field(
        16, description="epipolar: pixels between samples on a line (at most 1/16 of the image's longer side)")
    thickness: Annotated[Num, Field(gt=0)] = Field(1.0, description="m, how far behind a visible surface it blocks light")
    offscreen: Literal["lit", "shadowed"] = Field(
        "lit", description="what the part of a shadow ray outside the frame meets: nothing (lit) or an occluder (shadowed)")
    tfm_size: Annotated[int, Field(ge=16, le=1024, strict=True)] = Field(
        256, description="noise media: texels per side of each light's transmittance function map")
    coefficients: Annotated[int, Field(ge=2, le=32, strict=True)] = Field(
        16, description="noise media: DCT coefficients of the optical depth along each map texel's ray")


# ----------------------------------------------------------------------------- render, output

class Separation(_Model):
    """Iser's pixel separation; defaults calibrated on night scenes (docs/calibration-separation.md)."""
    enabled: bool = Field(False, description="bright near pixels get a scattering chain of their own")
    luminance: Annotated[Num, Field(ge=0)] = Field(0.3, description="a pixel is bright above this luminance of L ...")
    luminance_width: Annotated[Num, Field(ge=0)] = Field(0.3, description="... ramping over this width")
    depth: Annotated[Num, Field(ge=0)] = Field(1000.0, description="near: optical depth D' = P below this ...")
    depth_width: Annotated[Num, Field(ge=0)] = Field(1000.0, description="... ramping over this width")
    level: Annotated[Num, Field(ge=0, le=1)] = Field(0.9, description="receiver fetch: k_ssc = level * K")


class Render(_Model):
    method: Literal["pyramid", "naive", "reference"] = Field(
        "pyramid", description="pyramid (fast) | naive | reference (exact, slow)")
    psf: Literal["apsf", "gaussian"] = Field(
        "apsf", description="apsf: the point spread of multiple scattering by radiative transfer | gaussian: one Gaussian per source")
    border: Literal["open", "closed", "extend"] = Field(
        "extend", description="open: light scattered across the frame edge leaves it | closed: it stays in the frame | "
                            "extend: the world goes on past the edge like the edge itself (border_margin)")
    border_margin: Annotated[Num, Field(ge=0)] = Field(
        0.05, description="extend: how far past each side the edge continues, in frame widths (heights); the default "
        "is the margin closest to path tracing on the calibration scenes (tools/border_margin.py)")
    border_band: Annotated[Num, Field(ge=0)] = Field(
        0.03, description="extend: what the edge continues as: the mean of the band this wide next to it, in frame "
        "widths (heights), at least one pixel (0: the edge pixel itself), over the edge pixel's surface (its log P near "
        "the edge pixel's); one row's texture is not the surface's, a lamp a few pixels in is not continued. The default is "
        "chosen with border_margin (tools/border_margin.py)")
    emission_profile: Literal["lambertian", "isotropic"] = Field(
        "lambertian", description="apsf: weight each source by a matte surface's emission towards the camera (normals from depth)")
    ground: Literal["auto", "none"] = Field(
        "auto", description="auto: a ground plane found in the depth and the sky above it light the medium as the "
        "boundaries of a slab (homogeneous media; docs/method.md) | none: every pixel is a point source in an infinite medium")
    halo_depth: Literal["receiver", "none"] = Field(
        "receiver", description="apsf pyramid: receiver: a surface nearer than a source gets only the part of the "
        "source's glow that scatters in front of it (docs/method.md) | none: every pixel gets the whole glow")
    spread_space: Literal["angles", "pixels"] = Field(
        "angles", description="apsf pyramid, open or extend border: angles: the wide part of the glow spreads over "
        "the angles around its source, as light does (a pinhole image stretches them away from its centre) | pixels: "
        "over the image's pixels")
    spread_model: Literal["angular", "paper"] = Field("angular", description="psf gaussian: the blur width model")
    spread_scale: Annotated[Num, Field(ge=0)] = Field(1.0, description="widens (> 1) or narrows the blur")
    kernel: Literal[2, 4, 6] = Field(4, description="pyramid filter taps")
    interpolation: Literal["linear-bilinear", "linear-bicubic", "cubic-bicubic"] = Field(
        "linear-bicubic", description="between levels - within a level")
    fetch: Literal["source", "receiver"] = Field("source", description="source (default) | receiver (Elek eq. 10-12)")
    c: Annotated[Num, Field(gt=0)] | Auto = Field(
        "auto", description="blur of level k is c 2^k pixels; auto: derived from kernel and interpolation")
    epsilon: Annotated[Num, Field(ge=0)] | Auto = Field("auto", description="masking ramp width; auto: calibrated")
    threshold: Annotated[Num, Field(gt=0)] | Auto = Field(
        "auto", description="masking threshold factor; auto: calibrated")
    levels: Annotated[int, Field(ge=1, le=24, strict=True)] | Auto = Field(
        "auto", description="pyramid levels; auto: down to one pixel")
    separation: Separation = Separation()
    noise_stride: Annotated[int, Field(ge=1, le=16, strict=True)] | Literal["auto"] = Field(
        "auto", description="noise media: rays are marched every this many pixels and interpolated where the "
        "surface agrees (1: every pixel); auto: a third of the finest noise features' size in pixels, 1 to 8")
    lights: LightsRender = LightsRender()

    @model_validator(mode="before")
    @classmethod
    def _gaussian_only(cls, d):
        if not isinstance(d, dict):
            return d
        if d.get("method") == "naive" or (d.get("method", "pyramid") == "pyramid" and d.get("fetch") == "receiver"):
            # the naive and receiver-fetch composites read one Gaussian level per pixel
            if d.get("psf") == "apsf":
                raise ValueError("psf: apsf needs render.method pyramid (fetch: source) or reference; "
                                 "naive and the receiver fetch are Gaussian models (render.psf: gaussian)")
            d = {**d, "psf": "gaussian"}
        if d.get("psf") == "gaussian" and "border" not in d:
            # the Gaussian model's calibration (docs/calibration.md) is for the closed border,
            # what it always did (the default `extend` is the tabulated point spread's)
            d = {**d, "border": "closed"}
        if d.get("psf") == "gaussian" and d.get("border") == "extend":
            raise ValueError("border: extend continues the frame's edge for the tabulated point spread; it needs "
                             "render.psf: apsf (with psf gaussian, open or closed; left out, closed)")
        if d.get("psf") == "gaussian" and d.get("emission_profile") == "lambertian":
            raise ValueError("emission_profile: lambertian weights the tabulated point spread; it needs render.psf: apsf")
        sep = d.get("separation")
        if isinstance(sep, dict) and sep.get("enabled") is True and d.get("method", "pyramid") != "pyramid":
            raise ValueError("separation.enabled: pixel separation needs render.method: pyramid")
        return d

    def resolved(self) -> tuple[float, float, float]:
        """(c, epsilon, threshold) with auto replaced by the derived c and the calibrated values."""
        fetch = self.fetch if self.method == "pyramid" else "receiver"   # naive fetches too
        e0, t0 = CALIBRATED[fetch][self.kernel]
        pick = lambda v, d: d if v == "auto" else float(v)  # noqa: E731
        return pick(self.c, c_theory(self.kernel, self.interpolation, fetch)), pick(self.epsilon, e0), pick(self.threshold, t0)


class Output(_Model):
    exposure: Num = Field(0.0, description="EV, for PNG/TIFF/JPEG output")
    type: Literal["auto", "half", "float"] = Field(
        "auto", description="EXR type of what fogcli writes: auto (the input colour's; float otherwise); copied channels keep theirs")
    compression: Literal["auto", "none", "rle", "zip", "zips", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"] = Field(
        "auto", description="EXR compression: auto (the input's; zip otherwise); pxr24, b44, dwaa, dwab are lossy")
    data_window: Literal["grow", "keep"] = Field(
        "grow", description="an EXR whose data window is not its display window: grow: the output's is both windows' "
        "union (the light scattered past the data window kept; the camera is the display window's in either case) | "
        "keep: the input's (--keep-data-window)")


_SIZE_UNITS = {"": 1, "b": 1, "k": 1e3, "kb": 1e3, "kib": 2**10, "m": 1e6, "mb": 1e6, "mib": 2**20,
               "g": 1e9, "gb": 1e9, "gib": 2**30, "t": 1e12, "tb": 1e12, "tib": 2**40}


def _memory_size(v):
    """auto, a share of the memory available (60%), or a size: bytes, 8GB, 512 MiB, 1.5G."""
    if v == "auto" or isinstance(v, str) and v.strip().endswith("%"):
        text = v.strip()
        if text != "auto":
            try:
                share = float(text[:-1])
            except ValueError:
                share = -1.0
            if not 0 < share <= 100:
                raise ValueError(f"expected auto, a share of the available memory (1% to 100%) or a size "
                                 f"(8GiB, 512MB, bytes), got {v!r}")
        return text
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        n = float(v)
    else:
        import re

        m = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*([a-zA-Z]*)\s*", str(v))
        if not m or m.group(2).lower() not in _SIZE_UNITS:
            raise ValueError(f"expected auto, a share of the available memory (60%) or a size (8GiB, 512MB, "
                             f"bytes), got {v!r}")
        n = float(m.group(1)) * _SIZE_UNITS[m.group(2).lower()]
    if not 2**20 <= n <= 2**60:
        raise ValueError(f"expected a size between 1 MiB and 1 EiB, got {v!r}")
    return int(n)


class Limits(_Model):
    memory: Annotated[Union[int, str], BeforeValidator(_memory_size)] = Field(
        "auto", description="most memory one frame may need: an image whose estimate (from its header) is larger is "
        "refused before it is read. auto: 60% of the memory available (MemAvailable, and below a cgroup's limit); "
        "a share of it (80%); or a size (8GiB, 512MB, bytes)")


class Config(_Model):
    medium: Medium = Medium()
    camera: Camera = Camera()
    render: Render = Render()
    output: Output = Output()
    limits: Limits = Limits()
    lights: list[Light] = Field([], description="lights in the medium (point, spot, directional)")

    @model_validator(mode="after")
    def _lights_need(self):
        r = self.render
        if self.lights and not (r.method == "pyramid" and r.fetch == "source" and r.psf == "apsf"):
            raise ValueError("lights: lights need render.method pyramid with fetch source and psf apsf (the defaults)")
        if r.lights.airlight == "pk" and self.medium.heterogeneous:
            raise ValueError("render.lights.airlight: pk is for homogeneous media; use quadrature")
        return self
