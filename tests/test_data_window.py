"""An EXR whose data window is a part of its display window (an element's bounding box;
issue 41): the light the medium scatters past the data window lands in the display window,
as a compositor grows a blur's bounding box, and the camera is the display window's."""
import numpy as np
import pytest

from helpers import read, run, write_img

DISPLAY = (0, 0, 160, 100)
WINDOW = (50, 30, 70, 40)           # x, y, width, height: inside the display window


def _element(alpha=True):
    """A dark wall at 20 m with a bright lamp near the window's right edge."""
    x, y, w, h = WINDOW
    rgb = np.full((h, w, 3), 0.02, np.float32)
    rgb[18:22, 62:66] = 400.0
    z = np.full((h, w), 20.0, np.float32)
    planes = [rgb, np.ones((h, w, 1), np.float32)] if alpha else [rgb]
    return np.concatenate(planes + [z[:, :, None]], 2), (["R", "G", "B", "A", "Z"] if alpha else ["R", "G", "B", "Z"])


def _outside(px, spec):
    """The output's light outside the input's data window (summed RGB) and inside it."""
    x, y, w, h = WINDOW
    ox, oy = spec.x, spec.y
    m = np.ones(px.shape[:2], bool)
    m[y - oy:y - oy + h, x - ox:x - ox + w] = False
    return float(px[m][:, :3].sum()), px[~m][:, :3]


def test_glow_continues_past_the_data_window(tmp_path):
    """The energy outside the old window equals what the same frame gives with its data
    window set to the display window (colour 0, alpha 0, Z 0 there, as `oiiotool
    --croptofull` writes it): issue 41 asks within 10 %."""
    data, names = _element()
    cropped, full = tmp_path / "cropped.exr", tmp_path / "full.exr"
    write_img(cropped, data, names, window=WINDOW[:2], display=DISPLAY)
    x, y, w, h = WINDOW
    padded = np.zeros((DISPLAY[3], DISPLAY[2], len(names)), np.float32)
    padded[y:y + h, x:x + w] = data
    write_img(full, padded, names, window=(0, 0), display=DISPLAY)
    outs = {}
    for name, src in (("cropped", cropped), ("full", full)):
        o = tmp_path / f"{name}.fog.exr"
        code, text, _ = run("apply", src, "-o", o, "--medium", "fog", "--set", "medium.visibility=60")
        assert code == 0, text
        outs[name] = read(o)
    (sc, pc), (sf, pf) = outs["cropped"], outs["full"]
    assert (sc.x, sc.y, sc.width, sc.height) == (0, 0, 160, 100)
    e_c, in_c = _outside(pc, sc)
    e_f, in_f = _outside(pf, sf)
    assert e_f > 0.05 * float(in_f.sum())          # the glow past the window is not a trace
    assert abs(e_c / e_f - 1.0) < 0.01, (e_c, e_f)
    np.testing.assert_allclose(in_c, in_f, rtol=1e-5, atol=1e-6)
    assert np.all(pc[:, :, 3][_mask(sc)] == 0.0)   # the glow over empty pixels: alpha 0


def _mask(spec):
    x, y, w, h = WINDOW
    m = np.ones((spec.height, spec.width), bool)
    m[y - spec.y:y - spec.y + h, x - spec.x:x - spec.x + w] = False
    return m


def test_keep_data_window_keeps_it_and_its_pixels(tmp_path):
    """--keep-data-window: the input's window, and inside it the pixels the grown output
    has (the camera is the display window's either way)."""
    data, names = _element()
    src = tmp_path / "cropped.exr"
    write_img(src, data, names, window=WINDOW[:2], display=DISPLAY)
    grown, kept = tmp_path / "grown.exr", tmp_path / "kept.exr"
    assert run("apply", src, "-o", grown)[0] == 0
    assert run("apply", src, "-o", kept, "--keep-data-window")[0] == 0
    (_, pg), (sk, pk) = read(grown), read(kept)
    assert (sk.x, sk.y, sk.width, sk.height) == WINDOW
    x, y, w, h = WINDOW
    np.testing.assert_array_equal(pk, pg[y:y + h, x:x + w])


