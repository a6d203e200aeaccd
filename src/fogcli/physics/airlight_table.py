"""Tables of the airlight of a point light in a homogeneous medium (kernels/lights.cl,
`airlight_table`, `airlight_table_grey`): the quadrature of every pixel replaced by four
table look-ups per channel.

With s = d1 + R sinh(x) along the ray (so t = R cosh(x) is the distance to the light and
ds / t^2 = dx / R), the airlight between the camera and the surface is

    ss I / R  exp(-a d1)  integral_{x0}^{x1} h(x) exp(-beta E_r(x)) dx,
    h(x) = p_g(-tanh x) / cosh x,   E_r(x) = r sinh x + cosh x,   beta = sigma R,

with a the coefficient of the camera leg and sigma that of the light leg, r = a / sigma:
r = 1 (both legs extinction: what reaches the camera directly; E_1 = e^x) or r = sa / st
of a channel (the camera leg absorbs only: the direct part plus what scatters again). For
a given g and r the integral is F(beta, x1) - F(beta, x0) = C(beta, x0) - C(beta, x1), with
F and C its cumulative integrals from the left and from the right. The tables hold them on
a grid of (ln beta, x) as logarithms with the double-exponential factor taken out where it
dominates (left of E_r's minimum for F, right of it for C), so that bilinear interpolation
is accurate to about 1e-4 (tests/test_lights.py holds the kernel to 1e-3 of the float64
reference). The cumulative integrals are computed in the log domain with a rule exact for
exponentials, so nothing underflows however large beta E_r gets."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

X0, X1, NX = -14.0, 14.0, 1121          # x = asinh((s - d1) / R): +-14 covers d1 / R up to 6e5
LB0, LB1, NB = -14.0, 7.0, 337          # ln beta; beyond e^7 the light is > 1000 optical depths away
SUB = 2                                  # integration steps per table step

DEFINES = {"AL_X0": f"{X0!r}f", "AL_X1": f"{X1!r}f", "AL_NX": NX, "AL_LB0": f"{LB0!r}f", "AL_LB1": f"{LB1!r}f",
           "AL_NB": NB, "AL_BMIN": f"{math.exp(LB0)!r}f", "AL_BMAX": f"{math.exp(LB1)!r}f"}


def _hg(g: float, cosa: np.ndarray) -> np.ndarray:
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cosa) ** 1.5)


def split(r: float) -> tuple[float, float]:
    """(x where E_r is smallest, that smallest value); r = 1 has none (E_1 = e^x)."""
    return (-math.inf, 0.0) if r >= 1.0 else (-math.atanh(r), math.sqrt(1.0 - r * r))


def factors(r: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What the F and C tables have added, per unit of beta, at x."""
    xm, em = split(r)
    e = r * np.sinh(x) + np.cosh(x)
    return np.where(x < xm, e, em), np.where(x > xm, e, em)


def build(g: float, r: float) -> np.ndarray:
    """(NB, NX, 2) float32: ln F + beta phi_F and ln C + beta phi_C for one g and r."""
    x = np.linspace(X0, X1, (NX - 1) * SUB + 1)
    lb = np.linspace(LB0, LB1, NB)[:, None]
    beta = np.exp(lb)
    lf = np.log(_hg(g, -np.tanh(x)) / np.cosh(x))[None, :] - beta * (r * np.sinh(x) + np.cosh(x))[None, :]
    dx = x[1] - x[0]
    # one step: integral of exp(linear in x) between the samples, exact for an exponential
    ad = np.abs(lf[:, 1:] - lf[:, :-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(ad > 1e-7, -np.expm1(-ad) / ad, 1.0 - ad / 2)
    lseg = np.maximum(lf[:, 1:], lf[:, :-1]) + np.log(dx * k)
    lF = np.logaddexp.accumulate(lseg, axis=1)
    lF = np.concatenate([np.full((NB, 1), -np.inf), lF], axis=1)
    if r >= 1.0:       # below X0, h exp(-beta e^x) ~ h(X0) e^(x - X0): its integral is the sample
        lF = np.logaddexp(lF, lf[:, :1])
    lC = np.logaddexp.accumulate(lseg[:, ::-1], axis=1)[:, ::-1]
    lC = np.concatenate([lC, np.full((NB, 1), -np.inf)], axis=1)
    pF, pC = factors(r, x)
    with np.errstate(invalid="ignore"):
        tF, tC = lF + beta * pF[None, :], lC + beta * pC[None, :]
    out = np.stack([tF[:, ::SUB], tC[:, ::SUB]], axis=-1)
    # the last column of C is empty (nothing right of X1); the one before stands in for it
    out[:, -1, 1] = out[:, -2, 1] - 50.0
    return np.ascontiguousarray(np.maximum(out, -1e30), np.float32)


@lru_cache(maxsize=8)
def tables(g: float, rs: tuple[float, ...]) -> np.ndarray:
    """(1 + len(rs), NB, NX, 2): r = 1 first, then one table per r of rs (the channels)."""
    return np.stack([build(g, 1.0)] + [build(g, r) for r in rs])
