"""The command line with Marlin's settings: ``--firmware`` or the content, ``compensate`` through
Marlin's model, ``export --controller marlin`` read back as Marlin's values."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.compensation import compensate
from deltacal.controller import corrected_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.io import load_calibration, load_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.fitting import EXPORT_FIRST_LAYER_WEIGHT
from deltacal.printer.firmware.klipper.fit import error_stats
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.settings import load_marlin
from deltacal.printer.firmware.marlin.values import to_klipper

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
PRINTER = load_printer(KOSSEL)


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """plan --object, simulate and identify through the nominal printer's M503 settings (seed 77)."""
    folder = tmp_path_factory.mktemp("cli_marlin")
    settings = MARLIN.save_config(folder / "m503.gcode", MARLIN.nominal(PRINTER), complete=True)
    plan = folder / "plan"
    assert main(["plan", str(KOSSEL), "--object", "--controller", str(settings), "-o", str(plan)]) == 0
    assert main(["simulate", str(KOSSEL), str(plan / "probe.csv"), str(plan / "distances.csv"),
                 "--controller", str(settings), "--firmware", "marlin", "--perturb", "77",
                 "-o", str(folder / "probe.csv"), "--distances-output", str(folder / "distances.csv")]) == 0
    assert main(["identify", str(KOSSEL), str(folder / "probe.csv"), str(folder / "distances.csv"),
                 "--controller", str(settings), "-o", str(folder / "cal.toml")]) == 0
    return folder, settings


@pytest.mark.slow
def test_corrected_targets_go_through_marlins_model(identified, capsys):
    folder, settings = identified
    targets = np.array([[0.0, 0.0, 0.2], [50.0, -40.0, 20.0], [-60.0, 30.0, 120.0]])
    np.savetxt(folder / "t.csv", targets, delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    # the true bed is below Marlin's z 0 here: its soft endstops would clamp the first target
    assert main(["compensate", str(folder / "cal.toml"), str(folder / "t.csv"), "--controller", str(settings),
                 "--firmware", "marlin", "-o", str(folder / "c.csv")]) == 1
    err = capsys.readouterr().err
    assert "line 2 (data row 1)" in err and "soft endstop Min Z 0" in err and "M211 S0" in err
    assert not (folder / "c.csv").exists()
    lowered = MARLIN.save_config(folder / "m503_low.gcode", load_marlin(settings).with_minimum_z(-1.0),
                                 complete=True)
    assert main(["compensate", str(folder / "cal.toml"), str(folder / "t.csv"), "--controller", str(lowered),
                 "--firmware", "marlin", "-o", str(folder / "c.csv")]) == 0
    sent = np.loadtxt(folder / "c.csv", delimiter=",", skiprows=1)[:, 3:6]
    calibration = load_calibration(folder / "cal.toml")
    controller = MARLIN.controller(load_marlin(lowered), PRINTER.step_distance)
    # what compensate sends is the library's route where the calibration holds (weighted by its σ) ...
    assert_allclose(sent, corrected_targets(calibration, controller, targets).commands, atol=1e-8)
    # ... and corrected wholly, through Marlin's model, the identified printer (in Marlin's frame along
    # the bed) lands on the targets
    whole = corrected_targets(calibration, controller, targets, bound=math.inf).commands
    geometry = aligned_to_controller(calibration.geometry, controller, float(calibration.holds.radius[-1]))
    readings = load_marlin(settings).inverse(whole, PRINTER.step_distance)
    assert_allclose(exact.forward(geometry, readings).point(geometry.tool), targets, atol=1e-6)
    assert_allclose(readings, compensate(geometry, targets), atol=1e-6)


@pytest.mark.slow
def test_exported_values_are_marlins_and_near_the_best(identified, capsys):
    folder, settings = identified
    out = folder / "calibrated.gcode"
    assert main(["export", str(folder / "cal.toml"), "--controller", "marlin", "--config", str(settings),
                 "--robot", str(KOSSEL), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "wrote the Marlin values" in printed
    # what the values leave of each source, and how to apply them, from the firmware object
    assert "what Marlin's values cannot hold of each error source alone" in printed
    assert f"to apply: {MARLIN.apply_note}" in printed and "M500" in MARLIN.apply_note
    assert out.read_text().splitlines()[1] == f"; {MARLIN.apply_note}"
    assert re.search(r"^;   tower lean +\d\.\d{3} / \d\.\d{3} mm$", out.read_text(), flags=re.M)
    lines = [line for line in out.read_text().splitlines() if not line.startswith(";")]
    assert [line.split()[0] for line in lines] == ["M665", "M666", "M92", "M500"]
    exported = load_marlin(out)
    assert np.all(exported.endstop_adj <= 0.0) and abs(exported.angle_trim.sum()) < 3e-4  # 4 decimals
    truth = load_geometry(folder / "probe.truth.toml")
    nominal = load_marlin(settings)
    best = MARLIN.fit(truth, nominal, PRINTER.step_distance, PRINTER.workspace,
                      first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT)
    left = error_stats(truth, to_klipper(exported), PRINTER.step_distance, PRINTER.workspace, part_frame=True)
    assert left.max_3d <= 1.25 * best.after.max_3d + 0.01


def test_a_file_no_firmware_recognises_needs_firmware(tmp_path, capsys):
    bare = tmp_path / "settings.gcode"
    bare.write_text("M665 L269 R134.4 H295.6\nM92 X80 Y80 Z80\n")
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,1\n")
    out = tmp_path / "o.toml"
    code = main(["identify", str(KOSSEL), str(targets), "--controller", str(bare), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "give --firmware klipper|rrf|marlin" in err and err.count("\n") == 1


MARLIN_PROGRAM = """; a Marlin delta program's shape: home, absolute E, an arc, a relative lift
G28
G90
M82
G92 E0
G1 Z0.3 F3000
G1 X20 Y0 Z0.3 F3000
G1 X-20 Y0 E1.5 F1200
G2 X20 Y0 I20 J0 E3.0
M83
G1 X0 Y20 E0.8
G91
G1 Z2 E-0.5
G90
M82
G92 E0
G1 X0 Y0 Z5 F3000
"""


@pytest.mark.slow
def test_a_marlin_program_is_corrected_through_its_settings(identified, tmp_path, capsys):
    """compensate PART.gcode --controller M503 --firmware marlin: Marlin's reading, its soft endstops."""
    folder, settings = identified
    program, out = tmp_path / "part.gcode", tmp_path / "out.gcode"
    program.write_text(MARLIN_PROGRAM)
    lowered = MARLIN.save_config(tmp_path / "m503_low.gcode", load_marlin(settings).with_minimum_z(-1.0),
                                 complete=True)
    assert main(["compensate", str(folder / "cal.toml"), str(program), "--controller", str(lowered),
                 "--firmware", "marlin", "-o", str(out)]) == 0
    written = out.read_text().splitlines()[1:]  # after the marker line
    kept = [line for line in MARLIN_PROGRAM.splitlines() if not line.startswith(("G1 ", "G2 "))]
    assert [line for line in written if not line.startswith(("G0 ", "G1 "))] == kept
    absolute = written[:written.index("G91")]  # the moves up to the relative lift: positions
    moves = np.array([[float(w[1:]) for w in line.split()[1:4]] for line in absolute
                      if line.startswith("G1 X")])
    assert len(moves) > 10 and not np.any(load_marlin(lowered).outside(moves))
    # Marlin 2: G91 makes E relative too (G90 then M82 make it absolute again): the lift's E is -0.5
    lift = [line for line in written if line.startswith("G1 ") and "E-0.5" in line]
    assert len(lift) == 1
