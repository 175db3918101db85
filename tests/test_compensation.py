import numpy as np
import pytest
from conftest import MODELS, workspace_points
from numpy.testing import assert_allclose

from deltacal import Tolerances, UnreachableError
from deltacal.compensation import (
    METHODS,
    CompensationMethod,
    LinearCalibration,
    compensate,
    compensate_bai,
    compensate_exact,
    compensate_linear,
    compensate_savoure,
    predicted_plate_displacement,
    singularity_margin,
)
from deltacal.errormodels import get_model
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody


def _scaled_errors(model, rng, mm=0.05, rad=2e-4):
    return np.array([rng.normal(0, mm if u == "mm" else rad) for u in model.units])


def test_exact_compensation_reaches_targets_on_the_geometry(bai):
    rng = np.random.default_rng(21)
    g = bai.geometry().perturbed(Tolerances.bai2015(), rng).with_tool([0, 0, -200.0])
    targets = workspace_points(bai, 100, rng) + g.tool
    q = compensate(g, targets)
    np.testing.assert_allclose(exact.forward(g, q).point(g.tool), targets, atol=1e-9)


def test_each_method_takes_what_it_needs_and_compensate_dispatches_by_name(bai):
    rng = np.random.default_rng(24)
    model = get_model("complete")
    g0 = bai.geometry().with_tool([0, 0, -100.0])
    linear = LinearCalibration(g0, model, _scaled_errors(model, rng))
    g = model.apply(g0, linear.deviation)
    targets = workspace_points(bai, 20, rng) + g.tool
    assert np.array_equal(compensate_exact(g, targets), compensate(g, targets))
    assert np.array_equal(compensate_savoure(g, linear, targets), compensate(g, targets, "savoure", linear))
    assert np.array_equal(compensate_bai(g, linear, targets, min_margin=0.5),
                          compensate(g, targets, "bai", linear, min_margin=0.5))
    for args, says in ((("exact", linear), "method 'exact' takes no linear calibration"),
                       (("savoure",), "method 'savoure' needs the nominal geometry"),
                       (("magic", linear), "method must be one of exact, savoure, bai, got 'magic'")):
        with pytest.raises(ValueError, match=says):
            compensate(g, targets, *args)
    with pytest.raises(ValueError, match="method 'bai' cannot represent a payload"):
        compensate(g, targets, "bai", linear, payload=1.0)
    # the method as a value: the same readings as its word, and the same refusals
    assert METHODS == ("exact", "savoure", "bai") == tuple(CompensationMethod)
    assert np.array_equal(compensate(g, targets, CompensationMethod.BAI, linear, min_margin=0.5),
                          compensate(g, targets, "bai", linear, min_margin=0.5))
    with pytest.raises(ValueError, match="method 'exact' takes no linear calibration"):
        compensate(g, targets, CompensationMethod.EXACT, linear)
    with pytest.raises(ValueError, match="method must be 'savoure' or 'bai', got 'exact'"):
        compensate_linear(linear, targets, CompensationMethod.EXACT)


@pytest.mark.parametrize("name", ["complete", "bai42", "classical"])
def test_predicted_displacement_equals_sensitivity_times_deviation(bai, name):
    rng = np.random.default_rng(22)
    model = get_model(name)
    g = bai.geometry()
    dk = _scaled_errors(model, rng)
    q = VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 30, rng))
    x = VirtualDelta.from_nominal(bai).forward(q)
    S = model.sensitivity(g, q)
    np.testing.assert_allclose(
        predicted_plate_displacement(LinearCalibration(g, model, dk), q, x), S @ dk, rtol=1e-9, atol=1e-12
    )


def test_linear_compensators_are_first_order_accurate(bai):
    """Savoure's scheme leaves an error quadratic in the deviations; Bai's misses the tilt lever."""
    rng = np.random.default_rng(23)
    model = get_model("complete")
    g0 = bai.geometry().with_tool([0, 0, -200.0])
    dk = _scaled_errors(model, rng)
    targets = workspace_points(bai, 60, rng) + g0.tool
    errors = {}
    for scale in (1.0, 0.1):
        truth = model.apply(g0, scale * dk)
        cal = LinearCalibration(g0, model, scale * dk)
        for method in ("savoure", "bai"):
            q = compensate(truth, targets, method, cal)
            reached = exact.forward(truth, q).point(truth.tool)
            errors[method, scale] = np.max(np.linalg.norm(reached - targets, axis=1))
        q = compensate(truth, targets, "exact")
        assert np.max(np.linalg.norm(exact.forward(truth, q).point(truth.tool) - targets, axis=1)) < 1e-9
    # second order: ten times smaller errors leave about a hundred times smaller residual
    assert errors["savoure", 0.1] < errors["savoure", 1.0] / 30.0
    # Bai's compensator corrects the plate's reference point, not the tool 200 mm below: first order left
    assert errors["bai", 0.1] > errors["bai", 1.0] / 30.0
    assert errors["bai", 1.0] > 3.0 * errors["savoure", 1.0]


