"""Pose planning: Bai's pose sets, the κ(n) rule, D-optimal selection, the POSES file, `plan`."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from conftest import MODELS
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.io import load_nominal, read_poses, write_poses
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.singularity import jacobian_condition, singularity_measures
from deltacal.planning import (
    ConditionCurve,
    PlanningError,
    PlanOptions,
    PoseSet,
    SingularityMargin,
    bai_poses,
    candidate_pool,
    condition_curve,
    d_optimal,
    rough_poses,
)


def azimuths(points: np.ndarray) -> np.ndarray:
    return np.mod(np.arctan2(points[:, 1], points[:, 0]), 2.0 * np.pi)


# --------------------------------------------------------------------------- pose sets
@pytest.mark.parametrize("n", [3, 7])
def test_bai_poses_centre_then_top_and_bottom_circles(bai, n):
    ws = bai.workspace
    poses = bai_poses(bai, n)
    assert len(poses) == 2 * n + 1
    assert_allclose(poses.targets[0], [0.0, 0.0, ws.middle_z], atol=1e-12)
    for block, z in ((poses.targets[1 : n + 1], ws.top_z), (poses.targets[n + 1 :], ws.bottom_z)):
        assert_allclose(block[:, 2], z, atol=1e-12)
        assert_allclose(np.hypot(block[:, 0], block[:, 1]), ws.radius, atol=1e-9)
        assert_allclose(azimuths(block), 2.0 * np.pi * np.arange(n) / n, atol=1e-12)
    # the readings put the nominal TCP on the targets
    x = VirtualDelta.from_nominal(bai).forward(poses.q) + bai.tool
    assert_allclose(x, poses.targets, atol=1e-9)


def test_rough_poses_on_the_middle_circle(bai):
    ws = bai.workspace
    poses = rough_poses(bai, 5)
    assert len(poses) == 6  # Bai §5.1: K = C(6, 2) = 15 distances
    assert_allclose(poses.targets[0], ws.centre, atol=1e-12)
    assert_allclose(poses.targets[1:, 2], ws.middle_z, atol=1e-12)
    assert_allclose(np.hypot(*poses.targets[1:, :2].T), ws.radius, atol=1e-9)
    assert len(rough_poses(bai, 5, centre=False)) == 5


def test_another_tool_shifts_the_targets_and_keeps_the_motions(flexpicker):
    tool = np.array([10.0, -5.0, -120.0])
    plain = bai_poses(flexpicker, 4)
    shifted = bai_poses(flexpicker, 4, tool=tool)
    assert_allclose(shifted.q, plain.q, atol=0.0)
    assert_allclose(shifted.targets - plain.targets, np.broadcast_to(tool - flexpicker.tool, (9, 3)))
    geometry = flexpicker.geometry().with_tool(tool)
    assert_allclose(exact.inverse(geometry, shifted.targets), shifted.q, atol=1e-9)


# --------------------------------------------------------------------------- κ(n) rule
def test_kappa_rule_picks_the_least_n_satisfying_it():
    curve = ConditionCurve(
        model="m", measurement="distance", points=["tcp"], layers="top-bottom",
        n=np.arange(2, 9),
        kappa=np.array([np.inf, 10.0, 8.0, 7.9, 7.0, 6.99, 6.98]),
        epsilon=np.array([np.nan, np.inf, 0.25, 0.0127, 0.1286, 0.00143, 0.00143]),
        base_names=[], scaled=True,
    )
    assert curve.least_n(0.01) == 7
    assert curve.least_n(0.02) == 5
    assert curve.least_n(0.3) == 4  # n = 3 has ε = inf (κ_2 infinite)
    assert curve.least_n(0.3, n_min=5) == 5
    with pytest.raises(PlanningError, match="below 0.1 %"):
        curve.least_n(0.001)


def test_kappa_decreases_and_rule_on_bai2015(bai):
    rough = condition_curve(bai, "rough", "distance", n_max=12)
    assert rough.layers == "middle" and rough.base_names == ["offset1", "offset2", "offset3"]
    assert rough.kappa[0] == math.inf  # n = 2: centre and two opposite poses are collinear
    assert np.all(np.diff(rough.kappa[1:]) <= 1e-12)  # κ_n decreases from n = 3 on
    n = rough.least_n(0.01)
    k = int(np.flatnonzero(rough.n == n)[0])
    assert rough.epsilon[k] <= 0.01 and np.all(rough.epsilon[1:k] > 0.01)
    assert n == 5  # Bai §5.1, Fig. 6: n = 5

    fine = condition_curve(bai, "bai18", "distance", n_max=12)
    assert len(fine.base_names) == 18
    # n <= 4: at most 36 distances of 9 poses do not identify the 18 parameters
    assert np.all(np.isinf(fine.kappa[fine.n <= 4])) and np.all(np.isfinite(fine.kappa[fine.n >= 5]))
    assert fine.least_n(0.01) == 8  # Bai Fig. 7: 7
    plain = condition_curve(bai, "bai18", "distance", n_max=12, scaled=False)
    assert plain.least_n(0.01) == 9


def test_kappa_rule_model32_two_points(bai):
    curve = condition_curve(bai, "bai32", "distance", n_max=10)
    assert curve.points == ["smr_centre", "smr_offset"]
    assert len(curve.base_names) == 32  # Bai §3.2: rank(H) = 32 with two points
    assert curve.least_n(0.01) == 9  # Bai Fig. 7: 9


def test_kappa_of_pose_measurements_is_finite_once_identifiable(bai):
    curve = condition_curve(bai, "complete", "pose", n_max=6)
    assert np.isfinite(curve.kappa[-1]) and len(curve.base_names) < 51


# --------------------------------------------------------------------------- candidates, D-optimal
def test_candidate_pool_reachable_inside_and_away_from_singularities(bai):
    ws = bai.workspace
    margin = SingularityMargin(min_arm_rod_angle=math.radians(50.0), max_condition=3.0)
    pool = candidate_pool(bai, 300, np.random.default_rng(1), margin)
    assert len(pool) == 300
    ref = pool.targets - bai.tool
    assert np.all(np.hypot(ref[:, 0], ref[:, 1]) <= ws.radius + 1e-9)
    assert np.all((ref[:, 2] <= ws.top_z + 1e-9) & (ref[:, 2] >= ws.bottom_z - 1e-9))
    virtual = VirtualDelta.from_nominal(bai)
    angle, _ = singularity_measures(virtual, pool.q)
    cond = jacobian_condition(virtual, pool.q)
    assert np.all(angle >= margin.min_arm_rod_angle) and np.all(cond <= margin.max_condition)
    # the margin bites: the whole cylinder has smaller angles (min ~44 deg on bai2015)
    loose = candidate_pool(bai, 300, np.random.default_rng(1), SingularityMargin(0.0, 0.0, np.inf))
    assert np.min(singularity_measures(virtual, loose.q)[0]) < margin.min_arm_rod_angle
    assert_allclose(exact.inverse(bai.geometry(), pool.targets), pool.q, atol=1e-9)
    with pytest.raises(PlanningError, match="reachable"):
        candidate_pool(bai, 10, np.random.default_rng(1), SingularityMargin(math.radians(89.0)))


@pytest.mark.parametrize(
    ("model", "measurement", "count"), [("complete", "pose", 10), ("classical", "position", 12)]
)
def test_d_optimal_beats_random_selection(bai, model, measurement, count):
    design = d_optimal(bai, model, count, np.random.default_rng(2), pool_size=400, measurement=measurement)
    assert len(design.poses) == count and len(set(design.selected.tolist())) == count
    assert_allclose(design.poses.q, design.pool.q[design.selected])
    assert design.log_det == pytest.approx(design.log_det_of(design.selected))
    assert np.isfinite(design.log_det)
    rng = np.random.default_rng(3)
    random = [design.log_det_of(rng.choice(len(design.pool), count, replace=False)) for _ in range(200)]
    assert design.log_det > max(random)
    # every selected pose is reachable by the nominal robot and reaches its target
    x = VirtualDelta.from_nominal(bai).forward(design.poses.q) + bai.tool
    assert_allclose(x, design.poses.targets, atol=1e-9)


def test_d_optimal_rejects_impossible_requests(bai):
    pool = bai_poses(bai, 3)
    with pytest.raises(PlanningError, match="cannot select 8 poses from 7"):
        d_optimal(bai, "classical", 8, pool=pool)
    with pytest.raises(ValueError, match="pose or position"):
        d_optimal(bai, "classical", 3, pool=pool, measurement="distance")


def test_d_optimal_takes_one_options_value_and_overrides_of_its_fields(bai):
    pool = candidate_pool(bai, 120, np.random.default_rng(4))
    options = PlanOptions(measurement="position", max_passes=2)
    by_options = d_optimal(bai, "classical", 12, pool=pool, options=options)
    by_keywords = d_optimal(bai, "classical", 12, pool=pool, measurement="position", max_passes=2)
    overridden = d_optimal(bai, "classical", 12, pool=pool, options=PlanOptions(max_passes=2),
                           measurement="position")
    assert by_options.selected.tolist() == by_keywords.selected.tolist() == overridden.selected.tolist()
    assert overridden.measurement == "position"
    assert PlanOptions(tool=np.array([0.0, 0.0, -100.0])).tool == (0.0, 0.0, -100.0)
    assert PlanOptions(points=["tcp", "tcp"]).points == ("tcp",)
    with pytest.raises(TypeError, match=r"'max_pass' is not an option of PlanOptions \(did you mean"):
        d_optimal(bai, "classical", 12, pool=pool, max_pass=2)  # type: ignore[call-arg]
    for bad, says in (({"pool_size": 0}, "pool_size must be a positive integer"),
                      ({"max_passes": -1}, "max_passes must be a non-negative integer"),
                      ({"sigma_angle": 0.0}, "sigma_angle must be a positive finite number"),
                      ({"tool": (0.0, 1.0)}, "tool must be 3 finite coordinates"),
                      ({"payloads": (math.nan,)}, "payloads must be finite masses")):
        with pytest.raises(ValueError, match=says):
            PlanOptions(**bad)


# --------------------------------------------------------------------------- POSES file
def test_poses_file_round_trip_and_validation(bai, tmp_path):
    poses = bai_poses(bai, 4)
    path = tmp_path / "poses.csv"
    write_poses(path, poses)
    assert path.read_text().splitlines()[0] == "q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm"
    back, warnings = read_poses(path, bai)
    assert warnings == []
    assert_allclose(back.q, poses.q, atol=1e-15, rtol=0)
    assert_allclose(back.targets, poses.targets, atol=0.0)

    lines = path.read_text().splitlines()
    bad = tmp_path / "bad.csv"
    fields = lines[2].split(",")
    bad.write_text("\n".join([lines[0], lines[1], ",".join([fields[0], "abc", *fields[2:]])]) + "\n")
    with pytest.raises(InputError, match=r"bad.csv: line 3 \(data row 2\), column q2_deg: value 'abc'"):
        read_poses(bad)
    bad.write_text("q1_deg,q2_deg,x_mm,y_mm,z_mm\n1,2,3,4,5\n")
    with pytest.raises(InputError, match="missing required column.*q3_deg"):
        read_poses(bad)
    # readings that do not reach the row's target: planned for another robot, or edited
    fields = lines[2].split(",")
    fields[3] = repr(float(fields[3]) + 0.5)
    bad.write_text("\n".join([lines[0], lines[1], ",".join(fields)]) + "\n")
    read_poses(bad)  # fine without a robot to check against
    with pytest.raises(InputError, match=r"line 3.*0\.5 mm from the target"):
        read_poses(bad, bai)


def test_failed_poses_write_leaves_the_existing_file(bai, tmp_path, monkeypatch):
    path = tmp_path / "poses.csv"
    path.write_text("old content\n")

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        write_poses(path, bai_poses(bai, 3))
    monkeypatch.undo()
    assert path.read_text() == "old content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["poses.csv"]  # no temporary left
    nan = PoseSet(np.full((1, 3), np.nan), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="not finite"):
        write_poses(path, nan)
    assert path.read_text() == "old content\n"


# --------------------------------------------------------------------------- command line
def test_plan_command(tmp_path, capsys):
    robot = str(MODELS / "bai2015.toml")
    out = tmp_path / "rough.csv"
    assert main(["plan", robot, "--model", "rough", "--epsilon", "1%", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "chosen n = 5" in printed
    poses, _ = read_poses(out, load_nominal(robot))
    assert len(poses) == 6

    out = tmp_path / "fixed.csv"
    assert main(["plan", robot, "--model", "bai18", "--n", "7", "-o", str(out)]) == 0
    assert len(read_poses(out)[0]) == 15

    out = tmp_path / "dopt.csv"
    args = ["plan", robot, "--strategy", "doptimal", "--count", "8", "--pool", "200", "--seed", "4"]
    assert main([*args, "-o", str(out)]) == 0
    assert len(read_poses(out)[0]) == 8
    first = out.read_text()
    assert main([*args, "-o", str(out)]) == 0
    assert out.read_text() == first  # seeded

    out = tmp_path / "none.csv"
    # options of the other strategy are a usage error (2), like any wrong combination of options
    assert main(["plan", robot, "--strategy", "doptimal", "--n", "3", "-o", str(out)]) == 2
    assert "apply to --strategy bai" in capsys.readouterr().err
    assert main(["plan", robot, "--strategy", "doptimal", "--measure", "distance", "-o", str(out)]) == 2
    assert "pose or position measurements" in capsys.readouterr().err
    assert not out.exists()
    assert main(["plan", robot, "--points", "nope", "-o", str(out)]) == 1
    assert "unknown point 'nope'" in capsys.readouterr().err
    assert not out.exists()
