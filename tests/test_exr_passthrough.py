"""EXR in, EXR out as a compositing pipeline expects (issue 9): every channel, part and view
fogcli does not produce is copied exactly, pixel types, windows, attributes and the
compression follow the input, and only the colour read (and its alpha) is replaced."""
import numpy as np
import OpenImageIO as oiio
import pytest

from helpers import assert_one_line_error, run

# a beachball-like single-part stereo file: 19 channels, the left view unprefixed
NAMES = ["R", "G", "B", "A", "Z", "disparityL.x", "disparityL.y", "forward.u", "forward.v", "whitebarmask.mask",
         "right.R", "right.G", "right.B", "right.A", "right.Z", "right.disparityR.x", "right.disparityR.y",
         "right.forward.u", "right.forward.v"]
H, W = 36, 52


def _data(names, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0, 1, (H, W, len(names))).astype(np.float32)
    for i, n in enumerate(names):
        if n.endswith("Z"):
            d[:, :, i] = rng.uniform(3, 80, (H, W))
        if n.endswith("A"):
            d[:, :, i] = 1.0
    return d


def _spec(names, fmt_of, window=(11, 4), display=(0, 0, 80, 50)):
    spec = oiio.ImageSpec(W, H, len(names), "half")
    spec.channelnames = tuple(names)
    spec.channelformats = tuple(oiio.TypeDesc(fmt_of(n)) for n in names)
    spec.x, spec.y = window
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = display
    spec.attribute("compression", "piz")
    spec.attribute("studio:shot", "bb010")
    return spec


def _fmt(n):
    return "float" if n.endswith("Z") else ("uint" if n.endswith("mask") else "half")


def _read_all(path):
    """[(spec, {channel: float64 plane})] of every part."""
    inp = oiio.ImageInput.open(str(path))
    parts, i = [], 0
    while inp.seek_subimage(i, 0):
        s = oiio.ImageSpec(inp.spec())
        px = np.asarray(inp.read_image(i, 0, 0, s.nchannels, "double")).reshape(s.height, s.width, s.nchannels)
        parts.append((s, {n: px[:, :, k] for k, n in enumerate(s.channelnames)}))
        i += 1
    inp.close()
    return parts


def _formats(spec):
    fmts = list(map(str, spec.channelformats)) or [str(spec.format)] * spec.nchannels
    return dict(zip(spec.channelnames, fmts))


@pytest.fixture
def stereo(tmp_path):
    p = tmp_path / "singlepart.exr"
    data = _data(NAMES)
    ids = np.arange(H * W).reshape(H, W) * 7919 + 16_777_219          # above 2^24: not exact in float32
    data = data.astype(np.float64)
    data[:, :, NAMES.index("whitebarmask.mask")] = ids / 4294967295.0   # OpenImageIO normalises uint
    spec = _spec(NAMES, _fmt)
    spec.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
    out = oiio.ImageOutput.create(str(p))
    assert out.open(str(p), spec)
    assert out.write_image(data)
    out.close()
    return p


def _inside(a, so, si):
    """Of an output plane, the pixels of the input's data window."""
    return a[si.y - so.y:si.y - so.y + si.height, si.x - so.x:si.x - so.x + si.width]