def test_refuses_targets_out_of_reach_and_near_singularities(bai):
    g = bai.geometry()
    with pytest.raises(UnreachableError, match=r"index 1"):
        compensate(g, np.array([[0, 0, -850.0], [0, 0, -5000.0]]))
    # plate pulled up until the arms and rods are nearly aligned: refuse by margin
    v = VirtualDelta.from_nominal(bai)
    # full extension below the centre: |(b - a, z)| = L + l
    z_limit = -np.sqrt((bai.arm_length + bai.rod_length) ** 2 - (bai.base_radius - bai.plate_radius) ** 2)
    z = z_limit + np.array([1e-4, 1e-2, 1.0, 100.0])
    pts = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    margin = singularity_margin(g, v.inverse(pts))
    assert np.all(np.diff(margin) > 0)  # the margin shrinks towards the singularity
    assert margin[0] < 1.0 < margin[-1]
    with pytest.raises(UnreachableError, match="singularity"):
        compensate(g, pts[:1])
    compensate(g, pts[-1:])


@pytest.mark.parametrize("method", ["exact", pytest.param("savoure", marks=pytest.mark.slow),
                                    pytest.param("bai", marks=pytest.mark.slow)])
def test_targets_on_the_reach_limit_are_refused_never_answered_with_garbage(bai, method):
    """Issue 12: on the nominal reach limit savoure and bai wrote joints of 1e14 deg, exit 0."""
    from deltacal.compensation import linear_calibration_from_result
    from deltacal.identification import identify
    from deltacal.planning import d_optimal
    from deltacal.simulation import Metrology, simulate_measurements

    rng = np.random.default_rng(2015)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    poses = d_optimal(bai, "complete", 40, rng=rng).poses
    result = identify(bai.geometry(), simulate_measurements(truth, poses.q, rng, Metrology()), "complete")
    limit = np.array([[0.0, 0.0, -555.3593431283929], [815.1039511850273, 0.0, -850.0]])
    inside = np.array([[0.0, 0.0, -850.0]])
    linear = linear_calibration_from_result(result)
    for target in limit:
        with pytest.raises(UnreachableError) as caught:
            compensate(result.geometry, target[None], method, None if method == "exact" else linear)
        assert caught.value.reason in UnreachableError.REASONS  # out of reach, singular, or check failed
    q = compensate(result.geometry, inside, method, None if method == "exact" else linear)
    assert np.all(np.isfinite(q))


def test_the_output_check_catches_what_a_method_gets_wrong(bai):
    from deltacal.compensation import CHECK_TOLERANCE, check_readings

    g = bai.geometry()
    targets = np.array([[0.0, 0.0, -850.0], [100.0, 50.0, -800.0], [0.0, 0.0, -900.0]])
    q = compensate(g, targets)
    assert not np.any(check_readings(g, targets, q, "savoure"))
    garbage = q.copy()
    garbage[0] = [2.6e12, 0.1, 0.1]  # the 1.5e14 deg of the first release
    garbage[1] += np.radians(0.5)  # assembles, but a few mm off the target
    garbage[2, 0] = np.nan
    assert check_readings(g, targets, garbage, "savoure").tolist() == [True, True, True]
    assert CHECK_TOLERANCE["exact"] < CHECK_TOLERANCE["savoure"] < CHECK_TOLERANCE["bai"]


def _singularity_measures_by_svd(virtual, q, x=None):
    """The measures as first written (rotation matrices, numpy's SVD): the reference."""
    x = virtual.forward(q) if x is None else x
    E = virtual.elbows(q)
    w = virtual.actuator_rotation[:, :, 1]
    arm = E - virtual.axis_point[None]
    u = arm / np.linalg.norm(arm, axis=2, keepdims=True)
    rod = x[:, None, :] + virtual.plate_attachment[None] - E
    rod /= np.linalg.norm(rod, axis=2, keepdims=True)
    sin_t = np.abs(np.sum(rod * np.cross(w[None], u), axis=2))
    angle = np.arcsin(np.clip(sin_t, 0.0, 1.0)).min(axis=1)
    s = np.linalg.svd(rod, compute_uv=False)
    return angle, s[:, -1] / s[:, 0]


