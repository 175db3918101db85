"""The package's structure stays one-way (issue 10): read from the source, not from imports at run time.

Every import of a ``deltacal`` module, at module level or inside a function, must point down the
layers below (a module may import one of its own layer or a lower one), the graph has no cycle,
nothing outside ``deltacal.cli`` imports the command line, no module grows past 700 lines and no
function past 80 lines of code (issue 20: its docstring aside). A name another module needs is public
where it lives, and no two classes share a name (issue 37).
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "deltacal"

#: Top-level part of each module -> its layer (higher imports lower, never the reverse).
LAYERS = {
    "__init__": 100,
    "cli": 90,
    "demo": 80,
    "wings": 75,  # each robot kind's jobs behind one interface: over the report, the export and both wings
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
    "controller_record": 34,  # the firmware configuration a printer's calibration was measured against
    "measured_record": 34,  # what a printer's calibration was identified from, to re-anchor it
    "compensation": 33,
    "observations": 30,
    "identifiability": 30,
    "errormodels": 25,
    "kinematics": 20,
    "arguments": 12,  # the Python API's points and geometry arguments, checked: over the geometry
    "geometry": 10,
    "chains": 10,
    "rotations": 10,
    "towers": 10,  # values held per tower of a linear Delta
    "tolerances": 10,  # the σ of a Delta's build errors: the priors' and the simulations' stuff
    "resources": 5,
    "options": 0,  # the options values' shared plumbing: imports nothing of deltacal
    "exceptions": 0,
    "_version": 0,
    "_lazy": 0,
    "_moved": 0,
}
MAX_LINES = 700
#: Files that are one file by necessity, and their bound: the live Klipper module is copied alone into
#: klippy/extras/ (standard-library Python, nothing of deltacal's to import).
ARTIFACT_LINES = {"deltacal.printer.firmware.klipper.live.deltacal_geometry": 800}
#: Lines of code of a function at most, from its first statement after the docstring to its end.
MAX_FUNCTION_LINES = 80


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def parsed(path: Path) -> ast.Module:
    """The file's syntax tree, parsed once per version of the file (every check below reads it)."""
    stat = path.stat()
    return _parse(path, stat.st_mtime_ns, stat.st_size)


