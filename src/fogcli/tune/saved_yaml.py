"""The YAML that `fogcli tune` saves: only what differs from the preset, each key with the
config model's own description of it as a comment, read back to the same data."""
from __future__ import annotations

import yaml
from pydantic import BaseModel

from fogcli.config.model import Config


def prune(data: dict, base: dict) -> dict:
    """data without the keys whose values base already has (sections left empty dropped)."""
    out = {}
    for k, v in data.items():
        b = base.get(k) if isinstance(base, dict) else None
        if isinstance(v, dict) and isinstance(b, dict):
            sub = prune(v, b)
            if sub:
                out[k] = sub
        elif k not in (base or {}) or v != b:
            out[k] = v
    return out


def _flow(v) -> str:
    """One value as YAML on one line."""
    return yaml.safe_dump([v], default_flow_style=True, sort_keys=False, width=10_000).strip()[1:-1]


def _model_of(model, key: str):
    """The sub-model class of a section's key (render.lights: LightsRender), else None."""
    f = getattr(model, "model_fields", {}).get(key) if model is not None else None
    t = getattr(f, "annotation", None)
    return t if isinstance(t, type) and issubclass(t, BaseModel) else None


def _emit(data: dict, model, depth: int, lines: list) -> None:
    pad = "  " * depth
    for k, v in data.items():
        f = getattr(model, "model_fields", {}).get(k) if model is not None else None
        if f is not None and f.description:
            lines.append(f"{pad}# {f.description}")
        sub = _model_of(model, k)
        if isinstance(v, dict) and sub is not None:
            lines.append(f"{pad}{k}:")
            _emit(v, sub, depth + 1, lines)
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            lines.append(f"{pad}{k}:")
            lines += [f"{pad}  - {_flow(x)}" for x in v]
        else:
            lines.append(f"{pad}{k}: {_flow(v)}")


def commented_yaml(data: dict, preset: str, image: str) -> str:
    head = [f"# fogcli tune on {image}: what differs from the medium {preset}.",
            f"#   fogcli apply {image} --medium {preset} --config THIS_FILE", ""]
    body: list = []
    _emit(data, Config, 0, body)
    text = "\n".join(head + body) + "\n"
    if (yaml.safe_load(text) or {}) != data:      # never a file that says other than the page
        text = "\n".join(head) + "\n" + yaml.safe_dump(data, sort_keys=False)
    return text
