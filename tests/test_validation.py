"""Bai's validation set and metrics (TCP error, Δρ, Δv)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal import Tolerances
from deltacal.kinematics import exact
from deltacal.validation import (
    metrics_from_positions,
    validate,
    validation_poses,
    validation_reference,
    validation_targets,
)


def test_validation_set_97_targets_on_six_circles(bai):
    ws = bai.workspace
    targets = validation_targets(bai)
    assert targets.shape == (97, 3)
    assert_allclose(targets[0], ws.centre, atol=1e-12)
    circles = targets[1:].reshape(6, 16, 3)
    expected = [(z, f * ws.radius) for z in (ws.top_z, ws.middle_z, ws.bottom_z) for f in (0.5, 1.0)]
    for points, (z, radius) in zip(circles, expected, strict=True):
        assert_allclose(points[:, 2], z, atol=1e-12)
        assert_allclose(np.hypot(points[:, 0], points[:, 1]), radius, atol=1e-9)
        angle = np.mod(np.arctan2(points[:, 1], points[:, 0]), 2 * np.pi)
        assert_allclose(angle, 2 * np.pi * np.arange(16) / 16, atol=1e-12)


def test_targets_follow_the_tool(flexpicker):
    tool = np.array([0.0, 20.0, -100.0])
    assert_allclose(
        validation_targets(flexpicker, tool=tool),
        validation_reference(flexpicker) + tool - flexpicker.tool,
    )


def test_hand_made_delta_rho_and_delta_v():
    T = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]])
    P = np.array([[1.0, 0.0, 0.0], [102.0, 0.0, 0.0], [1.0, 100.0, 3.0]])
    m = metrics_from_positions(P, T)
    # P - P0 = (0,0,0), (101,0,0), (0,100,3); T - T0 = (0,0,0), (100,0,0), (0,100,0)
    assert_allclose(m.delta_rho_mm, [0.0, 1.0, math.sqrt(100.0**2 + 9.0) - 100.0], atol=1e-12)
    assert_allclose(m.delta_v_mm, [0.0, 1.0, 3.0], atol=1e-12)
    assert_allclose(m.error_mm, [1.0, 2.0, math.sqrt(10.0)], atol=1e-12)
    assert m.max_mm == pytest.approx(math.sqrt(10.0))
    assert m.rms_mm == pytest.approx(math.sqrt((1.0 + 4.0 + 10.0) / 3.0))
    assert m.max_delta_rho_mm == pytest.approx(1.0) and m.max_delta_v_mm == pytest.approx(3.0)
    # a rigid translation is invisible to Δρ and Δv; a rotation about home only to Δρ
    shifted = metrics_from_positions(T + [0.3, -0.4, 0.0], T)
    assert_allclose([shifted.max_delta_rho_mm, shifted.max_delta_v_mm], 0.0, atol=1e-12)
    assert shifted.max_mm == pytest.approx(0.5) and shifted.rms_mm == pytest.approx(0.5)
    c, s = math.cos(0.01), math.sin(0.01)
    turned = metrics_from_positions(T @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T, T)
    assert turned.max_delta_rho_mm < 1e-12 and turned.max_delta_v_mm == pytest.approx(200 * math.sin(0.005))
    # another home pose
    assert_allclose(metrics_from_positions(P, T, home=1).delta_v_mm, [1.0, 0.0, math.sqrt(10.0)], atol=1e-12)
    d = m.as_dict()
    assert d["poses"] == 3 and d["max_delta_v_mm"] == pytest.approx(3.0) and len(d["delta_rho_mm"]) == 3
    with pytest.raises(ValueError, match="finite"):
        metrics_from_positions(P * np.nan, T)


def test_perfect_robot_commanded_by_its_own_inverse_kinematics(bai):
    poses = validation_poses(bai)
    m = validate(bai.geometry(), poses.q, poses.targets)
    assert m.max_mm < 1e-9 and m.max_delta_rho_mm < 1e-9 and m.max_delta_v_mm < 1e-9
    # a real robot: errors of the order of mm uncompensated, zero with its own exact IK
    truth = bai.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(3))
    before = validate(truth, poses.q, poses.targets)
    assert before.max_mm > 0.5 and before.max_delta_v_mm > 0.5
    after = validate(truth, exact.inverse(truth, poses.targets), poses.targets)
    assert after.max_mm < 1e-8 and after.max_delta_v_mm < 1e-8 and after.max_delta_rho_mm < 1e-8
    assert after.actual.shape == (97, 3)
