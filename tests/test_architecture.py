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
    for p in sorted([*root.rglob("*.cl"), *root.rglob("*.h")]):      # the kernels: lines only
        n = len(p.read_text().splitlines())
        if n > MAX_MODULE:
            out.append(f"{p.relative_to(root)}: {n} lines")
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
    kernel = tmp_path / "k"
    kernel.mkdir()
    (kernel / "long.cl").write_text("int x;\n" * (MAX_MODULE + 1))
    assert oversized(kernel) == [f"long.cl: {MAX_MODULE + 1} lines"]
    pkg = planted(tmp_path, "errors.py", "def _planted():\n" + "    x = 1\n" * MAX_FUNCTION)
    assert oversized(pkg / "fogcli") == ["errors.py:" + str(len((SRC / "errors.py").read_text().splitlines()) + 3)
                                         + " _planted: 81 lines"]


# What a runtime needs besides its modules: the kernels, the presets, the shipped tables.
def _package_data() -> tuple:
    """The runtime's data files as pyproject.toml declares them (package-data), as wheel paths."""
    import tomllib

    decl = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    return tuple(f"{pkg.replace('.', '/')}/{pat}" for pkg, pats in decl.items() for pat in pats)


DATA = _package_data()
REACHED = textwrap.dedent("""
    import grimp

    g = grimp.build_graph("fogcli", cache_dir=None)
    roots = ("fogcli", "fogcli.__main__", "fogcli.cli", "fogcli.api")
    print(sorted(set(roots).union(*(g.find_upstream_modules(r) for r in roots))))
""")


def wheel_problems(files: list[str], reached: set[str]) -> list[str]:
    """Files of the wheel that the runtime does not import and that are not its data."""
    import fnmatch

    out = []
    for f in files:
        if f.startswith("fogcli-") and ".dist-info/" in f:
            continue
        if f.endswith(".py"):
            mod = f[:-3].replace("/", ".").removesuffix(".__init__")
            package = f.endswith("/__init__.py") and any(m.startswith(mod + ".") for m in reached)
            if mod not in reached and not package:
                out.append(f"{f}: not imported by the runtime")
        elif not any(fnmatch.fnmatch(f, d) for d in DATA):
            out.append(f"{f}: neither a module nor the runtime's data")
    return out


def test_the_wheel_holds_the_runtime_and_its_data_only(tmp_path):
    import zipfile

    tree = tmp_path / "tree"       # built from a copy: the build writes into its source folder
    tree.mkdir()
    shutil.copytree(ROOT / "src", tree / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for f in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / f, tree / f)
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path / "wheel"),
                        str(tree)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    (wheel,) = (tmp_path / "wheel").glob("fogcli-*.whl")
    files = zipfile.ZipFile(wheel).namelist()
    r = subprocess.run([sys.executable, "-c", REACHED], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 0, r.stderr
    reached = set(ast.literal_eval(r.stdout.strip()))
    assert wheel_problems(files, reached) == []
    modules = {f for f in files if f.endswith(".py")}
    assert {"fogcli/device/plan.py", "fogcli/physics/apsf.py", "fogcli/config/media/fog.yaml",
            "fogcli/physics/data/apsf.npz", "fogcli/device/kernels/pyramid.cl"} <= set(files)
    assert not [f for f in modules if f.split("/")[-1] in ("apsf_mc.py", "hdr_scenes.py", "metrics.py")]
    # a module nothing imports, and a file that is not the runtime's data, are found
    assert wheel_problems(files + ["fogcli/physics/orphan.py", "fogcli/notes.txt"], reached) == [
        "fogcli/physics/orphan.py: not imported by the runtime", "fogcli/notes.txt: neither a module nor the runtime's data"]
