"""Compliances identified with the geometry and compensated (issue 23), on a robot no test was tuned on."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import workspace_points

from deltacal.calibration import Calibration
from deltacal.compensation import compensate
from deltacal.geometry import Masses, NominalDelta, Tolerances, Workspace
from deltacal.identification import FitOptions, identify
from deltacal.io import load_calibration, save_calibration
from deltacal.kinematics import exact
from deltacal.simulation import compliant_forward, simulate_measurements

#: A mid-size pick-and-place Delta built for this test only (arms 0.31 m, rods 0.82 m).
NOMINAL = NominalDelta(
    name="midsize", base_radius=160.0, plate_radius=40.0, arm_length=310.0, rod_length=820.0,
    rod_spacing=60.0, limb_azimuth=np.radians([90.0, 210.0, 330.0]), tool=np.array([0.0, 0.0, -80.0]),
    workspace=Workspace(radius=300.0, height=200.0, top_z=-650.0),
    masses=Masses(arm=0.35, rod=0.04, plate=0.4),
)
PAYLOADS = (0.0, 3.0)


@pytest.fixture(scope="module")
def session():
    """Truth with compliances 2e-5 ± 20 %, 60 poses measured at 0 and 3 kg (Pinocchio ground truth)."""
    start = NOMINAL.geometry()
    rng = np.random.default_rng(2023)
    compliance = 2e-5 * rng.uniform(0.8, 1.2, 3)
    truth = replace(start.perturbed(Tolerances.bai2015(), rng), compliance=compliance)
    q = exact.inverse(start, workspace_points(NOMINAL, 60, np.random.default_rng(2024)))
    readings, payload = np.vstack([q, q]), np.repeat(PAYLOADS, len(q))
    measured = simulate_measurements(truth, readings, np.random.default_rng(2025), payload=payload)
    # the same robot with rigid actuators, measured alike: its calibration's error is the noise floor
    rigid_truth = replace(truth, compliance=np.zeros(3))
    rigid_measured = simulate_measurements(rigid_truth, readings, np.random.default_rng(2025),
                                           payload=payload)
    targets = workspace_points(NOMINAL, 40, np.random.default_rng(2026))
    return start, truth, measured, rigid_truth, rigid_measured, targets


def tcp_error(geometry, truth, targets: np.ndarray, payload: float, commanded_payload: float) -> float:
    """Largest distance [mm] from the targets of the true loaded TCP at the compensated readings."""
    q = compensate(geometry, targets, payload=commanded_payload)
    reached = compliant_forward(truth, q, payload).point(truth.tool)  # Pinocchio's equilibrium
    return float(np.linalg.norm(reached - targets, axis=1).max())


@pytest.mark.slow
def test_compliances_identified_and_compensated(session, tmp_path):
    start, truth, measured, rigid_truth, rigid_measured, targets = session
    elastic = identify(start, measured, "complete", options=FitOptions(compliance=True))
    sigma = dict(zip(elastic.base.base_names, elastic.sigma, strict=True))
    c_sigma = np.array([sigma[n] for n in ("c1", "c2", "c3")])
    assert np.all(c_sigma < 0.1 * truth.compliance)  # identified, not just fitted
    assert np.all(np.abs(elastic.geometry.compliance - truth.compliance) < 3.0 * c_sigma)

    floor = tcp_error(identify(start, rigid_measured, "complete").geometry, rigid_truth, targets, 0.0, 0.0)
    for payload in PAYLOADS:
        assert tcp_error(elastic.geometry, truth, targets, payload, payload) < 1.5 * floor

    # the rigid calibration of the elastic robot: several times worse with 3 kg
    rigid = identify(start, measured, "complete", options=FitOptions(accept_poor_fit=True))
    assert tcp_error(rigid.geometry, truth, targets, 3.0, 0.0) > 4.0 * floor

    # the calibration file holds them, with σ, and compensation reads them back
    save_calibration(elastic, tmp_path / "cal.toml")
    text = (tmp_path / "cal.toml").read_text()
    assert "[compliance]" in text and "actuator_rad_per_nm" in text
    back: Calibration = load_calibration(tmp_path / "cal.toml")
    assert back.compliance is not None and back.compliance_sigma is not None
    np.testing.assert_array_equal(back.compliance, elastic.geometry.compliance)
    np.testing.assert_allclose(back.compliance_sigma, c_sigma, rtol=1e-12)
    np.testing.assert_array_equal(back.geometry.compliance, elastic.geometry.compliance)


def test_one_payload_and_a_massless_model_leave_the_compliances_out(session):
    """The QR says when the compliances are not identifiable: no torque, no column."""
    start, _, measured, _, _, _ = session
    massless = replace(start, masses=Masses())
    unloaded = measured.subset(np.flatnonzero(measured.payload_kg == 0.0))
    options = FitOptions(compliance=True, accept_poor_fit=True)
    result = identify(massless, unloaded, "complete", options=options)
    assert set(result.confounded) >= {"c1", "c2", "c3"}
    assert "compliances not identifiable" in result.report()
    np.testing.assert_array_equal(result.geometry.compliance, np.zeros(3))


def test_payload_compensation_refused_by_the_linear_methods(session):
    start, *_ = session
    with pytest.raises(ValueError, match="cannot represent a payload"):
        compensate(start, np.array([[0.0, 0.0, -700.0]]), method="bai", payload=3.0)


def test_the_rigid_fit_of_a_loaded_robot_is_warned(session):
    """Unmodelled deflections show in the variance factor: warned (not refused at this size)."""
    start, _, measured, *_ = session
    rigid = identify(start, measured, "complete")
    elastic = identify(start, measured, "complete", options=FitOptions(compliance=True))
    assert rigid.variance_factor > 1.5
    assert elastic.variance_factor < 1.2
    assert any("variance factor" in w for w in rigid.warnings)


def test_the_planner_plans_for_the_compliances():
    """Poses measured at 0 and 3 kg keep c1..c3 as base parameters; a massless robot at 0 kg does not."""
    from deltacal.planning import d_optimal

    loaded = d_optimal(NOMINAL, "complete", 30, rng=np.random.default_rng(5), pool_size=200,
                       payloads=(0.0, 3.0))
    assert {"c1", "c2", "c3"} <= set(loaded.base_names)
    assert loaded.blocks.shape[1] == 12  # six rows per pose at each payload
    rigid = d_optimal(NOMINAL, "complete", 30, rng=np.random.default_rng(5), pool_size=200)
    assert len(loaded.base_names) == len(rigid.base_names) + 3
    massless = replace(NOMINAL, masses=Masses())
    none = d_optimal(massless, "complete", 30, rng=np.random.default_rng(5), pool_size=200, payloads=(0.0,))
    assert not {"c1", "c2", "c3"} & set(none.base_names)
