"""Real inputs: camera RAW (a DNG made here with pidng), multi-part and multi-view EXR,
compositor layer names, an RGB-D frame from a Kinect-like sensor."""
import numpy as np
import OpenImageIO as oiio
import pytest
from click.testing import CliRunner

from fogcli.cli import main
from fogcli.errors import UserError
from fogcli.io.images import read_image
from helpers import read, write_img


def run(*args):
    r = CliRunner().invoke(main, [str(a) for a in args])
    return r.exit_code, r.output


def _dng(path, raw):
    from pidng.core import RAW2DNG, DNGTags, Tag
    from pidng.defs import (CalibrationIlluminant, CFAPattern, DNGVersion, Orientation,
                            PhotometricInterpretation, PreviewColorSpace)

    h, w = raw.shape
    t = DNGTags()
    for tag, v in [(Tag.ImageWidth, w), (Tag.ImageLength, h), (Tag.TileWidth, w), (Tag.TileLength, h),
                   (Tag.Orientation, Orientation.Horizontal),
                   (Tag.PhotometricInterpretation, PhotometricInterpretation.Color_Filter_Array),
                   (Tag.SamplesPerPixel, 1), (Tag.BitsPerSample, 16), (Tag.CFARepeatPatternDim, [2, 2]),
                   (Tag.CFAPattern, CFAPattern.RGGB), (Tag.BlackLevel, 0), (Tag.WhiteLevel, 4095),
                   (Tag.ColorMatrix1, [[1, 1], [0, 1], [0, 1], [0, 1], [1, 1], [0, 1], [0, 1], [0, 1], [1, 1]]),
                   (Tag.CalibrationIlluminant1, CalibrationIlluminant.D65), (Tag.AsShotNeutral, [[1, 1], [1, 1], [1, 1]]),
                   (Tag.BaselineExposure, [[0, 100]]), (Tag.Make, "fogcli"), (Tag.Model, "test"),
                   (Tag.DNGVersion, DNGVersion.V1_4), (Tag.DNGBackwardVersion, DNGVersion.V1_2),
                   (Tag.PreviewColorSpace, PreviewColorSpace.sRGB)]:
        t.set(tag, v)
    conv = RAW2DNG()
    conv.options(t, path="", compress=False)
    conv.convert(raw, filename=str(path.with_suffix("")))
    return path


def test_camera_raw_is_decoded_linear(tmp_path):
    raw = (np.random.default_rng(0).uniform(0.05, 0.3, (48, 64)) * 4095).astype(np.uint16)
    a = read_image(_dng(tmp_path / "a.dng", raw))
    b = read_image(_dng(tmp_path / "b.dng", raw * 2))
    assert a.rgb.shape == (48, 64, 3) and a.rgb.dtype == np.float32
    # linear: twice the photons, twice the value (no gamma, no auto-brightening); demosaic
    # and the colour matrix are linear too
    ratio = b.rgb.mean(axis=(0, 1)) / a.rgb.mean(axis=(0, 1))
    np.testing.assert_allclose(ratio, 2.0, rtol=0.03)
    assert 0.05 < a.rgb.mean() < 0.5
    np.save(tmp_path / "d.npy", np.full((48, 64), 30.0, np.float32))
    code, text = run("apply", tmp_path / "a.dng", "--depth", tmp_path / "d.npy", "-o", tmp_path / "o.exr")
    assert code == 0, text
    assert np.isfinite(read(tmp_path / "o.exr")[1]).all()
    bad = tmp_path / "bad.dng"
    bad.write_bytes(b"II*\x00 not a raw")
    code, text = run("apply", bad, "--depth", tmp_path / "d.npy", "-o", tmp_path / "o2.exr")
    assert code == 2 and "bad.dng: cannot read camera RAW" in text and len(text.strip().splitlines()) == 1


def _multipart(path, parts):
    """parts: (name, channel names, data, view or None)."""
    specs = []
    for name, names, data, view in parts:
        h, w, c = data.shape
        s = oiio.ImageSpec(w, h, c, "float")
        s.channelnames = tuple(names)
        s.attribute("name", name)
        if view:
            s.attribute("view", view)
        specs.append(s)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), specs), oiio.geterror()
    for i, (_, _, data, _) in enumerate(parts):
        if i:
            assert out.open(str(path), specs[i], "AppendSubimage"), out.geterror()
        assert out.write_image(np.ascontiguousarray(data, np.float32))
    out.close()