def _peak(tmp_path, window, size, display, extra=()):
    """Where (display pixels) the glow of a point light that the display window's camera
    sees at pixel (120.5, 30.5) of a 160-px-wide display has its peak, and the output's
    data window."""
    (x, y), (w, h) = window, size
    focal = 80 / np.tan(np.radians(30))                  # fov 60 over the display's 160 px
    px, py = 120.5, 30.5
    pos = [float(10 * (px - 80) / focal), float(-10 * (py - 50) / focal), -10.0]
    data = np.concatenate([np.full((h, w, 3), 0.01, np.float32), np.ones((h, w, 1), np.float32),
                           np.full((h, w, 1), 30.0, np.float32)], 2)
    src = tmp_path / "part.exr"
    write_img(src, data, ["R", "G", "B", "A", "Z"], window=(x, y), display=display)
    cfg = tmp_path / "light.yaml"
    cfg.write_text(f"lights:\n  - {{type: point, position: {pos}, intensity: [50, 50, 50]}}\n")
    o = tmp_path / "o.exr"
    code, text, _ = run("apply", src, "-o", o, "--config", cfg, "--set", "camera.fov=60", *extra)
    assert code == 0, text
    spec, out = read(o)
    r, c = np.unravel_index(np.argmax(out[:, :, 1]), out.shape[:2])
    return (spec.x + c + 0.5, spec.y + r + 0.5), (spec.x, spec.y, spec.width, spec.height)


def test_the_camera_is_the_display_windows(tmp_path):
    """A data window off the display window's centre: a point light (camera space) lights
    the medium where the display window's camera sees it. Planted bug (the data window taken
    as the whole frame, fogcli before issue 41): the glow's peak lands 15 px away."""
    (cx, cy), win = _peak(tmp_path, (90, 10), (60, 40), DISPLAY, ["--keep-data-window"])
    assert abs(cx - 120.5) <= 1 and abs(cy - 30.5) <= 1 and win == (90, 10, 60, 40), (cx, cy, win)


def test_overscan_keeps_the_display_windows_camera(tmp_path):
    """A data window larger than the display window (overscan): nothing to grow, and the
    camera is still the display window's (its centre is not the data window's)."""
    (cx, cy), win = _peak(tmp_path, (-20, -30), (200, 140), DISPLAY)
    assert win == (-20, -30, 200, 140) and abs(cx - 120.5) <= 1 and abs(cy - 30.5) <= 1, (cx, cy, win)


def test_a_placeholder_display_window_is_not_the_camera(tmp_path):
    """A display window less than half the data window (a writer's 1x1 placeholder) is
    ignored: the data window is the frame, as for any other image."""
    (cx, cy), win = _peak(tmp_path, (0, 0), (160, 100), (0, 0, 1, 1))
    assert win == (0, 0, 160, 100) and abs(cx - 120.5) <= 1 and abs(cy - 30.5) <= 1, (cx, cy, win)


@pytest.mark.parametrize("fmt", ["exr", "png"])
def test_without_alpha_the_padding_is_empty(tmp_path, fmt):
    """A file without alpha: the padding is empty (not a black wall at its neighbours'
    depth), and the output has no alpha of its own either."""
    data, names = _element(alpha=False)
    src = tmp_path / "noalpha.exr"
    write_img(src, data, names, window=WINDOW[:2], display=DISPLAY)
    o = tmp_path / f"o.{fmt}"
    code, text, _ = run("apply", src, "-o", o, "--set", "medium.visibility=60")
    assert code == 0, text
    spec, px = read(o)
    assert spec.nchannels == (4 if fmt == "exr" else 3)              # R, G, B (+ Z copied) ; no A
    assert "A" not in spec.channelnames
    assert (spec.width, spec.height) == (160, 100)
    e, inside = _outside(px, spec)
    assert e > 0.05 * float(inside.sum())
