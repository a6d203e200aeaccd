"""Medium presets (configs/*.yaml shipped in the package) and the config assembly
preset < --medium file < --config < --set."""
from __future__ import annotations

from pathlib import Path

from fogcli.config import model as C
from fogcli.config import yaml_source as S
from fogcli.config.validate import build, problems_of
from fogcli.errors import UserError

PRESET_DIR = Path(__file__).resolve().parent / "media"
DEFAULT_MEDIUM = "fog"


def presets() -> dict[str, Path]:
    return {p.stem: p for p in sorted(PRESET_DIR.glob("*.yaml"))}


def describe(path: Path) -> str:
    """The preset's first comment line."""
    for line in path.read_text().splitlines():
        if line.startswith("#"):
            return line.lstrip("# ").strip()
    return ""


def _medium_source(name: str) -> Path:
    p = Path(name)
    if p.suffix.lower() in (".yaml", ".yml") or p.exists():
        if not p.is_file():
            raise UserError(f"--medium {name}: file not found")
        return p
    table = presets()
    if name not in table:
        raise UserError(f"--medium {name}: no such preset (have: {', '.join(table)}) and no such file")
    return table[name]


def assemble(medium: str | None = None, config_file: str | list | None = None,
             sets: tuple[str, ...] = (), camera_file: str | None = None,
             camera_section: dict | None = None) -> C.Config:
    """Merge the sources in order (preset < --medium < --config < --camera < --set) and
    validate once."""
    locs: dict = {}
    data = S.merge(medium_data(medium, locs), given_data(config_file, camera_file, camera_section, locs))
    for item in sets:
        data = S.merge(data, S.parse_set(item, locs))
    return build(data, locs)


def medium_data(medium: str | None, locs: dict) -> dict:
    """The preset's (or --medium file's) data, unvalidated."""
    return S.load_yaml(_medium_source(medium or DEFAULT_MEDIUM), locs)


def given_data(config_file: str | list | None = None, camera_file: str | None = None,
               camera_section: dict | None = None, locs: dict | None = None) -> dict:
    """What the --config files and the camera add to the medium, merged in order, unvalidated."""
    locs = {} if locs is None else locs
    data: dict = {}
    for f in ([config_file] if isinstance(config_file, str) else config_file or []):
        data = S.merge(data, S.load_yaml(f, locs))
    if camera_file:
        from fogcli.config.intrinsics import load

        data = S.merge(data, load(camera_file))
    if camera_section:
        data = S.merge(data, {"camera": dict(camera_section)})
    return data


def check_file(path: str) -> list[str]:
    """Every problem of one config file (empty when fine)."""
    locs: dict = {}
    try:
        data = S.load_yaml(path, locs)
    except UserError as exc:
        return [str(exc)]
    _, problems = problems_of(data, locs)
    return problems


def visibility_m(m: C.Medium) -> float:
    """Koschmieder visibility of the mean extinction at density 1 (inf: no extinction)."""
    st = sum(a + b for a, b in zip(m.absorption, m.scattering)) / 3.0
    return C.VISIBILITY_CONTRAST / st if st > 0 else float("inf")