def test_closed_form_inverse_condition_matches_numpy_svd():
    from deltacal.kinematics.singularity import inverse_condition_3x3

    rng = np.random.default_rng(13)
    M = rng.normal(size=(20_000, 3, 3)) * rng.uniform(1e-3, 1e3, (20_000, 1, 1))
    s = np.linalg.svd(M, compute_uv=False)
    assert np.all(np.abs(inverse_condition_3x3(M) - s[:, 2] / s[:, 0]) <= 1e-13)
    # near-singular: known singular values (1..3, 0.1..1, eps) in random orthonormal frames
    for eps in (1e-3, 1e-6, 1e-9, 1e-12, 0.0):
        U = np.linalg.qr(rng.normal(size=(2000, 3, 3)))[0]
        V = np.linalg.qr(rng.normal(size=(2000, 3, 3)))[0]
        sv = np.stack([rng.uniform(1, 3, 2000), rng.uniform(0.1, 1, 2000), np.full(2000, eps)], axis=1)
        M = U @ (sv[..., None] * V)
        s = np.linalg.svd(M, compute_uv=False)
        got = inverse_condition_3x3(M)
        assert np.all(np.abs(got - s[:, 2] / s[:, 0]) <= 1e-15)
        assert np.all(np.abs(got - eps / sv[:, 0]) <= 1e-15 + 1e-12 * eps)
    # singular values that coincide (a Delta's symmetric poses): a double or triple eigenvalue keeps
    # half the digits, 2e-8 at worst here (documented bound 1e-7); then rank 1, zero, NaN
    for sv in ([2.0, 1e-3, 1e-3], [2.0, 0.5, 0.5], [1.0, 1.0, 0.5], [1.0, 1.0, 1.0], [1.0, 1e-6, 1e-6]):
        M = U @ (np.array(sv)[:, None] * V)
        s = np.linalg.svd(M, compute_uv=False)
        assert_allclose(inverse_condition_3x3(M), s[:, 2] / s[:, 0], rtol=0, atol=1e-7)
    assert_allclose(inverse_condition_3x3(np.stack([np.eye(3), 2 * np.eye(3), -np.eye(3)[::-1]])), 1.0,
                    rtol=0, atol=1e-15)
    assert inverse_condition_3x3(np.ones((1, 3, 3))).tolist() == [0.0]
    assert inverse_condition_3x3(np.zeros((1, 3, 3))).tolist() == [0.0]
    assert np.isnan(inverse_condition_3x3(np.full((1, 3, 3), np.nan))).all()


@pytest.mark.parametrize("perturbed", [False, True])
def test_singularity_measures_match_the_svd_reference(bai, perturbed):
    from deltacal.kinematics.singularity import singularity_measures

    rng = np.random.default_rng(7)
    g = bai.geometry()
    if perturbed:  # elbows off the arm's plane (e_y != 0), tilted axes, offsets
        g = g.perturbed(Tolerances.bai2015(), rng)
    v = VirtualDelta.from_geometry(g)
    x = workspace_points(bai, 3000, rng) - g.tool
    # and towards the singularities: full extension below the centre
    z_limit = -np.sqrt((bai.arm_length + bai.rod_length) ** 2 - (bai.base_radius - bai.plate_radius) ** 2)
    x = np.concatenate([x, [[0.0, 0.0, z_limit + d] for d in (1e-2, 1.0, 10.0)]])
    q = v.inverse(x, check=False)
    ok = np.all(np.isfinite(q), axis=1)
    x, q = x[ok], q[ok]
    for given in (None, x):  # from the forward kinematics, or given where exact
        angle, conditioning = _singularity_measures_by_svd(v, q, given)
        a, c = singularity_measures(v, q, given)
        assert_allclose(a, angle, rtol=0, atol=1e-12)
        # symmetric poses have two equal singular values: half the digits (see above)
        assert_allclose(c, conditioning, rtol=0, atol=1e-7)


