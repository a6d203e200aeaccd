"""fogcli tune without a browser: the page's guards (token, Host, Origin, no path from the
page), the saved YAML, and Save's frame against `fogcli apply` with the printed command.
The page in a real browser: tests/test_tune_browser.py."""
from __future__ import annotations

import asyncio
import json
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from helpers import SAMPLE, read

from fogcli.tune.page_app import PageApp
from fogcli.tune.saved_yaml import commented_yaml, prune
from fogcli.tune.session import Session

TOKEN, PORT = "t0ken-abc", 8765
HOST = f"127.0.0.1:{PORT}"


def call(app, method, path, query="", headers=None, body=b""):
    """One request through the ASGI app: (status, body)."""
    hdr = {"host": HOST, **(headers or {})}
    scope = {"type": "http", "method": method, "path": path, "query_string": query.encode(),
             "headers": [(k.encode(), v.encode()) for k, v in hdr.items() if v is not None]}
    got = {}

    async def receive():
        return {"type": "http.request", "body": body, "more_body": False}

    async def send(msg):
        if msg["type"] == "http.response.start":
            got["status"] = msg["status"]
            got["headers"] = dict(msg["headers"])
        else:
            got["body"] = msg["body"]

    asyncio.run(app(scope, receive, send))
    return got["status"], got["body"]


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("tune")
    shutil.copy(SAMPLE, d / "harbour.exr")
    return Session(str(d / "harbour.exr"))


@pytest.fixture(scope="module")
def app(session):
    a = PageApp(session, TOKEN, PORT, echo=lambda m: None)
    yield a
    a.pool.shutdown()


def test_the_page_and_its_api_answer_with_the_token(app):
    status, body = call(app, "GET", "/", f"token={TOKEN}")
    assert status == 200 and b"fogcli tune" in body and f"tune.js?token={TOKEN}".encode() in body
    status, body = call(app, "GET", "/api/state", headers={"x-fogcli-token": TOKEN})
    assert status == 200 and json.loads(body)["width"] == 640


@pytest.mark.parametrize("why, query, headers", [
    ("no token", "", {}),
    ("a wrong token", "token=t0ken-abd", {}),
    ("a foreign Host (DNS rebinding)", f"token={TOKEN}", {"host": f"evil.example:{PORT}"}),
    ("another port's Host", f"token={TOKEN}", {"host": "127.0.0.1:8766"}),
    ("a foreign Origin", f"token={TOKEN}", {"origin": "http://evil.example"}),
    ("a cross-site fetch", f"token={TOKEN}", {"sec-fetch-site": "cross-site"}),
])
def test_a_request_is_refused(app, why, query, headers):
    for path in ("/", "/api/state", "/tune.js"):
        status, body = call(app, "GET", path, query, headers)
        assert status == 403 and body.startswith(b"refused"), (why, path, status)


def test_a_post_needs_the_token_in_a_header_not_in_the_address(app):
    """A form or an image on another site can put the token in an address it learnt, not
    in a header (that needs a CORS preflight, which this server never grants)."""
    body = json.dumps({"overrides": {}}).encode()
    assert call(app, "POST", "/api/render", f"token={TOKEN}", body=body)[0] == 403
    assert call(app, "POST", "/api/render", headers={"x-fogcli-token": TOKEN, "origin": f"http://{HOST}"},
                body=body)[0] == 200


@pytest.mark.parametrize("method, path, query, body", [
    ("GET", "/../../etc/passwd", "", b""),
    ("GET", "/page/tune.html", "", b""),
    ("GET", "/api/image", "which=../../etc/passwd", b""),
    ("GET", "/api/image", "which=/etc/passwd", b""),
    ("POST", "/api/save", "", json.dumps({"overrides": {"output": {"type": "float"}}}).encode()),
    ("POST", "/api/save", "", json.dumps({"overrides": {"camera": {"fov": 40}}}).encode()),
    ("POST", "/api/preset", "", json.dumps({"name": "/etc/passwd"}).encode()),
    ("POST", "/api/preset", "", json.dumps({"name": "../media/fog"}).encode()),
])
def test_no_path_reaches_a_file(app, session, method, path, query, body):
    """The page names no file: unknown paths are 404, values that look like paths are
    refused (400), sections other than the look's (output, camera) are refused."""
    before = sorted(p.name for p in session.image.parent.iterdir())
    status, out = call(app, method, path, query, {"x-fogcli-token": TOKEN}, body)
    assert status in (400, 404), (path, status, out[:200])
    assert b"root:" not in out
    assert sorted(p.name for p in session.image.parent.iterdir()) == before


def test_the_saved_yaml_holds_what_differs_from_the_preset_and_reads_back():
    base = {"medium": {"visibility": 150, "albedo": 0.999, "asymmetry": 0.85}}
    page = {"medium": {"visibility": "300%", "albedo": 0.999, "asymmetry": 0.7},
            "lights": [{"type": "point", "position": [1.0, 2.0, -3.0], "intensity": [5.0, 5.0, 5.0]}]}
    kept = prune(page, base)
    assert kept == {"medium": {"visibility": "300%", "asymmetry": 0.7}, "lights": page["lights"]}
    text = commented_yaml(kept, "fog", "shot.exr")
    assert yaml.safe_load(text) == kept
    assert "# g of the Henyey-Greenstein phase function" in text       # the model's description as a comment


