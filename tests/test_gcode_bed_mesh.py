"""A bed mesh turned on over a corrected program (issue 40 item 10): the line kept, with a warning.

deltacal's correction already holds the bed the calibration measured; a firmware's mesh turned on
by the program (Klipper's ``BED_MESH_PROFILE LOAD=`` and ``BED_MESH_CALIBRATE``, directly or in a
macro; Marlin's ``M420 S1`` and ``G29``; RRF's ``G29``, ``G29 S1``) adds its own on top: the first
layer corrected twice. Each such line is named, with how to turn the mesh off.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal import InputWarning
from deltacal.cli import main
from deltacal.gcode import filter_lines
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).parent / "data"
START = "G1 X0 Y0 Z10\n"
MACROS = """
[gcode_macro START_MESHED]
gcode:
    G28
    BED_MESH_PROFILE LOAD=default
    G1 X0 Y0 Z5

[gcode_macro OUTER]
gcode:
    START_MESHED

[gcode_macro BED_MESH_CALIBRATE]
rename_existing: _BED_MESH_CALIBRATE
gcode:
    _BED_MESH_CALIBRATE PROFILE=adaptive
"""


def run(text: str, dialect) -> tuple[str, list[str]]:
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        out = "".join(filter_lines(text.splitlines(keepends=True), lambda p: p + 0.01, dialect=dialect))
    return out, [str(w.message) for w in said if issubclass(w.category, InputWarning)]


@pytest.fixture(scope="module")
def klipper(tmp_path_factory):
    cfg = kossel_printer_cfg(tmp_path_factory.mktemp("mesh") / "printer.cfg")
    cfg.write_text(cfg.read_text() + MACROS)
    return KLIPPER.dialect(cfg)


@pytest.mark.parametrize("line, says", [
    ("BED_MESH_PROFILE LOAD=default", "'BED_MESH_PROFILE LOAD=default': it turns Klipper's bed mesh on"),
    ('bed_mesh_profile load="my mesh"', "'bed_mesh_profile load=\"my mesh\"': it turns Klipper's bed mesh"),
    ("START_MESHED", "'START_MESHED': it runs BED_MESH_PROFILE LOAD=default, which turns Klipper's bed mesh"),
    ("OUTER", "'OUTER': it runs START_MESHED: it runs BED_MESH_PROFILE LOAD=default, which turns"),
    ("BED_MESH_CALIBRATE", "'BED_MESH_CALIBRATE': it runs _BED_MESH_CALIBRATE PROFILE=adaptive, which turns"),
])
def test_a_klipper_mesh_turned_on_is_named_with_how_to_turn_it_off(klipper, line, says):
    out, said = run(START + line + "\nG1 X0 Y0 Z0.3\n", klipper)
    assert out.splitlines()[1] == line  # kept as it is
    assert len(said) == 1 and said[0].startswith(f"G-code: line 2: {says}")
    assert "on top of deltacal's correction" in said[0] and "send BED_MESH_CLEAR after it" in said[0]


def test_klippers_own_bed_mesh_calibrate_is_named_too():
    klipper = KLIPPER.dialect(DATA / "klipper" / "printer.cfg")  # no macro of that name
    _, said = run(START + "BED_MESH_CALIBRATE\nG1 X0 Y0 Z1\nBED_MESH_CALIBRATE\nG1 X0 Y0 Z1\n", klipper)
    assert len(said) == 1
    assert said[0].startswith("G-code: line 2: 'BED_MESH_CALIBRATE': it probes the bed and turns Klipper's")
    assert "(also line 4: 2 lines in all)" in said[0]


@pytest.mark.parametrize("line", ["BED_MESH_PROFILE SAVE=x", "BED_MESH_PROFILE REMOVE=x", "BED_MESH_CLEAR"])
def test_klipper_mesh_lines_that_turn_nothing_on_say_nothing(klipper, line):
    assert run(START + line + "\n", klipper)[1] == []


@pytest.mark.parametrize("firmware, line, says", [
    ("marlin", "M420 S1", "'M420 S1': it turns Marlin's bed levelling on: the firmware adds its mesh"),
    ("marlin", "M420 S Z10", "'M420 S Z10': it turns Marlin's bed levelling on"),
    ("marlin", "G29", "'G29': it probes the bed, and most builds then turn Marlin's bed levelling on"),
    ("rrf", "G29", "'G29': it turns RepRapFirmware's mesh bed compensation on"),
    ("rrf", "G29 S1", "'G29 S1': it turns RepRapFirmware's mesh bed compensation on"),
])
def test_marlin_and_rrf_meshes_turned_on_are_named(firmware, line, says):
    dialect = MARLIN.dialect(DATA / "marlin_m503.txt") if firmware == "marlin" else \
        RRF_FIRMWARE.dialect(DATA / "rrf" / "config.g")
    out, said = run(START + line + "\nG1 X0 Y0 Z0.3\n", dialect)
    assert out.splitlines()[1] == line
    assert len(said) == 1 and said[0].startswith(f"G-code: line 2: {says}")
    assert ("send M420 S0 after it" if firmware == "marlin" else "send G29 S2 after it") in said[0]


@pytest.mark.parametrize("firmware, line", [("marlin", "M420 S0"), ("marlin", "M420 V"), ("rrf", "G29 S2"),
                                            ("rrf", "G29 S3"), (None, "G29")])
def test_lines_that_turn_no_mesh_on_say_nothing(firmware, line):
    dialect = None if firmware is None else MARLIN.dialect(DATA / "marlin_m503.txt") if firmware == "marlin" \
        else RRF_FIRMWARE.dialect(DATA / "rrf" / "config.g")
    assert run(START + line + "\n", dialect)[1] == []


def test_compensate_says_the_mesh_line_on_stderr(capsys, tmp_path):
    cfg = kossel_printer_cfg(tmp_path / "printer.cfg")
    cal, program, out = tmp_path / "cal.toml", tmp_path / "p.gcode", tmp_path / "o.gcode"
    save_geometry(load_printer(MODELS / "kossel.toml").geometry(), cal)
    program.write_text("G28\nBED_MESH_PROFILE LOAD=default\nG1 X0 Y0 Z10\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(cfg), "-o", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"warning: {program}: line 2: 'BED_MESH_PROFILE LOAD=default': it turns")
    assert out.read_text().splitlines()[2] == "BED_MESH_PROFILE LOAD=default"
