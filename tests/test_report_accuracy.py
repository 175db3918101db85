"""The predicted σ of the TCP (deltacal.report.accuracy) against a Monte-Carlo of whole calibrations,
and its Jacobian against finite differences through the exact kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import workspace_points

from deltacal.geometry import Tolerances
from deltacal.identification import identify
from deltacal.io import save_calibration
from deltacal.kinematics import exact
from deltacal.report import load_calibration, predicted_tcp_sigma, sigma_3d, tcp_jacobian
from deltacal.report.accuracy import reachable_readings
from deltacal.simulation import simulate_measurements

#: Monte-Carlo repeats: the sample std of N normal draws has a relative σ of 1/√(2(N−1)) ≈ 0.05.
REPEATS = 200
#: Allowed |observed/predicted − 1|: 4 times that sampling error (15 correlated comparisons).
TOLERANCE = 4.0 / np.sqrt(2.0 * (REPEATS - 1))


@pytest.fixture(scope="module")
def setup(bai, tmp_path_factory):
    rng = np.random.default_rng(2024)
    nominal = bai.geometry()
    truth = nominal.perturbed(Tolerances.bai2015(), np.random.default_rng(7))
    targets = workspace_points(bai, 40, rng)
    q = exact.inverse(nominal, targets)
    measured = simulate_measurements(truth, q, np.random.default_rng(1000))
    result = identify(nominal, measured, "complete")
    path = tmp_path_factory.mktemp("mc") / "cal.toml"
    save_calibration(result, path)
    ws = bai.workspace
    points = np.array([
        ws.centre,
        [0.0, 0.0, ws.top_z],
        [0.9 * ws.radius, 0.0, ws.bottom_z],
        [-0.6 * ws.radius, 0.6 * ws.radius, ws.middle_z],
        [0.0, -0.95 * ws.radius, ws.top_z],
    ])
    return nominal, truth, q, load_calibration(path), points


@pytest.mark.long
def test_predicted_sigma_matches_the_spread_of_repeated_calibrations(setup, capsys):
    nominal, truth, q, calibration, points = setup
    predicted = predicted_tcp_sigma(calibration, points)
    assert predicted.shape == (len(points), 3) and np.all(predicted > 0.0)
    reached = np.empty((REPEATS, len(points), 3))
    for k in range(REPEATS):
        # fresh noise, same robot and poses (exact forward kinematics: the Pinocchio model agrees to 1e-9 mm)
        measured = simulate_measurements(truth, q, np.random.default_rng(k), forward=exact.forward)
        result = identify(nominal, measured, "complete")
        commanded = exact.inverse(result.geometry, points)  # compensation with the identified robot
        reached[k] = exact.forward(truth, commanded).point(truth.tool)
    observed = reached.std(axis=0, ddof=1)
    ratio = observed / predicted
    ratio_3d = sigma_3d(observed) / sigma_3d(predicted)
    with capsys.disabled():
        print(f"\nMonte-Carlo ({REPEATS} calibrations), TCP σ per axis [µm], tolerance ±{TOLERANCE:.3f}:")
        for p, s, o, r in zip(points, predicted, observed, ratio, strict=True):
            print(f"  at {np.round(p, 1).tolist()}: predicted {np.round(s * 1e3, 3).tolist()}, observed "
                  f"{np.round(o * 1e3, 3).tolist()}, ratio {np.round(r, 3).tolist()}")
        print(f"  3-D ratio {np.round(ratio_3d, 3).tolist()}")
    assert np.all(np.abs(ratio - 1.0) < TOLERANCE), ratio
    assert np.all(np.abs(ratio_3d - 1.0) < TOLERANCE), ratio_3d
    # the compensated TCP is unbiased: its mean within the mean's sampling error (4 σ/√N) of the target
    bias = reached.mean(axis=0) - points
    with capsys.disabled():
        print(f"  bias / (σ/√N): {np.round(bias / (predicted / np.sqrt(REPEATS)), 2).tolist()}")
    assert np.all(np.abs(bias) < 4.0 * predicted / np.sqrt(REPEATS)), bias


@pytest.mark.parametrize("tool", [None, np.array([12.0, -20.0, -85.0])])
def test_tcp_jacobian_matches_finite_differences(setup, tool):
    _, _, _, calibration, points = setup
    geometry = calibration.geometry if tool is None else calibration.geometry.with_tool(tool)
    q = reachable_readings(geometry, points)
    J = tcp_jacobian(geometry, calibration, q)
    model = calibration.model
    assert J.shape == (len(points), 3, len(calibration.robot_names))
    for k, name in enumerate(calibration.robot_names):
        j = model.names.index(name)
        h = 1e-4 if model.units[j] == "mm" else 1e-6
        dk = np.zeros(model.size)
        dk[j] = h
        plus = exact.forward(model.apply(geometry, dk), q).point(geometry.tool)
        minus = exact.forward(model.apply(geometry, -dk), q).point(geometry.tool)
        fd = (plus - minus) / (2.0 * h)
        scale = max(float(np.max(np.abs(fd))), 1e-3)
        assert np.max(np.abs(J[:, :, k] - fd)) < 1e-5 * scale, (name, J[:, :, k], fd)


def test_sigma_follows_the_covariance_and_the_tool(setup):
    _, _, _, calibration, points = setup
    base = predicted_tcp_sigma(calibration, points)
    # a tool far below the plate feels the plate's tilt uncertainty: its σ changes
    long = predicted_tcp_sigma(calibration, points + [0.0, 0.0, -300.0], np.array([0.0, 0.0, -300.0]))
    assert np.all(np.isfinite(long)) and not np.allclose(long, base, rtol=1e-3)
    # σ scales with the parameters' σ
    from dataclasses import replace

    doubled = replace(calibration, base=[replace(p, sigma=2.0 * p.sigma) for p in calibration.base])
    assert np.allclose(predicted_tcp_sigma(doubled, points), 2.0 * base, rtol=1e-12)
    # out of reach: NaN, the others unchanged
    far = np.vstack([points, [[5000.0, 0.0, -800.0]]])
    out = predicted_tcp_sigma(calibration, far)
    assert np.all(np.isnan(out[-1])) and np.allclose(out[:-1], base, rtol=1e-12)
