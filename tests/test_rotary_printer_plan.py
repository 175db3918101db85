"""``plan --object`` and ``simulate`` of a rotary Delta printer (issue 48, deliver 2), through the CLI's main.

Klipper's example-rotary-delta.cfg imported (its robot file in {O}, the shoulders' centre), its
``[workspace]`` radius widened from its ``[delta_calibrate] radius`` of 50 mm to 80 mm (the linear
object's pads need more than 50 mm: the 50 mm one is refused, said), a ``[probe]`` added to a copy of the
configuration for the probe program. The plan is in Klipper's bed frame (commanded coordinates); the
simulation's truth, read back, gives the probe heights and distances of
:mod:`deltacal.printer.rotary_simulation`.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, kossel_printer_cfg

from deltacal.cli import main
from deltacal.geometry import Tolerances
from deltacal.io import load_geometry, load_nominal
from deltacal.printer.files.measurements import read_printed_distances, read_probe_heights
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.printed.object import tallest_fitting
from deltacal.printer.rotary_simulation import RotaryPrinter, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE

FILES = ("object.stl", "probe.csv", "distances.csv", "probe.gcode", "sheet.html")
#: The probe's trigger height above the bed in the configuration's [probe] (z_offset) [mm].
Z_OFFSET = 1.5


def _rows(path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def printer(tmp_path_factory):
    """The imported example (robot file with an 80 mm workspace), its configuration with a probe, Klipper's
    values, the plan's folder and what plan said."""
    folder = tmp_path_factory.mktemp("rotary")
    cfg = folder / "rotary.cfg"
    cfg.write_text(EXAMPLE.read_text() + f"\n[probe]\npin: ^PA4\nz_offset: {Z_OFFSET}\n")
    assert main(["import", str(cfg), "-o", str(folder / "imported")]) == 0
    text = (folder / "imported" / "printer.toml").read_text()
    assert "radius_mm = 50.0" in text
    robot = folder / "printer.toml"
    robot.write_text(text.replace("radius_mm = 50.0", "radius_mm = 80.0"))
    code = main(["plan", str(robot), "--object", "--controller", str(cfg), "-o", str(folder / "obj")])
    return {"folder": folder, "cfg": cfg, "robot": robot, "code": code,
            "klipper": rotary_from_config(read_klipper_config(cfg)),
            "small": folder / "imported" / "printer.toml"}


@pytest.fixture(scope="module")
def simulated(printer):
    """``simulate --perturb 3`` of the plan's templates, without noise: the filled files and the truth."""
    folder, obj = printer["folder"], printer["folder"] / "obj"
    code = main(["simulate", str(printer["robot"]), str(obj / "probe.csv"), str(obj / "distances.csv"),
                 "--controller", str(printer["cfg"]), "-o", str(folder / "probe_measured.csv"),
                 "--distances-output", str(folder / "d.csv"), "--perturb", "3", "--sigma-height", "0",
                 "--sigma-distance", "0"])
    return {"code": code, "probe": folder / "probe_measured.csv", "distances": folder / "d.csv",
            "truth": folder / "probe_measured.truth.toml"}


def test_plan_object_of_a_rotary_printer_writes_the_five_files_in_klippers_frame(printer):
    """Before: refused ('--object plans a linear Delta printer's object'). Now the five files: the probe
    points inside the printable radius at z = 0 (the bed's frame: commanded coordinates), every planned
    feature and probe point reached within Klipper's rotary limits, the features standing on the bed (from
    z = 8 mm up, not at the shoulders' {O} heights)."""
    assert printer["code"] == 0
    obj = printer["folder"] / "obj"
    for name in FILES:
        assert (obj / name).stat().st_size > 0, name
    k = printer["klipper"]
    probe = read_probe_heights(obj / "probe.csv", filled=False)
    xy = probe.commanded[:, :2]
    assert len(xy) == 49 and np.hypot(*xy.T).max() <= 80.0 + 1e-9 and 80.0 < k.max_radius
    pairs = read_printed_distances(obj / "distances.csv", filled=False).pairs.reshape(-1, 3)
    assert len(pairs) == 80
    assert pairs[:, 2].min() >= 8.0 - 1e-9 and pairs[:, 2].max() <= k.limit_z
    points = np.vstack([pairs, np.column_stack([xy, np.zeros(len(xy))])])
    assert np.all(k.outside(points) == 0)
    assert np.all(np.isfinite(k.shoulder_angles(points, check=False)))
    gcode = (obj / "probe.gcode").read_text()
    assert "G28" in gcode and gcode.count("PROBE") >= 49


