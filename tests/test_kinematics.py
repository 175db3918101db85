from dataclasses import replace

import numpy as np
import pytest
from conftest import workspace_points

from deltacal import AssemblyError, Tolerances, UnreachableError
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta


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


# ------------------------------------------------- the solvers' batched algebra and blocks (issue 13)
def test_batch3_algebra_matches_numpy():
    from scipy.spatial.transform import Rotation

    from deltacal.kinematics import batch3

    rng = np.random.default_rng(31)
    a, b = rng.normal(size=(3, 50)), rng.normal(size=(3, 50))
    m, k = rng.normal(size=(3, 3, 50)), rng.normal(size=(3, 4, 50))
    stack = m.transpose(2, 0, 1)  # (N, 3, 3)
    np.testing.assert_allclose(batch3.cross(a, b), np.cross(a.T, b.T).T, atol=1e-14)
    np.testing.assert_allclose(batch3.dot(a, b), np.sum(a * b, axis=0), atol=1e-14)
    np.testing.assert_allclose(batch3.matmul(m, a), np.einsum("nij,nj->in", stack, a.T), atol=1e-13)
    np.testing.assert_allclose(batch3.matmul(m, k), np.einsum("nij,njk->ikn", stack, k.transpose(2, 0, 1)),
                               atol=1e-13)
    adj, det = batch3.adjugate(m)
    np.testing.assert_allclose(det, np.linalg.det(stack), rtol=1e-12)
    np.testing.assert_allclose(np.einsum("nij,jkn->nik", stack, adj),
                               det[:, None, None] * np.eye(3), atol=1e-12)
    x, _ = batch3.solve(m, a)
    np.testing.assert_allclose(x, np.linalg.solve(stack, a.T[..., None])[..., 0].T, rtol=1e-9, atol=1e-10)
    singular = m.copy()
    singular[2] = singular[0] + singular[1]
    x_singular, _ = batch3.solve(singular, a)  # no meaningful solution: not finite, or huge
    assert np.all(~np.isfinite(x_singular) | (np.abs(x_singular) > 1e6))
    # Rodrigues on both sides of the series' switch (1e-3 rad), at 0 and far from it
    angle = np.array([0.0, 1e-12, 1e-6, 0.999e-3, 1.001e-3, 0.3, 2.0, 3.1])
    axis = rng.normal(size=(angle.size, 3))
    phi = axis / np.linalg.norm(axis, axis=1, keepdims=True) * angle[:, None]
    R = batch3.rotation_from_vector(phi.T).transpose(2, 0, 1)
    np.testing.assert_allclose(R, Rotation.from_rotvec(phi).as_matrix(), atol=2e-16 * 8)


@pytest.mark.parametrize("robot", ["bai", "flexpicker"])
def test_exact_solvers_are_the_same_in_blocks_and_alone(robot, request):
    """Across block edges, with poses that converge at different iterations, each pose as if solved alone."""
    nominal = request.getfixturevalue(robot)
    rng = np.random.default_rng(32)
    g = nominal.geometry().perturbed(Tolerances.bai2015(), rng).with_tool([5.0, 0.0, -120.0])
    n = 2 * exact.BLOCK + 7
    target = workspace_points(nominal, n, rng) + g.tool
    q = exact.inverse(g, target)
    pose = exact.forward(g, q)
    # half of the poses start at their solution (converged at once), the rest cold
    warm = exact.initial_pose(g, q)
    half = rng.random(n) < 0.5
    warm.position[half] = pose.position[half]
    warm.rotation[half] = pose.rotation[half]
    mixed = exact.forward(g, q, start=warm)
    np.testing.assert_allclose(mixed.position, pose.position, atol=1e-10)
    for k in (0, exact.BLOCK - 1, exact.BLOCK, n - 1):
        alone = exact.forward(g, q[k])
        np.testing.assert_allclose(alone.position[0], pose.position[k], atol=1e-10)
        np.testing.assert_allclose(alone.rotation[0], pose.rotation[k], atol=1e-13)
        np.testing.assert_allclose(exact.inverse(g, target[k])[0], q[k], atol=1e-12)
    np.testing.assert_allclose(pose.point(g.tool), target, atol=1e-9)


