"""A printer's per-tower values: rods, endstops and step distances, a number or ``[a, b, c]``.

Real printers differ per tower (Klipper's ``[stepper_a..c]`` hold each tower's ``arm_length``,
``position_endstop`` and ``rotation_distance``); a robot file says so with ``[a, b, c]``.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from deltacal.calibration import Calibration
from deltacal.cli.main import main
from deltacal.controller import corrected_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.exceptions import InputError
from deltacal.io import load_calibration, load_geometry, save_calibration, save_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.simulation import random_printer

KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
SCALARS = {"rod_length_mm": "269.0", "endstop_height_mm": "558.62", "step_distance_mm": "0.0125"}
#: One real Kossel's towers: endstops 3.8 mm apart, rods and step distances that differ.
PER_TOWER = {"rod_length_mm": "[269.0, 269.4, 268.8]", "endstop_height_mm": "[558.62, 556.3, 560.1]",
             "step_distance_mm": "[0.0125, 0.0125, 0.0124]"}
EQUAL = {"rod_length_mm": "[269.0, 269.0, 269.0]", "endstop_height_mm": "[558.62, 558.62, 558.62]",
         "step_distance_mm": "[0.0125, 0.0125, 0.0125]"}


def robot_file(path: Path, values: dict[str, str]) -> Path:
    """models/kossel.toml with these ``[geometry]`` values in place of its own."""
    text = KOSSEL.read_text()
    for key, value in values.items():
        text, n = re.subn(rf"^{key} = {re.escape(SCALARS[key])}", f"{key} = {value}", text, flags=re.M)
        assert n == 1, key
    path.write_text(text)
    return path


def targets(n: int = 200) -> np.ndarray:
    """Nozzle targets over the printable cylinder of models/kossel.toml [mm], (n, 3)."""
    rng = np.random.default_rng(3)
    r, a = 115.0 * np.sqrt(rng.random(n)), rng.uniform(0.0, 2.0 * np.pi, n)
    return np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.0, 200.0, n)])


def test_per_tower_values_are_read_per_tower(tmp_path):
    printer = load_printer(robot_file(tmp_path / "p.toml", PER_TOWER))
    assert printer.rod_length.tolist() == [269.0, 269.4, 268.8]
    assert printer.endstop_height.tolist() == [558.62, 556.3, 560.1]
    assert printer.step_distance.tolist() == [0.0125, 0.0125, 0.0124]
    geometry = printer.geometry()
    assert geometry.rod_length.tolist() == [[269.0] * 2, [269.4] * 2, [268.8] * 2]
    assert geometry.axis_point[:, 2].tolist() == [558.62, 556.3, 560.1]
    assert geometry.step_distance is not None and geometry.step_distance.tolist() == [0.0125, 0.0125, 0.0124]


def test_klippers_values_of_a_per_tower_printer_put_the_nozzle_where_commanded(tmp_path):
    printer = load_printer(robot_file(tmp_path / "p.toml", PER_TOWER))
    klipper = KlipperDelta.from_printer(printer)
    assert klipper.arm_length.tolist() == [269.0, 269.4, 268.8]
    assert klipper.step_distance.tolist() == [0.0125, 0.0125, 0.0124]
    assert np.ptp(klipper.position_endstop) > 3.0  # the endstops' spread, seen through each tower's rods
    geometry, points = printer.geometry(), targets()
    readings = klipper.inverse(points, printer.step_distance)  # tower i's steps times d_i
    assert_allclose(readings / printer.step_distance, klipper.steps(points), rtol=1e-15)
    landed = exact.forward(geometry, readings).point(geometry.tool)
    assert_allclose(landed, points, atol=1e-9, rtol=0)
    # the controller of the printer's readings commands the same
    controller = KLIPPER.controller(klipper, printer.step_distance)
    assert_allclose(controller.inverse(points), readings, atol=1e-12, rtol=0)
    assert_allclose(controller.forward(readings), points, atol=1e-9, rtol=0)
    # readings counted in one step distance for the three towers would miss on tower C
    wrong = exact.forward(geometry, klipper.steps(points) * 0.0125).point(geometry.tool)
    assert np.max(np.abs(wrong - points)) > 0.1


def test_equal_towers_read_exactly_as_a_number(tmp_path):
    scalar = load_printer(KOSSEL)
    equal = load_printer(robot_file(tmp_path / "p.toml", EQUAL))
    for key in ("rod_length", "endstop_height", "step_distance"):
        assert_array_equal(getattr(equal, key), getattr(scalar, key))
    a, b = scalar.geometry(), equal.geometry()
    for key in ("axis_point", "arm_ball", "plate_ball", "rod_length", "step_distance"):
        assert_array_equal(getattr(a, key), getattr(b, key))


def test_a_geometry_writes_its_step_distance_as_a_number_when_the_towers_agree(tmp_path):
    scalar = load_printer(KOSSEL).geometry()
    save_geometry(scalar, tmp_path / "one.toml")
    assert "\nstep_distance_mm = 0.0125\n" in (tmp_path / "one.toml").read_text()
    printer = load_printer(robot_file(tmp_path / "p.toml", PER_TOWER))
    truth = random_printer(printer, np.random.default_rng(2))
    save_geometry(truth, tmp_path / "three.toml")
    assert "\nstep_distance_mm = [0.0125, 0.0125, 0.0124]\n" in (tmp_path / "three.toml").read_text()
    back = load_geometry(tmp_path / "three.toml")
    assert back.step_distance is not None and back.step_distance.tolist() == [0.0125, 0.0125, 0.0124]
    assert_array_equal(back.axis_point, truth.axis_point)


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("rod_length_mm", "[269.0, 120.0, 269.0]",
         r"key geometry.rod_length_mm: rods of 120.0 mm \(tower B\) cannot reach"),
        ("rod_length_mm", "[269.0, 269.4]", r"key geometry.rod_length_mm: must be a number or \[a, b, c\]"),
        ("endstop_height_mm", "[558.62, 556.3, 0.5601]", r"key geometry.endstop_height_mm: 0.5601 mm is "
                                                         r"implausible .*\(tower C\)"),
        ("endstop_height_mm", "[558.62, -556.3, 560.1]", r"key geometry.endstop_height_mm: must be positive, "
                                                         r"got -556.3 on tower B"),
        ("step_distance_mm", "[0.0125, 80.0, 0.0125]", r"key geometry.step_distance_mm: 80.0 mm per step "
                                                       r"\(tower B\) is not a printer's"),
        ("step_distance_mm", '[0.0125, "x", 0.0125]', r"key geometry.step_distance_mm: must be a number"),
        ("endstop_height_mm", "[558.62, 556.3, 300.0]", r"key workspace: the workspace reaches"),
    ],
)
def test_a_bad_tower_is_named(tmp_path, key, value, message):
    path = robot_file(tmp_path / "p.toml", {key: value})
    with pytest.raises(InputError, match=message) as err:
        load_printer(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


@pytest.mark.long
def test_a_calibration_compares_its_step_distances_per_tower(tmp_path):
    printer = load_printer(robot_file(tmp_path / "p.toml", PER_TOWER))
    cfg = KLIPPER.save_config(tmp_path / "printer.cfg", KlipperDelta.from_printer(printer), complete=True)
    cal = _identified(tmp_path, tmp_path / "p.toml", cfg)
    calibration = load_calibration(cal)
    assert calibration.nominal.step_distance is not None
    assert calibration.nominal.step_distance.tolist() == [0.0125, 0.0125, 0.0124]
    text = cal.read_text()
    assert text.count("\nstep_distance_mm = [0.0125, 0.0125, 0.0124]\n") == 2  # [geometry] and [nominal]
    edited = tmp_path / "edited.toml"
    edited.write_text(text.replace("\nstep_distance_mm = [0.0125, 0.0125, 0.0124]\n",
                                   "\nstep_distance_mm = [0.0125, 0.0125, 0.0125]\n", 1))
    with pytest.raises(InputError, match=r"key geometry.step_distance_mm = 0.0125, but key "
                                         r"nominal.step_distance_mm = \[0.0125, 0.0125, 0.0124\]"):
        load_calibration(edited)
    assert isinstance(calibration, Calibration)
    save_calibration(calibration, tmp_path / "again.toml")
    assert (tmp_path / "again.toml").read_text() == text


def _identified(folder: Path, robot: Path, cfg: Path) -> Path:
    """plan --object, simulate (a perturbed printer) and identify: the calibration file."""
    cfg.write_text(cfg.read_text() + "\n[probe]\npin: ^PA4\nz_offset: 0\n")  # the probe program needs one
    plan = folder / "plan"
    assert main(["plan", str(robot), "--object", "--controller", str(cfg), "-o", str(plan)]) == 0
    assert main(["simulate", str(robot), str(plan / "probe.csv"), str(plan / "distances.csv"), "--controller",
                 str(cfg), "--perturb", "24", "--seed", "5", "-o", str(folder / "probe.csv"),
                 "--distances-output", str(folder / "d.csv")]) == 0
    out = folder / "cal.toml"
    assert main(["identify", str(robot), str(folder / "probe.csv"), str(folder / "d.csv"), "--controller",
                 str(cfg), "-o", str(out)]) == 0
    return out


@pytest.mark.long
def test_the_commands_take_a_per_tower_printer(tmp_path):
    """plan -> simulate -> identify -> compensate, export, report and view on a per-tower robot file."""
    robot = robot_file(tmp_path / "p.toml", PER_TOWER)
    printer = load_printer(robot)
    cfg = KLIPPER.save_config(tmp_path / "printer.cfg", KlipperDelta.from_printer(printer), complete=True)
    cal = _identified(tmp_path, robot, cfg)
    truth = load_geometry(tmp_path / "probe.truth.toml")
    geometry = load_calibration(cal).geometry
    # the identified printer is the true one where it prints (up to the bed's gauge: heights)
    layer = np.column_stack([targets(60)[:, :2] * 0.8, np.full(60, 0.2)])
    landed = exact.forward(truth, exact.inverse(geometry, layer)).point(truth.tool)
    assert np.ptp(landed[:, 2]) < 0.05
    points = targets(40)
    csv = tmp_path / "targets.csv"
    csv.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x:.4f},{y:.4f},{z:.4f}\n" for x, y, z in points))
    assert main(["compensate", str(cal), str(csv), "--controller", str(cfg),
                 "-o", str(tmp_path / "sent.csv")]) == 0
    table = np.loadtxt(tmp_path / "sent.csv", delimiter=",", skiprows=1)
    calibration = load_calibration(cal)
    controller = KLIPPER.controller(KLIPPER.read_config(cfg), printer.step_distance)
    # compensate sends the library's route where the calibration holds, and corrected wholly the identified
    # printer (in Klipper's frame along the bed) lands on the targets
    route = corrected_targets(calibration, controller, table[:, :3]).commands
    assert_allclose(table[:, 3:], route, atol=1e-8)
    whole = corrected_targets(calibration, controller, table[:, :3], bound=math.inf).commands
    aligned = aligned_to_controller(geometry, controller, float(calibration.holds.radius[-1]))
    sent = exact.forward(aligned, controller.inverse(whole)).point(aligned.tool)
    assert np.max(np.linalg.norm(sent - table[:, :3], axis=1)) < 1e-6
    assert main(["export", str(cal), "--controller", "klipper", "-o", str(tmp_path / "fitted.cfg"),
                 "--config", str(cfg)]) == 0
    assert main(["report", str(cal), "-o", str(tmp_path / "report.html")]) == 0
    assert (tmp_path / "report.html").stat().st_size > 0
    assert main(["view", str(robot), "--calibration", str(cal), "--html", str(tmp_path / "view.html")]) == 0
    assert "MeshCat.Viewer" in (tmp_path / "view.html").read_text(encoding="utf-8")


@pytest.mark.long
def test_equal_towers_give_the_same_outputs_as_a_number(tmp_path):
    outputs = {}
    for name, values in (("number", {}), ("equal", EQUAL)):
        folder = tmp_path / name
        folder.mkdir()
        robot = robot_file(folder / "printer.toml", values)
        cfg = KLIPPER.save_config(folder / "printer.cfg", KlipperDelta.from_printer(load_printer(robot)),
                                  complete=True)
        cal = _identified(folder, robot, cfg)
        written = [p for p in sorted(folder.rglob("*")) if p.is_file() and p.name != "printer.toml"]
        outputs[name] = {path.relative_to(folder): path.read_bytes().replace(bytes(folder), b"DIR")
                         for path in written}
        assert cal.relative_to(folder) in outputs[name]
    assert outputs["number"].keys() == outputs["equal"].keys()
    for path, content in outputs["number"].items():
        assert outputs["equal"][path] == content, path