@pytest.mark.parametrize("view,keep", [(None, False), (None, True), ("left", True), ("right", True)])
def test_stereo_single_part_keeps_every_channel_and_view(stereo, tmp_path, view, keep):
    """Every channel kept; the data window grown to the display window (zeros where the
    file had none) unless --keep-data-window."""
    out = tmp_path / "out.exr"
    args = ["apply", stereo, "-o", out] + (["--view", view] if view else []) + (["--keep-data-window"] if keep else [])
    code, text, _ = run(*args)
    assert code == 0, text
    (si, ci), = _read_all(stereo)
    (so, co), = _read_all(out)
    assert sorted(so.channelnames) == sorted(si.channelnames) and len(co) == 19
    assert _formats(so) == _formats(si)                           # half stays half, uint stays uint
    assert (so.x, so.y, so.width, so.height) == ((si.x, si.y, si.width, si.height) if keep else (0, 0, 80, 50))
    assert (so.full_x, so.full_y, so.full_width, so.full_height) == (0, 0, 80, 50)
    assert tuple(so.getattribute("multiView")) == ("left", "right")
    assert so.getattribute("compression") == "piz" and so.getattribute("studio:shot") == "bb010"
    # by default every view is fogged; --view one of them
    changed = {p + c for p in {None: ("", "right."), "left": ("",), "right": ("right.",)}[view] for c in "RGB"}
    for n in ci:
        inside = _inside(co[n], so, si)
        if n in changed:
            assert np.abs(inside - ci[n]).max() > 1e-3, n         # fogged
        else:
            np.testing.assert_array_equal(inside, ci[n], err_msg=n)  # copied bit for bit
            assert np.count_nonzero(co[n]) == np.count_nonzero(ci[n]), n     # nothing where it had no data
    mask = NAMES.index("whitebarmask.mask")
    raw = [_uint_channel(f, "whitebarmask.mask") for f in (stereo, out)]
    np.testing.assert_array_equal(raw[0], _inside(raw[1], so, si))     # ids beyond float32's integers survive
    assert raw[0].min() > 2 ** 24 and mask >= 0


def test_every_view_is_fogged_with_its_own_depth(stereo, tmp_path):
    """Issue 41: a stereo pair stays a pair. Each view of the default run is what --view
    gives for it alone (right.Z for the right view: the two depths differ), in one file."""
    outs = {}
    for view in (None, "left", "right"):
        outs[view] = tmp_path / f"out_{view}.exr"
        code, text, _ = run("apply", stereo, "-o", outs[view], *(["--view", view] if view else []),
                            "--aov", "transmittance")
        assert code == 0, text
        assert "view" not in text, text                     # nothing to warn about
    (_, both), = _read_all(outs[None])
    (_, left), = _read_all(outs["left"])
    (_, right), = _read_all(outs["right"])
    for c in ("R", "G", "B", "transmittance.R"):
        np.testing.assert_array_equal(both[c], left[c], err_msg=c)
        np.testing.assert_array_equal(both["right." + c], right["right." + c], err_msg=c)
    assert np.abs(both["right.transmittance.R"] - both["transmittance.R"]).max() > 0.05   # its own depth


def test_a_view_without_depth_is_named(tmp_path):
    import OpenImageIO as oiio

    names = [n for n in NAMES if n != "right.Z"]
    p = tmp_path / "nodepth.exr"
    spec = _spec(names, _fmt)
    spec.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
    out = oiio.ImageOutput.create(str(p))
    assert out.open(str(p), spec) and out.write_image(_data(names))
    out.close()
    o = tmp_path / "o.exr"
    code, text, _ = run("apply", p, "-o", o, "--keep-data-window")
    assert code == 0, text
    assert "view right has no depth channel of its own (right.Z); copied unfogged" in text
    (_, ci), = _read_all(p)
    (_, co), = _read_all(o)
    np.testing.assert_array_equal(co["right.R"], ci["right.R"])
    assert np.abs(co["R"] - ci["R"]).max() > 1e-3
    code, text, _ = run("apply", p, "-o", tmp_path / "o.png")
    assert code == 0 and "views left, right: o.png holds one; fogged left (--view NAME picks another)" in text


def _uint_channel(path, name):
    inp = oiio.ImageInput.open(str(path))
    c = list(inp.spec().channelnames).index(name)
    px = np.asarray(inp.read_image(0, 0, c, c + 1, "uint"))
    inp.close()
    return px


