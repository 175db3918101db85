"""Marlin's G33 and RepRapFirmware's G32, emulated (``marlin/calibrate.py``, ``rrf/calibrate.py``), and the
firmwares' comparison on fresh printers (slow)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from deltacal.printer.comparison import (
    CLASSES,
    GCODE,
    UNCALIBRATED,
    WORKSPACE,
    best_name,
    evaluate,
    exported_name,
    gcode_refused,
    run_printer,
)
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.fit import error_stats
from deltacal.printer.firmware.marlin.calibrate import g33_probe_weights, marlin_g33
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.values import to_klipper
from deltacal.printer.firmware.rrf.calibrate import bed_points, rrf_auto_calibration, rrf_g32
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE
from deltacal.printer.printed.plan import plan_object
from deltacal.printer.simulation import probe_heights, random_true_printer, typical_kit

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


@pytest.fixture(scope="module")
def printer():
    return load_printer(MODELS / "kossel.toml")


@pytest.mark.parametrize("points, probes", [(1, 1), (2, 4), (3, 9), (4, 16), (5, 25), (6, 36), (7, 49),
                                            (8, 64), (9, 81), (10, 100)])
def test_g33_probes_as_many_points_as_marlin_says(points, probes):
    """G33.cpp's comments: P3 9 probes, P4 16, P7 49, P10 100; each radius point a mean of its shares."""
    xy, weights = g33_probe_weights(points, 105.0)
    assert len(xy) == probes
    if points >= 2:
        assert np.max(np.hypot(xy[:, 0], xy[:, 1])) == pytest.approx(105.0)
        used = weights[1:][weights[1:].sum(axis=1) > 0]
        np.testing.assert_allclose(used.sum(axis=1), 1.0, atol=1e-12)


def test_rrf_auto_calibration_recovers_values_rrf_can_hold(printer):
    """A printer that is RRF's model with other endstops, radius and angles: two S6 runs on exact heights
    find them."""
    nominal = RRF_FIRMWARE.nominal(printer)
    true = replace(nominal, endstop_adjustment=np.array([0.4, -0.3, -0.1]), radius=nominal.radius + 0.5,
                   angle_correction=np.radians([0.2, -0.15, 0.0]))
    points = bed_points(105.0)
    steps = true.steps(np.column_stack([points, np.zeros(len(points))]))  # the nozzle on the true bed
    found = nominal
    for _ in range(2):  # G32 twice: the bed's height where each run's values see it (G30)
        found = rrf_auto_calibration(found, points, found.positions(steps)[:, 2], 6)
    np.testing.assert_allclose(found.radius, true.radius, atol=1e-3)
    np.testing.assert_allclose(np.degrees(found.angle_correction), np.degrees(true.angle_correction),
                               atol=1e-3)
    np.testing.assert_allclose(found.carriage_top - found.carriage_top.mean(),
                               true.carriage_top - true.carriage_top.mean(), atol=1e-3)


@pytest.mark.parametrize("calibrate", ["marlin", "rrf"])
def test_own_calibration_flattens_a_kit(printer, calibrate):
    """On a typical kit the firmware's own calibration takes the first layer's error below 0.1 mm."""
    rng = np.random.default_rng(4242)
    truth = random_true_printer(printer, rng, typical_kit()).geometry
    step = printer.step_distance
    probe = lambda values, xy: probe_heights(truth, values, step, xy, 0.01, rng)[:, 2]  # noqa: E731
    if calibrate == "marlin":
        start = MARLIN.nominal(printer)
        result = marlin_g33(start, probe, 115.0)
        assert 2 <= result.iterations <= 31 and result.std_dev < 0.05
        values = result.values
        before, after = (error_stats(truth, to_klipper(v), step, WORKSPACE) for v in (start, values))
        assert np.all(values.endstop_adj <= 0.0) and abs(float(np.sum(values.angle_trim))) < 1e-9
    else:
        start = RRF_FIRMWARE.nominal(printer)
        calibrated = rrf_g32(start, probe, 105.0)
        before, after = (error_stats(truth, v, step, WORKSPACE) for v in (start, calibrated))
    assert before.flatness > 0.3
    assert after.flatness < 0.1 and after.max_3d < before.max_3d


@pytest.mark.long
@pytest.mark.parametrize("firmware", [MARLIN, RRF_FIRMWARE], ids=lambda f: f.name)
def test_firmware_routes_meet_the_criteria_on_fresh_printers(printer, firmware):
    """3 fresh kits (seeds 26100-26102, no other test's): the G-code route <= 0.05 mm and a tenth of
    the uncalibrated error (mean), inside the firmware's limits; exported <= 1.25 x best + 0.01 mm."""
    plan = plan_object(printer, firmware.nominal(printer))
    tolerances, tilt = CLASSES["typical kit"]
    figures = {name: [] for name in (UNCALIBRATED, GCODE, exported_name(30.0), best_name(30.0))}
    for seed in (26100, 26101, 26102):
        run = run_printer(printer, plan, seed, tolerances, tilt, (30.0,), firmware_type=firmware, best=True)
        assert gcode_refused(run) == 0
        head = evaluate(run)["less bed motion"]
        for name in figures:
            figures[name].append(head[name].max_3d)
    mean = {name: float(np.mean(v)) for name, v in figures.items()}
    assert mean[GCODE] <= 0.05
    assert mean[GCODE] <= 0.1 * mean[UNCALIBRATED]
    assert mean[exported_name(30.0)] <= 1.25 * mean[best_name(30.0)] + 0.01
