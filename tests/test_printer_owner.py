"""A printer's errors in its owner's words (issue 39): towers' endstops, leans, travels, rods and the bed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from deltacal.calibration import Calibration
from deltacal.errormodels import get_model
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer
from deltacal.printer.owner import Estimate, PrinterErrors, TowerErrors, printer_errors

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
MODEL = get_model("printer")


@pytest.fixture(scope="module")
def nominal():
    return load_printer(MODELS / "kossel.toml").geometry()


def _deviations(**values: float) -> np.ndarray:
    dk = np.zeros(MODEL.size)
    for name, v in values.items():
        dk[MODEL.names.index(name)] = v
    return dk


def _measure(truth, rng, distances=True):
    u = np.linspace(-115.0, 115.0, 7)
    xy = np.stack(np.meshgrid(u, u), axis=-1).reshape(-1, 2)
    xy = xy[np.hypot(*xy.T) <= 115.0 + 1e-9]
    probe = exact.inverse(truth, np.column_stack([xy, np.zeros(len(xy))]))
    probe = probe + rng.normal(size=probe.shape) * 0.01
    if not distances:
        return PrinterMeasurements(probe)
    heights = (5.0, 35.0, 70.0, 100.0)
    points = np.array([[r * np.cos(a + h / 90.0), r * np.sin(a + h / 90.0), h]
                       for h in heights for a in np.radians(np.arange(0, 360, 45)) for r in (40.0, 85.0)])
    pairs = rng.choice(len(points), size=(240, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]][:40]
    features = points[pairs]
    readings = exact.inverse(truth, features.reshape(-1, 3)).reshape(-1, 2, 3)
    measured = np.linalg.norm(features[:, 0] - features[:, 1], axis=1) + rng.normal(size=len(features)) * 0.02
    return PrinterMeasurements(probe, readings, measured)


def test_a_positive_lean_t_moves_the_top_outwards_and_lean_r_clockwise(nominal):
    """The signs the owner's words rest on, read off the geometry the model builds."""
    eps = 1e-4
    for i in range(3):
        r = np.array([np.cos(nominal.limb_azimuth[i]), np.sin(nominal.limb_azimuth[i]), 0.0])
        t = np.array([-r[1], r[0], 0.0])
        out = MODEL.apply(nominal, _deviations(**{f"lean{i + 1}t": eps}))
        move = out.axis_direction[i] - nominal.axis_direction[i]
        assert move @ r == pytest.approx(eps, rel=1e-3) and abs(move @ t) < 1e-9
        side = MODEL.apply(nominal, _deviations(**{f"lean{i + 1}r": eps}))
        move = side.axis_direction[i] - nominal.axis_direction[i]
        assert move @ t == pytest.approx(-eps, rel=1e-3) and abs(move @ r) < 1e-9


def test_the_owner_reads_each_towers_error_and_the_bed_from_a_calibration(nominal):
    """A printer built with known errors: tower B's endstop 0.23 mm high, tower A leaning 0.07° outwards,
    tower C travelling 0.3 % long, the bed tilted 0.2° (all three towers leaning alike): the owner's
    values recover each within 3 σ, all determined by heights and the printed object's distances."""
    lean = np.radians(0.07)
    tilt = np.radians(0.2)  # towers' tops moved by m = tilt along +x: the bed turned about y
    dk = _deviations(endstop2=0.23, scale3=0.3, lean1t=lean)
    azimuth = nominal.limb_azimuth
    for i in range(3):  # the common move m = (tilt, 0) as lean_it r_i − lean_ir t_i
        r = np.array([np.cos(azimuth[i]), np.sin(azimuth[i])])
        t = np.array([-r[1], r[0]])
        m = np.array([tilt, 0.0])
        dk[MODEL.names.index(f"lean{i + 1}t")] += m @ r
        dk[MODEL.names.index(f"lean{i + 1}r")] += -(m @ t)
    truth = MODEL.apply(nominal, dk)
    result = identify_printer(nominal, _measure(truth, np.random.default_rng(3901)))
    errors = printer_errors(Calibration.from_result(result))
    a, b, c = errors.towers
    for estimate, want in ((b.endstop, 0.23), (c.travel, 0.3), (a.lean_out, 0.07), (errors.bed_tilt, 0.2),
                           (a.endstop, 0.0), (b.lean_out, 0.0), (a.travel, 0.0)):
        assert estimate.determined, estimate
        assert abs(estimate.value - want) < 3 * estimate.sigma + 1e-3, (estimate, want)
    # the towers' tops moved towards +x: relative to them the bed is turned about y by −tilt, which
    # raises its +x side: low towards azimuth 180°
    assert abs((errors.bed_low_azimuth - 180.0 + 180.0) % 360.0 - 180.0) < 10.0
    text = "\n".join(errors.lines())
    assert b.endstop.value > 0.0 and "stops high" in text
    assert f"tower B: endstop {b.endstop.value:+.2f}" in text
    assert "travels long" in text


