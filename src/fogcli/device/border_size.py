"""The sizes of `render.border`: how far the frame's edge is continued, as what band, at
which level, and whether the tabulated point spread runs at all."""
from __future__ import annotations

from fogcli.config.model import Config

# render.border: extend: a band pixel stands for the surface past the edge only if its log P is
# within this of the end pixel's (about 10 % in depth in a homogeneous medium): a lamp or a
# pole a few pixels in is not continued (kernels/edge_bands.h; plaza-fog's lamp 5 px from the
# edge went on past it as a bright strip without it)
EDGE_BAND_LOGP = 0.1
EXT_LEVEL = 3   # render.border: extend spreads the continued edge at level 3's resolution (1/8)


def open_border(cfg: Config) -> bool:
    """Light that crosses the frame's edge (or the edge continued, `extend`) leaves. `extend`
    needs the tabulated point spread; with the Gaussian one it continues the edge without
    limit, which is the closed border."""
    return cfg.render.border == "open" or (cfg.render.border == "extend" and uses_apsf(cfg))


def border_margin(cfg: Config, width: int, height: int) -> tuple[int, int]:
    """`render.border: extend`: pixels the frame's edge is continued by on each side (x, y)."""
    if cfg.render.border != "extend" or not uses_apsf(cfg):
        return 0, 0
    f = cfg.render.border_margin
    return int(round(f * width)), int(round(f * height))


def border_band(cfg: Config, width: int, height: int) -> tuple[int, int]:
    """`render.border: extend`: the columns (x) and rows (y) next to each edge whose mean the
    continued edge is (at least the edge pixel, at most the frame)."""
    f = cfg.render.border_band
    return (min(width, max(1, int(round(f * width)))), min(height, max(1, int(round(f * height)))))


def edge_entries(width: int, height: int) -> int:
    """What the edge continues as is kept per entry (kernels/edge_bands.h, edge_entries): each
    row's left and right end, each column's top and bottom end and the four corners."""
    return 2 * (width + height) + 4


def edge_band_bytes(width: int, height: int) -> int:
    """Two float4 an entry: the pyramid's band terms (edge_bands), or the reference's entries
    followed by its two blurred rows of `width` (ref_edge_profiles, ref_profile_rows)."""
    return 32 * edge_entries(width, height)


def ext_level(cfg: Config, width: int, height: int) -> int:
    """The level at whose resolution `border: extend` spreads the continued edge: EXT_LEVEL,
    or finer where the margin is narrow, so that it is at least two of the level's pixels
    across. One cell wider than the margin puts the continued light half a cell out, too far
    to reach the frame through the narrowest blurs: a 7 px margin at level 3 added 0.76 of
    what the exact padding adds (tests/test_border_extend.py, 96 x 64 at the default margin)."""
    m = min([v for v in border_margin(cfg, width, height) if v] or [0])
    level = EXT_LEVEL
    while level > 1 and m < 2 * 2 ** level:
        level -= 1
    return level


def uses_apsf(cfg: Config) -> bool:
    """The tabulated point spread runs in the source collapse and in the reference."""
    r = cfg.render
    return r.psf == "apsf" and (r.method == "reference" or (r.method == "pyramid" and r.fetch == "source"))
