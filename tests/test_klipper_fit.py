"""Klipper's values fitted to a printer (issue 24): recovery on a Klipper-shaped printer, no worse than
Klipper's own calibration, and the printer.cfg writer's round trip (what they leave per error source:
test_firmware_budget.py, for every firmware)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.geometry import DeltaGeometry, Workspace
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.calibrate import klipper_basic, probe_points
from deltacal.printer.firmware.klipper.config import klipper_config_text, load_klipper, save_klipper_config
from deltacal.printer.firmware.klipper.fit import (
    KLIPPER_NAMES,
    error_stats,
    fit_klipper,
    nozzle_errors,
    values_of,
)
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.robot import NominalLinearDelta
from deltacal.printer.simulation import probe_heights, random_true_printer, typical_kit

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
WORKSPACE = Workspace(radius=92.0, height=100.0, top_z=100.0)
EFFECTOR = 30.0


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def klipper_shaped(klipper: KlipperDelta, step_distance: np.ndarray | float) -> DeltaGeometry:
    """A printer Klipper's model describes exactly: vertical towers, parallelograms, nozzle at the effector.

    Tower radius ρ + a with an effector radius a (each parallelogram keeps the effector level, so its
    centre follows Klipper's point effector), both rods of tower i of length ℓ_i, carriage at E_i at
    the endstop, true step distance d_i (joint_scale d_i / d).
    """
    height = float(np.mean(klipper.carriage_top))
    nominal = NominalLinearDelta("klipper-shaped", klipper.delta_radius + EFFECTOR, EFFECTOR, 269.0,
                                 50.0, np.array(klipper.angle), height, step_distance)
    errors = {}
    for i in range(3):
        errors[f"limb{i + 1}.axis_point.z"] = float(klipper.carriage_top[i] - height)
        for rod in ("rod1", "rod2"):
            errors[f"limb{i + 1}.{rod}.length"] = float(klipper.arm_length[i] - 269.0)
        nominal_step = np.broadcast_to(step_distance, 3)[i]
        errors[f"limb{i + 1}.joint_scale"] = float(klipper.step_distance[i] / nominal_step - 1.0)
    return nominal.geometry().with_errors(errors)


def odd_klipper(kossel: NominalLinearDelta) -> KlipperDelta:
    """Klipper's values a little away from the nominal printer's, each differently."""
    k0 = KlipperDelta.from_printer(kossel)
    return KlipperDelta(k0.delta_radius + 0.7, k0.angle + np.radians([0.3, -0.2, 0.25]),
                        k0.arm_length + np.array([0.4, -0.3, 0.2]),
                        k0.position_endstop + np.array([0.5, -0.8, 0.3]),
                        k0.step_distance * np.array([1.002, 0.999, 1.0015]))


def test_klipper_shaped_printer_follows_klipper(kossel):
    # the test printer is what it claims: Klipper's values put its nozzle on every target
    truth = odd_klipper(kossel)
    printer = klipper_shaped(truth, kossel.step_distance)
    grid = np.array([[0.0, 0.0, 0.2], [60.0, -40.0, 50.0], [-80.0, 30.0, 100.0]])
    assert np.max(np.abs(nozzle_errors(printer, truth, kossel.step_distance, grid))) < 1e-9


def test_fit_recovers_klipper_shaped_values(kossel):
    truth = odd_klipper(kossel)
    printer = klipper_shaped(truth, kossel.step_distance)
    fit = fit_klipper(printer, KlipperDelta.from_printer(kossel), kossel.step_distance, WORKSPACE,
                      part_frame=False)
    assert fit.fitted == list(KLIPPER_NAMES) and fit.unidentifiable == []
    found, want = values_of(fit.values), values_of(truth)
    assert_allclose(found[:10], want[:10], atol=1e-6, rtol=0)  # mm and rad
    assert_allclose(found[10:], want[10:], rtol=1e-6, atol=0)  # step distances, relative
    assert fit.after.max_3d < 1e-6 < 0.5 < fit.before.max_3d


def test_fit_with_step_distances_held_keeps_them(kossel):
    truth = odd_klipper(kossel)
    printer = klipper_shaped(truth, kossel.step_distance)
    start = KlipperDelta.from_printer(kossel)
    fit = fit_klipper(printer, start, kossel.step_distance, WORKSPACE, hold_step_distance=True,
                      part_frame=False)
    assert_allclose(fit.values.step_distance, start.step_distance, rtol=0, atol=0)
    assert fit.held == list(KLIPPER_NAMES[10:])
    free = fit_klipper(printer, start, kossel.step_distance, WORKSPACE, part_frame=False)
    assert free.after.rms_3d < fit.after.rms_3d < fit.before.rms_3d


@pytest.mark.parametrize("seed", [11, 12])
def test_fit_no_worse_than_klipper_basic(kossel, seed):
    rng = np.random.default_rng(seed)
    truth = random_true_printer(kossel, rng, typical_kit()).geometry
    k0 = KlipperDelta.from_printer(kossel)
    probes = probe_heights(truth, k0, kossel.step_distance, probe_points(115.0), 0.0, rng)
    basic = error_stats(truth, klipper_basic(k0, probes), kossel.step_distance, WORKSPACE)
    fit = fit_klipper(truth, k0, kossel.step_distance, WORKSPACE, part_frame=False)
    assert fit.after.rms_3d <= basic.rms_3d
    assert fit.after.max_3d <= basic.max_3d
    # the Jacobian's scaled singular values: all 13 values identifiable, none a gauge
    assert fit.singular_values.shape == (13,) and fit.singular_values[-1] > 1e-6 * fit.singular_values[0]


def test_in_the_parts_frame_a_printer_turned_and_shifted_on_its_bed_is_klippers(kossel):
    """A Klipper-shaped printer turned about the bed's normal and shifted along it prints the same parts:
    in the part's frame its values are found with angle_c held (the towers' common turn is the part's).

    The turn brings tower C back to Klipper's 90 deg: the in-plane motion removed is linear in the
    turn, so a turn of the whole would leave its second order (R θ² / 2, 0.01 mm at 0.65 deg)."""
    truth = odd_klipper(kossel)
    turn = -(truth.angle[2] - np.radians(90.0))
    c, s = np.cos(turn), np.sin(turn)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    printer = klipper_shaped(truth, kossel.step_distance).moved_rigidly(rotation, np.array([0.8, -0.5, 0.0]))
    start = KlipperDelta.from_printer(kossel)
    absolute = fit_klipper(printer, start, kossel.step_distance, WORKSPACE, part_frame=False)
    fit = fit_klipper(printer, start, kossel.step_distance, WORKSPACE)
    assert fit.held == ["angle_c"] and "angle_c" not in fit.unidentifiable
    assert fit.after.max_3d < 1e-6 < 0.1 < error_stats(printer, absolute.values, kossel.step_distance,
                                                        WORKSPACE).max_3d
    assert error_stats(printer, fit.values, kossel.step_distance, WORKSPACE, part_frame=True).max_3d < 1e-6


def test_writer_round_trip(kossel, tmp_path):
    fitted = odd_klipper(kossel)
    source = tmp_path / "printer.cfg"
    source.write_text("[printer]\nkinematics: delta\ndelta_radius: 130\n"
                      + "".join(f"[stepper_{t}]\nmicrosteps: 16\nrotation_distance: 40\n"
                                f"position_endstop: 290\narm_length: 260\n" for t in "abc")
                      + "[stepper_b]\ngear_ratio: 2:1\nfull_steps_per_rotation: 400\n")
    text = klipper_config_text(fitted, source)
    assert "assumes" not in text
    merged = tmp_path / "merged.cfg"
    save_klipper_config(merged, fitted, source)
    merged.write_text(source.read_text() + merged.read_text())  # a later value of an option wins
    back = load_klipper(merged)
    assert_allclose(back.delta_radius, fitted.delta_radius, atol=5e-7, rtol=0)
    assert_allclose(np.degrees(back.angle), np.degrees(fitted.angle), atol=5e-5, rtol=0)
    assert_allclose(back.arm_length, fitted.arm_length, atol=5e-7, rtol=0)
    assert_allclose(back.position_endstop, fitted.position_endstop, atol=5e-7, rtol=0)
    assert_allclose(back.step_distance, fitted.step_distance, rtol=5e-7 / 10.0, atol=0)
    assert "rotation_distance: " in text and "[stepper_c]" in text and "kinematics" not in text


def test_writer_without_source_writes_no_rotation_distance(kossel, tmp_path):
    """Without the printer's microstepping, rotation_distance cannot be known: none is written."""
    fitted = odd_klipper(kossel)
    text = klipper_config_text(fitted)
    assert "rotation_distance:" not in text
    assert "# no rotation_distance for stepper_a, stepper_b, stepper_c: its microsteps are not known" in text
    cfg = tmp_path / "printer.cfg"
    steppers = "".join(f"[stepper_{t}]\nmicrosteps: 32\nrotation_distance: 40\n" for t in "abc")
    cfg.write_text("[printer]\nkinematics: delta\n" + steppers + text)
    back = load_klipper(cfg)  # the printer's own stepping stays: 40 mm over 200 x 32 steps
    assert_allclose(back.step_distance, np.full(3, 40.0 / 6400.0), rtol=1e-15, atol=0)
    assert_allclose(back.arm_length, fitted.arm_length, rtol=0, atol=5e-7)


def test_first_layer_weight_buys_flatness(kossel):
    truth = random_true_printer(kossel, np.random.default_rng(21), typical_kit()).geometry
    k0 = KlipperDelta.from_printer(kossel)
    plain = fit_klipper(truth, k0, kossel.step_distance, WORKSPACE)
    weighted = fit_klipper(truth, k0, kossel.step_distance, WORKSPACE, first_layer_weight=10.0)
    assert weighted.after.flatness < plain.after.flatness
    assert plain.after.rms_3d <= weighted.after.rms_3d  # the plain fit is the volume's least squares
    assert weighted.points == plain.points
