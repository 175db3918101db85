import numpy as np
import pytest
from conftest import workspace_points

from deltacal import AssemblyError, Tolerances, UnreachableError, VirtualDelta
from deltacal.kinematics import exact


@pytest.mark.parametrize("robot", ["bai", "flexpicker"])
def test_closed_form_round_trip_and_branch(robot, request):
    nominal = request.getfixturevalue(robot)
    rng = np.random.default_rng(11)
    x = workspace_points(nominal, 500, rng)
    v = VirtualDelta.from_nominal(nominal)
    q = v.inverse(x)
    np.testing.assert_allclose(v.forward(q), x, atol=1e-9)
    # knee-out branch: the other solution of each limb has a smaller cos(q)
    elbows = v.elbows(q)
    assert np.all(np.linalg.norm(elbows[..., :2], axis=2) > nominal.base_radius * 0.5)


def test_closed_form_jacobians_match_finite_differences(bai):
    rng = np.random.default_rng(12)
    x = workspace_points(bai, 20, rng)
    v = VirtualDelta.from_nominal(bai)
    q = v.inverse(x)
    J = v.jacobian(q)
    h = 1e-6
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = h
        fd = (v.forward(q + dq) - v.forward(q - dq)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, rtol=1e-6, atol=1e-6)
    Jm = v.inverse_jacobian(q)
    np.testing.assert_allclose(Jm @ J, np.broadcast_to(np.eye(3), J.shape), atol=1e-10)


def test_closed_form_refuses_out_of_reach(bai):
    v = VirtualDelta.from_nominal(bai)
    with pytest.raises(UnreachableError, match=r"index 1"):
        v.inverse(np.array([[0, 0, -800.0], [0, 0, -2000.0]]))
    with pytest.raises(AssemblyError, match="index 0"):
        v.forward(np.radians([[0.0, 0.0, 175.0]]))


def test_exact_nominal_is_parallel_and_closed_form(bai):
    g = bai.geometry()
    x = workspace_points(bai, 200, np.random.default_rng(13))
    q = VirtualDelta.from_nominal(bai).inverse(x)
    pose = exact.forward(g, q)
    np.testing.assert_allclose(pose.position, x, atol=1e-9)
    np.testing.assert_allclose(pose.rotation, np.broadcast_to(np.eye(3), (200, 3, 3)), atol=1e-12)


@pytest.mark.parametrize("robot", ["bai", "flexpicker"])
def test_exact_ik_fk_round_trip_on_perturbed_robots(robot, request):
    nominal = request.getfixturevalue(robot)
    rng = np.random.default_rng(14)
    g = nominal.geometry().perturbed(Tolerances.bai2015(), rng).with_tool([10.0, -5.0, -150.0])
    target = workspace_points(nominal, 300, rng) + g.tool
    q = exact.inverse(g, target)
    pose = exact.forward(g, q)
    np.testing.assert_allclose(pose.point(g.tool), target, atol=1e-9)
    A = g.arm_balls_in_base(q).reshape(-1, 6, 3)
    B = pose.position[:, None] + np.einsum("nkl,jl->njk", pose.rotation, g.plate_ball.reshape(6, 3))
    rods = np.broadcast_to(g.rod_length.reshape(6), (300, 6))
    np.testing.assert_allclose(np.linalg.norm(B - A, axis=2), rods, atol=1e-9)
    assert np.all(np.degrees(pose.tilt()) > 1e-3)


def test_exact_forward_jacobian_matches_finite_differences(bai):
    rng = np.random.default_rng(15)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 10, rng))
    J = exact.forward_jacobian(g, q, exact.forward(g, q))
    h = 1e-6
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = h
        p, m = exact.forward(g, q + dq), exact.forward(g, q - dq)
        np.testing.assert_allclose(J[:, :3, k], (p.position - m.position) / (2 * h), rtol=1e-5, atol=1e-5)


def test_exact_reports_no_assembly(bai):
    with pytest.raises(AssemblyError, match=r"175\.0"):
        exact.forward(bai.geometry(), np.radians([[0.0, 0.0, 175.0]]))
    with pytest.raises(UnreachableError, match="index 0"):
        exact.inverse(bai.geometry(), np.array([[0.0, 0.0, -3000.0]]))