@functools.cache
def _parse(path: Path, mtime_ns: int, size: int) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _import_stem(name: str, path: Path, node: ast.ImportFrom) -> str:
    """The absolute module an ``import from`` names (a relative one resolved)."""
    if not node.level:
        return node.module or ""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    base = package.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports_of(name: str, path: Path, known: set[str]) -> set[str]:
    """deltacal modules imported anywhere in the file (relative imports resolved)."""
    tree = parsed(path)
    found: set[str] = set()
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            stem = _import_stem(name, path, node)
            # `from pkg import sub` imports the submodule when there is one
            subs = [f"{stem}.{alias.name}" for alias in node.names if f"{stem}.{alias.name}" in known]
            targets = subs or [stem]
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def _dotted(node: ast.expr) -> str | None:
    """``a.b.c`` of a chain of attributes over a name, or None."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        head = _dotted(node.value)
        return None if head is None else f"{head}.{node.attr}"
    return None


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_names_taken(name: str, path: Path, known: set[str]) -> list[str]:
    """Private names (one leading underscore) of other deltacal modules this module uses.

    ``from X import _name`` (a private module too), and ``X._name`` where ``X`` is a deltacal
    module bound by an import (``from . import toml``, ``import deltacal.io.toml as t``, or the
    dotted path itself).
    """
    tree = parsed(path)
    bound: dict[str, str] = {}  # a name in this module -> the deltacal module it holds
    found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            stem = _import_stem(name, path, node)
            if stem != "deltacal" and not stem.startswith("deltacal."):
                continue
            for alias in node.names:
                if f"{stem}.{alias.name}" in known:
                    bound[alias.asname or alias.name] = f"{stem}.{alias.name}"
                if _private(alias.name):
                    found.append(f"{name} (line {node.lineno}) takes {stem}.{alias.name}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("deltacal"):
                    bound[alias.asname or alias.name] = alias.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _private(node.attr):
            held = _dotted(node.value)
            module = bound.get(held or "", held if held in known else None)
            if module is not None and module != name:
                found.append(f"{name} (line {node.lineno}) takes {module}.{node.attr}")
    return found


def graph() -> dict[str, set[str]]:
    mods = modules()
    return _graph(tuple((name, path, path.stat().st_mtime_ns) for name, path in mods.items()))


@functools.cache
def _graph(mods: tuple[tuple[str, Path, int], ...]) -> dict[str, set[str]]:
    known = {name for name, _, _ in mods}
    return {name: imports_of(name, path, known) for name, path, _ in mods}


def layer(name: str) -> int:
    """The layer of a module: its longest dotted prefix (below ``deltacal``) in :data:`LAYERS`."""
    parts = name.split(".")[1:] or ["__init__"]
    for end in range(len(parts), 0, -1):
        key = ".".join(parts[:end])
        if key in LAYERS:
            return LAYERS[key]
    raise AssertionError(f"{name}: not in any layer; add it to LAYERS (and to the docs' layout)")


@pytest.mark.long
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


#: Private names a module may still take from another, each with the reason it stays private
#: (``"<module> (line N) takes <module>.<name>"`` without the line -> why). Issue 37: at most 5.
PRIVATE_CROSSINGS: dict[str, str] = {}
MAX_PRIVATE_CROSSINGS = 5


def test_a_name_another_module_needs_is_public_where_it_lives():
    mods = modules()
    taken = [t for n, p in mods.items() for t in private_names_taken(n, p, set(mods))]
    unexplained = [t for t in taken if re.sub(r" \(line \d+\)", "", t) not in PRIVATE_CROSSINGS]
    assert len(PRIVATE_CROSSINGS) <= MAX_PRIVATE_CROSSINGS
    assert not unexplained, ("private names taken across modules (make them public where they live, "
                             "or justify them in PRIVATE_CROSSINGS):\n" + "\n".join(unexplained))


def class_definitions(path: Path) -> list[tuple[str, int]]:
    """Every class the file defines, nested ones too, with its line."""
    tree = parsed(path)
    return [(node.name, node.lineno) for node in ast.walk(tree) if isinstance(node, ast.ClassDef)]


def test_no_class_name_is_defined_twice():
    where: dict[str, list[str]] = {}
    for name, path in modules().items():
        for cls, line in class_definitions(path):
            where.setdefault(cls, []).append(f"{name}:{line}")
    twice = {cls: places for cls, places in where.items() if len(places) > 1}
    assert not twice, f"class names defined more than once (one name per class): {twice}"


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


def test_module_size():
    lines = {name: path.read_text(encoding="utf-8").count("\n") for name, path in modules().items()}
    long = {name: n for name, n in lines.items() if n > ARTIFACT_LINES.get(name, MAX_LINES)}
    assert not long, f"modules over {MAX_LINES} lines: {long}; split them by concept"


def function_lengths(path: Path) -> dict[str, int]:
    """Lines of code of each function (methods and nested ones too), docstring aside."""
    tree = parsed(path)
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


def test_function_size():
    long = {f"{name}: {f}": n for name, path in modules().items()
            for f, n in function_lengths(path).items() if n > MAX_FUNCTION_LINES}
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines of code: {long}; split them"


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


def test_the_checker_sees_private_names_and_twin_classes(tmp_path, monkeypatch):
    """A private name taken by import or through a module, and a class defined twice, are caught."""
    pkg = tmp_path / "deltacal"
    (pkg / "io").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "io" / "__init__.py").write_text("class Plane:\n    pass\n")
    (pkg / "io" / "toml.py").write_text("def _shown():\n    pass\n\n"
                                        "class Outer:\n    class Plane:\n        pass\n")
    (pkg / "geometry.py").write_text("from .io.toml import _shown\nimport deltacal.io.toml as t\n"
                                     "from .io import toml\n\ndef f():\n    return t._x, toml._y, _shown\n")
    monkeypatch.setattr(__import__(__name__), "PACKAGE", pkg)
    mods = modules()
    taken = private_names_taken("deltacal.geometry", mods["deltacal.geometry"], set(mods))
    assert [t.split(" takes ")[1] for t in taken] == ["deltacal.io.toml._shown", "deltacal.io.toml._x",
                                                       "deltacal.io.toml._y"]
    with pytest.raises(AssertionError, match="deltacal.io.toml._shown"):
        test_a_name_another_module_needs_is_public_where_it_lives()
    with pytest.raises(AssertionError, match="'Plane'"):
        test_no_class_name_is_defined_twice()


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
        for node in ast.walk(parsed(path)):
            if isinstance(node, ast.Import):
                used |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                used.add(node.module.split(".")[0])
    third_party = {m for m in used if m not in sys.stdlib_module_names and m != "deltacal"}
    assert third_party <= declared_imports, f"imported but not declared: {third_party - declared_imports}"
    assert declared_imports <= third_party, f"declared but never imported: {declared_imports - third_party}"


#: Lines of ``deltacal/cli/`` at most, all modules together (issue 37: a thin command line over the wings).
MAX_CLI_LINES = 2400
#: Words no module of ``deltacal/cli/`` is named for: a robot kind, a firmware, a printer's job.
KIND_WORDS = ("rotary", "printer", "linear", "klipper", "marlin", "rrf", "reprap", "firmware", "object",
              "probe", "prints")
#: The firmwares' own packages, which the command line and the report reach only through their interface.
FIRMWARE_PACKAGES = tuple(f"deltacal.printer.firmware.{name}" for name in ("klipper", "marlin", "rrf"))
#: The classes of a robot, which the command line never tests for (the wing of its kind is asked instead).
ROBOT_CLASSES = ("NominalDelta", "NominalLinearDelta", "DeltaGeometry", "Chain", "RevoluteChain",
                 "PrismaticChain")


def cli_modules() -> dict[str, Path]:
    return {name: path for name, path in modules().items() if name.startswith("deltacal.cli")}


def test_no_command_module_is_named_for_a_kind_or_a_firmware():
    """One module per command: a kind's or a firmware's route lives in its wing, not beside the command."""
    named = [name for name in cli_modules() if any(word in name.rpartition(".")[2] for word in KIND_WORDS)]
    assert not named, f"command modules named for a kind, a firmware or a printer's job: {named}"


def class_tests(path: Path) -> list[str]:
    """``isinstance(x, C)`` / ``issubclass`` / ``type(x) is C`` of a robot class in a file, by line."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in (
                "isinstance", "issubclass") and len(node.args) == 2:
            classes = node.args[1].elts if isinstance(node.args[1], ast.Tuple) else [node.args[1]]
        elif isinstance(node, ast.Compare) and isinstance(node.left, ast.Call) and isinstance(
                node.left.func, ast.Name) and node.left.func.id == "type":
            classes = node.comparators
        else:
            continue
        names = [c.attr if isinstance(c, ast.Attribute) else getattr(c, "id", "") for c in classes]
        found += [f"line {node.lineno}: {name}" for name in names if name in ROBOT_CLASSES]
    return found


