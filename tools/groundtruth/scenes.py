"""Ground-truth scenes for fogcli: pure data plus functions that build Mitsuba 3 scene dicts.

Conventions (fogcli's camera, checked numerically by ``render.py --check``):
camera at the origin looking down -Z, +Y up, +X right; image W x H, horizontal field of view
FOV degrees, f = (W/2)/tan(FOV/2); pixel (i, j) = (column, row from the top) has its centre at
(i+0.5, j+0.5) and camera-space direction d = ((i+0.5-W/2)/f, -(j+0.5-H/2)/f, -1).
Depth is the RAY LENGTH to the first surface along that direction (metres).

Every surface is NON-reflecting (black diffuse BSDF, reflectance 0) and may carry an ``area``
emitter; so the radiance leaving a surface does not depend on the medium around it.
Rectangles/discs emit on their +normal side only (Mitsuba area emitters are one-sided).

Mitsuba is imported lazily (inside the builders) so that this file can be read without it.
"""
import math

import numpy as np

WIDTH, HEIGHT, FOV = 256, 192, 60.0          # FOV: horizontal, degrees
FOCAL = (WIDTH / 2) / math.tan(math.radians(FOV) / 2)
TAN_X = (WIDTH / 2) / FOCAL                    # half-width of the frustum at unit distance
TAN_Y = (HEIGHT / 2) / FOCAL                   # half-height of the frustum at unit distance
GROUND_Y = -1.6                                # camera 1.6 m above the ground where there is one
DOME_R = 1000.0                                # sky dome radius (m)
NEAR_DOME_R = 150.0                            # `skyline` only: a sky that the media do not extinguish

# ---------------------------------------------------------------- media
# sigma_s, sigma_a per RGB channel (1/m); HG asymmetry g.
def _medium(sigma_s, sigma_a, g):
    s = np.broadcast_to(np.asarray(sigma_s, float), (3,)).copy()
    a = np.broadcast_to(np.asarray(sigma_a, float), (3,)).copy()
    return {"sigma_s": s.tolist(), "sigma_a": a.tolist(), "g": float(g)}


MEDIA = {
    # fog: sigma_s 0.12, albedo 0.999 -> sigma_a = sigma_s (1/albedo - 1)
    "fog": _medium(0.12, 0.12 * (1 / 0.999 - 1), 0.85),
    # haze: sigma_s 0.025, albedo 0.9
    "haze": _medium(0.025, 0.025 * (1 / 0.9 - 1), 0.7),
    # sea water: absorbing, chromatic
    "sea": _medium([0.15, 0.18, 0.20], [0.25, 0.07, 0.04], 0.92),
}


def sigma_t(medium):
    m = MEDIA[medium] if isinstance(medium, str) else medium
    return np.asarray(m["sigma_s"]) + np.asarray(m["sigma_a"])


def mitsuba_medium(m):
    """Mitsuba homogeneous medium dict for a MEDIA entry (chromatic sigma_t / albedo as RGB)."""
    st = np.asarray(m["sigma_s"]) + np.asarray(m["sigma_a"])
    alb = np.where(st > 0, np.asarray(m["sigma_s"]) / np.where(st > 0, st, 1), 0.0)
    return {"type": "homogeneous",
            "sigma_t": {"type": "rgb", "value": st.tolist()},
            "albedo": {"type": "rgb", "value": alb.tolist()},
            "scale": 1.0,
            "phase": {"type": "hg", "g": m["g"]}}


# ---------------------------------------------------------------- textures (numpy)
def _rng(seed):
    return np.random.default_rng(seed)


