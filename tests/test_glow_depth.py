"""render.halo_depth: receiver (physics/glow_depth.py): where along a receiver's ray a source's
glow scatters, against a dense quadrature of its own definition, and what it does to a frame."""
import math

import numpy as np

import fogcli
from fogcli.physics import glow_depth


def dense_cdf(theta, tau, g, u, n=400_000):
    """The definition on an even grid of t / D over [0, 3]: single scattering of a facing
    matte source (max(0, mu0)), HG phase, exp(-tau (rho + t)), 1 / rho^2; normalised at u = 1."""
    t = np.linspace(0.0, 3.0, n)
    s, c = math.sin(theta), math.cos(theta)
    xz = 1 - t * c
    rho = np.sqrt((t * s) ** 2 + xz ** 2)
    cs = (-t * s * s + xz * c) / rho
    f = (1 - g * g) / (1 + g * g - 2 * g * cs) ** 1.5 * np.maximum(xz / rho, 0) / rho ** 2 * np.exp(-tau * (rho + t - 1))
    cum = np.cumsum(f)
    return np.interp(u, t, cum) / np.interp(1.0, t, cum)


def test_depth_cdf_is_its_definition():
    u = np.array([0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.98, 1.0, 1.5])
    for theta in (0.003, 0.03, 0.3, 1.0):
        for tau, g in ((0.1, 0.85), (3.0, 0.85), (1.0, 0.3), (2.0, 0.95)):
            got = glow_depth.depth_cdf(theta, [tau], g, u)[0]
            np.testing.assert_allclose(got, np.minimum(dense_cdf(theta, tau, g, np.minimum(u, 1.0)), 1.0), atol=3e-3)
            assert np.all(np.diff(got) >= -1e-12) and got[-1] == 1.0


def test_forward_glow_scatters_near_the_camera():
    """Why the weight matters: at g 0.85, 80 % of the glow seen 3 degrees from a source at
    tau 1 scatters nearer than 0.8 of its distance (the small scattering angle there
    outweighs the source's nearness), against 21 % at g 0."""
    u = np.array([0.5, 0.8])
    fwd = glow_depth.depth_cdf(math.radians(3), [1.0], 0.85, u)[0]
    iso = glow_depth.depth_cdf(math.radians(3), [1.0], 0.0, u)[0]
    assert fwd[1] > 0.75 and iso[1] < 0.25 and fwd[0] > 5 * iso[0]


def test_a_near_floor_keeps_less_of_a_far_signs_glow():
    """A bright sign at 30 m above a floor 2 m away (fog): with halo_depth receiver the floor
    gets a fraction of the glow it gets with none; the sign's own surroundings at its depth
    keep theirs."""
    h, w = 96, 128
    rgb = np.zeros((h, w, 3), np.float32)
    depth = np.full((h, w), 30.0, np.float32)
    rgb[20:36, 50:78] = 20.0                          # the sign
    depth[64:] = 2.0                                  # the floor, near
    out = {}
    for halo in ("receiver", "none"):
        cfg = fogcli.make_config("fog", sets=[f"render.halo_depth={halo}", "camera.depth=distance"])
        out[halo] = fogcli.apply(rgb, depth, cfg)
    floor = (slice(70, 96), slice(40, 88))
    beside = (slice(20, 36), slice(84, 100))
    ratio = out["receiver"][floor].sum() / out["none"][floor].sum()
    assert ratio < 0.8, ratio
    np.testing.assert_allclose(out["receiver"][beside].sum(), out["none"][beside].sum(), rtol=0.02)
