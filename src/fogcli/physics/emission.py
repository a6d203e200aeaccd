"""The emission profile of the tabulated point spread (`render.emission_profile`): the table's
source is isotropic; a matte surface emits max(0, cos) around its normal and nothing behind
it. The Monte Carlo records in which direction (relative to the line to the camera) the
light that reaches the camera after scattering left the source, per class of the angle at
which it arrives; from that come the Lambertian emitter's weights (docs/method.md)."""
from __future__ import annotations

import math

import numpy as np

from fogcli.physics.apsf import _along_tau, _slice_ga

NC = 16           # samples of the view cosine (emission_profile: lambertian) ...
COS_MIN = 0.05    # ... from here to 1; grazing views clamp here


def lambert_gain(mu0: np.ndarray, cos_view: np.ndarray) -> np.ndarray:
    """A Lambertian surface's intensity over an isotropic source's (both send the camera the
    same radiance) in the directions at cosine mu0 from the line to the camera, averaged
    over their azimuth, for a normal at cosine cos_view to that line: (len(mu0), len(cos_view)).
    The surface emits max(0, cos_view mu0 + sin_view sqrt(1 - mu0^2) cos(phi)) / cos_view
    times the isotropic source's intensity; the average over phi is closed form."""
    mu = np.asarray(mu0, np.float64)[:, None]
    ct = np.asarray(cos_view, np.float64)[None, :]
    st = np.sqrt(np.maximum(1.0 - ct * ct, 0.0))
    A = ct * mu
    B = st * np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        phi0 = np.arccos(np.clip(np.where(B > 0, -A / B, np.sign(-A) * 2.0), -1.0, 1.0))
    return (A * phi0 + B * np.sin(phi0)) / np.pi / ct