def test_exact_solvers_name_the_failing_index_in_a_later_block(bai):
    g = bai.geometry()
    n = exact.BLOCK + 10
    rng = np.random.default_rng(33)
    target = workspace_points(bai, n, rng)
    target[exact.BLOCK + 3] = [0.0, 0.0, -3000.0]
    with pytest.raises(UnreachableError, match=f"index {exact.BLOCK + 3}"):
        exact.inverse(g, target)
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, n, rng))
    q[exact.BLOCK + 5] = np.radians([0.0, 0.0, 175.0])
    with pytest.raises(AssemblyError, match=f"index {exact.BLOCK + 5}"):
        exact.forward(g, q)


def test_exact_solvers_fall_back_where_the_closed_form_step_fails(bai, monkeypatch):
    """Where a 3x3 solve gives no finite step (a singular matrix), the pivoted 6x6 step takes over."""
    from deltacal.kinematics import batch3

    rng = np.random.default_rng(34)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    target = workspace_points(bai, 40, rng)
    q = exact.inverse(g, target)
    pose = exact.forward(g, q)
    start_pose = exact.initial_pose(g, q)  # the virtual model's solve is not the one under test
    start_q = VirtualDelta.from_geometry(g).inverse(target - g.tool)
    solve = batch3.solve
    calls = []

    def failing(m, b):
        x, det = solve(m, b)
        x[..., ::3] = np.nan  # every third pose of each call has no closed-form step
        calls.append(1)
        return x, det

    monkeypatch.setattr(batch3, "solve", failing)
    fallback = exact.forward(g, q, start=start_pose)
    np.testing.assert_allclose(fallback.position, pose.position, atol=1e-10)
    np.testing.assert_allclose(exact.inverse(g, target, start=start_q), q, atol=1e-12)
    assert calls


def test_plate_displacement_solves_the_pose_jacobian(bai):
    """δX = −J_X⁻¹ δr in closed form equals the pivoted dense solve, tilted plates and blocks included."""
    rng = np.random.default_rng(35)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    n = exact.BLOCK + 30
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, n, rng))
    pose = exact.forward(g, q)
    assert np.degrees(pose.tilt()).max() > 0.05
    change = rng.normal(0.0, 0.01, (n, 6))
    dense = -np.linalg.solve(exact.pose_jacobian(g, q, pose), change[..., None])[..., 0]
    np.testing.assert_allclose(exact.plate_displacement(g, q, pose, change), dense, rtol=0,
                               atol=1e-10 * np.max(np.abs(dense)))
    # and it is what the FK does to first order: lengthen the rods by δl, the residuals change by −δl
    dl = rng.normal(0.0, 1e-4, 6)
    longer = replace(g, rod_length=g.rod_length + dl.reshape(3, 2))
    moved = exact.forward(longer, q[:5], start=pose[:5])
    step = exact.plate_displacement(g, q[:5], pose[:5], np.broadcast_to(-dl, (5, 6)))
    np.testing.assert_allclose(moved.position - pose.position[:5], step[:, :3], atol=1e-8)


def test_exact_solvers_report_what_is_known_of_a_failure(bai):
    """Out of iterations: the residual at the state reached; a NaN pose is one row's NaN, not an error."""
    rng = np.random.default_rng(36)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 3, rng))
    with pytest.raises(AssemblyError, match="rod residual") as failed:
        exact.forward(g, q, max_iter=1)
    pose = exact.forward(g, q)
    A = g.arm_balls_in_base(q).reshape(-1, 6, 3)
    start = exact.initial_pose(g, q)
    B = start.position[:, None] + g.plate_ball.reshape(6, 3)
    first = np.abs(np.linalg.norm(B - A, axis=2) - g.rod_length.reshape(6)).max()
    assert 0.0 < failed.value.residual < first  # after one step, below the start's residual
    poses = exact.PlatePose(np.vstack([pose.position, [np.nan] * 3]),
                            np.concatenate([pose.rotation, np.eye(3)[None]]))
    change = np.full((4, 6), 0.01)
    moved = exact.plate_displacement(g, np.vstack([q, q[:1]]), poses, change)
    assert np.all(np.isnan(moved[3])) and np.all(np.isfinite(moved[:3]))


def test_cached_geometry_arrays_are_read_only(bai):
    g = bai.geometry()
    for v in (*g.arm_ball_circle, *VirtualDelta.from_geometry(g).elbow_circle):
        with pytest.raises(ValueError, match="read-only"):
            v[0] = 0.0
    R0 = g.actuator_rotation()
    R0[0] = 0.0  # a copy: the geometry is unchanged
    np.testing.assert_array_equal(g.actuator_rotation(), bai.geometry().actuator_rotation())
