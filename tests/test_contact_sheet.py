"""`fogcli media --sheet`: every preset, and each --config file, on the user's image as a
labelled contact sheet; bad use refused in one line."""
from __future__ import annotations

import cv2
import numpy as np

from helpers import SAMPLE, assert_one_line_error, run

from fogcli.config.presets import presets

TILE_W, TILE_H, BAND, GAP = 160, 90, 40, 6     # the sample is 640x360


def tiles(path, n):
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    out = []
    for i in range(n):
        r, c = divmod(i, 3)
        y, x = GAP + r * (TILE_H + BAND + GAP), GAP + c * (TILE_W + GAP)
        out.append(img[y:y + TILE_H, x:x + TILE_W].astype(np.float32))
    return img, out


def test_every_preset_and_a_config_file_get_a_tile(tmp_path):
    mine = tmp_path / "mine.yaml"
    mine.write_text("medium:\n  visibility: 20\n  asymmetry: 0.5\n")
    code, out, _ = run("media", "--sheet", SAMPLE, "--config", mine, "--width", TILE_W, "-o", tmp_path / "sheet.png")
    assert code == 0, out
    n = 1 + len(presets()) + 1
    rows = -(-n // 3)
    img, ts = tiles(tmp_path / "sheet.png", n)
    assert img.shape == (rows * (TILE_H + BAND + GAP) + GAP, 3 * (TILE_W + GAP) + GAP, 3)
    # each tile its own medium: every pair differs, and each differs from the input
    for i in range(n):
        for j in range(i + 1, n):
            assert np.abs(ts[i] - ts[j]).mean() > 0.5, (i, j)
    # the label band holds text (light pixels on the dark ground)
    y = GAP + TILE_H
    assert (img[y:y + BAND, GAP:GAP + TILE_W] > 150).sum() > 50


def test_bad_use_is_one_line(tmp_path):
    code, out, _ = run("media", "--sheet", SAMPLE)
    assert_one_line_error(code, out, "go together")
    code, out, _ = run("media", "--sheet", SAMPLE, "-o", tmp_path / "sheet.exr")
    assert_one_line_error(code, out, "expected a .png")
    code, out, _ = run("media", "--sheet", tmp_path / "missing.exr", "-o", tmp_path / "s.png")
    assert_one_line_error(code, out, "missing.exr")
