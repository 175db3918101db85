"""Klipper's own delta calibration (issue 24's anchor) and the printer simulation it is measured with."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_klipper_fit import WORKSPACE, klipper_shaped

from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.calibrate import (
    delta_analyze_distances,
    klipper_basic,
    klipper_enhanced,
    object_pairs,
    probe_points,
    stable_positions,
)
from deltacal.printer.firmware.klipper.fit import error_stats, values_of
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.robot import NominalLinearDelta
from deltacal.printer.simulation import (
    bed_motion,
    printed_distances,
    probe_heights,
    random_printer,
    random_true_printer,
    typical_kit,
    well_built,
)

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def test_probe_pattern_and_object():
    points = probe_points(100.0)
    assert points.shape == (7, 2)
    assert_allclose(points[0], [0.0, 0.0], atol=0)
    assert_allclose(np.hypot(*points[1:].T), [95.0, 90.0, 85.0, 70.0, 75.0, 80.0], atol=1e-12)
    assert_allclose(np.degrees(np.arctan2(points[1, 1], points[1, 0])), 90.0, atol=1e-12)
    pairs = object_pairs()
    assert pairs.shape == (12, 6) and np.all(pairs[:, [2, 5]] == 0.0)
    # every measured span is the object's 65 mm pillar spacing between ridges 4.5 mm off centre
    assert_allclose(np.linalg.norm(pairs[:, :3] - pairs[:, 3:], axis=1), 65.0, atol=1e-12)
    # an outer span ends near the neighbouring pillar (60 deg on)
    end = pairs[6, 3:5]
    pillar = 65.0 * np.array([np.cos(np.radians(270.0)), np.sin(np.radians(270.0))])
    assert_allclose(np.linalg.norm(end - pillar), 4.5, atol=1e-12)
    d = delta_analyze_distances([75.0] * 6, [10.0, 11.0, 12.0], [70.0] * 6, [5.0] * 6)
    assert_allclose(d, [65.0, 63.0, 64.0, 65.0, 63.0, 64.0] + [65.0] * 6, atol=1e-12)


def test_stable_positions_are_klippers_forward(kossel):
    k = KlipperDelta.from_printer(kossel)
    targets = np.array([[0.0, 0.0, 0.0], [50.0, -30.0, 20.0], [-70.0, 40.0, 90.0]])
    v = np.concatenate([[k.delta_radius], np.degrees(k.angle), k.arm_length, k.position_endstop])
    assert_allclose(stable_positions(v, k.step_distance, k.steps(targets)), targets, atol=1e-9)


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (20.0, -15.0, -3.0)])
def test_probe_heights_on_the_bed(kossel, offset):
    rng = np.random.default_rng(3)
    truth = random_printer(kossel, rng, typical_kit())
    firmware = KlipperDelta.from_printer(kossel)
    xy = probe_points(115.0)
    probes = probe_heights(truth, firmware, kossel.step_distance, xy, 0.0, rng, probe_offset=offset)
    assert_allclose(probes[:, :2], xy, atol=0)
    pose = exact.forward(truth, firmware.inverse(probes, kossel.step_distance))
    tip = pose.point(truth.tool + np.asarray(offset))
    assert np.max(np.abs(tip[:, 2])) < 1e-8
    # the uncalibrated printer's bed is not at the commanded z = 0
    assert np.max(np.abs(probes[:, 2] + offset[2])) > 0.05
    noisy = probe_heights(truth, firmware, kossel.step_distance, xy, 0.01, np.random.default_rng(4),
                          probe_offset=offset)
    assert 0.0 < np.max(np.abs(noisy[:, 2] - probes[:, 2])) < 0.05


def test_random_printer_bed_is_z0(kossel):
    made = random_true_printer(kossel, np.random.default_rng(8), well_built(), bed_tilt_deg=0.5)
    rotation = made.bed_rotation
    assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-14)
    tilt = np.degrees(np.arccos(rotation[2, 2]))
    assert 0.0 < tilt < 3.0
    r, t = bed_motion(0.0, 0.0, 2.0)
    assert_allclose(r, np.eye(3), atol=0) and assert_allclose(t, [0.0, 0.0, -2.0], atol=0)


def test_printed_distances_through_the_truth(kossel):
    firmware = KlipperDelta.from_printer(kossel)
    perfect = kossel.geometry()
    pairs = object_pairs()
    d = printed_distances(perfect, firmware, kossel.step_distance, pairs, 0.0, np.random.default_rng(0))
    assert_allclose(d, 65.0, atol=1e-9)  # the perfect printer prints what it is told


def test_basic_recovers_a_klipper_shaped_printer(kossel):
    k0 = KlipperDelta.from_printer(kossel)
    truth = KlipperDelta(k0.delta_radius + 0.7, k0.angle + np.radians([0.3, -0.2, 0.0]), k0.arm_length,
                         k0.position_endstop + np.array([0.5, -0.8, 0.3]), k0.step_distance)
    printer = klipper_shaped(truth, kossel.step_distance)
    rng = np.random.default_rng(0)
    probes = probe_heights(printer, k0, kossel.step_distance, probe_points(115.0), 0.0, rng)
    found = klipper_basic(k0, probes)
    # coordinate descent stops when its steps sum below 1e-5 (mm, deg): values to about 1e-6
    assert_allclose(values_of(found), values_of(truth), atol=5e-6, rtol=0)
    assert error_stats(printer, found, kossel.step_distance, WORKSPACE).max_3d < 2e-5


@pytest.mark.slow
def test_enhanced_recovers_arms_too(kossel):
    k0 = KlipperDelta.from_printer(kossel)
    truth = KlipperDelta(k0.delta_radius + 0.7, k0.angle + np.radians([0.3, -0.2, 0.0]),
                         k0.arm_length + np.array([0.4, -0.3, 0.2]),
                         k0.position_endstop + np.array([0.5, -0.8, 0.3]), k0.step_distance)
    printer = klipper_shaped(truth, kossel.step_distance)
    rng = np.random.default_rng(0)
    probes = probe_heights(printer, k0, kossel.step_distance, probe_points(115.0), 0.0, rng)
    pairs = object_pairs()
    distances = printed_distances(printer, k0, kossel.step_distance, pairs, 0.0, rng)
    found = klipper_enhanced(k0, probes, pairs, distances)
    # the arms are weakly seen (a 65 mm span's length changes 1e-4 mm per 1e-3 mm of arm): the
    # descent's stopping rule leaves them to about 1e-4 mm, the nozzle to a few 1e-5 mm
    assert_allclose(values_of(found), values_of(truth), atol=1e-3, rtol=0)
    assert error_stats(printer, found, kossel.step_distance, WORKSPACE).max_3d < 1e-4
    basic = klipper_basic(k0, probes)
    assert error_stats(printer, basic, kossel.step_distance, WORKSPACE).max_3d > 0.01  # it cannot fit arms
