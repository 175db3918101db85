"""Identification of a linear Delta printer from probe heights and printed distances, on exact printers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from deltacal.errormodels import get_model
from deltacal.geometry import Tolerances
from deltacal.io.calibration import calibration_from_result, load_calibration, save_calibration
from deltacal.io.geometry_file import load_geometry, save_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.identification.fit import (
    PrinterFitOptions,
    PrinterMeasurements,
    identify_printer,
    measured_combinations,
    posterior_sigma,
)
from deltacal.printer.simulation import random_printer
from deltacal.report.accuracy import less_bed_motion

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"
PRINTER = load_printer(MODELS / "kossel.toml")


@pytest.fixture(scope="module")
def nominal():
    return load_printer(MODELS / "kossel.toml").geometry()


def _printer(nominal, seed):
    """A printer no test was tuned on: kit tolerances, on a tilted bed (the simulation's)."""
    return random_printer(PRINTER, np.random.default_rng(seed), Tolerances.printer_kit())


def _bed_grid(radius=115.0):
    u = np.linspace(-radius, radius, 7)
    xy = np.stack(np.meshgrid(u, u), axis=-1).reshape(-1, 2)
    return xy[np.hypot(*xy.T) <= radius + 1e-9]


def _features(rng, count=40):
    heights = (5.0, 35.0, 70.0, 100.0)
    points = np.array([[r * np.cos(a + h / 90.0), r * np.sin(a + h / 90.0), h]
                       for h in heights for a in np.radians(np.arange(0, 360, 45)) for r in (40.0, 85.0)])
    pairs = rng.choice(len(points), size=(6 * count, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    length = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    pairs = pairs[np.argsort(-length, kind="stable")][:count]
    return points[pairs]  # (M, 2, 3)


def _measure(truth, rng, distances=True, sigma=(0.01, 0.02)):
    """Readings at which the truth's nozzle touches the bed, and distances between printed features."""
    xy = _bed_grid()
    probe = exact.inverse(truth, np.column_stack([xy, np.zeros(len(xy))]))
    probe = probe + rng.normal(size=probe.shape) * sigma[0]  # the trigger's scatter, in readings
    if not distances:
        return PrinterMeasurements(probe)
    features = _features(rng)
    pairs = exact.inverse(truth, features.reshape(-1, 3)).reshape(-1, 2, 3)
    measured = np.linalg.norm(features[:, 0] - features[:, 1], axis=1)
    measured = measured + rng.normal(size=len(features)) * sigma[1]
    return PrinterMeasurements(probe, pairs, measured)


def _volume(count=1500, seed=7):
    rng = np.random.default_rng(seed)
    r, a = 92.0 * np.sqrt(rng.uniform(size=count)), rng.uniform(0.0, 2 * np.pi, count)
    return np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(0.2, 100.0, count)])


def _shape_error(truth, identified, points):
    """Largest TCP error over points, less the shift along the bed and turn about it nothing measures."""
    pose = exact.forward(truth, exact.inverse(identified, points))
    error, _ = less_bed_motion(points, pose.position + pose.rotation @ truth.tool - points)
    return float(np.max(np.linalg.norm(error, axis=1)))


def test_printer_geometry_file_round_trips_bit_for_bit(nominal, tmp_path):
    truth = _printer(nominal, 3)
    save_geometry(truth, tmp_path / "g.toml")
    back = load_geometry(tmp_path / "g.toml")
    assert back.joint == "prismatic"
    for key in ("axis_point", "axis_direction", "encoder_offset", "joint_scale", "arm_ball", "plate_ball",
                "rod_length", "tool"):
        assert np.array_equal(getattr(back, key), getattr(truth, key)), key


def test_noise_free_measurements_are_fitted_exactly(nominal):
    """Exact measurements, said to be far surer than the tolerances (σ 1 nm): the priors yield."""
    truth = _printer(nominal, 11)
    data = _measure(truth, np.random.default_rng(1), sigma=(0.0, 0.0))
    data = PrinterMeasurements(data.probe, data.pairs, data.distance, height_sigma=1e-6, distance_sigma=1e-6)
    result = identify_printer(nominal, data)
    assert result.before.height_max > 0.5 and result.before.distance_max > 0.5
    assert result.after.height_max < 1e-5
    assert result.after.distance_max < 1e-5
    assert _shape_error(truth, result.geometry, _volume()) < 1e-4


def test_identify_printer_takes_one_options_value_and_overrides_of_its_fields(nominal):
    data = _measure(_printer(nominal, 12), np.random.default_rng(2))
    options = PrinterFitOptions(method="linear", tolerance_scale=0.5)
    by_options = identify_printer(nominal, data, options=options)
    by_keywords = identify_printer(nominal, data, method="linear", tolerance_scale=0.5)
    overridden = identify_printer(nominal, data, options=PrinterFitOptions(tolerance_scale=0.5),
                                  method="linear")
    assert np.array_equal(by_options.values, by_keywords.values)
    assert np.array_equal(by_options.values, overridden.values) and overridden.method == "linear"
    with pytest.raises(TypeError, match="'tolerance' is not an option of PrinterFitOptions"):
        identify_printer(nominal, data, tolerance=Tolerances.printer_kit())  # type: ignore[call-arg]
    with pytest.raises(ValueError, match="method must be 'linear' or 'iterated', got 'newton'"):
        PrinterFitOptions(method="newton")  # type: ignore[arg-type]


@pytest.mark.parametrize("seed", [31, *(pytest.param(s, marks=pytest.mark.slow) for s in (32, 33))])
def test_probe_and_distances_reach_a_few_hundredths_of_a_millimetre(nominal, seed):
    """Issue 24: 49 probe heights (σ 10 µm) and 40 distances (σ 20 µm) on printers no test was tuned on."""
    truth = _printer(nominal, seed)
    rng = np.random.default_rng(seed + 1000)
    data = _measure(truth, rng)
    volume = _volume()
    complete = identify_printer(nominal, data)
    firmware = identify_printer(nominal, data, "klipper")
    uncalibrated = _shape_error(truth, nominal, volume)
    error = _shape_error(truth, complete.geometry, volume)
    assert error < 0.08, (uncalibrated, error)
    assert error < 0.5 * _shape_error(truth, firmware.geometry, volume)
    assert 0.5 < complete.variance_factor < 2.0
    # without the printed object, the probe heights alone leave most of the error in the volume
    probe_data = _measure(truth, np.random.default_rng(seed + 1000), distances=False)
    probe_only = identify_printer(nominal, probe_data)
    assert _shape_error(truth, probe_only.geometry, volume) > 3 * error


def test_what_probe_heights_alone_cannot_give(nominal):
    truth = _printer(nominal, 41)
    rng = np.random.default_rng(2)
    probe_data, both_data = _measure(truth, rng, distances=False), _measure(truth, rng)
    assert measured_combinations(nominal, both_data).rank > measured_combinations(nominal, probe_data).rank
    prior, probe = posterior_sigma(nominal, probe_data)
    _, both = posterior_sigma(nominal, both_data)
    names = get_model("printer").names
    # a tower's step distance scales the volume: on the bed alone it is one height among others, the
    # printed object's distances measure it
    for name in ("scale1", "scale2", "scale3"):
        k = names.index(name)
        assert probe[k] > 0.5 * prior[k] and both[k] < 0.1 * prior[k], (name, prior[k], probe[k], both[k])
    # the endstops are the bed's height under each tower: the probe bounds them (with the scales, the
    # travel down to the bed), the object pins them
    for name in ("endstop1", "endstop2", "endstop3"):
        k = names.index(name)
        assert probe[k] < 0.1 * prior[k] and both[k] < 0.5 * probe[k]


def test_printer_calibration_file_round_trips(nominal, tmp_path):
    truth = _printer(nominal, 51)
    result = identify_printer(nominal, _measure(truth, np.random.default_rng(3)))
    save_calibration(calibration_from_result(result), tmp_path / "cal.toml")
    calibration = load_calibration(tmp_path / "cal.toml")
    assert calibration.model.name == "printer" and calibration.geometry.joint == "prismatic"
    assert np.array_equal(calibration.geometry.axis_point, result.geometry.axis_point)
    assert np.array_equal(calibration.geometry.joint_scale, result.geometry.joint_scale)


def test_positions_an_instrument_measured_in_its_own_frame(nominal):
    """Nozzle positions measured by an instrument whose frame is unknown (free, fitted in closed form)."""
    truth = _printer(nominal, 61)
    rng = np.random.default_rng(4)
    volume = _volume(60, seed=8)
    readings = exact.inverse(truth, volume)
    turn = np.radians(25.0) * np.array([0.2, -0.3, 0.93])
    c, s, k = np.cos(np.linalg.norm(turn)), np.sin(np.linalg.norm(turn)), turn / np.linalg.norm(turn)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R = np.eye(3) + s * K + (1 - c) * K @ K
    measured = volume @ R.T + np.array([1500.0, -200.0, 40.0]) + rng.normal(size=volume.shape) * 0.01
    probe = _measure(truth, rng, distances=False)
    data = PrinterMeasurements(probe.probe, positions=readings, measured=measured)
    result = identify_printer(nominal, data)
    assert result.after.position_rms < 0.02 < result.before.position_rms
    assert 0.5 < result.variance_factor < 2.0
    assert _shape_error(truth, result.geometry, _volume()) < 0.05