def test_multipart_exr_depth_in_its_own_part_and_layer_choice(tmp_path):
    rng = np.random.default_rng(3)
    beauty = rng.uniform(0, 1, (20, 30, 4)).astype(np.float32)
    diffuse = rng.uniform(0, 1, (20, 30, 3)).astype(np.float32)
    z = rng.uniform(2, 50, (20, 30, 1)).astype(np.float32)
    p = tmp_path / "nuke.exr"
    _multipart(p, [("depth", ["depth.Z"], z, None), ("rgba", ["R", "G", "B", "A"], beauty, None),
                   ("diffuse", ["diffuse.R", "diffuse.G", "diffuse.B"], diffuse, None)])
    f = read_image(p)
    np.testing.assert_array_equal(f.rgb, beauty[:, :, :3])
    np.testing.assert_array_equal(f.alpha, beauty[:, :, 3])
    np.testing.assert_array_equal(f.depth, z[:, :, 0])
    g = read_image(p, layer="diffuse")
    np.testing.assert_array_equal(g.rgb, diffuse)
    np.testing.assert_array_equal(g.depth, z[:, :, 0])
    with pytest.raises(UserError, match="--layer specular: no such layer"):
        read_image(p, layer="specular")
    code, text = run("apply", p, "--layer", "diffuse", "-o", tmp_path / "o.exr")
    assert code == 0, text


def test_multiview_exr(tmp_path):
    rng = np.random.default_rng(4)
    left, right = rng.uniform(0, 1, (16, 24, 3)), rng.uniform(0, 1, (16, 24, 3))
    zl, zr = np.full((16, 24, 1), 5.0), np.full((16, 24, 1), 9.0)
    p = tmp_path / "stereo.exr"
    data = np.concatenate([left, zl, right, zr], axis=2)
    h, w, c = data.shape
    s = oiio.ImageSpec(w, h, c, "float")
    s.channelnames = ("R", "G", "B", "Z", "right.R", "right.G", "right.B", "right.Z")
    s.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
    out = oiio.ImageOutput.create(str(p))
    assert out.open(str(p), s)
    assert out.write_image(np.ascontiguousarray(data, np.float32))
    out.close()
    f = read_image(p)
    np.testing.assert_allclose(f.rgb, left, rtol=1e-6)
    assert (f.depth == 5).all()
    r = read_image(p, view="right")
    np.testing.assert_allclose(r.rgb, right, rtol=1e-6)
    assert (r.depth == 9).all()
    with pytest.raises(UserError, match="no such view"):
        read_image(p, view="centre")


def test_blender_layer_names(tmp_path):
    """Blender multilayer: ViewLayer.Combined.RGBA, ViewLayer.Depth.Z, and a normal pass
    whose .Z must not be taken for depth."""
    rng = np.random.default_rng(5)
    comb = rng.uniform(0, 1, (10, 12, 4))
    normal = rng.uniform(-1, 1, (10, 12, 3))
    depth = rng.uniform(3, 30, (10, 12, 1))
    names = ["ViewLayer.Normal.X", "ViewLayer.Normal.Y", "ViewLayer.Normal.Z",
             "ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A",
             "ViewLayer.Depth.Z"]
    p = tmp_path / "blender.exr"
    write_img(p, np.concatenate([normal, comb, depth], axis=2), names)
    f = read_image(p)
    np.testing.assert_allclose(f.rgb, comb[:, :, :3], rtol=1e-6)
    np.testing.assert_allclose(f.alpha, comb[:, :, 3], rtol=1e-6)
    np.testing.assert_allclose(f.depth, depth[:, :, 0], rtol=1e-6)
    # Houdini: the beauty plain, depth as a one-channel plane Pz.Y beside P.X/P.Y/P.Z
    h = tmp_path / "houdini.exr"
    pos = rng.uniform(-5, 5, (10, 12, 3))
    write_img(h, np.concatenate([comb, pos, depth], axis=2), ["R", "G", "B", "A", "P.X", "P.Y", "P.Z", "Pz.Y"])
    g = read_image(h)
    np.testing.assert_allclose(g.depth, depth[:, :, 0], rtol=1e-6)