@pytest.mark.parametrize("view", [None, "right"])
def test_multipart_views_and_tiles(tmp_path, view):
    """Two parts (one per view, `view` attributes) and a depth part, tiled (OpenEXR has no
    scanline access to them): --view right replaces the right part's colour, by default
    both views'; everything else is copied."""
    p = tmp_path / "multipart.exr"
    rgbaz = ["R", "G", "B", "A", "Z"]
    specs = []
    for name, view in (("left", "left"), ("right", "right")):
        s = _spec(rgbaz, _fmt)
        s.attribute("name", name)
        s.attribute("view", view)
        specs.append(s)
    sd = _spec(["depth.Z"], lambda n: "float")
    sd.attribute("name", "depth")
    specs.append(sd)
    for s in specs:
        s.tile_width, s.tile_height = 16, 8
    datas = [_data(rgbaz, 1), _data(rgbaz, 2), _data(["depth.Z"], 3) + 10]
    out = oiio.ImageOutput.create(str(p))
    assert out.open(str(p), tuple(specs))
    for i, (s, d) in enumerate(zip(specs, datas)):
        if i:
            assert out.open(str(p), s, "AppendSubimage")
        assert out.write_image(d)
    out.close()
    o = tmp_path / "o.exr"
    code, text, _ = run("apply", p, *(["--view", view] if view else []), "-o", o, "--aov", "transmittance",
                        "--keep-data-window")
    assert code == 0, text
    pin, pout = _read_all(p), _read_all(o)
    fogged = ("left", "right") if view is None else (view,)
    assert [s.getattribute("name") for s, _ in pout] == ["left", "right", "depth"]
    assert [s.getattribute("view") for s, _ in pout] == ["left", "right", None]
    for (si, ci), (so, co) in zip(pin, pout):
        assert (so.x, so.y, so.width, so.height) == (si.x, si.y, si.width, si.height)
        for n in ci:
            assert _formats(so)[n] == _formats(si)[n]
            if si.getattribute("name") in fogged and n in "RGB":
                assert np.abs(co[n] - ci[n]).max() > 1e-3
            else:
                np.testing.assert_array_equal(co[n], ci[n], err_msg=f"{si.getattribute('name')}.{n}")
    assert {"transmittance.R", "transmittance.G", "transmittance.B"} <= set(pout[1][1])   # AOVs join the part read
    assert ("transmittance.R" in pout[0][1]) == (view is None)


def test_drop_channels_and_output_type(stereo, tmp_path):
    o = tmp_path / "o.exr"
    code, text, _ = run("apply", stereo, "-o", o, "--drop-channels", "--set", "output.type=float",
                        "--set", "output.compression=zips")
    assert code == 0, text
    (so, co), = _read_all(o)
    assert list(so.channelnames) == ["R", "G", "B", "A", "Z"]             # the input's depth kept (issue 41)
    assert set(_formats(so).values()) == {"float"} and so.getattribute("compression") == "zips"
    assert so.getattribute("multiView") is None
    assert (so.x, so.y, so.width, so.height) == (0, 0, 80, 50)          # grown to the display window
    (si, ci), = _read_all(stereo)
    np.testing.assert_array_equal(_inside(co["Z"], so, si), ci["Z"])
    assert np.count_nonzero(co["Z"]) == np.count_nonzero(ci["Z"])
    o3 = tmp_path / "o3.exr"
    code, text, _ = run("apply", stereo, "-o", o3, "--drop-channels", "--set", "output.type=half", "--keep-data-window")
    assert code == 0, text
    (s3, c3), = _read_all(o3)
    assert _formats(s3)["Z"] == "float" and _formats(s3)["R"] == "half"   # depth never in half
    np.testing.assert_array_equal(c3["Z"], ci["Z"])
    o2 = tmp_path / "o2.exr"
    code, text, _ = run("apply", stereo, "-o", o2, "--set", "output.type=float")
    assert code == 0, text
    f = _formats(_read_all(o2)[0][0])
    assert f["R"] == "float" and f["right.R"] == "float" and f["right.forward.u"] == "half" and f["whitebarmask.mask"] == "uint"


@pytest.mark.parametrize("names", [["A"], ["Z"], ["depth.Z"], ["A", "Z"]])
def test_exr_without_colour_is_refused(tmp_path, names):
    from helpers import assert_one_line_error, write_img

    p = tmp_path / "nocolour.exr"
    write_img(p, np.full((8, 9, len(names)), 3.0), names)
    assert_one_line_error(*run("apply", p, "--depth", p, "-o", tmp_path / "o.exr")[:2], "no colour channels")