def test_plan_object_of_a_rotary_printer_says_the_rotary_models_parameters(printer, capsys):
    """The distances chosen with the rotary printer model's rows: what they add names its arms' parameters
    (the shoulders' turns beta, the arms' step scales), not a linear printer's towers."""
    capsys.readouterr()
    folder = printer["folder"]
    assert main(["plan", str(printer["robot"]), "--object", "--controller", str(printer["cfg"]), "-o",
                 str(folder / "again"), "--distances", "12"]) == 0
    out = capsys.readouterr().out
    assert "probe heights alone identify" in out and "scale1" in out and "beta1t" in out
    assert len(_rows(folder / "again" / "distances.csv")) == 12


def test_simulate_of_a_rotary_printer_fills_the_templates_as_klipper_measures(printer, simulated):
    """Before: simulate refused --controller for a rotary robot file. Now the filled files and the truth
    (in the bed's frame, its arms' step scales drawn): read back, the probe heights and the distances are
    rotary_simulation's of that truth, commanded by the configuration's values (to 1e-9 mm)."""
    assert simulated["code"] == 0
    k = printer["klipper"]
    truth = load_geometry(simulated["truth"])
    assert np.ptp(truth.joint_scale) > 0.0  # the arms' step scales perturbed
    template = read_probe_heights(printer["folder"] / "obj" / "probe.csv", filled=False)
    filled = read_probe_heights(simulated["probe"])
    expected = probe_triggers(RotaryPrinter(truth, k), k, template.commanded[:, :2],
                              trigger_height=template.heights)
    assert np.abs(filled.commanded - expected).max() < 1e-9
    assert np.abs(filled.commanded[:, 2]).max() > 0.01  # the true printer is not Klipper's nominal one
    distances = read_printed_distances(simulated["distances"])
    ours = printed_distances(RotaryPrinter(truth, k), k, distances.pairs.reshape(-1, 6))
    assert np.abs(distances.distance - ours).max() < 1e-9


def test_simulate_of_a_rotary_printer_with_its_truth_given(printer, simulated, tmp_path):
    """``--truth`` the written truth: the same probe heights (no noise), no truth written."""
    obj = printer["folder"] / "obj"
    out = tmp_path / "p.csv"
    assert main(["simulate", str(printer["robot"]), str(obj / "probe.csv"), "--controller",
                 str(printer["cfg"]), "-o", str(out), "--truth", str(simulated["truth"]),
                 "--sigma-height", "0"]) == 0
    again, first = read_probe_heights(out).commanded, read_probe_heights(simulated["probe"]).commanded
    assert np.abs(again - first).max() < 1e-12
    assert not (tmp_path / "p.truth.toml").exists()


def test_the_rotary_kit_tolerances_are_the_identification_tests():
    """The prior of a rotary printer: its kit's tolerances (test_rotary_printer_identification.py's KIT)."""
    from tests.test_rotary_printer_identification import KIT

    assert Tolerances.rotary_printer_kit() == KIT


def test_a_fits_default_tolerances_are_its_models_kit():
    """What a printer's fit, its plan and its re-anchoring take unless told: the model's own kit, asked of the
    model (before, the fit's default was a linear kit's whatever the model, and a rotary plan or identify
    named the rotary kit on their own)."""
    from deltacal.errormodels import get_model
    from deltacal.printer.identification.errormodels import kit_tolerances

    assert kit_tolerances(get_model("rotary_printer")) == Tolerances.rotary_printer_kit()
    assert kit_tolerances(get_model("printer")) == Tolerances.printer_kit()
    assert kit_tolerances(get_model("classical")) == Tolerances.printer_kit()
    assert kit_tolerances(get_model("rotary_printer")) != Tolerances.printer_kit()


def _refused(args, capsys, *words) -> str:
    capsys.readouterr()
    assert main(args) != 0
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in captured.err, err
    for word in words:
        assert word in err, err
    return err


def test_a_linear_config_for_a_rotary_robot_file_is_refused(printer, tmp_path, capsys):
    """plan and simulate of the rotary robot file with a linear Delta's printer.cfg: one line, nothing
    written (before: plan refused --object for any rotary robot file, simulate --controller for any)."""
    linear = kossel_printer_cfg(tmp_path / "printer.cfg")
    _refused(["plan", str(printer["robot"]), "--object", "--controller", str(linear), "-o",
              str(tmp_path / "obj")], capsys, str(linear), "rotary Delta")
    assert not (tmp_path / "obj").exists()
    obj = printer["folder"] / "obj"
    _refused(["simulate", str(printer["robot"]), str(obj / "probe.csv"), "--controller", str(linear),
              "-o", str(tmp_path / "m.csv"), "--perturb", "1"], capsys, str(linear), "rotary Delta")
    assert not list(tmp_path.glob("m*"))


