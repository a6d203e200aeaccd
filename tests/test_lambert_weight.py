"""The Lambertian emission weight (physics/apsf.py: lambert_gain, lambert_weight, theta_seen)
against its limits, single-scattering quadrature and the pixels' own solid angles."""
import math

import numpy as np
import pytest

from fogcli.physics import apsf, emission


def test_lambert_weight_limits():
    """Light that left the source towards the camera (mu0 = 1) sees no difference; light
    that left in every direction alike sees the Lambertian mean, 1 / (4 cos)."""
    tab = {k: np.array(v, np.float64) for k, v in apsf.load_table().items()}
    cosv = np.array([0.1, 0.5, 1.0])
    edges = tab["emit_mu_edges"]
    tab["emit_mu"][:] = 0.0
    tab["emit_mu"][..., -1] = 1.0                          # mu0 in the last bin
    w = emission.lambert_weight(tab, 0.8, 0.9, np.array([1.0]), cosv)
    mu = 0.5 * (edges[-2] + edges[-1])
    # max(0, cos mu0 + sin sqrt(1 - mu0^2) cos phi) averages to cos mu0 where
    # cos mu0 >= sin sqrt(1 - mu0^2)
    np.testing.assert_allclose(w[0], mu, rtol=1e-9)
    tab["emit_mu"][:] = np.diff(edges) / 2.0               # uniform over the sphere
    w = emission.lambert_weight(tab, 0.8, 0.9, np.array([1.0]), cosv)
    np.testing.assert_allclose(w[0], 1 / (4 * cosv), rtol=0.01)   # the bins' midpoints


def test_lambert_gain_is_the_azimuthal_mean():
    """The closed form against the mean over 4000 azimuths of the tilted surface's intensity."""
    mu0 = np.linspace(-0.99, 0.99, 23)
    cosv = np.array([0.05, 0.3, 0.7, 1.0])
    phi = (np.arange(4000) + 0.5) / 4000 * 2 * math.pi
    st = np.sqrt(1 - cosv ** 2)
    brute = np.maximum(0.0, cosv[None, :, None] * mu0[:, None, None]
                       + st[None, :, None] * np.sqrt(1 - mu0 ** 2)[:, None, None] * np.cos(phi)).mean(-1) / cosv
    np.testing.assert_allclose(emission.lambert_gain(mu0, cosv), brute, rtol=1e-5, atol=1e-7)


def single_scatter_classes(g: float, tau: float, theta_edges, cosv, n_th=160, n_psi=400, n_phi=64):
    """Per theta class, the single-scattering energy reaching a camera at distance tau
    (scattering mean free paths, albedo 1) and the Lambertian gain averaged over it: the ray
    at angle theta from the source, t along it written as t = d cos + b tan(psi) (b = d sin),
    so that dt / rho^2 = dpsi / b, smooth through the point nearest the source; the gain as
    the mean over azimuths of the tilted surface's intensity (not lambert_gain's form)."""
    energy, gain = [], []
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * math.pi
    st = np.sqrt(1 - cosv ** 2)
    for a, b_ in zip(theta_edges[:-1], theta_edges[1:]):
        th = a + (np.arange(n_th) + 0.5) / n_th * (b_ - a)
        e_c, g_c = 0.0, np.zeros(len(cosv))
        for t_ in th:
            b = tau * math.sin(t_)
            psi0 = math.atan2(-tau * math.cos(t_), b)
            psi = psi0 + (np.arange(n_psi) + 0.5) / n_psi * (math.pi / 2 - psi0)
            t = tau * math.cos(t_) + b * np.tan(psi)
            x = np.stack([t * math.sin(t_), np.zeros_like(t), tau - t * math.cos(t_)], -1)
            rho = np.linalg.norm(x, axis=-1)
            u = x / rho[:, None]
            cs = u @ np.array([-math.sin(t_), 0.0, math.cos(t_)])
            p = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cs) ** 1.5)
            f = p * np.exp(-rho - t) / (4 * math.pi) / b * (math.pi / 2 - psi0) / n_psi
            w = f * 2 * math.pi * math.sin(t_) * (b_ - a) / n_th
            mu0 = u[:, 2]
            lam = np.maximum(0.0, cosv[None, :, None] * mu0[:, None, None] + st[None, :, None]
                             * np.sqrt(np.maximum(1 - mu0 ** 2, 0))[:, None, None] * np.cos(phi)).mean(-1) / cosv
            e_c += w.sum()
            g_c += w @ lam
        energy.append(e_c)
        gain.append(g_c / e_c)
    return np.array(energy), np.array(gain)


