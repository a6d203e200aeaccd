"""pixels.py against numpy's plain per-channel expressions, bit for bit: half widening (NaN,
inf, subnormals, -0), channel picks of every layout a frame comes in (runs and single
channels), planes, views, the RGBA packing into a foreign buffer (the mapped device image)
from float32 and from half columns, and the radiance check."""
import numpy as np
import pytest

from fogcli.device.preprocess import pack_rgba
from fogcli.io import pixels
from fogcli.physics.limits import check_radiance


def _frame(h, w, c, dtype, seed=0):
    rng = np.random.default_rng(seed)
    a = (rng.standard_normal((h, w, c)) * 100).astype(dtype)
    flat = a.reshape(-1)
    special = np.array([np.nan, np.inf, -np.inf, -0.0, 6e-8, -3e-6, 65504, 1e-7], dtype)
    flat[:special.size] = special
    return a


def _same(a, b):
    assert a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8))


@pytest.mark.parametrize("c", [1, 2, 3, 4, 5, 7])
def test_widen_is_numpys_cast_bit_for_bit(c):
    h = _frame(37, 53, c, np.float16)
    _same(pixels.widen(h), h.astype(np.float32))
    _same(pixels.widen(h[:, ::2]), h[:, ::2].astype(np.float32))        # a view: numpy's path
    f = h.astype(np.float32)
    assert pixels.widen(f) is f


@pytest.mark.parametrize("c,idx", [(4, [0, 1, 2]), (4, [2, 1, 0]), (3, [0, 1, 2]), (4, [0, 1, 2, 3]),
                                   (2, [0, 0, 0]), (5, [4, 0, 2]), (7, [1, 2, 3, 6]), (1, [0, 0, 0])])
@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_take_and_plane_match_numpy(c, idx, dtype):
    px = _frame(29, 41, c, dtype, seed=c)
    want = np.ascontiguousarray(px[:, :, idx], dtype=np.float32)
    got = pixels.take(px, idx)
    _same(got, want)
    assert got.flags.c_contiguous and not np.shares_memory(got, px)
    for i in range(c):
        p = pixels.plane(px, i)
        _same(p, np.ascontiguousarray(px[:, :, i], dtype=np.float32))
        assert not np.shares_memory(p, px)


@pytest.mark.parametrize("with_alpha", [False, True])
def test_pack_rgba_into_a_foreign_buffer(with_alpha):
    rgb = _frame(31, 47, 3, np.float32, seed=3)
    alpha = _frame(31, 47, 1, np.float32, seed=4)[:, :, 0] if with_alpha else None
    buf = bytearray(31 * 47 * 16)
    dst = np.frombuffer(buf, np.float32).reshape(31, 47, 4)
    pack_rgba(dst, rgb, alpha)
    want = np.dstack([rgb, alpha if with_alpha else np.ones((31, 47), np.float32)])
    _same(np.frombuffer(buf, np.float32).reshape(31, 47, 4), want)
    dst2 = np.zeros((31, 47, 4), np.float32)
    pack_rgba(dst2, rgb[:, :, ::-1], alpha)                      # a view: numpy's path
    _same(dst2[:, :, :3], np.ascontiguousarray(rgb[:, :, ::-1]))
    _same(np.ascontiguousarray(dst2[:, :, 3]), alpha if with_alpha else np.ones((31, 47), np.float32))
    dst3 = np.full((31, 47, 4), np.nan, np.float32)
    pack_rgba(dst3, rgb.astype(np.float16), alpha)                # half: numpy's path
    _same(dst3, np.dstack([rgb.astype(np.float16).astype(np.float32),
                           alpha if with_alpha else np.ones((31, 47), np.float32)]))


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_gather_matches_numpy(dtype):
    rgba = _frame(23, 31, 4, np.float32, seed=5) * 1e3           # beyond 65504: inf in half
    kept = _frame(23, 31, 4, np.float16, seed=6)
    alpha = _frame(23, 31, 1, np.float32, seed=7)[:, :, 0]
    rgb = rgba[:, :, :3]                                          # a view, as the download gives
    aov = rgba[:, :, 1]                                           # a strided plane
    for picks in ([(rgb, 0), (rgb, 1), (rgb, 2), (kept, 3)], [(kept, 0), (rgb, 2), (alpha, 0)],
                  [(rgb, 0), (rgb, 1), (rgb, 2), (alpha, 0), (kept, 3), (aov, 0)], [(kept, 2)]):
        want = np.empty((23, 31, len(picks)), dtype)
        with np.errstate(over="ignore"):
            for j, (a, c) in enumerate(picks):
                want[:, :, j] = a[:, :, c] if a.ndim == 3 else a
        _same(pixels.gather(picks, dtype), want)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_gather_of_row_strips_as_exr_write_passes_them(dtype):
    """The strips of a write: rows r0:r1 of the RGB view of an RGBA (the mapped result), of a
    plane, of a float64 strip of the input's own channels; runs of channels (R, G, B of the
    result) move together."""
    rgba = _frame(40, 33, 4, np.float32, seed=8) * 1e3
    own = _frame(40, 33, 6, np.float64, seed=9)
    alpha = _frame(40, 33, 1, np.float32, seed=10)[:, :, 0]
    rgb = rgba[:, :, :3]
    for r0, r1 in ((0, 16), (16, 32), (32, 40), (5, 6)):
        picks = [(own[r0:r1], 0), (rgb[r0:r1], 2), (rgb[r0:r1], 0), (rgb[r0:r1], 1), (rgb[r0:r1], 2),
                 (alpha[r0:r1], 0), (own[r0:r1], 4), (own[r0:r1], 5)]
        want = np.empty((r1 - r0, 33, len(picks)), dtype)
        with np.errstate(over="ignore"):
            for j, (a, c) in enumerate(picks):
                want[:, :, j] = a[:, :, c] if a.ndim == 3 else a
        _same(pixels.gather(picks, dtype), want)
    with pytest.raises(IndexError):
        pixels.gather([(rgb, 3)], dtype)                            # the hidden alpha is not a channel of rgb


def test_pack_rgba_from_half_columns_and_the_radiance_check():
    from fogcli.errors import UserError

    px = _frame(19, 23, 4, np.float16, seed=11)          # R, G, B, Z as a half EXR holds them
    px[0, :2, :] = 1.0                                  # its specials in the colour columns: away
    px.reshape(-1, 4)[:, :3] = np.nan_to_num(px.reshape(-1, 4)[:, :3], nan=0.5, posinf=2.0, neginf=-2.0)
    view = pixels.columns(px, [0, 1, 2])
    assert np.shares_memory(view, px)                   # a run: no copy
    dst = np.zeros((19, 23, 4), np.float32)
    pack_rgba(dst, view, None)
    _same(dst, np.dstack([px[:, :, :3].astype(np.float32), np.ones((19, 23), np.float32)]))
    check_radiance(dst, "colour")                # finite: passes
    assert not np.shares_memory(pixels.columns(px, [2, 1, 0]), px)
    dst[3, 4, 1] = np.inf
    dst[5, 6, 0] = np.nan
    with pytest.raises(UserError, match="colour: 2 pixel\\(s\\) hold NaN or infinite colour values"):
        check_radiance(dst, "colour")
    dst[3, 4, 1], dst[5, 6, 0] = 1e21, 0.0
    with pytest.raises(UserError, match="colour values up to 1e\\+21"):
        check_radiance(dst, "colour")
