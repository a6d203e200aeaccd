"""`fogcli tune` driven in Debian's headless Chromium (selenium and chromium-driver): what
tests/test_tune_browser.py and tools/tune_latency.py share. The server is the command as a
user runs it, in a process of its own."""
from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

CHROMIUM, DRIVER = Path("/usr/bin/chromium"), Path("/usr/bin/chromedriver")
NEEDED = "Debian's chromium and chromium-driver (apt-get install chromium chromium-driver; the README's test command)"


class Server:
    """`fogcli tune IMAGE --no-browser ...` until stop() (Ctrl-C, as a user ends it)."""

    def __init__(self, image: Path, *args: str):
        self.p = subprocess.Popen([sys.executable, "-m", "fogcli", "tune", str(image), "--no-browser", *args],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.p.stdout.readline()
        m = re.search(r"(http://127\.0\.0\.1:(\d+)/\?token=(\S+))", line)
        if not m:
            self.p.kill()
            raise AssertionError(f"no address printed: {line!r} {self.p.stderr.read()[-2000:]}")
        self.url, self.port, self.token = m.group(1), int(m.group(2)), m.group(3)

    def stop(self, timeout: float = 30.0) -> tuple[int, str, str]:
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
        try:
            out, err = self.p.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            out, err = self.p.communicate()
        return self.p.returncode, out, err


def browser(width: int = 1500, height: int = 950):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    missing = [str(p) for p in (CHROMIUM, DRIVER) if not p.exists()]
    if missing:
        raise AssertionError(f"{', '.join(missing)} not found: the page's tests need {NEEDED}")
    opts = webdriver.ChromeOptions()
    opts.binary_location = str(CHROMIUM)
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
              f"--window-size={width},{height}", "--disable-extensions", "--no-first-run"):
        opts.add_argument(a)
    # the driver named: Selenium Manager (which would download one) is not asked
    return webdriver.Chrome(service=Service(str(DRIVER)), options=opts)


def wait(drv, script: str, timeout: float = 60.0, what: str = ""):
    """Until the page's script returns something true; its value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        v = drv.execute_script(script)
        if v:
            return v
        time.sleep(0.05)
    status = drv.execute_script("return document.getElementById('status') && document.getElementById('status').textContent")
    raise AssertionError(f"timed out waiting for {what or script} (page status: {status!r})")


def count(drv, size: str) -> int:
    return int(drv.execute_script(f"return +document.getElementById('after').dataset.{size} || 0"))


MEAN_OF = """
const img = document.getElementById(arguments[0]);
const c = document.createElement('canvas'); c.width = img.naturalWidth; c.height = img.naturalHeight;
const g = c.getContext('2d'); g.drawImage(img, 0, 0);
const d = g.getImageData(0, 0, c.width, c.height).data; let s = 0;
for (let i = 0; i < d.length; i += 4) s += d[i] + d[i + 1] + d[i + 2];
return s / (d.length / 4 * 3);
"""


def drag(drv, element_id: str, steps: list[int], pause: float = 0.05) -> None:
    """Hold a slider's thumb and move it by these pixel steps, then let go: the page sees
    input events as it moves and a change on release, as from a mouse."""
    from selenium.webdriver.common.action_chains import ActionChains

    el = drv.find_element("id", element_id)
    a = ActionChains(drv).click_and_hold(el)
    for dx in steps:
        a = a.move_by_offset(dx, 0).pause(pause)
    a.release().perform()
