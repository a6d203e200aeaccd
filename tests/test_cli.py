"""The command line: outputs, formats, metadata, and every bad input as exit 2 with one
line and no traceback. Runs through click's runner and, once, a real subprocess."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from helpers import SAMPLE, assert_one_line_error, read, run, write_img
from fogcli.io.colour import linear_to_srgb


@pytest.fixture
def rgbz(tmp_path):
    rng = np.random.default_rng(0)
    h, w = 45, 61
    rgb = rng.uniform(0, 1, (h, w, 3)).astype(np.float32)
    rgb[10, 10] = 300.0
    z = rng.uniform(5, 200, (h, w)).astype(np.float32)
    z[:5] = np.inf
    p = tmp_path / "in.exr"
    write_img(p, np.dstack([rgb, z]), ["R", "G", "B", "Z"])
    return p, rgb, z


def test_apply_exr_with_embedded_z_and_timings(rgbz, tmp_path):
    p, rgb, z = rgbz
    out = tmp_path / "out.exr"
    code, text, _ = run("apply", p, "-o", out, "--medium", "fog", "--timings")
    assert code == 0, text
    spec, px = read(out)
    assert spec.channelnames == ("R", "G", "B", "Z")      # the input's Z passed through
    assert np.isfinite(px[:, :, :3]).all() and px.shape == (45, 61, 4)
    np.testing.assert_array_equal(px[:, :, 3], z)
    assert not np.allclose(px[:, :, :3], rgb)
    t = json.loads(text.strip().splitlines()[-1])
    assert set(t) == {"stages", "kernel_ms", "io_ms", "total_ms", "device", "pixels"}
    assert t["pixels"] == 45 * 61
    assert {"preprocess", "pyramid", "composite", "upload", "download"} <= set(t["stages"])
    assert abs(sum(t["stages"].values()) - t["kernel_ms"]) < 0.01
    assert 0 < t["kernel_ms"] < t["total_ms"]
    assert list(tmp_path.iterdir()) == sorted([p, out]) or set(tmp_path.iterdir()) == {p, out}


def test_aovs_as_exr_channels(rgbz, tmp_path):
    p, rgb, z = rgbz
    out = tmp_path / "aov.exr"
    code, text, _ = run("apply", p, "-o", out, *sum([["--aov", a] for a in
                        ["optical_depth", "transmittance", "spread", "level", "direct", "scattered", "emission"]], []))
    assert code == 0, text
    spec, px = read(out)
    names = list(spec.channelnames)
    for ch in ["optical_depth", "transmittance.R", "spread", "level", "direct.B", "scattered.G", "emission.R"]:
        assert ch in names
    od = px[:, :, names.index("optical_depth")]
    assert od[:5].max() == pytest.approx(1000.0)      # sky clamped at max_depth (fog: density 1)
    total = px[:, :, :3]
    parts = sum(px[:, :, [names.index(f"{k}.{c}") for c in "RGB"]] for k in ("direct", "scattered", "emission"))
    np.testing.assert_allclose(total, parts, rtol=1e-4, atol=1e-6)


def test_windows_alpha_metadata_and_half(tmp_path):
    rng = np.random.default_rng(1)
    h, w = 20, 30
    data = np.dstack([rng.uniform(0, 1, (h, w, 3)), rng.uniform(0, 1, (h, w)), rng.uniform(2, 50, (h, w))])
    p = tmp_path / "win.exr"
    write_img(p, data, ["R", "G", "B", "A", "Z"], window=(5, 7), display=(0, 0, 64, 48),
              attrs=[("studio:shot", "sh010"), ("Copyright", "vfx")])
    out = tmp_path / "win_out.exr"
    code, text, _ = run("apply", p, "-o", out, "--set", "output.type=half", "--set", "camera.empty_depth=0",
                        "--keep-data-window")      # tests/test_data_window.py: the grown window
    assert code == 0, text
    spec, px = read(out)
    assert (spec.x, spec.y, spec.width, spec.height) == (5, 7, w, h)
    assert (spec.full_x, spec.full_y, spec.full_width, spec.full_height) == (0, 0, 64, 48)
    assert spec.getattribute("studio:shot") == "sh010" and spec.getattribute("Copyright") == "vfx"
    fmts = dict(zip(spec.channelnames, map(str, spec.channelformats)))
    assert fmts == {"R": "half", "G": "half", "B": "half", "A": "half", "Z": "float"}   # Z copied exactly
    a = px[:, :, list(spec.channelnames).index("A")]
    np.testing.assert_allclose(a, data[:, :, 3], atol=1e-3)    # nothing in front of the plate; half
    assert spec.getattribute("compression") == "zip"
    out2 = tmp_path / "piz.exr"
    assert run("apply", p, "-o", out2, "--set", "output.compression=piz", "--keep-data-window")[0] == 0
    spec2, px2 = read(out2)
    assert spec2.getattribute("compression") == "piz"
    np.testing.assert_allclose(px2[:, :, :3], read(tmp_path / "win_out.exr")[1][:, :, :3], atol=2e-2)
    code, text, _ = run("apply", p, "-o", out2, "--set", "output.compression=lzma")
    assert code == 2 and "output.compression: expected one of" in text


@pytest.mark.parametrize("kind", ["exr", "tif", "png16", "npy"])
def test_separate_depth_files(rgbz, tmp_path, kind):
    p, rgb, z = rgbz
    img = tmp_path / "rgb.exr"
    write_img(img, rgb, ["R", "G", "B"])
    zf = np.where(np.isfinite(z), z, 0).astype(np.float32)   # 0 = hole, filled
    ref_out = tmp_path / "ref.exr"
    d_exr = tmp_path / "d.exr"
    write_img(d_exr, zf[:, :, None], ["Z"])
    # png16 holds centimetres: on this depth of random values every pixel is an edge, and
    # a centimetre flips some pixels' normal choices (one-sided steps, isolated pixels; a
    # 0.5 % change at 2 of 2745 pixels): the decoding is compared without normals
    profile = ["--set", "render.emission_profile=isotropic"] if kind == "png16" else []
    assert run("apply", img, "--depth", d_exr, "-o", ref_out, *profile)[0] == 0
    extra = list(profile)
    if kind == "exr":
        d = d_exr
    elif kind == "tif":
        d = tmp_path / "d.tif"
        write_img(d, zf[:, :, None], ["Y"])
    elif kind == "png16":
        d = tmp_path / "d.png"
        write_img(d, np.round(zf * 100)[:, :, None].astype(np.uint16), ["Y"], fmt="uint16")
        extra += ["--set", "camera.depth_scale=0.01"]
    else:
        d = tmp_path / "d.npy"
        np.save(d, zf)
    out = tmp_path / f"o_{kind}.exr"
    code, text, _ = run("apply", img, "--depth", d, "-o", out, *extra)
    assert code == 0, text
    assert "invalid depth pixel" in text            # the zero rows were holes
    tol = 2e-3 if kind == "png16" else 1e-6
    np.testing.assert_allclose(read(out)[1], read(ref_out)[1], rtol=tol, atol=tol)


def test_srgb_png_in_and_out(tmp_path):
    """8/16-bit inputs are sRGB: decoded to linear before physics (with no medium the
    output equals the decoded input), and PNG output is sRGB with exposure."""
    rng = np.random.default_rng(2)
    lin = rng.uniform(0, 1, (16, 24, 3)).astype(np.float32)
    png = tmp_path / "in.png"
    write_img(png, np.round(linear_to_srgb(lin) * 65535).astype(np.uint16), ["R", "G", "B"], fmt="uint16")
    d = tmp_path / "d.npy"
    np.save(d, np.full((16, 24), 10.0, np.float32))
    out = tmp_path / "o.exr"
    code, text, _ = run("apply", png, "--depth", d, "-o", out, "--set", "medium.visibility=1e9")
    assert code == 0, text
    np.testing.assert_allclose(read(out)[1], lin, atol=1e-3)
    out_png = tmp_path / "o.png"
    code, text, _ = run("apply", png, "--depth", d, "-o", out_png, "--set", "medium.visibility=1e9",
                        "--set", "output.exposure=-1")
    assert code == 0, text
    spec, px = read(out_png)
    assert str(spec.format) == "uint8"
    np.testing.assert_allclose(px, linear_to_srgb(lin * 0.5), atol=1 / 255 + 1e-3)


def test_nan_depth_is_filled_and_counted(rgbz, tmp_path):
    p, rgb, z = rgbz
    z2 = z.copy()
    z2[20:23, 30:33] = np.nan
    z2[0, 0] = -1
    q = tmp_path / "holes.exr"
    write_img(q, np.dstack([rgb, z2]), ["R", "G", "B", "Z"])
    code, text, _ = run("apply", q, "-o", tmp_path / "o.exr")
    assert code == 0
    assert "10 invalid depth pixel(s)" in text
    spec, px = read(tmp_path / "o.exr")
    assert np.isfinite(px[:, :, :3]).all()
    np.testing.assert_array_equal(px[:, :, 3], z2)      # the file's Z is copied, not the filled one


def test_bad_inputs_exit_2_with_one_line(rgbz, tmp_path):
    p, rgb, z = rgbz
    out = tmp_path / "o.exr"
    assert_one_line_error(*run("apply", tmp_path / "nope.exr", "-o", out)[:2], "nope.exr: file not found")
    junk = tmp_path / "junk.exr"
    junk.write_text("not an exr")
    assert_one_line_error(*run("apply", junk, "-o", out)[:2], "junk.exr")
    trunc = tmp_path / "trunc.exr"
    trunc.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    assert_one_line_error(*run("apply", trunc, "-o", out)[:2], "trunc.exr")
    small = tmp_path / "small.npy"
    np.save(small, np.ones((10, 10), np.float32))
    assert_one_line_error(*run("apply", p, "--depth", small, "-o", out)[:2], "must match")
    colour = tmp_path / "colour.exr"
    write_img(colour, np.random.default_rng(0).uniform(0, 1, (45, 61, 3)), ["R", "G", "B"])
    assert_one_line_error(*run("apply", p, "--depth", colour, "-o", out)[:2], "no usable depth channel")
    assert_one_line_error(*run("apply", colour, "-o", out)[:2], "no depth channel")
    zero = tmp_path / "zero.npy"
    np.save(zero, np.zeros((45, 61), np.float32))
    assert_one_line_error(*run("apply", p, "--depth", zero, "-o", out)[:2], "no valid pixel")
    cfg = tmp_path / "c.yaml"
    cfg.write_text("render:\n  levels: 3\n  kernal: 4\n")
    assert_one_line_error(*run("apply", p, "--config", cfg, "-o", out)[:2], "c.yaml:3: render.kernal")
    assert_one_line_error(*run("apply", p, "--medium", "fogg", "-o", out)[:2], "no such preset")
    assert_one_line_error(*run("apply", p, "-o", p)[:2], "refusing to overwrite an input")
    assert_one_line_error(*run("apply", p, "-o", tmp_path / "o.bmp")[:2], "unsupported output format")
    assert not out.exists()
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted(
        ["in.exr", "junk.exr", "trunc.exr", "small.npy", "colour.exr", "zero.npy", "c.yaml"])


def test_output_replaced_atomically_and_input_untouched(rgbz, tmp_path):
    p, rgb, z = rgbz
    before = p.read_bytes()
    out = tmp_path / "o.exr"
    out.write_text("old")
    assert run("apply", p, "-o", out)[0] == 0
    assert p.read_bytes() == before
    assert read(out)[1].shape == (45, 61, 4)
    assert not [f for f in tmp_path.iterdir() if ".tmp" in f.name]
    mask = os.umask(0)
    os.umask(mask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~mask     # not mkstemp's 0600


def test_devices_media_check(tmp_path):
    code, text, _ = run("devices")
    assert code == 0 and "default:" in text and "0:0" in text
    code, text, _ = run("media")
    assert code == 0 and all(n in text for n in ("fog", "haze", "sea", "harbour", "smoke"))
    good = tmp_path / "g.yaml"
    good.write_text("medium:\n  visibility: 80\n  albedo: 0.9\n")
    bad = tmp_path / "b.yaml"
    bad.write_text("medium:\n  visibility: -3\ncamera:\n  depth: zz\n")
    code, text, _ = run("check", good)
    assert code == 0 and "ok" in text
    code, text, _ = run("check", good, bad)
    assert code == 2 and "b.yaml:2: medium.visibility" in text and "b.yaml:4: camera.depth" in text
    assert "Traceback" not in text


def test_methods_run_through_the_same_command(rgbz, tmp_path):
    p, rgb, z = rgbz
    outs = {}
    for m in ("pyramid", "naive", "reference"):
        o = tmp_path / f"{m}.exr"
        assert run("apply", p, "-o", o, "--set", f"render.method={m}")[0] == 0
        outs[m] = read(o)[1]
    assert not np.allclose(outs["pyramid"], outs["naive"])
    assert not np.allclose(outs["pyramid"], outs["reference"])


def test_real_subprocess_on_the_sample(tmp_path):
    out = tmp_path / "harbour_fog.png"
    env = dict(os.environ, FOGCLI_DEVICE="cpu")
    r = subprocess.run([sys.executable, "-m", "fogcli", "apply", str(SAMPLE), "--medium", "sea",
                        "-o", str(out), "--timings"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    t = json.loads(r.stderr.strip().splitlines()[-1])
    assert t["pixels"] == 640 * 360
    spec, px = read(out)
    assert (spec.width, spec.height) == (640, 360) and px.std() > 0.01
    r = subprocess.run([sys.executable, "-m", "fogcli", "apply", str(tmp_path / "missing.exr")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_device_choice(rgbz, tmp_path, monkeypatch):
    p, rgb, z = rgbz
    code, text, _ = run("apply", p, "-o", tmp_path / "o.exr", "--device", "no-such-thing")
    assert_one_line_error(code, text, "--device 'no-such-thing': no such OpenCL device")
    assert run("apply", p, "-o", tmp_path / "o.exr", "--device", "0:0")[0] == 0
    from fogcli.device import runtime

    monkeypatch.setenv("FOGCLI_DEVICE", "nope")
    with pytest.raises(runtime.UserError, match="FOGCLI_DEVICE 'nope'"):
        runtime.Runtime(None)


def test_output_targets_refused_or_written_whole(rgbz, tmp_path, monkeypatch):
    """-o onto a folder: exit 2; a 240-character name works (its temporary name is short); a
    full disk: one line, exit 1, nothing left behind (display formats are encoded in memory
    and written by Python, which sees ENOSPC)."""
    import errno

    from fogcli.io import outputs

    p, rgb, z = rgbz
    assert_one_line_error(*run("apply", p, "-o", tmp_path)[:2], "is a folder")
    (tmp_path / "dir.png").mkdir()
    assert_one_line_error(*run("apply", p, "-o", tmp_path / "dir.png")[:2], "is a folder")
    long = tmp_path / ("x" * 236 + ".png")
    code, text, _ = run("apply", p, "-o", long)
    assert code == 0 and long.exists(), text

    def full(tmp, buf):
        open(tmp, "wb").write(bytes(buf)[:100])
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(outputs, "_write_bytes", full)
    before = set(tmp_path.iterdir())
    for ext in ("png", "jpg", "tif"):
        code, text, _ = run("apply", p, "-o", tmp_path / f"full.{ext}")
        assert code == 1 and "No space left on device" in text and len(text.strip().splitlines()) == 1, text
    assert set(tmp_path.iterdir()) == before


def test_frame_larger_than_limits_memory_is_refused_from_its_header(rgbz, tmp_path, monkeypatch):
    from fogcli.device import memory

    p, rgb, z = rgbz
    monkeypatch.setattr(memory, "available_bytes", lambda: 100_000)     # auto: 60 % of it
    assert_one_line_error(*run("apply", p, "-o", tmp_path / "o.exr")[:2],
                          "more than limits.memory allows (0.00 GiB: auto, 60% of the memory available)")
    monkeypatch.setattr(memory, "available_bytes", lambda: 2**40)
    big = tmp_path / "big.exr"          # 600 x 400: some 30 MB
    write_img(big, np.ones((400, 600, 4), np.float32), ["R", "G", "B", "Z"])
    assert_one_line_error(*run("apply", big, "-o", tmp_path / "o.exr", "--set", "limits.memory=10MB")[:2],
                          "big.exr: 600x400 needs about 0.03 GiB of memory, more than limits.memory allows (0.01 GiB)")
    assert sorted(f.name for f in tmp_path.iterdir()) == ["big.exr", "in.exr"]
    code, _, _ = run("apply", p, "-o", tmp_path / "o.exr", "--set", "limits.memory=50%")
    assert code == 0


@pytest.mark.parametrize("wrapped", ["cause", "schema"])
def test_a_ctrl_c_another_library_wrapped_is_an_interruption(wrapped, capsys):
    """A Ctrl-C while pydantic builds the config's validators (the models' first import) comes
    back as a SchemaError holding only its text; one under another exception as its cause.
    Either is "interrupted", exit 130, not "processing failed" (seen under a loaded CI)."""
    from pydantic_core import SchemaError

    from fogcli.cli import guarded

    def command():
        if wrapped == "schema":
            raise SchemaError('Error building "function-after" validator:\n  KeyboardInterrupt: ')
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise RuntimeError("while loading") from exc

    with pytest.raises(SystemExit) as stop:
        guarded(command)()
    assert stop.value.code == 130
    assert capsys.readouterr().err.strip() == "fogcli: interrupted"
