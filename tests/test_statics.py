"""Statics under gravity: gravity torques two ways, finite differences, the compliant equilibrium."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS, workspace_points
from numpy.testing import assert_allclose

from deltacal.exceptions import InputError
from deltacal.geometry import Masses, NominalDelta, Tolerances
from deltacal.io import load_geometry, load_nominal, read_measurements, save_geometry, write_measurements
from deltacal.kinematics import exact, statics
from deltacal.simulation import Metrology, compliant_forward, simulate_measurements

MASSES = Masses(arm=0.35, rod=0.04, plate=0.4)


@pytest.fixture(scope="module")
def heavy() -> tuple[NominalDelta, object]:
    """A perturbed flexpicker with masses and compliances of about 2e-5 rad/N m, and its readings."""
    nominal = load_nominal(MODELS / "flexpicker.toml")
    g = nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(23))
    g = replace(g, masses=MASSES, compliance=np.array([2.1e-5, 1.8e-5, 2.3e-5]))
    q = exact.inverse(g, workspace_points(nominal, 8, np.random.default_rng(24)))
    return g, q


def energy_gradient(g, q: np.ndarray, payload: float, h: float = 1e-5) -> np.ndarray:
    """-dU/dq by central differences of U (positions alone, exact FK)."""
    out = np.zeros_like(q)
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = h
        up = statics.gravitational_energy(g, q + dq, payload)
        down = statics.gravitational_energy(g, q - dq, payload)
        out[:, k] = -(up - down) / (2.0 * h)
    return out


@pytest.mark.parametrize("payload", [0.0, 3.0])
def test_torques_match_finite_differences_of_the_energy(heavy, payload):
    g, q = heavy
    tau = statics.gravity_torque(g, q, payload)
    fd = energy_gradient(g, q, payload)
    # central differences: truncation ~h² 1e-10, FK noise ~1e-11 mm / 1e-5 rad
    assert_allclose(tau, fd, rtol=0.0, atol=1e-7 * np.abs(fd).max())


@pytest.mark.parametrize("payload", [0.0, 3.0])
def test_virtual_work_agrees_with_pinocchio(heavy, payload):
    g, q = heavy
    tau = statics.gravity_torque(g, q, payload)
    truth = statics.multibody_gravity_torque(g, q, payload)
    assert np.abs(truth).max() > 0.5  # N m: the comparison means something
    assert_allclose(tau, truth, rtol=0.0, atol=1e-9 * np.abs(truth).max())


def test_each_body_separately(heavy):
    """Arms, rods, plate and payload each on its own: both computations agree (no term cancels a bug)."""
    g, q = heavy
    for masses, payload in ((Masses(arm=1.0), 0.0), (Masses(rod=1.0), 0.0), (Masses(plate=1.0), 0.0),
                            (Masses(), 1.0)):
        one = replace(g, masses=masses)
        truth = statics.multibody_gravity_torque(one, q[:3], payload)
        assert_allclose(statics.gravity_torque(one, q[:3], payload), truth, rtol=0.0,
                        atol=1e-9 * np.abs(truth).max())


def test_weight_lowers_the_arms_and_a_massless_robot_feels_nothing():
    nominal = load_nominal(MODELS / "flexpicker.toml")
    g = replace(nominal.geometry(), masses=Masses(plate=1.0))
    q = exact.inverse(g, np.array([[0.0, 0.0, -650.0]]))
    tau = statics.gravity_torque(g, q)
    # the plate hangs on the three arms alike: each holds a third of its weight, pulling its tip down
    assert np.all(tau > 0.0)
    assert_allclose(tau, tau[:, :1].repeat(3, axis=1), rtol=1e-9)
    assert np.all(statics.gravity_torque(nominal.geometry(), q) == 0.0)


@pytest.mark.parametrize("payload", [0.0, 3.0])
def test_compliant_equilibrium_two_ways(heavy, payload):
    g, q = heavy
    e_exact = statics.compliant_readings(g, q, payload)
    e_truth = statics.compliant_readings(g, q, payload, statics.multibody_gravity_torque)
    # it is an equilibrium: e = q + c tau(e)
    balance = q + g.compliance * statics.gravity_torque(g, e_exact, payload)
    assert_allclose(e_exact, balance, rtol=0.0, atol=1e-12)
    assert np.abs(e_exact - q).max() > 1e-5  # rad: the actuators yield
    assert_allclose(e_exact, e_truth, rtol=0.0, atol=1e-12)
    tcp_exact = compliant_forward(g, q, payload, exact.forward).point(g.tool)
    tcp_truth = compliant_forward(g, q, payload).point(g.tool)
    assert_allclose(tcp_exact, tcp_truth, rtol=0.0, atol=1e-9)


def test_a_payload_lowers_the_tcp(heavy):
    """The stiffness is positive: the TCP moves along the added weight (down), by tens of micrometres."""
    g, q = heavy
    free = compliant_forward(g, q, 0.0, exact.forward).point(g.tool)
    loaded = compliant_forward(g, q, 3.0, exact.forward).point(g.tool)
    assert np.all(loaded[:, 2] < free[:, 2])
    assert 0.005 < np.linalg.norm(loaded - free, axis=1).max() < 0.5  # mm
    # rigid actuators: nothing moves
    rigid = replace(g, compliance=np.zeros(3))
    assert_allclose(statics.compliant_readings(rigid, q, 3.0), q, rtol=0.0, atol=0.0)


def test_payload_per_pose_is_checked():
    with pytest.raises(ValueError, match="non-negative"):
        statics.payload_per_pose(np.array([1.0, -2.0]), 2)
    with pytest.raises(ValueError, match="one per pose"):
        statics.payload_per_pose(np.array([1.0, 2.0, 3.0]), 2)


def test_simulated_measurements_carry_the_payload(heavy, tmp_path):
    g, q = heavy
    payload = np.array([0.0, 3.0] * 4)
    m = simulate_measurements(g, q, np.random.default_rng(1), Metrology(sigma_position=0.0, sigma_angle=0.0),
                              forward=exact.forward, payload=payload)
    assert_allclose(m.payload, payload)
    assert_allclose(m.position, compliant_forward(g, q, payload, exact.forward).point(g.tool), atol=1e-12)
    path = tmp_path / "m.csv"
    write_measurements(path, m)
    assert "payload_kg" in path.read_text().splitlines()[0]
    back, _ = read_measurements(path)
    assert_allclose(back.payload, payload)


def test_negative_payload_in_a_file_is_refused(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm,payload_kg\n1,2,3,0,0,-600,0\n1,2,3,0,0,-600,-3\n")
    with pytest.raises(InputError, match=r"row 2.*column payload_kg.*>= 0 kg"):
        read_measurements(path)


def test_masses_and_compliances_round_trip_in_a_geometry_file(heavy, tmp_path):
    g, _ = heavy
    save_geometry(g, tmp_path / "g.toml")
    back = load_geometry(tmp_path / "g.toml")
    assert back.allclose(g) and back.masses == MASSES
    assert_allclose(back.compliance, g.compliance, rtol=0.0, atol=0.0)
    assert not back.allclose(replace(g, compliance=np.zeros(3)))


@pytest.mark.parametrize(
    "table, message",
    [
        ("arm_kg = 0.35\nrod_kg = 0.04\nplate_kg = -0.4\n", r"masses.plate_kg: a mass cannot be negative"),
        ("arm_kg = 0.35\nrod_kg = 0.04\n", r"key masses.plate_kg: missing required key"),
        ("arm_kg = 0.35\nrod_kg = 0.04\nplate_kg = 0.4\nmotor_kg = 1\n", r"masses.motor_kg: unknown key"),
        ("arm_kg = 'heavy'\nrod_kg = 0.04\nplate_kg = 0.4\n", r"key masses.arm_kg: must be a number"),
    ],
)
def test_robot_file_masses_errors_name_the_key(tmp_path, table, message):
    text = (MODELS / "flexpicker.toml").read_text() + "\n[masses]\n" + table
    path = tmp_path / "robot.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        load_nominal(path)


def test_robot_file_masses_reach_the_geometry(tmp_path):
    path = tmp_path / "robot.toml"
    path.write_text((MODELS / "flexpicker.toml").read_text() + "\n[masses]\narm_kg = 0.35\nrod_kg = 0.04\n"
                    "plate_kg = 0.4\n")
    assert load_nominal(path).geometry().masses == MASSES


def test_validation_stands_a_compliant_truth_at_its_equilibrium(heavy):
    from deltacal.validation import validate

    g, q = heavy
    loaded = compliant_forward(g, q, 3.0, exact.forward).point(g.tool)
    metrics = validate(g, q, loaded, forward=exact.forward, payload=3.0)
    assert_allclose(metrics.actual, loaded, rtol=0.0, atol=1e-12)
    rigid = validate(g, q, loaded, forward=exact.forward)  # unloaded: off by the payload's deflection
    assert np.abs(rigid.actual - loaded).max() > 1e-3


def test_a_controller_fit_sees_the_sag_of_a_compliant_robot(heavy):
    from deltacal.controller import Controller
    from deltacal.controller.fit import tcp_errors

    g, q = heavy
    nominal = load_nominal(MODELS / "flexpicker.toml")
    controller = Controller.from_geometry(nominal)
    points = exact.forward(g, q).point(g.tool)
    sagging = compliant_forward(g, controller.inverse(points), 0.0, exact.forward).point(g.tool)
    assert_allclose(tcp_errors(g, controller, points), sagging - points, rtol=0.0, atol=1e-9)
    rigid = replace(g, compliance=np.zeros(3))
    assert np.abs(tcp_errors(g, controller, points) - tcp_errors(rigid, controller, points)).max() > 1e-3
