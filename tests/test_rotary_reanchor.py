"""A rotary Delta printer's calibration re-anchored to the values Klipper's own calibration gives it
afterwards: the six simulated printers of tests/test_rotary_printer_identification.py.

Each printer (its truth and measurements: ``_identified``) is calibrated as ``deltacal identify`` calibrates
it through Klipper's example values (a rotary kit's tolerances scaled by the evidence, where it holds out to
Klipper's reach, the calibration in the robot's {O} recording the example's values and its measurements);
Klipper's extended DELTA_CALIBRATE is then run again on the same printer (fresh probing and print, the
example's values probing), and the calibration is compensated through the values it gives, re-anchored
(:meth:`~deltacal.printer.firmware.config_file.RotaryFirmwareConfig.anchor`).
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

from deltacal.calibration import Calibration
from deltacal.controller import corrected_targets
from deltacal.geometry import Tolerances
from deltacal.printer.firmware import firmware_named
from deltacal.printer.firmware.config_file import RotaryFirmwareConfig, out_of_firmware_frame
from deltacal.printer.firmware.klipper.rotary_calibrate import klipper_rotary_extended
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.identification.anchor import measured_record
from deltacal.printer.identification.errormodels import RotaryPrinterModel
from deltacal.printer.identification.fit import PrinterFitOptions, PrinterMeasurements, identify_printer
from deltacal.printer.rotary_simulation import printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE
from tests.test_rotary_printer_identification import OBJECT, PRINTERS, VOLUME, _identified, _nominal
from tests.test_rotary_printer_route import _layers

#: The issue-46 bound, applied to a rotary printer: re-anchored, never worse than the values' own + this [mm].
WORSE = 0.005


def test_an_arms_readings_are_counted_again_from_the_new_endstop_angle():
    """Re-anchoring counts the recorded steps in the values now given: arm A's endstop 0.5 mm up moves its
    endstop angle, so its readings of the same steps move by that angle's change; arms B and C, whose values
    did not change, read the same; counted back by the first values, the readings are the recorded ones."""
    k, _ = _nominal()
    before = KlipperRotaryController(k)
    after = before.with_values({"stepper_a.position_endstop": float(k.position_endstop[0]) + 0.5})
    q = np.random.default_rng(46).uniform(-0.8, 0.2, (20, 3))
    recounted = after.recounted(q, before)
    moved = after.firmware.endstop_angles - k.endstop_angles
    assert abs(moved[0]) > 1e-4 and np.all(moved[1:] == 0.0)
    assert np.allclose(recounted - q, -moved, rtol=0.0, atol=1e-12)
    assert np.allclose(before.recounted(recounted, after), q, rtol=0.0, atol=1e-12)


@functools.cache
def _calibrated(tolerances: Tolerances, seed: int) -> Calibration:
    """The printer's measurements identified as ``deltacal identify`` does through the example's values, in
    the robot's {O}, the values and the measurements recorded (``[controller]``, ``[measured]``)."""
    k, nominal = _nominal()
    printer, probe, pairs, distances = _identified(tolerances, seed)[:4]
    controller = KlipperRotaryController(k)
    data = PrinterMeasurements(printer.readings(k, probe), np.stack(
        [printer.readings(k, pairs[:, :3]), printer.readings(k, pairs[:, 3:])], axis=1), distances)
    options = PrinterFitOptions(tolerances=Tolerances.rotary_printer_kit(), workspace=OBJECT,
                                reach=controller.reach_radius)
    result = identify_printer(nominal, data, RotaryPrinterModel(), options=options)
    klipper = firmware_named("klipper")
    assert klipper is not None
    record = RotaryFirmwareConfig(klipper, controller, str(EXAMPLE)).record()
    return replace(out_of_firmware_frame(Calibration.from_result(result), controller), controller=record,
                   measured=measured_record(data, options, result.tolerance_scale))


@functools.cache
def _reanchored_layers(tolerances: Tolerances, seed: int) -> dict[str, np.ndarray]:
    """Per layer of VOLUME, 3-D max less the motion along the bed [mm]: the re-calibrated values' own, the
    calibration re-anchored to them, and through the example's values it was identified with."""
    k, _ = _nominal()
    printer, probe, pairs = _identified(tolerances, seed)[:3]
    rng = np.random.default_rng((seed, 48))
    again = probe_triggers(printer, k, probe[:, :2])
    again[:, 2] += rng.normal(0.0, 0.01, len(again))
    distances = printed_distances(printer, k, pairs) + rng.normal(0.0, 0.02, len(pairs))
    k2 = klipper_rotary_extended(k, again, pairs, distances)
    klipper = firmware_named("klipper")
    assert klipper is not None
    calibration = _calibrated(tolerances, seed)
    anchored, said = RotaryFirmwareConfig(klipper, KlipperRotaryController(k2), "recalibrated.cfg").anchor(
        calibration, "cal.toml")
    assert len(said) == 2 and "re-anchored" in said[0], said
    same, _ = RotaryFirmwareConfig(klipper, KlipperRotaryController(k), str(EXAMPLE)).anchor(calibration,
                                                                                             "cal.toml")
    return {"own": _layers(printer, k2, VOLUME),
            "reanchored": _layers(printer, k2, corrected_targets(anchored, KlipperRotaryController(k2),
                                                                 VOLUME).commands),
            "recorded": _layers(printer, k, corrected_targets(same, KlipperRotaryController(k),
                                                              VOLUME).commands)}


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize(("label", "tolerances", "seed"), PRINTERS,
                         ids=[f"{p[0]}-{p[2]}" for p in PRINTERS])
def test_reanchored_through_recalibrated_values_never_worse_than_their_own(label, tolerances, seed):
    """Issue 46's bound on the rotary printers: at every layer (z 0.2, 25, 50, 75, 100 mm; r <= 50) the
    calibration re-anchored to Klipper's re-calibrated values, 3-D max less the motion along the bed, never
    worse than those values' own + 0.005 mm. Measured [mm], per layer, the values' own / re-anchored /
    through the example's values as identified:
    kit 200: 0.161 0.082 0.054 0.082 0.132 / 0.030 0.019 0.025 0.021 0.020 / 0.033 0.020 0.028 0.023 0.035;
    kit 201: 0.220 0.106 0.115 0.206 0.312 / 0.027 0.013 0.017 0.030 0.059 / 0.020 0.008 0.010 0.021 0.036;
    kit 202: 0.306 0.158 0.167 0.304 0.467 / 0.040 0.035 0.041 0.079 0.138 / 0.025 0.027 0.023 0.020 0.035;
    well built 200: 0.042 0.022 0.016 0.023 0.033 / 0.023 0.012 0.013 0.016 0.020 / 0.022 0.015 0.018 0.020
    0.029; well built 201: 0.055 0.025 0.030 0.054 0.081 / 0.023 0.017 0.013 0.023 0.038 / 0.022 0.016 0.015
    0.020 0.033; well built 202: 0.077 0.047 0.051 0.081 0.116 / 0.023 0.023 0.025 0.024 0.052 / 0.022 0.019
    0.024 0.030 0.039. All six meet it (the script's well built 200, over it at z 50-100, was planned with
    the kit's plan, its distances rounded to the caliper's 0.001 mm and Klipper re-probing with the same
    stream of noise: other measurements). About 11 s of CPU each (an identification and a re-anchoring)."""
    layers = _reanchored_layers(tolerances, seed)
    assert np.all(layers["reanchored"] <= layers["own"] + WORSE), layers
