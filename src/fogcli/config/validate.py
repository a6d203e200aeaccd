"""A config's data (YAML, --set, a jobs file's line) checked against the model: every
problem as one line naming its key and, where the data came from a file, its line; and the
resolved config back as data (`fogcli config --show`)."""
from __future__ import annotations

import difflib

from pydantic import BaseModel, ValidationError

from fogcli.config.model import (AutoLights, Config, DirectionalLight, Exponential, Homogeneous, Noise, PointLight,
                                 Sphere, SpotLight)
from fogcli.errors import UserError


def _fields_at(loc: tuple) -> list[str]:
    """The keys allowed where an unknown key was found."""
    model = Config
    for part in loc[:-1]:
        if isinstance(part, int) or model is None:
            continue
        if part == "density":
            return sorted({f for m in (Homogeneous, Exponential, Sphere, Noise) for f in m.model_fields})
        if part == "lights" and model is Config:
            return sorted({f for m in (PointLight, SpotLight, DirectionalLight, AutoLights) for f in m.model_fields})
        fld = model.model_fields.get(part)
        ann = getattr(fld, "annotation", None)
        model = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
    return list(model.model_fields) if model is not None else []


def _message(err: dict) -> tuple[str, str]:
    # union members and validators appear in the loc as names of their own: not keys
    loc = tuple(p for p in err["loc"] if isinstance(p, int) or not (
        p in ("homogeneous", "exponential", "sphere", "noise", "point", "spot", "directional", "auto")
        or any(ch in p for ch in "[-(")))
    kind, msg, got = err["type"], err["msg"], err.get("input")
    if kind == "extra_forbidden":
        allowed = _fields_at(loc)
        hint = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        msg = f"unknown key (did you mean {hint[0]}?)" if hint else f"unknown key (expected one of: {', '.join(allowed)})"
    elif kind == "value_error":
        msg = msg.removeprefix("Value error, ")
        if msg.startswith("[") and "]: " in msg:     # an item of a list
            idx, msg = msg[1:].split("]: ", 1)
            loc = loc + (int(idx),)
        elif ": " in msg and msg.split(": ", 1)[0].replace(".", "").replace("_", "").isalpha():
            sub, msg = msg.split(": ", 1)      # a model validator naming its key
            loc = loc + tuple(sub.split("."))
    elif kind == "literal_error":
        msg = f"expected one of {err['ctx']['expected'].replace(' or ', ', ')}, got {got!r}".replace("'", "")
    elif kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        op = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}[kind]
        msg = f"expected a value {op} {list(err['ctx'].values())[0]}, got {got!r}"
    elif kind == "union_tag_invalid":
        msg = f"type: expected one of {err['ctx']['expected_tags'].replace(chr(39), '')}, got {got.get('type') if isinstance(got, dict) else got!r}"
    elif kind in ("model_type", "dict_type", "model_attributes_type"):
        msg = f"expected a mapping, got {got!r}"
    else:
        msg = f"{msg[0].lower()}{msg[1:]}, got {got!r}" if got is not None else msg
    path = ""
    for p in loc:
        path += f"[{p}]" if isinstance(p, int) else (f".{p}" if path else str(p))
    return path, msg


def _unset_nulls(d):
    """null means the default (a key written out with no value)."""
    if isinstance(d, dict):
        return {k: _unset_nulls(v) for k, v in d.items() if v is not None}
    return [_unset_nulls(v) for v in d] if isinstance(d, list) else d


def resolved_data(cfg: Config) -> dict:
    """The config as plain data with the image-independent `auto` values resolved (c,
    epsilon, threshold): what `fogcli config --show` prints."""
    def plain(v):
        return [plain(x) for x in v] if isinstance(v, (list, tuple)) else (
            {k: plain(x) for k, x in v.items() if x is not None} if isinstance(v, dict) else v)
    d = plain(cfg.model_dump())
    if not isinstance(cfg.medium.visibility, str):      # folded into absorption and scattering
        d["medium"].pop("visibility", None)
        d["medium"].pop("albedo", None)
    d["render"]["c"], d["render"]["epsilon"], d["render"]["threshold"] = cfg.render.resolved()
    return d


def problems_of(data: dict, locs: dict) -> tuple[Config | None, list[str]]:
    """(config, []) or (None, every problem as `file:line: key: message`, sorted by line)."""
    if not isinstance(data, dict):
        return None, ["expected a mapping of sections (medium, camera, render, output, lights, limits)"]
    try:
        return Config.model_validate(_unset_nulls(data)), []
    except ValidationError as exc:
        out, seen = [], {}
        for err in exc.errors(include_url=False):
            path, msg = _message(err)
            if path in seen:            # the other members of a union (a number or auto)
                if "auto" in msg and "or auto" not in out[seen[path]][3]:
                    out[seen[path]] = out[seen[path]][:3] + (out[seen[path]][3] + " (or auto)",)
                continue
            up, loc = path, locs.get(path)
            while loc is None and up:       # the line of the key, else of the nearest enclosing one
                up = up.rsplit("[", 1)[0] if up.endswith("]") else (up.rsplit(".", 1)[0] if "." in up else "")
                loc = locs.get(up)
            seen[path] = len(out)
            where = f"{loc}: " if loc and str(loc) != f"--set {path}" else ""   # --set names the key already
            out.append((str(loc.source) if loc else "", (loc.line or 0) if loc else 0, where,
                        f"{path}: {msg}" if where or not loc else f"{loc}: {msg}"))
        out.sort(key=lambda t: (t[0], t[1]))
        return None, [w + m for _, _, w, m in dict.fromkeys(out)]


def build(data: dict, locs: dict) -> Config:
    cfg, problems = problems_of(data, locs)
    if problems:
        more = f" (and {len(problems) - 1} more problem{'s' if len(problems) > 2 else ''})" if len(problems) > 1 else ""
        raise UserError(problems[0] + more)
    return cfg
