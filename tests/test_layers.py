"""The package's structure stays one-way (issue 10): read from the source, not from imports at run time.

Every import of a ``deltacal`` module, at module level or inside a function, must point down the
layers below (a module may import one of its own layer or a lower one), the graph has no cycle,
nothing outside ``deltacal.cli`` imports the command line, no module grows past 700 lines and no
function past 80 lines of code (issue 20: its docstring aside).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "deltacal"

#: Top-level part of each module -> its layer (higher imports lower, never the reverse).
LAYERS = {
    "__init__": 100,
    "cli": 90,
    "demo": 80,
    "report": 70,
    "export": 70,
    "viz": 60,
    "robots": 57,  # robot files and controllers of either kind: over the engine and the wing
    "printer": 55,  # the linear Delta's wing, over the engine
    "gcode": 52,
    "io": 50,
    "planar": 45,  # a paper's example: uses the core, nothing uses it
    "planning": 40,
    "simulation": 40,
    "validation": 40,
    "controller": 38,
    "calibration": 36,
    "identification": 35,
    "holds": 34,  # where a printer's calibration holds: its σ grid, read by calibration and above
    "compensation": 33,
    "observations": 30,
    "identifiability": 30,
    "errormodels": 25,
    "kinematics": 20,
    "geometry": 10,
    "chains": 10,
    "rotations": 10,
    "towers": 10,  # values held per tower of a linear Delta
    "resources": 5,
    "options": 0,  # the options values' shared plumbing: imports nothing of deltacal
    "exceptions": 0,
    "_version": 0,
    "_lazy": 0,
    "_moved": 0,
}
MAX_LINES = 700
#: Lines of code of a function at most, from its first statement after the docstring to its end.
MAX_FUNCTION_LINES = 80


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """deltacal modules imported anywhere in the file (relative imports resolved)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            # `from pkg import sub` imports the submodule when there is one
            subs = [f"{stem}.{alias.name}" for alias in node.names if f"{stem}.{alias.name}" in known]
            targets = subs or [stem]
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def graph() -> dict[str, set[str]]:
    mods = modules()
    return {name: imports_of(name, path, set(mods)) for name, path in mods.items()}


def layer(name: str) -> int:
    """The layer of a module: its longest dotted prefix (below ``deltacal``) in :data:`LAYERS`."""
    parts = name.split(".")[1:] or ["__init__"]
    for end in range(len(parts), 0, -1):
        key = ".".join(parts[:end])
        if key in LAYERS:
            return LAYERS[key]
    raise AssertionError(f"{name}: not in any layer; add it to LAYERS (and to the docs' layout)")


def test_every_import_points_down_the_layers():
    wrong = [
        f"{a} (layer {layer(a)}) imports {b} (layer {layer(b)})"
        for a, targets in graph().items()
        for b in sorted(targets)
        if layer(b) > layer(a)
    ]
    assert not wrong, "\n".join(wrong)


def test_nothing_but_the_command_line_imports_it():
    wrong = [
        f"{a} imports {b}"
        for a, targets in graph().items()
        for b in targets
        if (b == "deltacal.cli" or b.startswith("deltacal.cli.")) and not a.startswith("deltacal.cli")
    ]
    assert not wrong, "\n".join(wrong)


def test_no_import_cycle():
    edges = graph()
    state: dict[str, int] = {}
    cycles: list[list[str]] = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                cycles.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, stack + [nxt])
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            visit(node, [node])
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


@pytest.mark.parametrize("name", sorted(modules()))
def test_module_size(name):
    lines = modules()[name].read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_LINES, f"{name}: {lines} lines; split it by concept"


def function_lengths(path: Path) -> dict[str, int]:
    """Lines of code of each function (methods and nested ones too), docstring aside."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: dict[str, int] = {}
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        body = node.body
        if (len(body) > 1 and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            body = body[1:]
        end = body[-1].end_lineno or body[-1].lineno
        found[f"{node.name} (line {node.lineno})"] = end - body[0].lineno + 1
    return found


@pytest.mark.parametrize("name", sorted(modules()))
def test_function_size(name):
    long = {f: n for f, n in function_lengths(modules()[name]).items() if n > MAX_FUNCTION_LINES}
    assert not long, f"{name}: functions over {MAX_FUNCTION_LINES} lines of code: {long}; split them"


def test_the_function_cap_counts_code_not_the_docstring(tmp_path):
    """A function of 81 statements fails, one of 80 with a long docstring passes."""
    doc = '    """' + "\n" * 40 + '    """\n'
    path = tmp_path / "m.py"
    path.write_text("def long():\n" + "    x = 1\n" * 81 + "def short():\n" + doc + "    x = 1\n" * 80)
    assert function_lengths(path) == {"long (line 1)": 81, "short (line 83)": 80}


def test_the_checker_sees_a_cycle_and_an_upward_import(tmp_path, monkeypatch):
    """The checks above can fail: a fake package with a cycle and an upward import is caught."""
    pkg = tmp_path / "deltacal"
    (pkg / "cli").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "cli" / "__init__.py").write_text("")
    (pkg / "geometry.py").write_text("def f():\n    from .cli import main\n")
    (pkg / "exceptions.py").write_text("from . import geometry\n")
    monkeypatch.setattr(__import__(__name__), "PACKAGE", pkg)
    edges = graph()
    assert "deltacal.cli" in edges["deltacal.geometry"]  # an import inside a function counts
    assert "deltacal.geometry" in edges["deltacal.exceptions"]
    with pytest.raises(AssertionError):
        test_every_import_points_down_the_layers()
    with pytest.raises(AssertionError):
        test_nothing_but_the_command_line_imports_it()


def test_third_party_imports_are_declared_dependencies():
    """Every package the library imports is a core dependency in pyproject.toml, and every core
    dependency is imported (a bare ``pip install .`` has what the code needs, nothing more)."""
    import sys
    import tomllib

    project = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    declared = {re.split(r"[<>=!~ \[]", d)[0].lower() for d in project["dependencies"]}
    import_name = {"pin": "pinocchio", "u-msgpack-python": "umsgpack", "tomli-w": "tomli_w"}
    declared_imports = {import_name.get(d, d) for d in declared}
    used: set[str] = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                used |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                used.add(node.module.split(".")[0])
    third_party = {m for m in used if m not in sys.stdlib_module_names and m != "deltacal"}
    assert third_party <= declared_imports, f"imported but not declared: {third_party - declared_imports}"
    assert declared_imports <= third_party, f"declared but never imported: {declared_imports - third_party}"
