"""Light that a textured cube sends into the medium: Mitsuba 3 against equiangular.py.

The yard's box (a cube with a 4 x 4 checker of 0.03 and (0.4, 0.3, 0.2) on every face) and the
same box emitting 1 everywhere, in haze, no lights, max_depth 3. Far from the box the scattered
light of the checker box must be the face average of the checker times that of the uniform box:
(0.215, 0.165, 0.115). Both renderers agree on the vacuum image of every face (equiangular.py
--check; this script rotates the box to show each face), so any other ratio is the renderer's
scattered light disagreeing with its own camera-ray texture lookups.

    python tools/groundtruth/textured_cube_check.py          # needs mitsuba (the bench extra)

Mitsuba runs in a child process (scalar_rgb: llvm_ad_rgb needs an LLVM >= 16, see render.py),
the tracer in this one.
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import scenes as S  # noqa: E402

SPP = 256
ROTATIONS = [[("y", 25)], [("y", 115)], [("y", 205)], [("y", 295)], [("x", 90)], [("x", -90)]]


def boxes():
    textured = S.scene_yard()[1]
    return textured, dict(textured, radiance=[1.0, 1.0, 1.0])


def mitsuba_part(out):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    tex, uni = boxes()
    res = {}
    for name, b in (("textured", tex), ("uniform", uni)):
        d = S.mitsuba_scene([b], S.MEDIA["haze"], spp=SPP, max_depth=3)
        res[name] = np.array(mi.render(mi.load_dict(d), spp=SPP, seed=1), np.float64)
    for k, rot in enumerate(ROTATIONS):
        d = S.mitsuba_scene([dict(tex, rot=rot)], None, spp=64)
        res[f"vacuum{k}"] = np.array(mi.render(mi.load_dict(d), spp=64, seed=1), np.float64)
    np.savez(out, **res)


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--mitsuba":
        return mitsuba_part(sys.argv[2])
    import equiangular as E
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mitsuba.npz"
        subprocess.run([sys.executable, __file__, "--mitsuba", str(path)], check=True)
        mit = dict(np.load(path))
    m = S.MEDIA["haze"]
    ss, st, g = m["sigma_s"][0], m["sigma_s"][0] + m["sigma_a"][0], m["g"]
    tex, uni = boxes()
    ours = {name: E.Tracer("yard", shapes=[b], lights=[]).render(SPP, 5, ss, st, g, max_depth=3) / SPP
            for name, b in (("textured", tex), ("uniform", uni))}
    for k, rot in enumerate(ROTATIONS):
        v = E.Tracer("yard", shapes=[dict(tex, rot=rot)], lights=[]).render(64, 3, 0.0, 0.0, 0.0) / 64
        print(f"vacuum, box rotated {rot}: energy equiangular / Mitsuba {v.sum() / mit[f'vacuum{k}'].sum():.4f}")
    cols = np.arange(S.WIDTH)[None, :].repeat(S.HEIGHT, 0)
    _, c0, c1, _ = tex["radiance"]
    expect = (np.asarray(c0) + np.asarray(c1)) / 2
    print("face average of the checker:", np.round(expect, 3).tolist())
    for name, mask in (("left of the box", cols < 40), ("right of the box", cols >= 110)):  # it covers ~48-100
        rm = mit["textured"][mask].sum(0) / mit["uniform"][mask].sum(0)
        ro = ours["textured"][mask].sum(0) / ours["uniform"][mask].sum(0)
        print(f"{name}: scattered light textured / uniform, Mitsuba {np.round(rm, 3).tolist()}, "
              f"equiangular {np.round(ro, 3).tolist()}")


if __name__ == "__main__":
    main()
