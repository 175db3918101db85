"""Marlin 2.x behind the firmware interface: its M503 settings, its delta model against the facts of
its source (signs, homing, limits), Klipper's model where the values coincide, the fit, the export."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.exceptions import InputError
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import config_firmware, firmwares
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.model import (
    ABOVE_MAX_Z,
    BELOW_MIN_Z,
    BEYOND_RADIUS,
    MIN_STEPS_PER_SEGMENT,
    MarlinDelta,
)
from deltacal.printer.firmware.marlin.settings import load_marlin
from deltacal.printer.firmware.marlin.values import marlin_values, to_klipper
from deltacal.printer.robot import NominalLinearDelta
from deltacal.printer.simulation import random_true_printer, typical_kit

ROOT = Path(__file__).resolve().parents[1]
CAPTURE = ROOT / "tests" / "data" / "marlin_m503.txt"
EFFECTOR = 30.0


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(ROOT / "deltacal" / "models" / "kossel.toml")


def described(marlin: MarlinDelta, step_distance: float) -> object:
    """The printer Marlin's model describes exactly: vertical towers, parallelograms, a centred nozzle."""
    top = marlin.carriage_top
    height = float(np.mean(top))
    nominal = NominalLinearDelta("marlin-shaped", marlin.radius + EFFECTOR, EFFECTOR, 269.0, 50.0,
                                 marlin.angle, height, step_distance)
    errors = {}
    for i in range(3):
        errors[f"limb{i + 1}.axis_point.z"] = float(top[i] - height)
        for rod in ("rod1", "rod2"):
            errors[f"limb{i + 1}.{rod}.length"] = float(marlin.rods[i] - 269.0)
        errors[f"limb{i + 1}.joint_scale"] = float(marlin.step_distance[i] / step_distance - 1.0)
    return nominal.geometry().with_errors(errors)


def test_an_m503_capture_is_read_with_its_prefixes_and_limits():
    marlin = MARLIN.read_config(CAPTURE)
    assert (marlin.radius, marlin.rod, marlin.height) == (134.4, 269.0, 295.6)
    assert marlin.angle_trim.tolist() == [0.12, -0.2, 0.08] and marlin.rod_trim.tolist() == [0.1, -0.05, 0.0]
    assert marlin.endstop_adj.tolist() == [-0.41, 0.0, -0.87] and marlin.steps_per_mm.tolist() == [80.0] * 3
    assert marlin.probe_offset.tolist() == [0.0, 0.0, -1.2] and marlin.extruder_steps_per_mm == 415.0
    assert marlin.soft_endstops.radius == 115.0 and marlin.soft_endstops.maximum_z == 296.8
    assert config_firmware(CAPTURE) is MARLIN and MARLIN in firmwares()


def test_a_plain_program_is_not_taken_for_settings(tmp_path):
    program = tmp_path / "part.gcode"
    program.write_text("G28\nM665 L250 R124\nG1 X10 Y10 Z0.2\n")
    assert not MARLIN.is_config(program)


@pytest.mark.parametrize(("line", "where"), [
    ("echo:  M665 L269.00 R1x4 H295.6", "line 2, M665 R: value '1x4' is not a number"),
    ("echo:  M666 X0.30 Y0 Z0", "line 2, M666 X: value 0.3 must be <= 0"),
])
def test_a_bad_value_names_the_file_line_and_key(tmp_path, line, where):
    capture = tmp_path / "m503.txt"
    rest = "" if "M665" in line else "echo:  M665 L269 R134.4 H295.6\n"
    capture.write_text(f"echo:  M92 X80 Y80 Z80\n{line}\n{rest}")
    with pytest.raises(InputError, match=f"{capture}: {where}"):
        load_marlin(capture)


def test_a_missing_value_is_named(tmp_path):
    capture = tmp_path / "m503.txt"
    capture.write_text("echo:  M665 L269 R134.4\necho:  M92 X80 Y80 Z80\n")
    with pytest.raises(InputError, match="no M665 H"):
        load_marlin(capture)


def test_marlin_and_klipper_command_the_same_steps_for_the_same_printer(kossel):
    """Klipper's delta_radius, angles, arm_length and position_endstop of Marlin's R, trims, L + trim,
    H − M851 Z − M666: the same steps to 1e-9 over the printable volume."""
    rng = np.random.default_rng(11)
    marlin = replace(MARLIN.nominal(kossel), angle_trim=rng.normal(0, 0.3, 3), rod_trim=rng.normal(0, 0.4, 3),
                     endstop_adj=-rng.uniform(0.2, 1.0, 3), probe_offset=np.array([0, 0, -1.3]),
                     steps_per_mm=80.0 * (1 + rng.normal(0, 1e-3, 3)))
    klipper = KlipperDelta(marlin.radius, np.radians([210, 330, 90] + marlin.angle_trim),
                           marlin.rod + marlin.rod_trim,
                           marlin.height + 1.3 - marlin.endstop_adj, 1.0 / marlin.steps_per_mm)
    targets = np.column_stack([rng.uniform(-80, 80, (500, 2)), rng.uniform(0, 200, 500)])
    assert_allclose(marlin.steps(targets), klipper.steps(targets), atol=1e-9, rtol=0)
    assert_allclose(marlin.positions(marlin.steps(targets)), targets, atol=1e-9, rtol=0)


