"""No output over a file the firmware's configuration reads: its includes, the files ``config.g`` runs.

``-o printer.cfg`` was refused; ``-o steppers.cfg`` that printer.cfg includes, or ``-o config-override.g``
that config.g runs with ``M501`` (its ``M307`` and ``G10`` lines lost), were written over (issue 40,
item 9). Each is refused before any work, the file left as it was.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli import main
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import config_files

DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture
def printer(tmp_path):
    """A calibration (the nominal kossel's geometry), a program, a printer.cfg including its steppers."""
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), tmp_path / "cal.toml")
    (tmp_path / "part.gcode").write_text("G28\nG90\nG1 X0 Y0 Z10 F3000\n")
    text = kossel_printer_cfg(tmp_path / "whole.cfg").read_text()
    cut = text.index("[stepper_a]")
    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "steppers.cfg").write_text(text[cut:])
    (tmp_path / "printer.cfg").write_text(text[:cut] + "[include conf/*.cfg]\n")
    return tmp_path


def _refused(capsys, argv: list[str], output: Path) -> None:
    before = output.read_bytes()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and f"{output}: the output would overwrite an input file" in err
    assert output.read_bytes() == before


def test_compensate_does_not_write_over_an_included_file(printer, capsys):
    steppers = printer / "conf" / "steppers.cfg"
    assert config_files(printer / "printer.cfg") == (printer / "printer.cfg", steppers)
    _refused(capsys, ["compensate", str(printer / "cal.toml"), str(printer / "part.gcode"), "--controller",
                      str(printer / "printer.cfg"), "-o", str(steppers)], steppers)


def test_export_klipper_does_not_write_over_an_included_file(printer, capsys):
    steppers = printer / "conf" / "steppers.cfg"
    _refused(capsys, ["export", str(printer / "cal.toml"), "--controller", "klipper", "--config",
                      str(printer / "printer.cfg"), "-o", str(steppers)], steppers)


def _sys_folder(tmp_path: Path) -> Path:
    """tests/data's config.g (M501 at its end) with an M98 of a macro; config-override.g with heater lines."""
    sys = tmp_path / "sys"
    sys.mkdir()
    shutil.copy(DATA / "rrf" / "config.g", sys / "config.g")
    with open(sys / "config.g", "a") as f:
        f.write('M98 P"0:/sys/delta-limits.g"  ; a macro of the configuration\n')
    (sys / "delta-limits.g").write_text("M208 S1 Z-0.5\n")
    override = (DATA / "rrf" / "config-override.g").read_text()
    heater = "M307 H0 R0.43 C226.4 D6.32 S1.00 V24.0\nG10 L2 P1 X0 Y0 Z0\n"
    (sys / "config-override.g").write_text(override + heater)
    return sys


@pytest.mark.parametrize("name", ["config-override.g", "delta-limits.g"])
def test_export_rrf_does_not_write_over_a_file_config_g_runs(tmp_path, capsys, name):
    sys = _sys_folder(tmp_path)
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), tmp_path / "cal.toml")
    config = sys / "config.g"
    runs = ("config-override.g", "delta-limits.g", "homedelta.g")
    assert config_files(config) == (config, *(sys / name for name in runs))
    _refused(capsys, ["export", str(tmp_path / "cal.toml"), "--controller", "rrf", "--config", str(config),
                      "-o", str(sys / name)], sys / name)


def test_compensate_through_config_g_does_not_write_over_homedelta_g(tmp_path, capsys):
    sys = _sys_folder(tmp_path)
    (sys / "homedelta.g").write_text("G91\nG1 H1 X320 Y320 Z320 F1800\nG1 X-5 Y-5 Z-5\nG90\n")
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), tmp_path / "cal.toml")
    (tmp_path / "part.gcode").write_text("G28\nG90\nG1 X0 Y0 Z10 F3000\n")
    _refused(capsys, ["compensate", str(tmp_path / "cal.toml"), str(tmp_path / "part.gcode"), "--controller",
                      str(sys / "config.g"), "-o", str(sys / "homedelta.g")], sys / "homedelta.g")