def _apply_as_printed(command: str, out: Path) -> int:
    args = shlex.split(command)
    assert args[:2] == ["fogcli", "apply"]
    args[args.index("-o") + 1] = str(out)
    return subprocess.run([sys.executable, "-m", "fogcli", *args[1:]], capture_output=True, text=True).returncode


def test_save_writes_the_frame_that_the_printed_command_makes(session, tmp_path):
    """Bit for bit: the page's full-size frame (rendered from the page's config) is what
    `fogcli apply` makes with the saved YAML (read from the file)."""
    light = session.light_at(420, 150)
    page = {"medium": {"visibility": "250%", "asymmetry": 0.7, "ambient": [0.01, 0.012, 0.02]},
            "render": {"border": "closed"}, "lights": [light]}
    session.render(page, "full")
    saved = session.save(page)
    assert Path(saved["yaml"]).is_file() and Path(saved["output"]).is_file()
    assert _apply_as_printed(saved["command"], tmp_path / "again.exr") == 0
    spec_a, a = read(saved["output"])
    spec_b, b = read(tmp_path / "again.exr")
    assert spec_a.channelnames == spec_b.channelnames
    assert np.array_equal(a, b)
    # and the frame differs from the preset's: the page's config is in it
    _, plain = read(SAMPLE)
    assert np.abs(a[:, :, :3] - plain[:, :, :3]).mean() > 0.01


def test_a_save_that_cannot_write_is_one_line_on_the_page(session, app, monkeypatch):
    """A full disk or a read-only folder on Save: the page gets the reason (500, JSON),
    the terminal one line, and the server goes on."""
    said = []
    monkeypatch.setattr(app, "echo", said.append)

    def full_disk(*a, **k):
        raise OSError(28, "No space left on device", str(session.yaml_path))

    monkeypatch.setattr("fogcli.tune.session.outputs.atomic_write", full_disk)
    status, body = call(app, "POST", "/api/save", headers={"x-fogcli-token": TOKEN},
                        body=json.dumps({"overrides": {}}).encode())
    assert status == 500 and "No space left on device" in json.loads(body)["error"]
    assert len(said) == 1 and "Traceback" not in said[0]
    assert call(app, "GET", "/api/state", headers={"x-fogcli-token": TOKEN})[0] == 200


def test_an_rgbd_photo_with_a_set_key_saves_what_apply_makes(tmp_path):
    """An 8-bit photo with a 16-bit depth in millimetres (--set camera.depth_scale): the
    key goes into the saved YAML, and the PNG Save writes is apply's, byte for byte."""
    import cv2

    rng = np.random.default_rng(4)
    rgb = (rng.uniform(0.1, 0.9, (60, 80, 3)) * 255).astype(np.uint8)
    depth = np.tile(np.linspace(1500, 6000, 80, dtype=np.float32), (60, 1)).astype(np.uint16)
    cv2.imwrite(str(tmp_path / "photo.png"), rgb)
    cv2.imwrite(str(tmp_path / "photo_depth.png"), depth)
    s = Session(str(tmp_path / "photo.png"), str(tmp_path / "photo_depth.png"), "haze",
                sets=("camera.depth_scale=0.001",))
    assert 3.0 < s.median < 4.5                       # metres: the key was used
    saved = s.save({"medium": {"visibility": "100%"}})
    assert "depth_scale: 0.001" in Path(saved["yaml"]).read_text()
    assert Path(saved["output"]).suffix == ".png"
    assert _apply_as_printed(saved["command"], tmp_path / "again.png") == 0
    assert (tmp_path / "again.png").read_bytes() == Path(saved["output"]).read_bytes()


@pytest.mark.parametrize("args, needle", [
    (["missing.exr"], "missing.exr"),
    ([str(SAMPLE), "--set", "camera.depth_scale="], "empty value"),
    ([str(SAMPLE), "--medium", "nope"], "no such preset"),
])
def test_tune_refuses_bad_input_in_one_line(args, needle):
    from helpers import assert_one_line_error, run

    code, out, _ = run("tune", *args, "--no-browser")
    assert_one_line_error(code, out, needle)


def test_a_port_in_use_is_one_line():
    import socket

    from helpers import assert_one_line_error, run

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        code, out, _ = run("tune", SAMPLE, "--no-browser", "--port", taken.getsockname()[1])
    assert_one_line_error(code, out, "cannot listen on 127.0.0.1")


def test_without_the_tune_extra_it_says_what_to_install_before_reading(monkeypatch):
    import fogcli.tune.session as session_mod
    from helpers import assert_one_line_error, run

    monkeypatch.setitem(sys.modules, "uvicorn", None)          # not installed: import fails
    monkeypatch.setattr(session_mod, "Session", lambda *a, **k: pytest.fail("the image was read first"))
    code, out, _ = run("tune", SAMPLE, "--no-browser")
    assert_one_line_error(code, out, "pip install 'fogcli[tune]'")