def test_a_rotary_config_for_a_linear_printer_is_refused(printer, tmp_path, capsys):
    """plan --object of a linear printer's robot file with a rotary_delta configuration: one line naming it
    and what to give (before: the linear reader's refusal of kinematics: rotary_delta)."""
    _refused(["plan", str(MODELS / "kossel.toml"), "--object", "--controller", str(printer["cfg"]), "-o",
              str(tmp_path / "obj")], capsys, str(printer["cfg"]), "a rotary Delta printer's configuration")
    assert not (tmp_path / "obj").exists()


def test_a_rotary_printers_simulation_refuses_tolerance_classes(printer, tmp_path, capsys):
    """``--tolerances`` names a linear printer's classes: refused for a rotary printer, nothing written."""
    obj = printer["folder"] / "obj"
    _refused(["simulate", str(printer["robot"]), str(obj / "probe.csv"), "--controller", str(printer["cfg"]),
              "-o", str(tmp_path / "m.csv"), "--perturb", "1", "--tolerances", "well-built"], capsys,
             "--tolerances")
    assert not list(tmp_path.iterdir())


def test_the_configurations_own_radius_plans_a_lower_object(printer, tmp_path, capsys):
    """The example's [delta_calibrate] radius of 50 mm: the pads of the caliper's tallest balls (118 mm, 22.5
    mm across) do not fit (before: refused, "the printable radius 50 mm is too small for the object"); the
    object stands as high as its pads and labels fit, said in a note. The pads: a pad 2 + 2.5 + 0.06 (h -
    4.571 - 0.6) mm in radius, 8.80 for a ball at 76.8 mm, whose ring halfway out, (50 - 8.80) / 2 = 20.6
    mm, just clears 2 x 8.80 + 3 = 20.6; the labels then find no room for one ball, 5 mm lower they do:
    71.8 mm."""
    pad = 2.0 + 2.5 + 0.06 * (76.8 - (10.0 / math.sqrt(2.0) - 2.5) - 0.6)
    assert pad == pytest.approx(8.80, abs=0.01) and 0.5 * (50.0 - pad) >= 2.0 * pad + 3.0 - 0.01
    assert tallest_fitting(50.0, 118.0) == pytest.approx(76.8)
    capsys.readouterr()
    assert main(["plan", str(printer["small"]), "--object", "--controller", str(printer["cfg"]), "-o",
                 str(tmp_path / "obj")]) == 0
    out = capsys.readouterr().out
    assert "holds the pads and labels of balls up to 71.8 mm, not the 118 mm the caliper reaches" in out, out
    pads = read_printed_distances(tmp_path / "obj" / "distances.csv", filled=False)
    heights = np.unique(np.round(pads.pairs[:, [2, 5]], 3))
    assert heights.max() == pytest.approx(71.8) and heights.min() == pytest.approx(8.0)


@pytest.mark.slow
def test_a_bed_that_holds_the_tallest_pads_says_nothing_of_them(printer, tmp_path, capsys):
    """The 80 mm [workspace]: the object's layout reaches the caliper's 118 mm, no note of a lower object
    (the note judges the layout's top level, not the features the selection chose)."""
    capsys.readouterr()
    assert main(["plan", str(printer["robot"]), "--object", "--controller", str(printer["cfg"]), "-o",
                 str(tmp_path / "obj")]) == 0
    out = capsys.readouterr().out
    assert "holds the pads and labels" not in out and "object:" in out, out


def test_a_radius_too_small_for_two_levels_is_refused(printer, tmp_path, capsys):
    """A [workspace] of 20 mm radius holds no ring of pads even for the two lowest levels: one line, nothing
    written."""
    small = tmp_path / "small.toml"
    small.write_text(Path(printer["small"]).read_text().replace("radius_mm = 50.0", "radius_mm = 20.0"))
    _refused(["plan", str(small), "--object", "--controller", str(printer["cfg"]), "-o",
              str(tmp_path / "obj")], capsys, "printable radius 20 mm is too small")
    assert not (tmp_path / "obj").exists()


def test_the_robot_files_workspace_moves_into_the_bed_frame(printer):
    """The robot file's [workspace] is in {O} (top_z below the shoulders); the plan's is the bed's: from
    minimum_z_position (0) up to Klipper's limit_z."""
    from deltacal.printer.firmware.klipper.firmware import KLIPPER
    from deltacal.printer.printed.target import RotaryPrinterToPlan

    robot = load_nominal(printer["robot"])
    assert robot.workspace is not None and robot.workspace.top_z < 0.0
    target = RotaryPrinterToPlan(robot, KLIPPER.rotary_controller(printer["cfg"]))
    assert target.workspace is not None
    assert target.workspace.bottom_z == pytest.approx(0.0, abs=1e-9)
    assert target.workspace.top_z == pytest.approx(printer["klipper"].limit_z, abs=1e-9)