def test_signs_of_the_settings(kossel):
    """Facts of Marlin's source: +X trim turns tower A anticlockwise; M666 X-0.5 homes carriage A
    0.5 mm lower (more steps for every target), the nozzle then lands lower by tower A; A adds to L."""
    nominal = MARLIN.nominal(kossel)
    turned = replace(nominal, angle_trim=np.array([0.5, 0.0, 0.0]))
    a, b = nominal.towers[0], turned.towers[0]
    assert a[0] * b[1] - a[1] * b[0] > 0.0  # anticlockwise seen from above
    assert_allclose(turned.towers[1:], nominal.towers[1:], atol=1e-12)
    lowered = replace(nominal, endstop_adj=np.array([-0.5, 0.0, 0.0]))
    targets = np.array([[0.0, 0.0, 1.0], [-60.0, -35.0, 5.0], [40.0, 60.0, 100.0]])
    assert_allclose(lowered.steps(targets) - nominal.steps(targets), [[0.5 * 80.0, 0.0, 0.0]] * 3, atol=1e-9)
    truth = described(nominal, 0.0125)
    by_a = exact.forward(truth, lowered.inverse(targets[1:2], 0.0125)).point(truth.tool)
    assert by_a[0, 2] < targets[1, 2] - 0.1
    longer = replace(nominal, rod_trim=np.array([0.0, 0.0, 0.3]))
    assert_allclose(longer.rods, [269.0, 269.0, 269.3])


def test_a_small_endstop_adjustment_is_not_moved():
    """``homeaxis``: an adjustment of no more than MIN_STEPS_PER_SEGMENT steps is skipped."""
    few = (MIN_STEPS_PER_SEGMENT - 1) / 80.0
    small = MarlinDelta(134.4, 269.0, 295.6, endstop_adj=np.array([-few, 0, 0]))
    assert small.homing_moves.tolist() == [0.0, 0.0, 0.0]
    larger = replace(small, endstop_adj=np.array([-(MIN_STEPS_PER_SEGMENT + 1) / 80.0, 0, 0]))
    assert_allclose(larger.homing_moves, [(MIN_STEPS_PER_SEGMENT + 1) / 80.0, 0, 0])


def test_homing_leaves_the_nozzle_at_h_less_the_probe_offset():
    marlin = load_marlin(CAPTURE)
    controller = MARLIN.controller(marlin, 0.0125)
    assert_allclose(controller.home, [0.0, 0.0, 295.6 + 1.2])
    # the carriages stand at their endstops less the M666 moves
    assert_allclose(marlin.steps(controller.home[None])[0], [0.41 * 80, 0.0, 0.87 * 80], atol=1e-9)
    home = controller.home[None]
    assert_allclose(controller.forward(controller.inverse(home)), home, atol=1e-9)


def test_soft_endstops_and_printable_radius():
    marlin = load_marlin(CAPTURE)
    inside = np.array([[0.0, 0.0, 0.0], [114.0, 0.0, 10.0], [0.0, 0.0, 296.8]])
    outside = np.array([[82.0, 82.0, 10.0], [0.0, 0.0, -0.01], [0.0, 0.0, 296.81]])
    assert not marlin.outside(inside).any() and marlin.outside(outside).all()
    default = replace(marlin, soft_endstops=replace(marlin.soft_endstops, maximum_z=None))
    assert default.outside(np.array([[0.0, 0.0, 296.9]])).all()  # H − M851 Z = 296.8
    switched_off = replace(marlin, soft_endstops=replace(marlin.soft_endstops, enabled=False))
    assert not switched_off.outside(outside).any()
    assert marlin.outside(outside).tolist() == [BEYOND_RADIUS, BELOW_MIN_Z, ABOVE_MAX_Z]
    assert "Min Z 0" in marlin.refusal(outside[1:2]) and "M211 S0" in marlin.refusal(outside[1:2])
    lowered = marlin.with_minimum_z(-0.02)
    assert lowered.outside(outside[1:2]).tolist() == [0] and lowered.soft_endstops.minimum[2] == -0.02
    assert MARLIN.controller(marlin, 0.0125).limits is marlin