def test_what_heights_alone_do_not_measure_is_said(nominal):
    """Probe heights alone do not separate a tower's travel from its endstop: the travel is not measured."""
    truth = MODEL.apply(nominal, _deviations(endstop1=0.1, scale2=0.2))
    # the kit's tolerances as given: what is determined is judged against the prior the fit used
    result = identify_printer(nominal, _measure(truth, np.random.default_rng(3902), distances=False),
                              tolerance_scale=1.0)
    errors = printer_errors(Calibration.from_result(result))
    assert not any(t.travel.determined for t in errors.towers)
    assert "travel not measured" in "\n".join(errors.lines())


def test_the_owner_is_told_in_each_firmwares_words(nominal):
    """Klipper names [stepper_b] position_endstop, Marlin M666 Y, RRF M666 Y and its M666 A B for the bed."""
    from deltacal.printer.firmware import firmware_named
    from deltacal.printer.owner import owner_lines

    truth = MODEL.apply(nominal, _deviations(endstop2=0.23))
    result = identify_printer(nominal, _measure(truth, np.random.default_rng(3903)))
    calibration = Calibration.from_result(result)
    texts, b = {}, printer_errors(calibration).towers[1].endstop
    assert abs(b.value - 0.23) < 3 * b.sigma  # tower B's own endstop read back (as the test above)
    for name in ("klipper", "marlin", "rrf"):
        firmware = firmware_named(name)
        errors = printer_errors(calibration, names=firmware.owner_keys.towers)
        texts[name] = "\n".join(owner_lines(errors, firmware.owner_keys, firmware.title))
    said = f"endstop {b.value:+.2f} ± {b.sigma:.2f} mm (stops high)"
    assert f"tower B: {said}" in texts["klipper"] and "[stepper_b] position_endstop" in texts["klipper"]
    assert f"tower Y: {said}" in texts["marlin"] and "M666 Y" in texts["marlin"]
    assert "printer.cfg" not in texts["marlin"] + texts["rrf"] and "M666" not in texts["klipper"]
    assert "rotation_distance" in texts["klipper"] and "M92 Z" in texts["rrf"]


def test_a_quantity_within_its_sigma_is_not_determined_whatever_its_sign():
    """Issue 46: "endstop -0.26 ± 2.60 mm (stops low)" from seven heights said a sign nothing measured."""
    unknown = (Estimate(0.0, 1.0, False),) * 4
    towers = tuple(TowerErrors(name, Estimate(-0.26, 2.60, True), Estimate(0.5, 0.1, True), *unknown)
                   for name in "ABC")
    lines = PrinterErrors(towers, Estimate(0.0, 1.0, False), 0.0).lines()
    assert "endstop -0.26 ± 2.60 mm (not determined by these measurements)" in lines[0]
    assert "stops" not in lines[0] and "travels long" in lines[0]  # 0.5 ± 0.1 %: determined
    towers = tuple(TowerErrors(name, Estimate(-0.26, 0.03, True), Estimate(0.05, 0.1, True), *unknown)
                   for name in "ABC")
    line = PrinterErrors(towers, Estimate(0.0, 1.0, False), 0.0).lines()[0]
    assert "(stops low)" in line and "travel +0.05 ± 0.10 % (not determined by these measurements)" in line