def test_rgbd_frame_jpeg_and_millimetre_png(tmp_path):
    """640x480 JPEG + 16-bit millimetre PNG with ~13 % holes (0), depth_scale 0.001,
    focal_px 525: finite output, holes filled (not dark), PNG output too."""
    rng = np.random.default_rng(6)
    yy, xx = np.mgrid[0:480, 0:640]
    rgb = np.clip(0.4 + 0.2 * np.sin(xx / 40.0)[..., None] * [1, 0.5, 0.2] + rng.normal(0, 0.02, (480, 640, 3)), 0, 1)
    mm = (800 + 4000 * yy / 480 + 300 * np.sin(xx / 50.0)).astype(np.uint16)
    holes = rng.random((480, 640)) < 0.13
    holes[200:240, 300:360] = True
    mm[holes] = 0
    img, dep = tmp_path / "rgb.jpg", tmp_path / "depth.png"
    write_img(img, (rgb * 255 + 0.5).astype(np.uint8), ["R", "G", "B"], fmt="uint8")
    write_img(dep, mm[:, :, None], ["Y"], fmt="uint16")
    sets = ["--set", "camera.depth_scale=0.001", "--set", "camera.focal_px=525", "--medium", "haze",
            "--set", "medium.visibility=4"]
    code, text = run("apply", img, "--depth", dep, *sets, "-o", tmp_path / "o.exr",
                     "--aov", "transmittance", "--save-depth", tmp_path / "clean.exr")
    assert code == 0, text
    assert f"{int(holes.sum())} invalid depth pixel(s)" in text
    spec, out = read(tmp_path / "o.exr")
    assert np.isfinite(out).all()
    names = list(spec.channelnames)
    t = out[:, :, names.index("transmittance.G")]
    # a hole treated as depth 0 would have transmittance 1 and show as the bare (darker
    # than fog) photo; filled, it matches its measured neighbours
    ring = np.zeros_like(holes)
    ring[195:245, 295:365] = True
    ring &= ~holes
    assert abs(np.median(t[200:240, 300:360]) - np.median(t[ring])) < 0.02
    assert t[holes].max() < 0.99
    cleaned = read(tmp_path / "clean.exr")[1][:, :, 0]
    assert np.isfinite(cleaned).all() and cleaned.min() >= 0.8 - 0.31
    before = dep.read_bytes()
    code, text = run("apply", img, "--depth", dep, *sets, "-o", tmp_path / "o2.exr", "--save-depth", dep)
    assert code == 2 and "refusing to overwrite" in text and dep.read_bytes() == before
    code, text = run("apply", img, "--depth", dep, *sets, "-o", tmp_path / "o.png")
    assert code == 0, text
    spec, png = read(tmp_path / "o.png")
    assert (spec.width, spec.height) == (640, 480) and png.std() > 0.005


@pytest.mark.parametrize("cs,decode", [("sRGB", "srgb"), ("lin_rec709", "linear"), ("g22_rec709", "gamma"), (None, "srgb")])
def test_png_colour_space_metadata(tmp_path, cs, decode):
    from fogcli.io.colour import srgb_to_linear

    v = np.linspace(0, 1, 24, dtype=np.float32).reshape(2, 4, 3)
    p = tmp_path / "c.png"
    s = oiio.ImageSpec(4, 2, 3, "uint16")
    if cs:
        s.attribute("oiio:ColorSpace", cs)
    out = oiio.ImageOutput.create(str(p))
    assert out.open(str(p), s) and out.write_image(v)
    out.close()
    got = read_image(p).rgb
    code = np.round(v * 65535) / 65535
    want = {"srgb": srgb_to_linear(code), "linear": code, "gamma": code ** 2.2}[decode]
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("names", [["N.X"], ["Normal.Z"], ["P.X", "P.Z"], ["N.X", "N.Y", "N.Z"], ["P.Z", "N.Z"]])
def test_a_vector_pass_is_never_taken_as_depth(tmp_path, names):
    """Issue 41: a depth file holding only a normal or position pass was read as depth (one
    channel: that channel; two: grey + alpha)."""
    from helpers import assert_one_line_error, run

    img, d = tmp_path / "rgb.exr", tmp_path / "d.exr"
    write_img(img, np.full((8, 9, 3), 0.5), ["R", "G", "B"])
    write_img(d, np.random.default_rng(0).uniform(1, 20, (8, 9, len(names))), names)
    assert_one_line_error(*run("apply", img, "--depth", d, "-o", tmp_path / "o.exr")[:2],
                          "is a vector pass (normals, positions), not depth")