@pytest.mark.parametrize("zfmt", ["half", "float"])
def test_kept_pixels_write_what_a_second_decode_writes(tmp_path, zfmt):
    """A small EXR's channels that fogcli does not replace are kept from the read
    (Frame.pixels) instead of decoded again for the output, and an all-half part is handed to the writer as half: the file is the
    one the strip reader and the writer's own conversion make, beyond-half values included."""
    import dataclasses
    import warnings

    from fogcli.io.exr import write_passthrough
    from fogcli.io.images import read_image

    names = ["R", "G", "B", "A", "Z"]
    src = tmp_path / "in.exr"
    d = _data(names, seed=3)
    out = oiio.ImageOutput.create(str(src))
    assert out.open(str(src), _spec(names, lambda n: zfmt if n == "Z" else "half")) and out.write_image(d)
    out.close()
    frame = read_image(src)
    # R, G, B and A are replaced by fogcli's: only Z is kept
    assert frame.pixels is not None and frame.pixels.shape == (H, W, 1) and frame.kept_channels == (4,)
    rgb = frame.rgb * 1.5
    rgb[0, :3] = [1e5, -1e6, 65519.0]          # beyond half: inf, -inf; the last rounds to the largest half
    files = []
    for kept in (frame.pixels, None):
        f = dataclasses.replace(frame, pixels=kept)
        path = tmp_path / f"out_{kept is None}.exr"
        with warnings.catch_warnings():
            warnings.simplefilter("error")      # no numpy overflow warning on the way
            write_passthrough(path, str(path), [(f, rgb, frame.alpha, {})], "auto", "auto")
        files.append(_read_all(path))
    (spec_a, a), (spec_b, b) = files[0][0], files[1][0]
    assert _formats(spec_a) == _formats(spec_b) == {n: zfmt if n == "Z" else "half" for n in names}
    for n in names:
        assert np.array_equal(a[n], b[n]), n
    assert np.array_equal(a["Z"], d[:, :, 4].astype(np.float16 if zfmt == "half" else np.float32))
    assert a["R"][0, 0] == np.inf and a["G"][0, 0] == -np.inf and a["B"][0, 0] == 65504.0


@pytest.mark.parametrize("layout", ["one part", "a part a view, right first"])
def test_a_stereo_depth_file_gives_each_view_its_depth(tmp_path, layout):
    """--depth naming a stereo depth EXR (Z for the left view, right.Z for the right; or a
    part a view, the right one first): each view of a stereo image without depth takes its
    own, by default and with --view. Planted (the first part's depth for every view): the
    left view was fogged at 40 m."""
    import OpenImageIO as oiio

    rgb_names = ["R", "G", "B", "right.R", "right.G", "right.B"]
    img, dep = tmp_path / "rgb.exr", tmp_path / "depth.exr"
    for path, names, data in ((img, rgb_names, _data(rgb_names, 4)),
                              (dep, ["Z", "right.Z"], np.dstack([np.full((H, W), 5.0), np.full((H, W), 40.0)]))):
        spec = _spec(names, lambda n: "float", window=(0, 0), display=(0, 0, W, H))
        spec.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
        out = oiio.ImageOutput.create(str(path))
        if path == dep and layout != "one part":
            specs = []
            for view, z in (("right", 40.0), ("left", 5.0)):
                sp = _spec(["Z"], lambda n: "float", window=(0, 0), display=(0, 0, W, H))
                sp.attribute("name", view)
                sp.attribute("view", view)
                specs.append((sp, np.full((H, W, 1), z, np.float32)))
            assert out.open(str(path), tuple(sp for sp, _ in specs))
            for k, (sp, z) in enumerate(specs):
                assert (not k or out.open(str(path), sp, "AppendSubimage")) and out.write_image(z)
            out.close()
            continue
        assert out.open(str(path), spec) and out.write_image(np.ascontiguousarray(data, np.float32))
        out.close()
    outs = {}
    for view in (None, "right"):
        outs[view] = tmp_path / f"o_{view}.exr"
        code, text, _ = run("apply", img, "--depth", dep, "-o", outs[view], *(["--view", view] if view else []),
                            "--aov", "transmittance")
        assert code == 0 and "copied unfogged" not in text, text
    (_, both), = _read_all(outs[None])
    (_, right), = _read_all(outs["right"])
    np.testing.assert_array_equal(both["right.R"], right["right.R"])
    # 5 m and 40 m of the default fog: the right view is far more hidden
    assert both["transmittance.G"].mean() > 0.8 and both["right.transmittance.G"].mean() < 0.5