@pytest.mark.parametrize("method", [pytest.param("exact", marks=pytest.mark.slow), "savoure"])
# the reach limit itself, then the singularity margin
@pytest.mark.parametrize("min_margin", [pytest.param(0.0, marks=pytest.mark.slow), 1.0])
def test_the_screen_refuses_only_what_compensate_refuses(bai, method, min_margin):
    """Issue 13: the reading pass's screen never refuses a target the exact computation accepts."""
    from deltacal.compensation import screen

    rng = np.random.default_rng(1313)
    model = get_model("complete")
    deviation = _scaled_errors(model, rng, mm=0.3, rad=2e-3)  # imperfect parallelograms, tenths of mm
    nominal = bai.geometry()
    g = model.apply(nominal, deviation)
    linear = None if method == "exact" else LinearCalibration(nominal, model, deviation)
    virtual = VirtualDelta.from_geometry(g)
    # along a ray out of the workspace, the virtual model's limit (reach, or margin 1) by bisection
    centre = np.array([0.0, 0.0, -900.0])
    out = np.array([0.6, 0.3, -0.75]) / np.linalg.norm([0.6, 0.3, -0.75])

    def virtual_ok(s):
        x = (centre + s * out - g.tool)[None]
        q = virtual.inverse(x, check=False)
        return np.all(np.isfinite(q)) and (min_margin == 0.0 or singularity_margin(g, q, x)[0] >= min_margin)

    lo, hi = 0.0, 2000.0
    for _ in range(60):
        lo, hi = ((lo + hi) / 2, hi) if virtual_ok((lo + hi) / 2) else (lo, (lo + hi) / 2)
    # every 0.1 mm where the verdicts change (compensate's limit 0.4 to 4.2 mm inside the virtual
    # model's, the screen's at it), every 5 mm deeper inside, where both accept
    offsets = np.concatenate([np.arange(-30.0, -5.0, 5.0), np.linspace(-5.0, 3.0, 81)])
    sweep = centre + (lo + offsets)[:, None] * out
    accepted, screened = [], []
    for target in sweep:
        try:
            compensate(g, target[None], method, linear, min_margin)
            accepted.append(True)
        except UnreachableError as exc:
            accepted.append(False)
            reason = exc.reason
        try:
            screen(g, target[None], method, linear, min_margin)
            screened.append(False)
        except UnreachableError as exc:
            screened.append(True)
            assert exc.reason == reason and exc.indices == [0]
    accepted, screened = np.array(accepted), np.array(screened)
    assert not np.any(accepted & screened)  # never refuses what compensate accepts
    assert accepted[offsets <= -20.0].all() and screened[offsets > 1.0].all()  # inside accepted, out not
    last_inside = np.flatnonzero(accepted)[-1]  # within 0.1 mm of the limit, and not refused by the screen
    assert not screened[last_inside] and not accepted[last_inside + 1]
    # in a batch, the indices are the batch's: the unreachable last row, found among reachable ones
    batch = np.concatenate([workspace_points(bai, 500, rng) + g.tool - nominal.tool, sweep[-1:]])
    with pytest.raises(UnreachableError) as caught:
        screen(g, batch, method, linear, min_margin)
    assert caught.value.indices == [500]


def test_readings_of_another_assembly_are_refused(tmp_path):
    """Issue 21, item 1: far targets that the inverse closes in another assembly than the working one.

    On this calibration exact.inverse gives readings for (576.3, 576.3, -350) and (678.82, 678.82,
    -325) at which the robot coming from its home (the FK from the working assembly, and the
    Pinocchio model) puts the TCP millimetres away: compensate refuses them by index.
    """
    from deltacal.cli import main
    from deltacal.io import load_calibration

    robot = str(MODELS / "bai2015.toml")
    p, m, cal = (str(tmp_path / n) for n in ("p.csv", "m.csv", "cal.toml"))
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "60", "--seed", "1", "-o", p]) == 0
    assert main(["simulate", robot, p, "--perturb", "7", "--points", "smr_centre,smr_offset", "-o", m]) == 0
    assert main(["identify", robot, m, "-o", cal]) == 0
    g = load_calibration(cal).geometry
    targets = np.array([[0.0, 0.0, -850.0], [576.3, 576.3, -350.0], [678.82, 678.82, -325.0]])
    q = exact.inverse(g, targets)  # the inverse's own assembly reaches them ...
    working = DeltaMultibody(g).forward(q).point(g.tool)  # ... the robot from its home does not
    miss = np.linalg.norm(working - targets, axis=1)
    assert miss[0] < 1e-6 and np.all(miss[1:] > 1.0), miss
    with pytest.raises(UnreachableError) as info:
        compensate(g, targets)
    assert info.value.indices == [1, 2] and info.value.reason == UnreachableError.CHECK_FAILED


