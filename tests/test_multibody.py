"""The Pinocchio closed-loop model (ground truth) against the numpy solvers and geometry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from numpy.testing import assert_allclose

from deltacal.exceptions import AssemblyError, UnreachableError
from deltacal.geometry import NominalDelta, Tolerances, vector_from_rotation
from deltacal.io import load_nominal
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import ACCEPT, DeltaMultibody

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"


def nominal(name: str) -> NominalDelta:
    return load_nominal(MODELS / f"{name}.toml")


def workspace_readings(robot: NominalDelta, n: int, rng: np.random.Generator) -> np.ndarray:
    """Readings [rad] of the nominal robot at random points of its workspace cylinder."""
    ws = robot.workspace
    assert ws is not None
    radius = ws.radius * np.sqrt(rng.random(n))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    z = ws.top_z - ws.height * rng.random(n)
    points = np.stack([radius * np.cos(angle), radius * np.sin(angle), z], axis=1)
    return VirtualDelta.from_nominal(robot).inverse(points)


def rotation_angle(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """Angle [rad] of the rotation between two batches of orientations."""
    return np.linalg.norm(vector_from_rotation(np.swapaxes(Ra, -1, -2) @ Rb), axis=-1)


# ------------------------------------------------------------------ the model
def test_model_structure_and_jacobian():
    g = nominal("bai2015").geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(10))
    mb = DeltaMultibody(g)
    model = mb.model
    assert (model.nq, model.nv) == (3 + 6 * 4 + 7, 3 + 6 * 3 + 6)
    assert mb.point_names == ["plate", "tcp", "smr_centre", "smr_offset"]
    assert model.check(mb.data)
    x = mb.solve_forward(np.radians([10.0, 20.0, 30.0])).configuration
    # inertias are placeholders, but the joint-space mass matrix must be positive definite
    M = pin.crba(model, mb.data, x)
    assert np.all(np.linalg.eigvalsh(0.5 * (M + M.T)) > 0.0)
    # finite-difference check of the closure Jacobian, away from the solution
    rng = np.random.default_rng(11)
    x = pin.integrate(model, x, rng.normal(0.0, 0.05, model.nv))
    J = mb.closure_jacobian(x)
    h = 1e-6
    J_fd = np.zeros_like(J)
    for k in range(model.nv):
        dv = np.zeros(model.nv)
        dv[k] = h
        plus = mb.closure_residual(pin.integrate(model, x, dv)).ravel()
        minus = mb.closure_residual(pin.integrate(model, x, -dv)).ravel()
        J_fd[:, k] = (plus - minus) / (2.0 * h)
    # central differences on residuals of ~1e3 mm: truncation ~h^2 * 1e3, rounding ~1e-13 / h
    assert_allclose(J, J_fd, atol=1e-5)
    # idle spins (third local velocity of each rod): away from an assembly the spin turns the
    # frame the residual is expressed in; at an assembly its column vanishes with the residual
    spins = [model.joints[model.getJointId(f"rod{i}{j}")].idx_v + 2 for i in (1, 2, 3) for j in (1, 2)]
    assert np.max(np.abs(J[:, spins])) > 1.0
    sol = mb.solve_forward(np.radians([10.0, 20.0, 30.0]))
    J = mb.closure_jacobian(sol.configuration)
    assert np.max(np.abs(J[:, spins])) < 1e-10
    arms = [model.joints[model.getJointId(f"arm{i}")].idx_v for i in (1, 2, 3)]
    assert np.linalg.matrix_rank(np.delete(J, arms, axis=1)) == 18


# ------------------------------------------------------ forward kinematics
@pytest.mark.parametrize(
    ("robot", "tolerances", "seed"),
    [
        ("bai2015", Tolerances.bai2015(), 1),
        ("bai2015", Tolerances(), 2),
        ("flexpicker", Tolerances(), 3),
        ("flexpicker", Tolerances.bai2015(), 4),
    ],
)
def test_forward_agrees_with_exact_solver(robot, tolerances, seed):
    rng = np.random.default_rng(seed)
    nom = nominal(robot)
    g = nom.geometry().perturbed(tolerances, rng)
    q = workspace_readings(nom, 30, rng)
    mb = DeltaMultibody(g)
    pose = mb.forward(q, warm=False)
    reference = exact.forward(g, q)
    # two independent solvers, each converged to ~1e-12 mm on coordinates of ~1e3 mm
    assert_allclose(pose.position, reference.position, atol=1e-9, rtol=0)
    assert np.max(rotation_angle(pose.rotation, reference.rotation)) < 1e-9
    # the perturbed plate really tilts: the comparison is not between two parallel plates
    assert np.min(pose.tilt()) > 1e-6
    for qn in q[:5]:
        sol = mb.solve_forward(qn, warm=False)
        assert sol.method == "newton"
        assert sol.iterations <= 5
        assert sol.residual <= ACCEPT
        assert np.max(np.abs(mb.closure_residual(sol.configuration))) == pytest.approx(sol.residual)
        assert_allclose(sol.readings, qn, atol=0.0)


@pytest.mark.parametrize("robot", ["bai2015", "flexpicker"])
def test_nominal_plate_parallel_and_closed_form(robot):
    rng = np.random.default_rng(5)
    nom = nominal(robot)
    g = nom.geometry()
    q = workspace_readings(nom, 20, rng)
    pose = DeltaMultibody(g).forward(q)
    assert np.max(rotation_angle(pose.rotation, np.eye(3))) < 1e-12
    assert_allclose(pose.position, VirtualDelta.from_nominal(nom).forward(q), atol=1e-9, rtol=0)


def test_levenberg_marquardt_fallback():
    rng = np.random.default_rng(13)
    nom = nominal("bai2015")
    g = nom.geometry().perturbed(Tolerances.bai2015(), rng)
    q = workspace_readings(nom, 3, rng)
    mb = DeltaMultibody(g, max_iter=2)  # too few Newton steps from the closed-form start
    for qn in q:
        sol = mb.solve_forward(qn, warm=False)
        assert sol.method == "levenberg-marquardt"
        assert sol.residual <= ACCEPT
        reference = exact.forward(g, qn)
        assert_allclose(sol.position, reference.position[0], atol=1e-9, rtol=0)


def test_warm_and_explicit_start_give_the_same_assembly():
    rng = np.random.default_rng(6)
    nom = nominal("bai2015")
    g = nom.geometry().perturbed(Tolerances.bai2015(), rng)
    mb = DeltaMultibody(g)
    centre = nom.workspace.centre
    path = centre + np.cumsum(rng.normal(0.0, 1.0, (30, 3)), axis=0)  # 1 mm steps
    q = VirtualDelta.from_nominal(nom).inverse(path)
    warm = mb.forward(q, warm=True)
    cold = mb.forward(q, warm=False)
    assert_allclose(warm.position, cold.position, atol=1e-9, rtol=0)
    assert np.max(rotation_angle(warm.rotation, cold.rotation)) < 1e-9
    first = mb.solve_forward(q[0], warm=False)
    again = mb.solve_forward(q[1], start=first.configuration)
    assert again.iterations <= 3
    assert_allclose(again.position, cold.position[1], atol=1e-9, rtol=0)


def test_frame_positions_are_plate_points():
    rng = np.random.default_rng(7)
    nom = nominal("flexpicker")
    g = nom.geometry().perturbed(Tolerances.bai2015(), rng)
    mb = DeltaMultibody(g)
    q = workspace_readings(nom, 4, rng)
    pose = mb.forward(q)
    points = mb.point_positions(q)
    assert points.shape == (4, 3, 3)
    for k, name in enumerate(["tcp", "smr_centre", "smr_offset"]):
        assert_allclose(points[:, k], pose.point(g.point(name)), atol=1e-9, rtol=0)


# ------------------------------------------------------ inverse kinematics
@pytest.mark.parametrize(
    ("robot", "point"), [("bai2015", "tcp"), ("flexpicker", "tcp"), ("bai2015", "smr_offset")]
)
def test_inverse_round_trips_and_agrees_with_exact(robot, point):
    rng = np.random.default_rng(8)
    nom = nominal(robot)
    g = nom.geometry().perturbed(Tolerances.bai2015(), rng)
    mb = DeltaMultibody(g)
    q = workspace_readings(nom, 15, rng)
    in_plate = g.point(point)
    targets = mb.forward(q).point(in_plate)
    q_back = mb.inverse(targets, point)
    # readings recovered to ~residual / (arm length ~300 mm) << 1e-10 rad
    assert_allclose(q_back, q, atol=1e-10, rtol=0)
    assert_allclose(q_back, exact.inverse(g, targets, in_plate), atol=1e-10, rtol=0)
    assert_allclose(mb.forward(q_back).point(in_plate), targets, atol=1e-9, rtol=0)


def test_inverse_out_of_reach():
    mb = DeltaMultibody(nominal("bai2015").geometry())
    with pytest.raises(UnreachableError, match=r"\[0\.0, 0\.0, -3000\.0\] mm"):
        mb.solve_inverse(np.array([0.0, 0.0, -3000.0]))
    with pytest.raises(UnreachableError, match=r"1 target\(s\).*index 1"):
        mb.inverse(np.array([[0.0, 0.0, -850.0], [2000.0, 0.0, -850.0]]))


# --------------------------------------------------------- real-robot effects
def test_rod_length_difference_tilts_the_plate():
    """One rod longer by dl tilts the plate by about dl / c, and the TCP error grows with the tool.

    First order: subtracting the two rod equations of limb i, n_ij . (dp + dphi x R B_ij) = dl_ij,
    leaves (t_i x n_i) . dphi = (dl_i1 - dl_i2) / c (the pair's rods are parallel in the nominal
    robot). With the three vectors m_i = t_i x n_i = -cos(b_i) r_i + sin(b_i) z (b_i: angle of the
    rods from the vertical) and b_i = b, dphi has norm (dl / c) sqrt(4 / (9 cos^2 b) + 1 / (9 sin^2 b)),
    at least dl / c (equality at tan^2 b = 1/2): the plate turns by about dl / c. The linear
    prediction holds to O(dl / c) = 1e-3 relative; 1 % is asked.
    """
    nom = nominal("bai2015")
    perfect = nom.geometry()
    c = nom.rod_spacing
    dl = 0.1  # [mm]
    g = perfect.with_errors({"limb1.rod1.length": dl})
    rng = np.random.default_rng(9)
    q = workspace_readings(nom, 5, rng)
    pose = DeltaMultibody(g).forward(q)
    rotvec = pose.rotation_vector()
    # first-order prediction from the perfect robot's rod directions at the same readings
    ref = DeltaMultibody(perfect).forward(q)
    t = perfect.tangent
    for n in range(len(q)):
        arm = perfect.arm_balls_in_base(q[n])[0, :, 0]  # rod 1 of each limb (parallel to rod 2)
        rod = ref.position[n] + perfect.plate_ball[:, 0] - arm
        m = np.cross(t, rod / np.linalg.norm(rod, axis=1, keepdims=True))
        predicted = np.linalg.solve(m, np.array([dl / c, 0.0, 0.0]))
        assert_allclose(rotvec[n], predicted, rtol=0, atol=1e-2 * np.linalg.norm(predicted))
        angle = np.linalg.norm(rotvec[n])
        assert dl / c * (1 - 1e-2) <= angle <= 1.5 * dl / c
    # TCP error (same readings, against the perfect robot): dp + dphi x tool. Its lever part
    # is exactly R t - t, h times the tilt of the plate's z axis; near the plate it may partly
    # cancel dp, so the error grows with the tool's distance once h * tilt exceeds |dp|.
    errors = []
    for h in (0.0, 200.0, 400.0, 800.0):
        tool = np.array([0.0, 0.0, -h])
        real = DeltaMultibody(g.with_tool(tool)).point_positions(q, ["tcp"])[:, 0]
        ideal = DeltaMultibody(perfect.with_tool(tool)).point_positions(q, ["tcp"])[:, 0]
        errors.append(np.linalg.norm(real - ideal, axis=1))
        growth = np.linalg.norm((real - ideal) - (pose.position - ref.position), axis=1)
        assert_allclose(growth, 2.0 * h * np.sin(pose.tilt() / 2.0), rtol=1e-6, atol=1e-9)
    errors_arr = np.array(errors)
    assert np.all(np.diff(errors_arr[1:], axis=0) > 0.0)
    assert np.all(errors_arr[-1] > errors_arr[0] + 800.0 * 0.5 * dl / c)


# ------------------------------------------------------------------ errors
def test_readings_without_assembly_raise():
    rng = np.random.default_rng(12)
    g = nominal("bai2015").geometry().perturbed(Tolerances(), rng)
    mb = DeltaMultibody(g)
    with pytest.raises(AssemblyError, match=r"q = \[0\.0, 0\.0, 170\.0\] deg.*residual") as info:
        mb.solve_forward(np.radians([0.0, 0.0, 170.0]))
    assert info.value.residual > 1.0
    q = np.radians([[10.0, 20.0, 30.0], [0.0, 0.0, 170.0], [170.0, 0.0, 0.0]])
    with pytest.raises(AssemblyError, match=r"2 reading\(s\), first: q = \[0\.0, 0\.0, 170\.0\] deg") as info:
        mb.forward(q)
    assert info.value.indices == [1, 2]
    with pytest.raises(AssemblyError, match="finite"):
        mb.solve_forward(np.array([0.0, math.nan, 0.0]))
