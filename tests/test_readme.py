"""The README's Python example runs as written (from the repository root), and the API reference's
table of main objects matches the package."""

import os
import re

import pytest
from conftest import ROOT


def test_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "the README has a Python example"
    robot = ROOT / "deltacal" / "models" / "bai2015.toml"
    code = blocks[0].replace('"models/bai2015.toml"', repr(str(robot)))
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "plate tilt [deg]" in out and "rank 42 of 51" in out
    assert os.path.exists(tmp_path / "calibration.toml")
    # the validation line of the exact compensation with the 200 mm tool: within 0.02 mm
    max_mm = float(re.search(r"max error ([0-9.]+) mm", out).group(1))
    assert max_mm < 0.02


def test_the_api_tables_match_the_public_names():
    """Every name of ``deltacal.__all__`` (exceptions aside) is in the API reference's table of main
    objects (docs/api/index.md), and every name there imports from the module its row gives."""
    import importlib

    import deltacal
    import deltacal.exceptions

    text = (ROOT / "docs" / "api" / "index.md").read_text(encoding="utf-8")
    section = text[text.index("## Main objects"):text.index("## Reference pages")]
    named: set[str] = set()
    for line in section.splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        modules = re.findall(r"`([\w.]+)`", cells[1])
        for name in re.findall(r"`([A-Za-z_][\w.]*)`", cells[0]):
            named.add(name)
            found = False
            for module in modules:
                obj = importlib.import_module(f"deltacal.{module}")
                try:
                    for part in name.split("."):
                        obj = getattr(obj, part)
                    found = True
                except AttributeError:
                    continue
            assert found, f"docs/api/index.md names {name} in {modules}, which do not hold it"
    exceptions = {n for n in dir(deltacal.exceptions) if n[0].isupper()} | {"__version__"}
    missing = sorted(set(deltacal.__all__) - named - exceptions)
    assert not missing, f"exported but not in the API reference's table: {missing}"


def _printer_commands() -> list[list[str]]:
    """The README's printer commands (section "A Delta printer, from its printer.cfg"), as written."""
    import shlex

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## A Delta printer, from its printer.cfg"):]
    block = re.search(r"```bash\n(.*?)```", section, flags=re.S).group(1)
    return [shlex.split(line, comments=True) for line in block.splitlines() if line.startswith("deltacal ")]


@pytest.mark.long
def test_readme_printer_commands_run_on_the_printer_demos_files(tmp_path, monkeypatch, capsys):
    """The README's printer commands, parsed from README.md, on the printer demo's printer.cfg (no probe)
    and its part.gcode: import, plan, (simulate in place of the printer, after plan), identify,
    export, compensate, the live export. Before: plan refused the demo's printer.cfg (no probe
    section) and identify named printer/probe.csv, which import does not write without saved data."""
    from deltacal.cli import main
    from deltacal.printer.demo import nominal_title, part_gcode
    from deltacal.printer.files.robot_file import load_printer
    from deltacal.printer.firmware.klipper.firmware import KLIPPER

    monkeypatch.chdir(tmp_path)
    printer = load_printer(ROOT / "deltacal" / "models" / "kossel.toml")
    KLIPPER.save_config(tmp_path / "printer.cfg", KLIPPER.nominal(printer), title=nominal_title(KLIPPER),
                        complete=True)  # the demo's printer.cfg, as `deltacal demo --printer` writes it first
    (tmp_path / "part.gcode").write_text(part_gcode((0.2, 50.0)))  # the demo's part (--quick)
    commands = _printer_commands()
    assert [c[1] for c in commands] == ["import", "plan", "identify", "export", "compensate", "export"]
    for command in commands:
        code = main(command[1:])
        if code and command[1] == "compensate":  # the README's note: set the value the refusal names
            err = capsys.readouterr().err
            low = re.search(r"set \[printer\] minimum_z_position: ([-0-9.]+)", err).group(1)
            cfg = (tmp_path / "printer.cfg").read_text()
            cfg = cfg.replace("[printer]\n", f"[printer]\nminimum_z_position: {low}\n")
            (tmp_path / "printer.cfg").write_text(cfg)
            code = main(command[1:])
        assert code == 0, " ".join(command)
        if command[1] == "plan":  # the printer measured: its probe heights and distances filled in
            folder = command[command.index("-o") + 1]
            (tmp_path / "measured").mkdir()
            assert main(["simulate", command[2], f"{folder}/probe.csv", f"{folder}/distances.csv",
                         "--controller", "printer.cfg", "--perturb", "3", "-o", "measured/probe.csv",
                         "--distances-output", "measured/distances.csv"]) == 0
            for name in ("probe.csv", "distances.csv"):
                os.replace(tmp_path / "measured" / name, tmp_path / folder / name)
    out = capsys.readouterr().out
    for written in ("cal.toml", "calibrated.cfg", "part-corrected.gcode", "live/deltacal_geometry.py"):
        assert (tmp_path / written).stat().st_size > 0, written
    assert "wrote the program corrected" in out