@pytest.mark.long
@pytest.mark.parametrize("seed", [15, 14])
def test_only_readings_of_the_assembly_the_robot_comes_in_are_written(tmp_path, seed):
    """Targets at the outer rim (radius 650-900 mm, z -250 to -370) on robots calibrated from 60 poses.

    The truth is the robot coming along the straight line from its workspace centre, followed
    in 5 mm and 1 mm steps of the exact kinematics: every reading compensate writes is that one, and the
    targets the working assembly does not get to are refused as another assembly's.
    """
    from deltacal.cli import main
    from deltacal.io import load_calibration
    from deltacal.kinematics.continuation import inverse_along
    from deltacal.kinematics.workspace import default_workspace

    robot = str(MODELS / "bai2015.toml")
    p, m, cal = (str(tmp_path / n) for n in ("p.csv", "m.csv", "cal.toml"))
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "60", "--seed", str(seed), "-o", p]) == 0
    points = ["--points", "smr_centre,smr_offset"]
    assert main(["simulate", robot, p, "--perturb", str(seed), *points, "-o", m]) == 0
    assert main(["identify", robot, m, "-o", cal]) == 0
    g = load_calibration(cal).geometry
    r, z, azimuth = np.meshgrid(np.arange(650.0, 901.0, 50.0), np.arange(-250.0, -371.0, -30.0),
                                np.radians([0.0, 40.0, 75.0]))
    targets = np.stack([r * np.cos(azimuth), r * np.sin(azimuth), z], axis=-1).reshape(-1, 3)
    written, refused = [], []
    for k, target in enumerate(targets):
        try:
            written.append((k, compensate(g, target[None])[0]))
        except UnreachableError as exc:
            refused.append(exc.reason)
    for step in (5.0, 1.0):  # at 1 mm, seed 14's robot showed readings of the other assembly written
        truth_q = inverse_along(g, default_workspace(g).centre, targets[[k for k, _ in written]], step=step)
        apart = np.degrees(np.abs(np.array([q for _, q in written]) - truth_q)).max(axis=1)
        assert np.all(apart < 1e-6), apart[~(apart < 1e-6)]  # NaN (the robot does not get there) fails too
    assert UnreachableError.OTHER_ASSEMBLY in refused
    assert len(written) >= 10


@pytest.mark.long
def test_rim_readings_written_are_those_of_pinocchios_closed_loop_coming_from_the_workspace(tmp_path):
    """A fresh robot (seed 31): Pinocchio's inverse, followed in 2 mm steps from the workspace centre
    (each step started from the last assembly), gives the readings compensate writes at rim targets."""
    from deltacal.cli import main
    from deltacal.io import load_calibration
    from deltacal.kinematics.workspace import default_workspace

    robot, seed = str(MODELS / "bai2015.toml"), "31"
    p, m, cal = (str(tmp_path / n) for n in ("p.csv", "m.csv", "cal.toml"))
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "60", "--seed", seed, "-o", p]) == 0
    assert main(["simulate", robot, p, "--perturb", seed, "--points", "smr_centre,smr_offset", "-o", m]) == 0
    assert main(["identify", robot, m, "-o", cal]) == 0
    g = load_calibration(cal).geometry
    centre = default_workspace(g).centre
    azimuth = np.radians([10.0, 40.0, 100.0, 220.0])
    targets = np.stack([850.0 * np.cos(azimuth), 850.0 * np.sin(azimuth), np.full(4, -280.0)], axis=1)
    robot_model = DeltaMultibody(g)
    checked = 0
    for target in targets:
        try:
            written = compensate(g, target[None])[0]
        except UnreachableError:
            continue
        solution = robot_model.solve_forward(exact.inverse(g, centre[None])[0], warm=False)
        steps = int(np.ceil(np.linalg.norm(target - centre) / 2.0))
        for k in range(1, steps + 1):
            solution = robot_model.solve_inverse(centre + k / steps * (target - centre),
                                                 start=solution.configuration)
        np.testing.assert_allclose(written, solution.readings, rtol=0.0, atol=1e-8)  # rad
        checked += 1
    assert checked >= 2
