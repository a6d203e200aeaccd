"""The tune page in a real browser (Debian's headless Chromium): load it, drag a slider and
see previews then the full frame change, place a light by clicking the image, save, and
run the printed `fogcli apply`: its frame is the page's, bit for bit. Ctrl-C ends the
server, nothing left behind."""
from __future__ import annotations

import shlex
import shutil
import subprocess
import sys

import numpy as np
import pytest

from helpers import SAMPLE, read
from tune_browser import MEAN_OF, Server, browser, count, wait


@pytest.fixture
def page(tmp_path):
    shutil.copy(SAMPLE, tmp_path / "harbour.exr")
    drv = browser()         # first: without Chromium the error left the server running
    server = None
    try:
        server = Server(tmp_path / "harbour.exr")
        drv.get(server.url)
        wait(drv, "return document.body.dataset.ready && +document.getElementById('after').dataset.full >= 1",
             what="the first full-size frame")
        yield drv, server, tmp_path
    finally:
        drv.quit()
        if server is not None:
            code, out, err = server.stop()
            assert code == 0, err[-2000:]


def test_slider_light_save_reproduce(page):
    drv, server, tmp = page
    from selenium.webdriver.common.action_chains import ActionChains

    mean0 = drv.execute_script(MEAN_OF, "after")
    full0 = count(drv, "full")
    slider = drv.find_element("id", "visibility")
    held = ActionChains(drv).click_and_hold(slider)     # thicker: a shorter visibility, the mouse still down
    for _ in range(4):
        held = held.move_by_offset(-25, 0).pause(0.05)
    held.perform()
    wait(drv, "const a = document.getElementById('after'); return +a.dataset.preview >= 1 && a.dataset.size == 'preview'",
         what="a preview while the slider is held")
    assert count(drv, "full") == full0, "a full-size frame before the slider was let go"
    mean_held = drv.execute_script(MEAN_OF, "after")
    assert abs(mean_held - mean0) > 2.0, (mean0, mean_held)     # 8-bit levels: the preview shows the change
    ActionChains(drv).release().perform()
    wait(drv, f"return +document.getElementById('after').dataset.full > {full0}", what="the full frame on release")
    mean1 = drv.execute_script(MEAN_OF, "after")
    assert abs(mean1 - mean0) > 2.0, (mean0, mean1)
    # the preview was that frame, reduced: the same config, not the input nor the old frame
    assert abs(mean_held - mean1) < 0.25 * abs(mean1 - mean0), (mean0, mean_held, mean1)

    # a density primitive and the medium's colour: the frame follows, no error (the patches are
    # taken off again before the light: a light in a noise medium costs seconds a frame)
    for step in ("noise-on", "abs-2", "noise-on"):       # noise patches on, a colour, patches off
        full = count(drv, "full")
        if step == "abs-2":
            drv.find_element("tag name", "summary").click()
            field = drv.find_element("id", step)
            field.clear()
            field.send_keys("0.02\n")
        else:
            drv.find_element("id", step).click()
        wait(drv, f"return +document.getElementById('after').dataset.full > {full}", what=f"the frame after {step}")
        assert drv.find_element("id", "status").get_attribute("class") != "error", drv.find_element("id", "status").text

    mean_before_light = drv.execute_script(MEAN_OF, "after")
    full1 = count(drv, "full")
    drv.find_element("id", "place-light").click()
    img = drv.find_element("id", "after")
    ActionChains(drv).move_to_element_with_offset(img, 60, -40).click().perform()
    wait(drv, "return document.querySelectorAll('#lights li').length == 1", what="the light in the list")
    wait(drv, f"return +document.getElementById('after').dataset.full > {full1}", what="the frame with the light")
    mean2 = drv.execute_script(MEAN_OF, "after")
    assert mean2 > mean_before_light + 0.2, (mean_before_light, mean2)      # a light adds its glow

    drv.find_element("id", "save").click()
    text = wait(drv, "const t = document.getElementById('command').textContent; return t.includes('fogcli apply') && t",
                what="the saved command")
    command = text.strip().splitlines()[-1]
    saved_yaml, saved_out = tmp / "harbour.tune.yaml", tmp / "harbour.fog.exr"
    assert saved_yaml.is_file() and saved_out.is_file()
    saved = saved_yaml.read_text()
    assert all(k in saved for k in ("lights:", "visibility:", "absorption:", "density:")), saved
    args = shlex.split(command)
    args[args.index("-o") + 1] = str(tmp / "again.exr")
    r = subprocess.run([sys.executable, "-m", "fogcli", *args[1:]], capture_output=True, text=True, cwd=tmp)
    assert r.returncode == 0, r.stderr
    errors = [e["message"] for e in drv.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == [], errors            # no script error, no refused request, on the way
    _, a = read(saved_out)
    _, b = read(tmp / "again.exr")
    assert np.array_equal(a, b), np.abs(a - b).max()