def test_the_command_line_tests_no_robots_class():
    """The command line asks the robot's wing; it never tests which class of robot it holds."""
    wrong = {name: class_tests(path) for name, path in cli_modules().items() if class_tests(path)}
    assert not wrong, f"class tests of a robot in the command line: {wrong}"


def test_the_command_line_and_the_report_reach_firmwares_through_their_interface():
    """cli/ and report/ import nothing of a firmware's own package (Klipper's, Marlin's, RRF's)."""
    wrong = [f"{a} imports {b}" for a, targets in graph().items()
             if a.startswith(("deltacal.cli", "deltacal.report"))
             for b in sorted(targets) if b.startswith(FIRMWARE_PACKAGES)]
    assert not wrong, "\n".join(wrong)


def test_the_command_line_is_thin():
    lines = sum(path.read_text(encoding="utf-8").count("\n") for path in cli_modules().values())
    assert lines <= MAX_CLI_LINES, f"deltacal/cli/: {lines} lines; its logic belongs in the wings"


def test_the_house_checks_can_fail(tmp_path, monkeypatch):
    """A command module named for a firmware, a class test and a firmware import are each caught."""
    pkg = tmp_path / "deltacal"
    for sub in ("cli", "report", "printer/firmware/klipper"):
        (pkg / sub).mkdir(parents=True)
    for init in ("", "cli", "report", "printer", "printer/firmware", "printer/firmware/klipper"):
        (pkg / init / "__init__.py").write_text("")
    (pkg / "printer" / "robot.py").write_text("class NominalLinearDelta: ...\n")
    (pkg / "cli" / "export_klipper.py").write_text(
        "from ..printer.firmware.klipper import fit\nfrom ..printer.robot import NominalLinearDelta\n"
        "def run(robot):\n    return isinstance(robot, (int, NominalLinearDelta))\n")
    (pkg / "report" / "html.py").write_text("def f():\n    from ..printer.firmware import klipper\n")
    monkeypatch.setattr(__import__(__name__), "PACKAGE", pkg)
    assert class_tests(pkg / "cli" / "export_klipper.py") == ["line 4: NominalLinearDelta"]
    for check in (test_no_command_module_is_named_for_a_kind_or_a_firmware,
                  test_the_command_line_tests_no_robots_class,
                  test_the_command_line_and_the_report_reach_firmwares_through_their_interface):
        with pytest.raises(AssertionError):
            check()
    monkeypatch.setattr(__import__(__name__), "MAX_CLI_LINES", 3)
    with pytest.raises(AssertionError):
        test_the_command_line_is_thin()