def test_the_eyes_of_a_stereo_pair_share_one_medium(tmp_path):
    """A visibility relative to the scene is the first view's for both eyes: the right
    view, three times as deep, gets the same extinction (-ln T over the depth, pixel by
    pixel), not one of its own median (review of issue 41)."""
    stereo, out = tmp_path / "deep_right.exr", tmp_path / "out.exr"
    data = _data(NAMES)
    data[:, :, NAMES.index("Z")] = 10.0           # planes: the depth as the kernels take it, uncleaned
    data[:, :, NAMES.index("right.Z")] = 30.0
    spec = _spec(NAMES, _fmt)
    spec.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
    f = oiio.ImageOutput.create(str(stereo))
    assert f.open(str(stereo), spec) and f.write_image(data)
    f.close()
    code, text, _ = run("apply", stereo, "-o", out, "--set", "medium.visibility=200%", "--aov", "transmittance",
                        "--keep-data-window")
    assert code == 0, text
    (_, o), = _read_all(out)
    (_, i), = _read_all(stereo)
    left = -np.log(o["transmittance.R"]) / i["Z"]
    right = -np.log(o["right.transmittance.R"]) / i["right.Z"]
    assert left.min() > 0.01           # 200 % of 10 m: the medium is there
    np.testing.assert_allclose(right, left, rtol=2e-3)      # one extinction (its own median's: a third)


def test_a_stereo_pair_is_admitted_with_both_views(tmp_path, monkeypatch):
    """The views of a pair are held together: a limits.memory that one view fits in and the
    pair does not refuses the default run (one line naming the views) and lets --view pass
    (review of issue 41: each view was admitted alone). 640x360: limits.memory starts at 1 MiB."""
    from fogcli.device import memory

    stereo = tmp_path / "pair.exr"
    w, h = 640, 360
    data = np.random.default_rng(1).uniform(0, 1, (h, w, len(NAMES))).astype(np.float32)
    for i, n in enumerate(NAMES):
        data[:, :, i] = 20.0 if n.endswith("Z") else (1.0 if n.endswith("A") else data[:, :, i])
    spec = oiio.ImageSpec(w, h, len(NAMES), "half")
    spec.channelnames = tuple(NAMES)
    spec.channelformats = tuple(oiio.TypeDesc(_fmt(n)) for n in NAMES)
    spec.attribute("multiView", oiio.TypeDesc("string[2]"), ("left", "right"))
    f = oiio.ImageOutput.create(str(stereo))
    assert f.open(str(stereo), spec) and f.write_image(data)
    f.close()

    seen = []
    real = memory.admit
    monkeypatch.setattr(memory, "admit", lambda *a, **k: (seen.append((a, k)), real(*a, **k))[1])
    assert run("apply", stereo, "-o", tmp_path / "one.exr", "--view", "left")[0] == 0
    (src, w, h, ch, size), kw = seen[0]
    one = memory.estimate(w, h, ch, size, kw["cfg"], kw["aovs"])
    pair = one + w * h * (ch * (size + 4) + memory.HOST_BYTES_PER_PIXEL)
    limit = (one + pair) // 2
    code, text, _ = run("apply", stereo, "-o", tmp_path / "two.exr", "--set", f"limits.memory={limit}")
    assert_one_line_error(code, text, "(2 views) needs about")
    assert not (tmp_path / "two.exr").exists()
    code, text, _ = run("apply", stereo, "-o", tmp_path / "left.exr", "--view", "left", "--set", f"limits.memory={limit}")
    assert code == 0, text
