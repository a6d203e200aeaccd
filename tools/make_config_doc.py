"""Writes the key reference of docs/config.md from the config model (src/fogcli/config.py):
every key with its default, allowed values or range, and its doc, as a YAML file that is
itself valid (tests/test_config.py checks both). Run: python tools/make_config_doc.py"""
from __future__ import annotations

import sys
import typing
from pathlib import Path

import annotated_types as at
from pydantic import BaseModel

DOC = Path(__file__).resolve().parents[1] / "docs" / "config.md"
BEGIN, END = "<!-- keys: begin -->", "<!-- keys: end -->"     # tools/docblock.markers("keys")


def _walk(tp, lits: list, bounds: list) -> None:
    """Literal choices and numeric bounds anywhere in an annotation."""
    origin = typing.get_origin(tp)
    if origin is typing.Literal:
        lits.extend(typing.get_args(tp))
    elif origin is typing.Annotated:
        base, *meta = typing.get_args(tp)
        _walk(base, lits, bounds)
        for m in meta:
            for c in getattr(m, "metadata", [m]):
                for cls, op, attr in ((at.Gt, ">", "gt"), (at.Ge, ">=", "ge"), (at.Lt, "<", "lt"), (at.Le, "<=", "le")):
                    if isinstance(c, cls):
                        bounds.append(f"{op} {getattr(c, attr):g}")
    else:
        for a in typing.get_args(tp):
            _walk(a, lits, bounds)


def _value(v) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return f"{v:g}" if isinstance(v, float) else str(v)


def _lines(model: type[BaseModel], indent: int) -> list[str]:
    from fogcli.config.model import AutoLights, DirectionalLight, Exponential, Homogeneous, PointLight, Sphere, SpotLight

    out = []
    for name, fld in model.model_fields.items():
        pad = "  " * indent
        ann = fld.annotation
        sub = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
        if sub is not None:
            out.append(f"{pad}{name}:" + (f"  # {fld.description}" if fld.description else ""))
            out += _lines(sub, indent + 1)
            continue
        if name == "density":
            out.append(f"{pad}density:  # {fld.description}")
            for prim in (Homogeneous, Exponential, Sphere):
                kind = typing.get_args(prim.model_fields["type"].annotation)[0]
                keys = ", ".join(f"{k}: {_value(f.default)}" for k, f in prim.model_fields.items() if k != "type")
                out.append(f"{pad}  {'' if prim is Homogeneous else '# '}- {{type: {kind}, {keys}}}")
            for k, f in {**Exponential.model_fields, **Sphere.model_fields}.items():
                if f.description and k != "type":
                    out.append(f"{pad}  #   {k}: {f.description}")
            continue
        if name == "lights" and indent == 0:
            out.append(f"lights: []  # {fld.description}, entries as below")
            examples = {PointLight: "position: [1, 2, -8], intensity: [40, 30, 20]",
                        SpotLight: "position: [0, 3, 0], direction: [0, -1, -1], intensity: [200, 200, 180]",
                        DirectionalLight: "direction: [0.3, 1, 0.2], irradiance: [2, 2, 1.8]",
                        AutoLights: "threshold: auto"}
            for cls, ex in examples.items():
                kind = typing.get_args(cls.model_fields["type"].annotation)[0]
                out.append(f"  # - {{type: {kind}, {ex}}}")
            seen = set()
            for cls in examples:
                for k, f in cls.model_fields.items():
                    if k not in seen and k != "type":
                        seen.add(k)
                        dflt = "" if f.is_required() else f" (default {_value(f.default)})"
                        out.append(f"  #   {k}: {f.description}{dflt}")
            continue
        lits, bounds = [], []
        _walk(typing.Annotated[ann, *fld.metadata] if fld.metadata else ann, lits, bounds)
        allowed = " | ".join(map(_value, lits)) if len(lits) > 1 else ""
        extra = "; ".join(x for x in (allowed, ", ".join(bounds)) if x)
        doc = fld.description or ""
        out.append(f"{pad}{name}: {_value(fld.default)}  # {doc}" + (f" [{extra}]" if extra else ""))
    return out


def reference() -> str:
    from fogcli.config.model import Config

    return "```yaml\n" + "\n".join(_lines(Config, 0)) + "\n```\n"


def main() -> int:
    text = DOC.read_text()
    a, b = text.index(BEGIN) + len(BEGIN), text.index(END)
    DOC.write_text(text[:a] + "\n" + reference() + text[b:])
    print(f"wrote the key reference of {DOC}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
    sys.exit(main())
