"""Where config values come from: YAML files (every value remembers its file and line) and
--set items, merged in order preset < --medium file < --config < --camera < --set. Input is
screened before it is built: config files are small, so deep nesting, alias bombs and
tags are refused with the line they are on."""
from __future__ import annotations

import re
from pathlib import Path

import yaml

from fogcli.errors import UserError

class _Loader(yaml.SafeLoader):
    """YAML with 1.2-style floats, so that 1e9 and 5E-3 are numbers, as users expect."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*\.?[0-9_]*(?:[eE][-+]?[0-9]+)?|\.[0-9_]+(?:[eE][-+]?[0-9]+)?"
               r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))


class _Loc:
    """Where a value came from."""

    def __init__(self, source: str, line: int | None):
        self.source, self.line = source, line

    def __str__(self):
        return f"{self.source}:{self.line}" if self.line else self.source


# Config files are small: deeper nesting or more nodes (after aliases are expanded) than
# this is an attack or a mistake (billion laughs), refused before it costs time or memory.
MAX_DEPTH, MAX_NODES = 32, 20000
_PLAIN_TAGS = {f"tag:yaml.org,2002:{t}" for t in ("str", "int", "float", "bool", "null", "map", "seq")}


def _screen(text: str, source: str) -> None:
    """Depth, alias expansion and tags checked on the event stream (iterative, so a
    5000-deep flow list cannot exhaust Python's recursion before we refuse it)."""
    depth, anchors, stack = 0, {}, []     # stack: [anchor name, expanded size so far]
    total = 0
    for ev in yaml.parse(text, Loader=_Loader):
        line = ev.start_mark.line + 1
        tag = getattr(ev, "tag", None)
        if tag and tag not in _PLAIN_TAGS and tag not in ("!", "?"):
            raise UserError(f"{source}:{line}: invalid YAML: tag {tag} is not allowed (plain values only)")
        size = 0
        if isinstance(ev, yaml.AliasEvent):
            if ev.anchor not in anchors:
                raise UserError(f"{source}:{line}: invalid YAML: alias *{ev.anchor} is recursive or undefined")
            size = anchors[ev.anchor]
        elif isinstance(ev, yaml.ScalarEvent):
            size = 1 + len(ev.value) // 64        # long strings weigh more (an aliased 1 MB string)
            if ev.anchor:
                anchors[ev.anchor] = size
        elif isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                raise UserError(f"{source}:{line}: invalid YAML: nested deeper than {MAX_DEPTH} levels")
            stack.append([ev.anchor, 1])
            continue
        elif isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
            anchor, size = stack.pop()
            if anchor:
                anchors[anchor] = size
        else:
            continue
        if stack:
            stack[-1][1] += size
        total += size if not stack else 0
        if (stack and stack[-1][1] > MAX_NODES) or total > MAX_NODES:
            raise UserError(f"{source}:{line}: invalid YAML: expands to more than {MAX_NODES} values (aliases)")


def _node_to_py(node, source: str, path: str, locs: dict):
    locs[path] = _Loc(source, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        out = {}
        for knode, vnode in node.value:
            if not isinstance(knode, yaml.ScalarNode):
                raise UserError(f"{source}:{knode.start_mark.line + 1}: invalid YAML: a key must be a plain name")
            key = str(knode.value)
            if key in out:
                raise UserError(f"{source}:{knode.start_mark.line + 1}: {path + '.' if path else ''}{key}: duplicate key")
            child = f"{path}.{key}" if path else key
            out[key] = _node_to_py(vnode, source, child, locs)
            locs[child] = _Loc(source, knode.start_mark.line + 1)    # a key's problem is on the key's line
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_node_to_py(v, source, f"{path}[{i}]", locs) for i, v in enumerate(node.value)]
    return yaml.load(yaml.serialize(node), Loader=_Loader) if node.tag != "tag:yaml.org,2002:null" else None


def load_yaml(path: str | Path, locs: dict) -> dict:
    """Parse a YAML file into plain data, recording each key's line in ``locs``."""
    p = Path(path)
    if p.exists() and not p.is_file():
        raise UserError(f"{p}: not a regular file, expected a YAML config file")
    if p.is_file() and p.stat().st_size > 1_000_000:
        raise UserError(f"{p}: {p.stat().st_size} bytes; expected a small YAML config file")
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise UserError(f"{p}: config file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{p}: cannot read config file ({exc.__class__.__name__})") from None
    if not text.strip():           # empty, or blank lines and tabs only: no settings
        return {}
    try:
        _screen(text, str(p))
        node = yaml.compose(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        ctx, cmark = getattr(exc, "context", None) or "", getattr(exc, "context_mark", None)
        if cmark is not None and "flow" in ctx:
            # an unclosed [ or {: the parser notices on a later line; point at the bracket
            mark, problem = cmark, f"{ctx[len('while parsing a '):] if ctx.startswith('while parsing a ') else ctx} " \
                f"opened here is not closed ({problem})"
        line = f":{mark.line + 1}" if mark else ""
        raise UserError(f"{p}{line}: invalid YAML: {problem}") from None
    except RecursionError:
        raise UserError(f"{p}: invalid YAML: nested too deeply") from None
    if node is None:
        return {}
    if not isinstance(node, yaml.MappingNode):
        raise UserError(f"{p}:{node.start_mark.line + 1}: expected a mapping of sections (medium, camera, render, output)")
    try:
        return _node_to_py(node, str(p), "", locs)
    except (yaml.YAMLError, ValueError) as exc:   # a scalar YAML cannot convert (4300+ digit integers)
        if isinstance(exc, UserError):
            raise
        raise UserError(f"{p}: invalid YAML value ({str(exc).splitlines()[0][:80]})") from None


def parse_set(item: str, locs: dict) -> dict:
    """``--set render.kernel=6`` -> {'render': {'kernel': 6}}; the value is YAML."""
    if "=" not in item:
        raise UserError(f"--set {item!r}: expected KEY=VALUE, e.g. render.kernel=6")
    key, value = item.split("=", 1)
    parts = key.strip().split(".")
    if not all(parts):
        raise UserError(f"--set {item[:60]!r}: empty key part")
    if len(item) > 10_000:
        raise UserError(f"--set {key[:60]}: value of {len(value)} characters; expected a short YAML value")
    if not value.strip():       # a typo or an unset shell variable, not a wish to unset the key
        raise UserError(f"--set {key.strip()}=: empty value; expected a YAML value (null to unset the key)")
    try:
        _screen(value, f"--set {key.strip()}")
        val = yaml.load(value, Loader=_Loader)
    except (yaml.YAMLError, ValueError):   # ValueError: an integer of more than 4300 digits
        raise UserError(f"--set {key.strip()}: value is not valid YAML") from None
    out: dict = {}
    cur = out
    for p in parts[:-1]:
        cur = cur.setdefault(p, {})
    cur[parts[-1]] = val
    _record(out, "", _Loc(f"--set {key.strip()}", None), locs)
    return out


def _record(data, path, loc, locs):
    locs[path] = loc
    if isinstance(data, dict):
        for k, v in data.items():
            _record(v, f"{path}.{k}" if path else k, loc, locs)


# Within `medium`, the two ways of giving the coefficients exclude each other: a later
# source that uses one form drops the other form from earlier sources.
_FORM_A = ("absorption", "scattering")
_FORM_B = ("visibility",)


def merge(base: dict, new: dict) -> dict:
    out = dict(base)
    for k, v in new.items():
        if k == "medium" and isinstance(v, dict) and isinstance(out.get(k), dict):
            med = dict(out[k])
            if any(x in v for x in _FORM_A):
                for x in _FORM_B + ("albedo",):
                    med.pop(x, None)
            relative = isinstance(v.get("visibility"), str) and v["visibility"].strip().endswith("%")
            if any(x in v for x in _FORM_B) and not relative:     # a relative one scales them instead
                for x in _FORM_A:
                    med.pop(x, None)
            out[k] = merge(med, {kk: vv for kk, vv in v.items()})
        elif isinstance(v, dict) and isinstance(out.get(k), dict) and k != "density":
            out[k] = merge(out[k], v)
        else:
            out[k] = v
    return out