def tex_windows(seed, base, lit, n_x=8, n_y=6, res=16, frac=0.55):
    """Facade: dark base colour with a grid of windows, a random fraction of them lit."""
    rng = _rng(seed)
    img = np.empty((n_y * res, n_x * res, 3), np.float32)
    img[:] = base
    for r in range(n_y):
        for c in range(n_x):
            y0, x0 = r * res + res // 4, c * res + res // 4
            if rng.random() < frac:
                col = np.asarray(lit, float) * rng.uniform(0.5, 1.2)
            else:
                col = np.asarray(base, float) * 0.4
            img[y0:y0 + res // 2, x0:x0 + res // 2] = col
    return img


def tex_stripes(colors, n=8, res=64, vertical=False):
    img = np.zeros((res, res, 3), np.float32)
    idx = (np.arange(res) * n // res) % len(colors)
    cols = np.asarray(colors, np.float32)[idx]
    if vertical:
        img[:] = cols[None, :, :]
    else:
        img[:] = cols[:, None, :]
    return img


def tex_text(seed, bg, fg, rows=3, cols=10, res=(48, 128)):
    """A sign: background colour with random glyph-like blocks in the foreground colour."""
    rng = _rng(seed)
    h, w = res
    img = np.empty((h, w, 3), np.float32)
    img[:] = bg
    gh, gw = h // (rows + 1), w // (cols + 1)
    for r in range(rows):
        for c in range(cols):
            if rng.random() < 0.8:
                y0 = gh // 2 + r * gh + 1
                x0 = gw // 2 + c * gw + 1
                gly = rng.random((3, 3)) < 0.6
                blk = np.kron(gly, np.ones((max(1, (gh - 2) // 3), max(1, (gw - 2) // 3)), bool))
                sub = img[y0:y0 + blk.shape[0], x0:x0 + blk.shape[1]]
                sub[blk[:sub.shape[0], :sub.shape[1]]] = fg
    return img


def tex_gradient(top, bottom, res=64):
    t = np.linspace(0, 1, res, dtype=np.float32)[:, None, None]
    img = (1 - t) * np.asarray(top, np.float32) + t * np.asarray(bottom, np.float32)
    return np.repeat(img, 4, axis=1).astype(np.float32)


# ---------------------------------------------------------------- shape specs (pure data)
# Each shape: dict(kind=rectangle|disk|sphere|cube, pos, scale (float or 3), rot=[(axis, deg)...],
#                  radiance = float | rgb list | ("checker", c0, c1, repeats) | ("bitmap", array, repeats)
#                  or None (black, non-emissive), flip=bool)

def _c(v, k=1.0):
    return [float(x) * k for x in v]


WARM = [1.0, 0.62, 0.30]
COLD = [0.55, 0.75, 1.0]


def frustum_rect(dist, radiance):
    """A wall facing the camera at -dist, exactly the size of the view frustum there."""
    return dict(kind="rectangle", pos=[0, 0, -dist], scale=[dist * TAN_X, dist * TAN_Y, 1],
                radiance=radiance)


def ground(radiance, half=700.0):
    return dict(kind="rectangle", pos=[0, GROUND_Y, 0], scale=[half, half, 1], rot=[("x", -90)],
                radiance=radiance)


def dome(radiance, r=DOME_R):
    return dict(kind="sphere", pos=[0, 0, 0], scale=r, radiance=radiance, flip=True)


def box(center, half, radiance, yaw=0.0):
    return dict(kind="cube", pos=list(center), scale=list(half), rot=[("y", yaw)] if yaw else [],
                radiance=radiance)


def scene_lamps():
    L = []
    L.append(frustum_rect(45.0, [0.020, 0.020, 0.022]))
    lamps = [((-2.0, -0.8, -5.0), 0.06, _c(WARM, 450)),
             ((1.5, 0.6, -8.0), 0.10, _c(COLD, 300)),
             ((-6.0, 3.0, -15.0), 0.20, _c(WARM, 150)),
             ((5.0, -2.0, -20.0), 0.25, [80.0, 24.0, 16.0]),
             ((0.0, -3.0, -25.0), 0.30, [18.0, 60.0, 24.0]),
             ((12.0, 6.0, -40.0), 0.60, _c(WARM, 40)),
             ((-14.0, -5.0, -36.0), 0.50, _c(COLD, 60))]
    for p, r, c in lamps:
        L.append(dict(kind="sphere", pos=list(p), scale=r, radiance=c))
    # a disc lamp facing the camera
    L.append(dict(kind="disk", pos=[-10.0, -4.0, -30.0], scale=0.5, radiance=_c(COLD, 40)))
    return L


def scene_ground():
    return [ground(("checker", [0.15, 0.14, 0.12], [0.8, 0.75, 0.65], 175)),
            dome([1.2, 1.6, 2.6])]


def scene_street():
    S = []
    W, H, Z0, Z1 = 6.0, 20.0, 20.0, -80.0
    zc, zh = (Z0 + Z1) / 2, (Z0 - Z1) / 2
    yc = GROUND_Y + H / 2
    road = np.full((64, 8, 3), [0.04, 0.04, 0.045], np.float32)
    road[::8, 3:5] = [0.6, 0.6, 0.55]
    road[1::8, 3:5] = [0.6, 0.6, 0.55]
    road[2::8, 3:5] = [0.6, 0.6, 0.55]
    S.append(dict(kind="rectangle", pos=[0, GROUND_Y, zc], scale=[W, zh, 1], rot=[("x", -90)],
                  radiance=("bitmap", road, [1, 4])))
    S.append(dict(kind="rectangle", pos=[-W, yc, zc], scale=[zh, H / 2, 1], rot=[("y", 90)],
                  radiance=("bitmap", tex_windows(1, [0.10, 0.08, 0.06], [1.0, 0.75, 0.4], n_x=25, n_y=6), [1, 1])))
    S.append(dict(kind="rectangle", pos=[W, yc, zc], scale=[zh, H / 2, 1], rot=[("y", -90)],
                  radiance=("bitmap", tex_windows(2, [0.07, 0.08, 0.10], [0.6, 0.8, 1.0], n_x=25, n_y=6), [1, 1])))
    S.append(dict(kind="rectangle", pos=[0, yc, Z1], scale=[W, H / 2, 1],
                  radiance=("bitmap", tex_windows(3, [0.09, 0.09, 0.09], [1.0, 0.9, 0.6], n_x=4, n_y=6), [1, 1])))
    for z in [5.0, -5.0, -20.0, -35.0, -50.0, -65.0]:
        for x in (-4.6, 4.6):
            S.append(dict(kind="sphere", pos=[x, 3.0, z], scale=0.2, radiance=_c(WARM, 150)))
    S.append(dome([0.25, 0.30, 0.50]))
    return S


def scene_skyline():
    # At 1000 m every medium here extinguishes the sky completely (haze: tau = 28), so this scene
    # puts its bright sky at NEAR_DOME_R = 150 m (haze tau 4.2): a visible sky around silhouettes.
    S = [dome([3.0, 3.8, 5.0], NEAR_DOME_R), ground([0.01, 0.01, 0.01], half=NEAR_DOME_R)]
    dark = [0.01, 0.01, 0.01]
    # (centre x, centre z, half width, height, half depth); sky above rows ~40-80, one tower past
    # the top edge, buildings past the left and right edges
    for cx, cz, hw, h, hd in [(-9, -16, 3, 5, 3), (4, -30, 3, 14, 3), (-3, -50, 5, 10, 5),
                              (30, -60, 6, 16, 6), (-25, -70, 8, 12, 8), (20, -38, 4, 9, 4),
                              (8, -90, 10, 8, 6), (-40, -30, 6, 20, 6)]:
        S.append(box([cx, GROUND_Y + h / 2, cz], [hw, h / 2, hd], dark))
    return S


def scene_objects():
    S = [frustum_rect(35.0, ("bitmap", tex_gradient([0.12, 0.11, 0.10], [0.04, 0.05, 0.06]), [1, 1]))]
    S.append(box([-1.0, -0.5, -3.5], [0.35, 0.35, 0.35], ("checker", [0.4, 0.4, 0.4], [2.0, 1.8, 1.5], 4), yaw=30))
    S.append(dict(kind="sphere", pos=[1.5, 0.3, -6.0], scale=0.6,
                  radiance=("bitmap", tex_stripes([[2.5, 0.4, 0.3], [0.3, 2.0, 0.5], [0.4, 0.6, 3.0]], n=9), [1, 1])))
    S.append(box([3.0, -2.0, -12.0], [1.0, 1.0, 1.0], ("checker", [0.2, 0.4, 1.5], [2.0, 1.6, 0.3], 3)))
    S.append(dict(kind="sphere", pos=[-4.0, 2.0, -18.0], scale=1.5, radiance=[3.0, 1.2, 0.4]))
    S.append(box([6.0, 3.0, -28.0], [2.0, 2.0, 2.0], ("checker", [0.3, 1.2, 0.3], [1.2, 0.3, 1.1], 2), yaw=40))
    return S


def scene_signs():          # held out, nothing outside the frame
    S = [frustum_rect(80.0, None)]   # black, non-emissive far wall (closes the scene)
    signs = [((-1.5, 0.8, -4.0), (0.4, 0.15), 0, [8.0, 1.0, 0.8], [0.3, 0.02, 0.02], 0),
             ((2.5, -0.5, -9.0), (0.75, 0.3), 1, [3.0, 4.0, 6.0], [0.2, 0.2, 0.3], 0),
             ((4.0, -2.0, -15.0), (1.0, 0.5), 2, [6.0, 3.0, 0.5], [0.4, 0.1, 0.0], -40),
             ((-6.0, 2.5, -20.0), (1.5, 0.6), 3, [1.0, 6.0, 2.0], [0.05, 0.3, 0.1], 0),
             ((8.0, 4.0, -35.0), (2.0, 1.0), 4, [6.0, 5.0, 1.0], [0.3, 0.25, 0.05], 0),
             ((-12.0, -6.0, -55.0), (3.0, 1.0), 5, [5.0, 1.0, 5.0], [0.2, 0.02, 0.2], 0),
             ((0.0, 10.0, -70.0), (4.0, 1.5), 6, [1.0, 4.0, 5.0], [0.05, 0.2, 0.25], 0)]
    for p, (sx, sy), seed, fg, bg, yaw in signs:
        S.append(dict(kind="rectangle", pos=list(p), scale=[sx, sy, 1], rot=[("y", yaw)] if yaw else [],
                      radiance=("bitmap", tex_text(seed, bg, fg), [1, 1])))
    return S


def scene_plaza():          # held out, continues past the frame
    S = [ground(("checker", [0.05, 0.045, 0.04], [0.12, 0.11, 0.09], 350)), dome([0.03, 0.04, 0.08])]
    win = lambda seed, lit: ("bitmap", tex_windows(seed, [0.06, 0.05, 0.05], lit, n_x=10, n_y=8), [1, 1])
    S.append(box([-21.0, GROUND_Y + 12.5, -35.0], [9.0, 12.5, 25.0], win(11, [1.0, 0.8, 0.5])))
    S.append(box([25.0, GROUND_Y + 17.5, -35.0], [15.0, 17.5, 15.0], win(12, [0.7, 0.85, 1.0])))
    S.append(box([0.0, GROUND_Y + 9.0, -78.0], [15.0, 9.0, 7.0], win(13, [1.0, 0.9, 0.7])))
    S.append(box([3.0, GROUND_Y + 1.0, -10.0], [1.0, 1.0, 1.0], ("checker", [0.5, 0.1, 0.1], [2.0, 1.5, 0.3], 2), yaw=20))
    for p in [(-8, 2.9, -8), (8, 2.9, -15), (-8, 2.9, -25), (0, 2.9, 5), (6, 2.9, -40), (-6, 2.9, -50),
              (10, 2.9, 2)]:
        S.append(dict(kind="sphere", pos=list(map(float, p)), scale=0.25, radiance=_c([1.0, 0.75, 0.45], 200)))
    return S


# ---------------------------------------------------------------- night scenes with known lights
# Point lights (Mitsuba `point` emitters, radiant intensity in image radiance x m^2, which is
# fogcli's `intensity`) in the medium, camera space; nothing reflects, so a light shows only
# through the medium. Rendered into renders-lights/ (render.py --lights); fogcli gets the same
# lights as `lights:` entries (tools/lights.py).
def scene_quay():           # continues past the frame; a light outside the frame and one behind
    S = [ground(("checker", [0.012, 0.012, 0.014], [0.03, 0.028, 0.026], 350)), dome([0.004, 0.005, 0.01])]
    win = lambda seed, lit: ("bitmap", tex_windows(seed, [0.02, 0.02, 0.02], lit, n_x=10, n_y=6, frac=0.3), [1, 1])
    S.append(box([-18.0, GROUND_Y + 6.0, -40.0], [6.0, 6.0, 20.0], win(21, [0.5, 0.4, 0.25])))
    S.append(box([16.0, GROUND_Y + 8.0, -55.0], [8.0, 8.0, 10.0], win(22, [0.3, 0.4, 0.5])))
    S.append(box([2.0, GROUND_Y + 0.6, -9.0], [1.2, 0.6, 0.6], ("checker", [0.05, 0.05, 0.06], [0.3, 0.25, 0.2], 3)))
    return S


def scene_yard():           # held out; closed by a black wall, lights in and beside the frame
    S = [frustum_rect(40.0, None),
         box([-2.5, -1.0, -12.0], [1.0, 1.0, 1.0], ("checker", [0.03, 0.03, 0.03], [0.4, 0.3, 0.2], 2), yaw=25),
         dict(kind="rectangle", pos=[3.0, 0.5, -20.0], scale=[2.0, 1.0, 1], radiance=("bitmap", tex_text(31, [0.02, 0.02, 0.05], [0.6, 0.5, 1.2]), [1, 1]))]
    return S


def scene_panel():          # held out, continues past the frame: lit panels cut by the frame's edges
    # issue 40's hidden case, as its text describes it: a bright panel half outside the
    # frame (here the right edge cuts it at 8 m) and one across the bottom-left corner
    # (4 m); a black wall closes the view, so all scattered light is the panels'
    S = [frustum_rect(60.0, None),
         dict(kind="rectangle", pos=[8.0 * TAN_X, 0.4, -8.0], scale=[1.6, 1.0, 1],
              radiance=("bitmap", tex_text(41, [1.5, 1.4, 1.2], [5.0, 4.4, 3.4]), [1, 1])),
         dict(kind="rectangle", pos=[-4.0 * TAN_X, -4.0 * TAN_Y, -4.0], scale=[0.7, 0.45, 1],
              radiance=("bitmap", tex_windows(42, [0.25, 0.3, 0.45], [1.8, 2.2, 3.0], n_x=4, n_y=3), [1, 1]))]
    return S


def scene_edges():          # calibration, continues past the frame: what border_margin is chosen on
    # lit surfaces cut by the frame's edges, each at another depth and another share of it
    # outside (0.3, 0.6, 0.5: an edge cuts a surface at no particular place), black beyond
    # them; unlike the held-out `panel` (session 43 chose the margin with it in view)
    top, left = 5.0 * TAN_Y, -12.0 * TAN_X
    right, bottom = 20.0 * TAN_X, -20.0 * TAN_Y
    S = [frustum_rect(45.0, None),
         dict(kind="rectangle", pos=[0.6, top - 0.6 + 2 * 0.6 * 0.3, -5.0], scale=[1.5, 0.6, 1],
              radiance=("bitmap", tex_text(51, [0.9, 1.1, 1.4], [4.0, 4.5, 5.5]), [1, 1])),
         dict(kind="rectangle", pos=[left + 2.5 - 2 * 2.5 * 0.6, 1.0, -12.0], scale=[2.5, 3.0, 1],
              radiance=("bitmap", tex_windows(52, [0.3, 0.25, 0.2], [2.5, 1.9, 1.1], n_x=5, n_y=6), [1, 1])),
         dict(kind="rectangle", pos=[right, bottom, -20.0], scale=[2.0, 1.2, 1],
              radiance=("bitmap", tex_text(53, [1.2, 0.5, 0.4], [5.0, 2.5, 1.5]), [1, 1]))]
    return S


def scene_cuts(seed):
    """Calibration, continues past the frame: three lit rectangles facing the camera, each
    cut by an edge or a corner drawn at random (seeded), at a random depth (4-25 m), size and
    share outside (0.2-0.8 of its width or height past the edge); black beyond them. More of
    what `edges` is, drawn rather than placed, so that the border is chosen on cuts at no
    particular place."""
    rng = _rng(seed)
    S = [frustum_rect(50.0, None)]
    for i, side in enumerate(rng.choice(["top", "bottom", "left", "right", "corner"], 3, replace=False)):
        z = float(rng.uniform(4.0, 25.0))
        hw, hh = float(rng.uniform(0.06, 0.2)) * z, float(rng.uniform(0.04, 0.12)) * z
        out = float(rng.uniform(0.2, 0.8))
        ex, ey = z * TAN_X, z * TAN_Y
        x, y = float(rng.uniform(-0.5, 0.5)) * ex, float(rng.uniform(-0.5, 0.5)) * ey
        if side in ("left", "right", "corner"):
            x = (1 if side != "left" else -1) * (ex - hw + 2 * hw * out)
        if side in ("top", "bottom", "corner"):
            y = (1 if side == "top" else -1) * (ey - hh + 2 * hh * out)
        fg = (rng.uniform(0.3, 1.0, 3) * rng.uniform(2.0, 5.0)).tolist()
        bg = (np.asarray(fg) * rng.uniform(0.1, 0.4)).tolist()
        tex = tex_text(seed * 10 + i, bg, fg) if i % 2 == 0 else tex_windows(seed * 10 + i, bg, fg, n_x=5, n_y=4)
        S.append(dict(kind="rectangle", pos=[x, y, -z], scale=[hw, hh, 1], radiance=("bitmap", tex, [1, 1])))
    return S


LIGHTS = {
    "quay": [((-3.0, 2.5, -12.0), _c(WARM, 20.0)), ((5.0, 3.5, -28.0), _c(COLD, 50.0)),
             ((-16.0, 3.0, -9.0), _c(WARM, 40.0)), ((2.0, 3.0, 4.0), [20.0, 20.0, 20.0])],
    "yard": [((0.5, 1.2, -7.0), _c(WARM, 10.0)), ((-5.0, -0.5, -22.0), [14.0, 30.0, 20.0]),
             ((7.0, 1.0, -4.0), _c(COLD, 14.0))],
}

SCENES = {
    "lamps":   dict(build=scene_lamps,   outside=False, heldout=False),
    "ground":  dict(build=scene_ground,  outside=True,  heldout=False),
    "street":  dict(build=scene_street,  outside=True,  heldout=False),
    "skyline": dict(build=scene_skyline, outside=True,  heldout=False),
    "objects": dict(build=scene_objects, outside=False, heldout=False),
    "signs":   dict(build=scene_signs,   outside=False, heldout=True),
    "plaza":   dict(build=scene_plaza,   outside=True,  heldout=True),
    "quay":    dict(build=scene_quay,    outside=True,  heldout=False, lights=True),
    "yard":    dict(build=scene_yard,    outside=False, heldout=True,  lights=True),
    "panel":   dict(build=scene_panel,   outside=True,  heldout=True),
    "edges":   dict(build=scene_edges,   outside=True,  heldout=False),
    "cuts1":   dict(build=lambda: scene_cuts(61), outside=True, heldout=False),
    "cuts2":   dict(build=lambda: scene_cuts(62), outside=True, heldout=False),
    "cuts3":   dict(build=lambda: scene_cuts(63), outside=True, heldout=False),
    "cuts4":   dict(build=lambda: scene_cuts(64), outside=True, heldout=False),
}


# ---------------------------------------------------------------- Mitsuba dicts
def camera_directions(width=WIDTH, height=HEIGHT, fov=FOV):
    """fogcli's per-pixel camera-space ray directions (not normalised), shape (H, W, 3)."""
    f = (width / 2) / math.tan(math.radians(fov) / 2)
    i = np.arange(width) + 0.5
    j = np.arange(height) + 0.5
    x = (i[None, :] - width / 2) / f
    y = -(j[:, None] - height / 2) / f
    return np.stack(np.broadcast_arrays(x, y, -np.ones_like(x)), -1)


def _transform(shape):
    import mitsuba as mi
    T = mi.ScalarTransform4f().translate(shape["pos"])
    for axis, deg in shape.get("rot", []):
        T = T.rotate({"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}[axis], deg)
    s = shape["scale"]
    T = T.scale(s if isinstance(s, list) else [s, s, s])
    return T


def _radiance(r):
    import mitsuba as mi
    if isinstance(r, (int, float)):
        return {"type": "rgb", "value": [float(r)] * 3}
    if isinstance(r, list):
        return {"type": "rgb", "value": r}
    if r[0] == "checker":      # (Mitsuba's checkerboard texture clamps to [0, 1]: use a 2x2 bitmap)
        _, c0, c1, n = r
        arr = np.array([[c0, c1], [c1, c0]], np.float32)
        return _radiance(("bitmap", arr, [n, n]))
    if r[0] == "bitmap":
        _, arr, rep = r
        return {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(arr[::-1], np.float32)),
                "raw": True, "filter_type": "nearest", "wrap_mode": "repeat",
                "to_uv": mi.ScalarTransform4f().scale([rep[0], rep[1], 1])}
    raise ValueError(r)


def mitsuba_scene(name, medium=None, spp=16, integrator=None, sampler=None, fov=FOV,
                  width=WIDTH, height=HEIGHT, max_depth=-1, rr_depth=5):
    """Mitsuba dict for scene `name` in `medium` (a MEDIA entry/dict, or None = vacuum).

    integrator: None -> volpath (medium) / path (vacuum; surfaces are black, so one bounce)."""
    import mitsuba as mi
    shapes = SCENES[name]["build"]() if isinstance(name, str) else name
    d = {"type": "scene"}
    if integrator is None:
        integrator = {"type": "volpath", "max_depth": max_depth, "rr_depth": rr_depth}
    d["integrator"] = integrator
    sensor = {"type": "perspective", "fov": fov, "fov_axis": "x",
              "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 0, -1], up=[0, 1, 0]),
              "near_clip": 1e-3, "far_clip": 1e5,
              "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                       "pixel_format": "rgb", "component_format": "float32"},
              "sampler": sampler or {"type": "independent", "sample_count": spp}}
    if medium is not None:
        d["fogmedium"] = mitsuba_medium(medium)
        sensor["medium"] = {"type": "ref", "id": "fogmedium"}
    d["sensor"] = sensor
    for k, s in enumerate(shapes):
        sd = {"type": s["kind"], "to_world": _transform(s),
              "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}}
        if s.get("flip"):
            sd["flip_normals"] = True
        if s.get("radiance") is not None:
            sd["emitter"] = {"type": "area", "radiance": _radiance(s["radiance"])}
        if medium is not None:
            sd["exterior"] = {"type": "ref", "id": "fogmedium"}
            sd["interior"] = {"type": "ref", "id": "fogmedium"}
        d[f"shape{k:03d}"] = sd
    if medium is not None and isinstance(name, str):       # point lights only light the medium
        for k, (pos, I) in enumerate(LIGHTS.get(name, [])):
            d[f"light{k:02d}"] = {"type": "point", "position": list(pos),
                                  "intensity": {"type": "rgb", "value": list(map(float, I))}}
    return d
