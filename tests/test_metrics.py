import numpy as np

from metrics import rel_l1, ssim


def test_rel_l1_and_ssim_basics():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 2, (40, 50, 3))
    assert rel_l1(a, a) == 0.0
    assert abs(rel_l1(2 * a, a) - 1.0) < 1e-12
    assert abs(ssim(a, a) - 1.0) < 1e-9
    noisy = a + rng.normal(0, 0.3, a.shape)
    assert 0.2 < ssim(noisy, a) < 0.95
    assert ssim(noisy, a) < ssim(a + rng.normal(0, 0.05, a.shape), a)


def test_ssim_matches_direct_formula_on_constant_patches():
    """Constant images: SSIM reduces to the luminance term (2 mx my + C1)/(mx^2 + my^2 + C1)."""
    a = np.full((20, 20, 3), 0.5)
    b = np.full((20, 20, 3), 1.0)
    ta, tb = 1 - np.exp(-0.5), 1 - np.exp(-1.0)
    c1 = 0.01 ** 2
    want = (2 * ta * tb + c1) / (ta * ta + tb * tb + c1)
    assert abs(ssim(a, b) - want) < 1e-9