def test_the_probe_program_probes_with_the_nozzle_above_each_point():
    """G30 without X, Y probes where the probe stands: the nozzle's commanded x, y are the points'."""
    points = np.array([[0.0, 0.0, 0.0], [10.5, -20.25, 0.0]])
    text = MARLIN.probe_program(points, "test")
    lines = text.splitlines()
    assert lines[0] == "; test" and "G28 ; home" in lines
    probes = [k for k, line in enumerate(lines) if line == "G30"]
    assert len(probes) == 2
    assert [lines[k - 1] for k in probes] == ["G1 X0.000 Y0.000 Z5.000 F3000",
                                              "G1 X10.500 Y-20.250 Z5.000 F3000"]


def test_values_are_normalised_as_g33_leaves_them(kossel):
    klipper = to_klipper(load_marlin(CAPTURE))
    written = marlin_values(klipper.delta_radius, klipper.angle + 0.01, klipper.arm_length,
                            klipper.carriage_top + np.array([0.3, 0.0, -0.2]), klipper.step_distance,
                            turn=True)
    assert np.all(written.endstop_adj <= 0.0) and abs(written.angle_trim.sum()) < 1e-12
    assert abs(written.rod_trim.sum()) < 1e-12 and written.rod == pytest.approx(np.mean(klipper.arm_length))
    moved = written.homing_moves
    assert_allclose(moved, -written.endstop_adj, atol=0)  # none within G28's skipped steps
    assert np.all((written.endstop_adj == 0.0) | (moved > MIN_STEPS_PER_SEGMENT * written.step_distance))
    assert_allclose(written.carriage_top, klipper.carriage_top + np.array([0.3, 0.0, -0.2]), atol=1e-9)


def test_marlins_model_is_the_printer_it_describes():
    marlin = load_marlin(CAPTURE)
    truth = described(marlin, 0.0125)
    targets = np.array([[0.0, 0.0, 0.2], [60.0, -40.0, 30.0], [-70.0, 20.0, 150.0]])
    landed = exact.forward(truth, marlin.inverse(targets, 0.0125)).point(truth.tool)
    assert_allclose(landed, targets, atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_fit_leaves_what_klippers_leaves_in_the_same_gauge(kossel, seed):
    """Same model, same freedoms: Marlin's fit is Klipper's held at the same tower C angle; written by
    Marlin's rules it leaves the same errors (the trims' sum 0, M666 <= 0)."""
    made = random_true_printer(kossel, np.random.default_rng(seed), typical_kit())
    fit = MARLIN.fit(made.geometry, MARLIN.nominal(kossel), kossel.step_distance, kossel.workspace)
    same = KLIPPER.fit(made.geometry, replace(KLIPPER.nominal(kossel), angle=to_klipper(fit.values).angle),
                       kossel.step_distance, kossel.workspace)
    assert abs(fit.after.max_3d - same.after.max_3d) < 1e-6 and fit.after.max_3d < 0.5 * fit.before.max_3d
    assert abs(fit.values.angle_trim.sum()) < 1e-12 and np.all(fit.values.endstop_adj <= 0.0)
    assert "M665 Z" in fit.held


def test_export_reads_back(kossel, tmp_path):
    made = random_true_printer(kossel, np.random.default_rng(5), typical_kit())
    start = load_marlin(CAPTURE)
    fitted = MARLIN.fit(made.geometry, start, kossel.step_distance, kossel.workspace).values
    path = MARLIN.save_config(tmp_path / "calibrated.gcode", fitted, title="fitted")
    text = path.read_text()
    assert text.splitlines()[-1] == "M500 ; save to EEPROM" and config_firmware(path) is MARLIN
    back = load_marlin(path)  # no M851 line: the probe offset is the printer's, kept by the M665 H comment
    assert_allclose(back.rods, fitted.rods, atol=1e-4)
    assert back.radius == pytest.approx(fitted.radius, abs=5e-5)
    assert_allclose(back.angle_trim, fitted.angle_trim, atol=5e-5)
    assert_allclose(back.endstop_adj, fitted.endstop_adj, atol=5e-5)
    assert_allclose(back.steps_per_mm, fitted.steps_per_mm, atol=5e-7)
    assert back.height == pytest.approx(fitted.height, abs=5e-5)
    complete = MARLIN.save_config(tmp_path / "complete.gcode", fitted, complete=True)
    exact_back = load_marlin(complete)
    point = np.array([[10.0, 20.0, 30.0]])
    assert_allclose(exact_back.steps(point), fitted.steps(point), atol=1e-9, rtol=0)
    assert exact_back.soft_endstops.radius == fitted.soft_endstops.radius