def test_lambert_weight_per_theta_class_is_single_scattering_at_small_tau():
    """At tau 0.01 (albedo 1, the grid's first node) the table's light is single scattering: per class of the arrival
    angle, its share of the energy and its Lambertian weight are quadrature's. Light that
    arrives far from the source left it far from the camera's direction: the weight falls
    with theta, which is why the frame's classes matter (theta_seen)."""
    tab = apsf.load_table()
    edges = tab["emit_theta"]
    cosv = np.array([1.0, 0.6, 0.2])
    g, tau = 0.85, 0.01
    energy, gain = single_scatter_classes(g, tau, edges, cosv)
    share = energy / energy.sum()
    per = np.array([emission.lambert_weight(tab, g, 1.0, np.array([tau]), cosv, np.eye(len(energy))[c])[0]
                    for c in range(len(energy))])
    em = apsf._slice_ga(tab, "emit_mu", g, 1.0)[0].sum(-1)
    np.testing.assert_allclose(em / em.sum(), share, atol=0.02)
    np.testing.assert_allclose(per, gain, atol=0.02)        # measured 0.012 at most
    assert gain[0, 0] > 0.95 and gain[-1, 0] < 0.75


def test_theta_seen_is_the_frames_solid_angle_in_each_ring():
    """Against the pixels: per source pixel, the solid angle of the frame's pixels at angles
    in a class over the class's ring, averaged over the sources."""
    w, h, f = 48, 36, 40.0
    edges = np.radians([0.0, 5.0, 12.0, 25.0, 40.0, 60.0, 90.0])
    ys, xs = np.mgrid[0:h, 0:w]
    d = np.stack([xs + 0.5 - w / 2, ys + 0.5 - h / 2, np.full(xs.shape, f)], -1).reshape(-1, 3)
    n = np.linalg.norm(d, axis=-1)
    omega = f / n ** 3                                      # solid angle of a pixel
    u = d / n[:, None]
    got = np.zeros(len(edges) - 1)
    src = np.arange(0, w * h, 7)
    for s in src:
        th = np.arccos(np.clip(u @ u[s], -1, 1))
        c = np.searchsorted(edges, th, side="right") - 1
        ok = (c >= 0) & (c < len(edges) - 1)
        got += np.bincount(c[ok], omega[ok], minlength=len(edges) - 1)
    ring = 2 * math.pi * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    got /= len(src) * ring
    np.testing.assert_allclose(emission.theta_seen(edges, f, w, h, n=16), got, atol=0.03)


@pytest.mark.parametrize("g,albedo", [(0.85, 0.999), (0.7, 0.9), (0.92, 0.8)])
def test_lambert_shape_gives_each_class_its_weight(g, albedo):
    """emission.lambert_shape: the facing emitter's spread (the table's Gaussians each weighted
    at its own angle) gives every class of the arrival angle the Monte Carlo's weight for it
    (lambert_classes), within 0.01 from tau 0.3 to 5: a Gaussian reaches into its neighbours'
    classes, which each class's weight taken as it is would get wrong near the source (up to
    0.10 here)."""
    tab = apsf.load_table()
    tau = np.array([0.3, 1.0, 2.0, 5.0])
    q = emission.class_shares(tab["sigma_u"], tab["emit_theta"])
    _, sh = apsf.spread(tab, g, albedo, tau)
    w, _ = emission.lambert_classes(tab, g, albedo, tau, np.array([1.0]))
    shape, weight = emission.lambert_shape(tab, g, albedo, tau, sh, np.array([1.0]), None)
    got = (shape * weight[:, -1:]) @ q / (sh @ q)
    np.testing.assert_allclose(got, w[..., 0], atol=0.01)
    np.testing.assert_allclose(shape.sum(-1), 1.0, rtol=1e-9)