def lambert_classes(tab: dict, g: float, albedo: float, tau: np.ndarray, cos_view: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(weight, energy): per class of the angle theta at which the light reaches the camera
    (`emit_theta`), a Lambertian emitter's scattered energy over that of the isotropic source
    the table assumes, (len(tau), C, len(cos_view)), and the isotropic source's scattered
    energy in each class, (len(tau), C). Both sources send the camera the same radiance;
    they differ in what they emit elsewhere. The table gives, per class, the directions in
    which the light left the source (cosine mu0 against the line to the camera); the weight
    averages lambert_gain over them. Light arriving far from the source left it far from
    the camera's direction, where a surface facing the camera emits little (at tau 2 in
    fog: 0.95 within 3 degrees, 0.54 beyond 48)."""
    joint = _slice_ga(tab, "emit_mu", g, albedo)                                # (tau grid, C, M)
    em = _along_tau(tab, joint.reshape(len(joint), -1), tau).reshape((-1,) + joint.shape[1:])
    edges = tab["emit_mu_edges"]
    per_class = em @ lambert_gain(0.5 * (edges[:-1] + edges[1:]), cos_view)   # (T, C, V)
    share = em.sum(-1)                                                         # (T, C)
    # a class that holds (next to) nothing, or a little below it where the float16 table
    # rounds: its weight is the whole hemisphere's
    whole = per_class.sum(1) / np.maximum(share.sum(-1), 1e-300)[:, None]    # (T, V)
    some = share > 1e-6 * np.maximum(share.sum(-1, keepdims=True), 1e-300)
    w = np.where(some[..., None], per_class / np.where(some, share, 1.0)[..., None], whole[:, None, :])
    return w, np.maximum(share, 0.0)


def lambert_weight(tab: dict, g: float, albedo: float, tau: np.ndarray, cos_view: np.ndarray,
                   seen: np.ndarray | None = None) -> np.ndarray:
    """lambert_classes' weight over the classes, (len(tau), len(cos_view)), each class
    counted by its energy times `seen`: the share of the class that lands in the frame
    (theta_seen); the default counts the whole forward hemisphere."""
    return _over_classes(*lambert_classes(tab, g, albedo, tau, cos_view), seen)


def _over_classes(w: np.ndarray, share: np.ndarray, seen: np.ndarray | None) -> np.ndarray:
    """lambert_classes' (weight, energy) averaged over the classes, each counted by its
    energy times `seen` (None: 1)."""
    s = np.ones(share.shape[-1]) if seen is None else np.asarray(seen, np.float64)
    return (w * (share * s)[..., None]).sum(1) / np.maximum(share @ s, 1e-300)[:, None]


def class_shares(sigma_u: np.ndarray, theta_edges: np.ndarray) -> np.ndarray:
    """(J, C): the share of each table Gaussian (a 2-D Gaussian of std sigma_u in the image
    plane, u = tan theta) at angles within each class of theta."""
    t = np.tan(np.minimum(np.asarray(theta_edges, np.float64), math.pi / 2 - 1e-9))
    t[np.asarray(theta_edges) >= math.pi / 2 - 1e-9] = np.inf
    cdf = 1.0 - np.exp(-0.5 * (t[None, :] / np.asarray(sigma_u, np.float64)[:, None]) ** 2)
    return np.diff(cdf, axis=-1)


def lambert_shape(tab: dict, g: float, albedo: float, tau: np.ndarray, shape: np.ndarray, cos_grid: np.ndarray,
                  seen: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(shape, weight): the spread of a Lambertian emitter facing the camera and its
    scattered energy over the isotropic source's per view cosine (len(tau), len(cos_grid);
    cos_grid ends at 1, the facing one):
    the facing emitter's whole weight, times how a tilted one differs from it over the
    angles the frame shows (lambert_weight with `seen`). Each table Gaussian is weighted by
    the emitter's weight at its own angle (narrow ones keep more than wide ones), that
    weight linear in log tan theta between the classes' mean angles, its values found so
    that every class of theta receives the weight the Monte Carlo gives it: a Gaussian
    reaches into its neighbours' classes, and each class's weight taken as it is would
    leave the narrow classes too little and the wide ones too much."""
    per_cos, energy = lambert_classes(tab, g, albedo, tau, cos_grid)          # one interpolation of the table
    w = per_cos[..., -1]                                                       # (T, C): facing
    q = class_shares(tab["sigma_u"], tab["emit_theta"])                        # (J, C)
    th = tab["emit_theta"]
    node = np.log(np.tan(np.minimum(0.5 * (th[:-1] + th[1:]), 1.4)))
    at = np.log(1.2533 * np.asarray(tab["sigma_u"], np.float64))               # a Gaussian's mean radius
    basis = np.stack([np.interp(at, node, np.eye(len(node))[c]) for c in range(len(node))], -1)   # (J, C)
    reach = shape[:, :, None] * q[None]                                        # (T, J, C)
    target = w * np.einsum("tjc->tc", reach)
    x = w.copy()
    for _ in range(40):
        got = np.einsum("tjc,tj->tc", reach, x @ basis.T)
        # a facing emitter's weight is a mean of cosines, at most 1: bounded (with room for the
        # interpolation between nodes) where a class holds almost nothing and the ratio runs away
        x = np.clip(x * np.where(got > 1e-12, target / np.maximum(got, 1e-300), 1.0), 0.0, 2.0)
    per_j = shape * (x @ basis.T)
    face = per_j.sum(-1)
    frame = _over_classes(per_cos, energy, seen)
    tilt = frame / np.maximum(frame[:, -1:], 1e-300)
    # where the table holds no spread (thick, absorbing: the weights' sum ~0, or below it)
    # the shape stays and the weight is the frame's
    ok = face > 1e-6
    out = np.where(ok[:, None], per_j / np.where(ok, face, 1.0)[:, None], shape)
    return out, np.where(ok, face, frame[:, -1])[:, None] * tilt


def theta_seen(theta_edges: np.ndarray, focal_px: float, width: int, height: int, n: int = 12) -> np.ndarray:
    """Per class of theta (edges in radians), the share of the directions at those angles from
    a source in the frame that land in the frame (by solid angle): rings of sub-angles across
    each class, around sources on an n x n grid over the frame, through the pinhole."""
    sub = 4
    th = np.concatenate([np.linspace(a, b, sub + 2)[1:-1] for a, b in zip(theta_edges[:-1], theta_edges[1:])])
    phi = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
    g = (np.arange(n) + 0.5) / n
    sx, sy = np.meshgrid((g - 0.5) * width, (g - 0.5) * height)
    s = np.stack([sx.ravel(), sy.ravel(), np.full(n * n, focal_px)], -1)
    s /= np.linalg.norm(s, axis=-1, keepdims=True)                             # (S, 3)
    a = np.cross(s, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a, axis=-1, keepdims=True)
    b = np.cross(s, a)
    ring = np.cos(phi)[:, None, None] * a[None] + np.sin(phi)[:, None, None] * b[None]        # (F, S, 3)
    v = np.cos(th)[:, None, None, None] * s[None, None] + np.sin(th)[:, None, None, None] * ring[None]
    z = v[..., 2]
    ok = z > 1e-9
    zs = np.where(ok, z, 1.0)
    inside = ok & (np.abs(v[..., 0] / zs * focal_px) <= width / 2) & (np.abs(v[..., 1] / zs * focal_px) <= height / 2)
    sw = np.sin(th).reshape(-1, sub)
    return (inside.mean(axis=(1, 2)).reshape(-1, sub) * sw).sum(-1) / sw.sum(-1)
