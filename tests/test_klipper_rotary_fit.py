"""Klipper's rotary_delta values fitted to a rotary printer's geometry (the export's values), and their keys.

The printer: Klipper's example-rotary-delta.cfg, imported. (a) A true printer that is Klipper's model with
other values: the fit finds them. (b) A true printer with the complete error model's deviations (what
Klipper's model lacks): the fitted values leave less than the configured ones over the volume and no
more at the first layer.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.errormodels import get_model
from deltacal.geometry import Workspace
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_config_text, rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.firmware.klipper.rotary_fit import (
    ROTARY_NAMES,
    RotaryCommands,
    fit_klipper_rotary,
    values_of,
)
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta
from tests.test_klipper_rotary import EXAMPLE

#: The example's effector radius, rod spacing and nozzle drop (not in a printer.cfg) [mm].
MEASURED = ("--effector-radius", "25", "--rod-spacing", "45", "--nozzle-drop", "40")


def _start() -> KlipperRotaryDelta:
    return rotary_from_config(read_klipper_config(EXAMPLE))


def _volume(start: KlipperRotaryDelta) -> Workspace:
    """The imported robot file's volume in Klipper's frame: [delta_calibrate] radius 50, bed to limit_z."""
    return Workspace(50.0, start.limit_z, start.limit_z)


def _values(klipper: KlipperRotaryDelta) -> np.ndarray:
    return values_of(RotaryCommands(klipper, klipper.endstop_angles))


def _klipper_truth(start: KlipperRotaryDelta) -> tuple[KlipperRotaryDelta, object]:
    """Klipper's model with other values, as a geometry in {O} of the start's frame (bed at -(H_S + h)).

    Homed at its own endstops (the true position_endstop), so a reading of the start's (q = -theta_S) is
    the arm at q - (theta_end(true) - theta_end(start)): that encoder offset.
    """
    true = replace(start, shoulder_height=start.shoulder_height + 0.8,
                   shoulder_radius=start.shoulder_radius - 0.3, angle=start.angle + [0.004, -0.003, 0.0],
                   upper_arm=start.upper_arm + [0.3, -0.2, 0.1],
                   lower_arm=start.lower_arm + [-0.4, 0.25, 0.5],
                   position_endstop=start.position_endstop + [0.5, -0.7, 0.2])
    geometry = true.geometry(25.0, 45.0, 40.0).moved_rigidly(
        np.eye(3), np.array([0.0, 0.0, true.shoulder_height - start.shoulder_height]))
    return true, replace(geometry, encoder_offset=start.endstop_angles - true.endstop_angles)


def test_the_true_klipper_printer_is_built_as_klipper_steps_it():
    """The truth of (a) as Klipper drives it: the start's steps from the endstops, turned by the true
    model from its own endstop angles (Klipper's step_positions), put the true geometry's nozzle there."""
    start = _start()
    true, geometry = _klipper_truth(start)
    targets = np.array([[0.0, 0.0, 0.2], [40.0, -20.0, 30.0], [-35.0, 30.0, 150.0]])
    bed = KlipperRotaryController(start).in_bed_frame(geometry)
    nozzle = exact.forward(bed, start.inverse(targets)).point(bed.tool)
    np.testing.assert_allclose(nozzle, true.step_positions(start.steps(targets)), atol=1e-9)
    assert np.min(np.linalg.norm(nozzle - targets, axis=1)) > 0.3


def test_a_printer_that_is_klippers_model_gives_its_values_back():
    """Endstops, shoulder height and radius, two angles, the arms' lengths off: recovered within 1e-6,
    the nozzle error ~0 (from over 2 mm); stepper C's angle (the part's turn) held."""
    start = _start()
    true, geometry = _klipper_truth(start)
    fit = fit_klipper_rotary(geometry, start, _volume(start))
    assert fit.held == ["angle_c"] and fit.unidentifiable == []
    assert fit.before.max_3d > 2.0
    assert fit.after.max_3d < 1e-9 and fit.after.flatness < 1e-9
    np.testing.assert_allclose(_values(fit.values), _values(true), atol=1e-6, rtol=0.0)
    assert np.max(np.abs(_values(start) - _values(true))) > 0.5  # the start was off


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_the_complete_models_printer_fits_better_than_its_configured_values(tmp_path, seed):
    """A printer with the complete model's deviations (sigma 0.1 mm, 1 mrad): the fitted values leave a
    3-D max below half the configured values' (0.24 / 0.24 / 0.25 mm -> 0.094 / 0.097 / 0.075 mm) and a
    first layer no less flat (0.11 -> 0.003 mm)."""
    assert main(["import", str(EXAMPLE), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    nominal = load_nominal(tmp_path / "imp" / "printer.toml").geometry()
    model = get_model("complete")
    sigma = np.where(np.array(model.units) == "rad", 1e-3, 0.1)
    truth = model.apply(nominal, np.random.default_rng(seed).normal(0.0, 1.0, model.size) * sigma)
    start = _start()
    fit = fit_klipper_rotary(truth, start, _volume(start), nozzle_drop_of=nominal)
    assert fit.before.max_3d > 0.2
    assert fit.after.max_3d < 0.5 * fit.before.max_3d
    assert fit.after.flatness <= fit.before.flatness
    assert fit.after.flatness_pv <= fit.before.flatness_pv


def test_the_values_written_as_klippers_keys_read_back(tmp_path):
    """The keys Klipper reads ([printer] shoulder_height, shoulder_radius; each stepper's angle, arm
    lengths, position_endstop), pasted over the printer's configuration, read back to the written decimals."""
    start = _start()
    true, _ = _klipper_truth(start)
    text = rotary_config_text(true, "fitted")
    assert text.startswith("# fitted\n# Replace these keys")
    assert "[printer]\nshoulder_height: 413.700000\nshoulder_radius: 33.600000\n" in text
    assert "[stepper_b]\nangle: 149.8281\nupper_arm_length: 169.800000\nlower_arm_length: 320.250000\n" \
           "position_endstop: 251.300000\n" in text
    pasted = tmp_path / "printer.cfg"
    pasted.write_text(EXAMPLE.read_text() + "\n" + text)
    back = rotary_from_config(read_klipper_config(pasted))
    steps = np.array([1e-6, 1e-6] + [np.radians(1e-4)] * 3 + [1e-6] * 9)
    assert np.all(np.abs(_values(back) - _values(true)) <= 0.5 * steps + 1e-12)
    assert len(ROTARY_NAMES) == 14 and not np.allclose(_values(back), _values(start))
