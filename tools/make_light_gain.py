"""The energy of single scattering as fogcli's light model carries it, on the grid of the
point-spread table (src/fogcli/physics/data/apsf.npz): an isotropic point source, a camera at
optical distance tau, the light leg attenuated by extinction, the camera leg by absorption
only (what scatters again on it stays in the image, spread by the point spread). Its ratio
to the table's energy (all orders of scattering) is the gain fogcli applies to a light's
twice-scattered part (fogcli.device.lights.gain). Writes src/fogcli/physics/data/light_gain.npz (the energy
over the thin-medium form exp(-sa d)(1 - exp(-ss d)), as the table's `ratio`).

    python tools/make_light_gain.py        # about 3 minutes on 2 cores
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from apsf_mc import hg_phase  # noqa: E402

OUT = ROOT / "src" / "fogcli" / "physics" / "data" / "light_gain.npz"


def carried_energy(tau: float, g: float, albedo: float, n: int = 200) -> float:
    """Forward-hemisphere energy (over I / d^2) of single scattering with the light leg in
    extinction and the camera leg in absorption, by Gauss-Legendre quadrature: theta from the
    source direction, and along each view ray the angle b at the vertex (r = d sin(b - theta)
    / sin b, rho = d sin(theta) / sin b: smooth in b, as in apsf_fit.single_scatter)."""
    st, d = 1.0 / albedo, tau
    sa = st - 1.0
    xt, wt = np.polynomial.legendre.leggauss(n)
    th = (xt + 1.0) * math.pi / 4.0
    wth = wt * math.pi / 4.0
    xb, wb = np.polynomial.legendre.leggauss(n)
    b = th[:, None] + (math.pi - th[:, None]) * (xb[None, :] + 1.0) / 2.0
    jw = wb[None, :] * (math.pi - th[:, None]) / 2.0
    sb = np.sin(b)
    r = d * np.sin(b - th[:, None]) / sb
    rho = d * np.sin(th)[:, None] / sb
    dr = d * np.sin(th)[:, None] / sb ** 2
    f = d * d * np.sum(jw * dr * np.exp(-st * rho - sa * r) * hg_phase(np.cos(b), g) / rho ** 2, axis=1)
    return float(np.sum(wth * f * 2.0 * math.pi * np.sin(th)))


def main() -> int:
    sys.path.insert(0, str(ROOT / "tools"))
    import make_apsf_table as M     # the table's grid, as apsf.npz stores it (float32)

    gs, albedos, taus = (np.asarray(v, np.float32) for v in (M.G, M.ALBEDO, M.TAU))
    t0 = time.time()
    out = np.zeros((len(gs), len(albedos), len(taus)))
    for i, g in enumerate(gs):
        for j, a in enumerate(albedos):
            for k, tau in enumerate(taus):
                out[i, j, k] = carried_energy(float(tau), float(g), float(a))
        print(f"g {g}: {time.time() - t0:.0f} s", flush=True)
    # over the thin-medium form, like the table's `ratio`: no float32 underflow where the light
    # is absorbed (0 where even float64 underflows: no gain there)
    from fogcli.physics.apsf import thin_energy

    thin = thin_energy(taus[None, None, :], albedos[None, :, None])
    ratio = np.where(thin > 1e-300, out / np.maximum(thin, 1e-300), 0.0)
    np.savez_compressed(OUT, g=gs, albedo=albedos, tau=taus, carried_ratio=ratio.astype(np.float32))
    print(f"wrote {OUT.relative_to(ROOT)} in {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
