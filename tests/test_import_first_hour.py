"""Issue 39, "a printer owner's first hour": real firmware files given to ``import`` as an owner would.

Files told apart by what they hold (a ``//`` line no longer makes a Klipper log), ``--firmware`` to
say what a file is, a Marlin ``Configuration.h`` refused with what to give instead, a Marlin 1.1.0
report said to be whole but of a version whose homed height is compiled in, and the wording of
what ``import`` says. Each test failed on the main of the issue.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer

DATA = Path(__file__).resolve().parent / "data"
MINI_KOSSEL = DATA / "rrf" / "duet3d-minikossel" / "config.g"
ROSTOCK_301 = DATA / "marlin" / "geeetech-rostock-301-Configuration.h"
MARLIN_110 = DATA / "marlin" / "marlin-1.1.0-m503.txt"


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    return err


# ------------------------------------------------------------------ 3: files told apart by what they hold
def test_duet3ds_own_mini_kossel_config_g_imports_despite_its_double_slash_line(tmp_path, capsys):
    out = tmp_path / "mini"
    assert main(["import", str(MINI_KOSSEL), "-o", str(out)]) == 0
    printer = load_printer(out / "printer.toml")
    np.testing.assert_allclose(printer.tower_radius, 105.6 + 30.0, rtol=0, atol=1e-12)  # M665 R + effector
    np.testing.assert_allclose(printer.rod_length, 215.0, rtol=0, atol=0)
    np.testing.assert_allclose(printer.step_distance, 1 / 80.0, rtol=0, atol=0)
    assert printer.workspace is not None and printer.workspace.radius == 85.0  # M665 B85
    assert "RepRapFirmware's model" in capsys.readouterr().out


def test_a_marlin_configuration_h_is_refused_saying_to_capture_m503(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["import", str(ROSTOCK_301), "-o", str(out)]) == 1
    err = one_line_error(capsys)
    assert f"{ROSTOCK_301}: line 42: a Marlin Configuration.h holds the compiled defaults" in err
    assert "send M503 to the printer and save its whole answer" in err and not out.exists()


def test_a_configuration_h_given_as_marlins_settings_elsewhere_is_refused_too(tmp_path, capsys):
    robot = tmp_path / "robot.toml"
    shutil.copy(Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml", robot)
    probe = tmp_path / "probe.csv"
    probe.write_text("x_mm,y_mm,z_mm\n0,0,0.1\n")
    assert main(["identify", str(robot), str(probe), "--controller", str(ROSTOCK_301), "-o",
                 str(tmp_path / "cal.toml")]) == 1
    assert "a Marlin Configuration.h holds the compiled defaults" in one_line_error(capsys)


def test_firmware_says_what_a_file_is_when_its_content_cannot(tmp_path, capsys):
    settings = tmp_path / "settings.txt"  # RepRapFirmware's lines, not in a *.g
    settings.write_text("M665 L215 R105.6 H240 B85\nM666 X0 Y0 Z0\nM92 X80 Y80 Z80\n")
    assert main(["import", str(settings), "-o", str(tmp_path / "a")]) == 2
    assert "give --firmware klipper|rrf|marlin" in one_line_error(capsys)
    assert main(["import", str(settings), "--firmware", "rrf", "-o", str(tmp_path / "b")]) == 0
    assert np.all(load_printer(tmp_path / "b" / "printer.toml").rod_length == 215.0)


def test_firmware_names_the_firmware_a_file_is_when_it_is_another(tmp_path, capsys):
    assert main(["import", str(MINI_KOSSEL), "--firmware", "klipper", "-o", str(tmp_path / "a")]) == 1
    err = one_line_error(capsys)
    assert "RepRapFirmware's configuration by its content (config.g), not Klipper's" in err


def test_import_help_names_marlins_m503_capture(capsys):
    assert main(["import", "--help"]) == 0
    out = capsys.readouterr().out
    assert "M503" in out and "--firmware" in out


# ------------------------------------------------------------------ 40/16: the firmware a file is, named
@pytest.fixture
def geometry(tmp_path) -> Path:
    assert main(["import", str(DATA / "klipper" / "printer.cfg"), "-o", str(tmp_path / "k")]) == 0
    path = tmp_path / "geometry.toml"
    save_geometry(load_printer(tmp_path / "k" / "printer.toml").geometry(), path)
    return path


@pytest.mark.parametrize("controller, config, says", [
    ("rrf", DATA / "klipper" / "printer.cfg", "Klipper's configuration by its content (printer.cfg), not "
                                               "RepRapFirmware's"),
    ("klipper", DATA / "marlin_m503.txt", "Marlin's configuration by its content (m503.txt), not Klipper's"),
    ("marlin", MINI_KOSSEL, "RepRapFirmware's configuration by its content (config.g), not Marlin's"),
])
def test_export_names_the_firmware_whose_file_config_is(geometry, tmp_path, capsys, controller, config, says):
    capsys.readouterr()
    assert main(["export", str(geometry), "--controller", controller, "--config", str(config), "-o",
                 str(tmp_path / "values.txt")]) == 1
    err = one_line_error(capsys)
    assert says in err and "no M665" not in err and "outside any" not in err


# ------------------------------------------------------------------ 7: Marlin 1.1.0's whole report
def test_marlin_1_1_0s_report_is_said_whole_and_its_height_how_to_give(tmp_path, capsys):
    assert main(["import", str(MARLIN_110), "-o", str(tmp_path / "a")]) == 1
    err = one_line_error(capsys)
    assert "line 21: no M665 H: the report of a Marlin without it (1.1.0 or older" in err
    assert "MANUAL_Z_HOME_POS of its Configuration.h, plus this report's M206 Z1.25" in err
    assert "add a line 'M665 H<that height>'" in err and "capture M503's whole report" not in err
    given = tmp_path / "m503.txt"
    given.write_text(MARLIN_110.read_text() + "M665 H251.25\n")
    assert main(["import", str(given), "-o", str(tmp_path / "b")]) == 0
    assert np.all(load_printer(tmp_path / "b" / "printer.toml").rod_length == 215.0)


def test_marlin_1_1_0s_tower_angle_trims_are_not_dropped_without_a_word(tmp_path, capsys):
    given = tmp_path / "m503.txt"
    given.write_text(MARLIN_110.read_text().replace("I0.00 J0.00 K0.00", "I0.12 J-0.20 K0.00")
                     + "M665 H251.25\n")
    assert main(["import", str(given), "-o", str(tmp_path / "b")]) == 1
    assert "line 21, M665 I: value 0.12: M665 I J K are the tower angle trims of Marlin 1.1.0" in \
        one_line_error(capsys)


# ------------------------------------------------------------------ 2: a workspace the printer reaches
NO_M211 = DATA / "marlin" / "delta-1.1.6-m503-no-m211.txt"


def test_a_capture_without_m211_imports_a_workspace_plan_accepts(tmp_path, capsys):
    out = tmp_path / "delta"
    assert main(["import", str(NO_M211), "-o", str(out)]) == 0
    printer = load_printer(out / "printer.toml")  # its workspace reachable: refused before
    assert printer.workspace is not None
    reach = 180.5 - 100.0  # M665 L - R: the rod of the tower opposite lies flat there
    assert 0.95 * reach < printer.workspace.radius < reach  # Marlin's default 140 held within it
    text = (out / "printer.toml").read_text()
    assert "Marlin's default soft endstops' radius (no M211 Min/Max in the capture) 140 mm, held to" in text
    # the capture has no M851 either: plan --object writes no probe program for it (issue 47,
    # test_no_probe.py); with the probe's offset added, it plans one on the workspace import wrote
    probed = tmp_path / "m503-probe.txt"
    probed.write_text(NO_M211.read_text() + "echo:  M851 Z-1.50 ; (mm)\n")
    assert main(["plan", str(out / "printer.toml"), "--object", "--controller", str(probed), "-o",
                 str(tmp_path / "plan")]) == 0
    assert (tmp_path / "plan" / "probe.gcode").exists()


# ------------------------------------------------------------------ 7: what import says of RRF's values
def test_an_rrf_import_writes_the_azimuths_as_given_and_no_tilt_it_has_not(tmp_path, capsys):
    plain = tmp_path / "plain" / "config.g"  # without its '//' line (item 3 aside)
    plain.parent.mkdir()
    plain.write_text(MINI_KOSSEL.read_text().replace("// Z probe", "; Z probe"))
    assert main(["import", str(plain), "-o", str(tmp_path / "a")]) == 0
    said = capsys.readouterr().out
    text = (tmp_path / "a" / "printer.toml").read_text()
    assert "tower_azimuth_deg = [210.0, 330.0, 90.0]" in text
    assert "tilt" not in said and "Bed tilt" not in text  # no M666 A B: nothing to say of them
    tilted = tmp_path / "config.g"
    tilted.write_text(plain.read_text().replace("M666 X0 Y0 Z0", "M666 X0 Y0 Z0 A0.05 B-0.02")
                      .replace("M665 R105.6 L215.0 B85 H240", "M665 R105.6 L215.0 B85 H240 X-0.2 Y0.1"))
    assert main(["import", str(tilted), "-o", str(tmp_path / "b")]) == 0
    assert "its bed tilt M666 A B (0.05, -0.02 %) is not in the file" in capsys.readouterr().out
    text = (tmp_path / "b" / "printer.toml").read_text()
    assert "tower_azimuth_deg = [209.8, 330.1, 90.0]" in text and "# Bed tilt M666 A0.05 B-0.02" in text
