"""How much of a sky dome's scattered light the slab carries (issue 40, `skyline`): a Monte
Carlo of the dome alone (a hemisphere of radiance 1 over a black ground, the camera at its
centre at the scene's height; no buildings), against fogcli's model of it, the slab's sky
term with the dome's first order in place of the plane's (physics/slab.py, physics/dome.py),
per view elevation. The same walk under the slab's own plane sky checks the walk: there
both are exact and must agree.

    python tools/dome_check.py [--paths N] [--doc docs/physics.md]

Every medium is the `skyline` render's (its dome at 150 m, the camera 1.6 m up). Light
that reaches the camera unscattered is left out: the scattered part is what the slab
models. Noise: the walk's standard error is printed per cell (about 1 / sqrt(N) relative).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from backward_walk import scattered
from fogcli.physics import dome, slab
from groundtruth.load import cases

ELEVATIONS = (0.02, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9)     # sines of the view's elevation
HEIGHT = 1.6      # the camera above the ground (tools/groundtruth/scenes.py: GROUND_Y)
RADIUS = 150.0    # the dome (scenes.py: NEAR_DOME_R)


def walk(mu_v: float, albedo: float, g: float, tau_h: float, sky, n: int, rng) -> tuple[float, float]:
    """Mean scattered radiance (and its standard error) reaching the camera along a view of
    elevation sine mu_v, per unit sky radiance: n backward walks from the camera (optical
    units, the ground tau_h below it, black) scoring where they leave through the sky
    (backward_walk.scattered). sky(p, d) -> the optical distance from p along d to the sky
    (inf where it does not get there)."""
    def hit(p, d):
        to_sky = sky(p, d)
        with np.errstate(divide="ignore"):
            to_ground = np.where(d[:, 2] < 0.0, (p[:, 2] + tau_h) / np.maximum(-d[:, 2], 1e-300), np.inf)
        return np.minimum(to_sky, to_ground), np.where(to_sky <= to_ground, 1.0, 0.0)

    d = np.tile([np.sqrt(1.0 - mu_v * mu_v), 0.0, mu_v], (n, 1))
    score = scattered(np.zeros((n, 3)), d, 1.0, albedo, g, hit, rng)
    return float(score.mean()), float(score.std() / np.sqrt(n))


def dome_sky(tau_R: float):
    def to_sky(p, d):
        b = (p * d).sum(1)
        c = (p * p).sum(1) - tau_R * tau_R
        return -b + np.sqrt(np.maximum(b * b - c, 0.0))
    return to_sky


def plane_sky(tau_up: float):
    def to_sky(p, d):
        with np.errstate(divide="ignore"):
            return np.where(d[:, 2] > 0.0, (tau_up - p[:, 2]) / np.maximum(d[:, 2], 1e-300), np.inf)
    return to_sky


def model(albedo: float, g: float, tau_h: float, tau_R: float, tau_H: float, mu_v: float) -> float:
    """fogcli's scattered light of a unit dome sky along a view to the dome or the ground
    (as device/ground.table builds it and preprocess reads it at the pixel's depth: the
    slab's sky term, plus the dome's first order in place of the plane's where it counts)."""
    mu = np.array([mu_v])
    t = dome.ray_end(mu, tau_h, tau_R)        # a pixel of the dome or the ground: its depth ends the ray
    sky = slab.inscatter(albedo, g, tau_h, tau_H, mu, t)[1][0]
    if dome.matters(tau_R):
        sky += dome.table(albedo, g, tau_h, tau_R, tau_H - tau_h, mu, t)[0, 0]
    return float(sky)


def measure(paths: int) -> list[tuple]:
    rows = []
    for case in cases(scene="skyline"):
        meta = case["meta"]
        sa, ss, g = float(meta["sigma_a"][0]), float(meta["sigma_s"][0]), float(meta["g"])
        st = sa + ss
        albedo = ss / st
        tau_h, tau_R = st * HEIGHT, st * RADIUS
        if tau_R > 30.0:        # sea water's: exp(-tau_R) ~ 1e-26, and its light all but that
            continue
        tau_H = slab.sky_height(st, HEIGHT, RADIUS, True, albedo, g)
        rng = np.random.default_rng(46)
        for mu_v in ELEVATIONS:
            exact, err = walk(mu_v, albedo, g, tau_h, dome_sky(tau_R), paths, rng)
            ours = model(albedo, g, tau_h, tau_R, tau_H, mu_v)
            plane, perr = walk(mu_v, albedo, g, tau_h, plane_sky(tau_H - tau_h), paths // 4, rng)
            slab_only = float(slab.inscatter(albedo, g, tau_h, tau_H, np.array([mu_v]), np.array([np.inf]))[1][0])
            rows.append((case["name"], tau_R, mu_v, exact, err, ours, plane, perr, slab_only))
            print(rows[-1], flush=True, file=sys.stderr)
    return rows


def table(rows) -> str:
    out = ["| case | dome (optical radius) | view elevation sine | dome, Monte Carlo | fogcli's model | model / Monte Carlo "
           "| check: the slab's plane, Monte Carlo | the slab | slab / Monte Carlo |",
           "|---|---|---|---|---|---|---|---|---|"]
    for name, tau_R, mu_v, exact, err, ours, plane, perr, slab_only in rows:
        out.append(f"| {name} | {tau_R:.1f} | {mu_v:.2f} | {exact:.4f} +- {err:.4f} | {ours:.4f} | {ours / exact:.2f} "
                   f"| {plane:.4f} +- {perr:.4f} | {slab_only:.4f} | {slab_only / plane:.3f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=200_000, help="walks per view of the dome (a quarter for the plane)")
    ap.add_argument("--doc", help="write the table into this markdown file's dome-check block")
    args = ap.parse_args(argv)
    text = table(measure(args.paths))
    print(text)
    if args.doc:
        from docblock import cpu_name, markers, write_block
        begin, end = markers("dome-check")
        head = (f"Written by `python tools/dome_check.py --paths {args.paths} --doc {args.doc}` on {cpu_name()}. "
                "The scattered light of a dome sky of radiance 1 (no buildings, a black ground, the camera 1.6 m up "
                "at its centre) along views to it, per view elevation, in `skyline`'s media; the check columns walk "
                "the same medium under the slab's plane sky, where the slab is exact.\n\n")
        write_block(Path(args.doc), begin, end, f"{begin}\n{head}{text}\n{end}", new_doc="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
