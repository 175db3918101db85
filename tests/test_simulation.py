"""Simulated metrology: exactness without noise, noise statistics, layout, `simulate`."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MODELS, workspace_points
from numpy.testing import assert_allclose

from deltacal import DeltaGeometry, Tolerances
from deltacal.cli import main
from deltacal.geometry import rotation_from_vector, vector_from_rotation
from deltacal.io import load_geometry, load_nominal, read_measurements, write_poses
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.observations import build_rows
from deltacal.planning import bai_poses
from deltacal.simulation import (
    Metrology,
    ground_truth_forward,
    pose_stations,
    simulate_measurements,
    truth_path,
)


@pytest.fixture(scope="module")
def truth(bai) -> DeltaGeometry:
    return bai.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(5))


@pytest.fixture(scope="module")
def readings(bai) -> np.ndarray:
    return VirtualDelta.from_nominal(bai).inverse(workspace_points(bai, 20, np.random.default_rng(6)))


def test_noise_free_simulation_is_the_forward_kinematics(truth, readings):
    metrology = Metrology(points=("tcp", "smr_offset", "smr_centre"), sigma_position=0.0, sigma_angle=0.0)
    meas = simulate_measurements(truth, readings, np.random.default_rng(0), metrology)
    pose = exact.forward(truth, readings)
    mb = DeltaMultibody(truth).point_positions(readings, ["tcp", "smr_offset", "smr_centre"])
    for k, name in enumerate(metrology.points):
        rows = slice(k, None, 3)
        assert meas.point[rows] == [name] * len(readings)
        assert_allclose(meas.q[rows], readings, atol=0.0)
        assert_allclose(meas.position[rows], pose.point(truth.point(name)), atol=1e-9)
        assert_allclose(meas.position[rows], mb[:, k], atol=1e-9)
    assert_allclose(meas.rotation_vector[0::3], pose.rotation_vector(), atol=1e-12)
    assert np.all(np.isnan(meas.rotation_vector[1::3])) and np.all(np.isnan(meas.rotation_vector[2::3]))
    # at the true geometry the identification rows have zero residuals, positions and distances
    for distances in (False, True):
        rows = build_rows(truth, meas, lambda g, q, p: np.zeros((len(q), 6, 1)), 0.005, 1e-5, distances)
        assert np.max(np.abs(rows.residual)) < 1e-9


@pytest.mark.slow
def test_noise_statistics(truth, readings):
    reps = 150  # 3000 measurements, 9000 coordinates
    q = np.tile(readings, (reps, 1))
    metrology = Metrology(
        points=("smr_offset",), sigma_position=0.01, sigma_angle=math.radians(0.01), repeats=4
    )
    meas = simulate_measurements(truth, q, np.random.default_rng(7), metrology)
    pose = ground_truth_forward(truth, q)
    err = meas.position - pose.point(truth.point("smr_offset"))
    ang = vector_from_rotation(rotation_from_vector(meas.rotation_vector) @ np.swapaxes(pose.rotation, 1, 2))
    for e, sigma in ((err, 0.005), (ang, math.radians(0.005))):  # σ / sqrt(4)
        n = e.shape[0]
        # means within 4.5 standard errors; the sample σ of 9000 values has a relative standard
        # error of 0.75 %: 5 % catches a wrong σ / sqrt(repeats) (a factor 2) with a wide margin
        assert np.all(np.abs(e.mean(axis=0)) < 4.5 * sigma / math.sqrt(n))
        assert abs(e.std() / sigma - 1.0) < 0.05
        assert abs(np.corrcoef(e.T)[0, 1]) < 0.1  # axes independent


def test_layout_seeds_and_options(truth, readings):
    m1 = simulate_measurements(truth, readings, np.random.default_rng(1))
    m2 = simulate_measurements(truth, readings, np.random.default_rng(1))
    m3 = simulate_measurements(truth, readings, np.random.default_rng(2))
    assert_allclose(m1.position, m2.position, atol=0.0)
    assert not np.allclose(m1.position, m3.position, atol=1e-6)
    assert len(m1) == len(readings) and m1.point == ["tcp"] * len(readings)
    assert np.all(m1.has_orientation)
    blind = simulate_measurements(
        truth, readings, np.random.default_rng(1), Metrology(orientation=False), forward=exact.forward
    )
    assert not np.any(blind.has_orientation)
    with pytest.raises(ValueError, match="repeats"):
        Metrology(repeats=0)
    with pytest.raises(ValueError, match="sigma_position"):
        Metrology(sigma_position=-1.0)
    with pytest.raises(Exception, match="unknown point 'nope'"):
        simulate_measurements(truth, readings, np.random.default_rng(1), Metrology(points=("nope",)))


def test_simulate_command(tmp_path, capsys):
    robot = MODELS / "bai2015.toml"
    nominal = load_nominal(robot)
    poses_path = tmp_path / "poses.csv"
    write_poses(poses_path, bai_poses(nominal, 3))
    out = tmp_path / "meas.csv"
    args = ["simulate", str(robot), str(poses_path), "--perturb", "11", "--points", "smr_centre,smr_offset",
            "--repeats", "3", "--seed", "2", "-o", str(out)]
    assert main(args) == 0
    assert truth_path(out) == tmp_path / "meas.truth.toml"
    truth = load_geometry(truth_path(out))
    assert truth.allclose(nominal.geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(11)))
    meas, _ = read_measurements(out, truth.point_names)
    assert len(meas) == 14 and meas.point[:2] == ["smr_centre", "smr_offset"]
    assert int(meas.has_orientation.sum()) == 7
    expected = exact.forward(truth, meas.q).point(np.stack([truth.point(p) for p in meas.point]))
    assert np.max(np.abs(meas.position - expected)) < 6 * 0.005 / math.sqrt(3)  # noise only

    out2 = tmp_path / "again.csv"
    assert main(["simulate", str(robot), str(poses_path), "--truth", str(truth_path(out)),
                 "--no-orientation", "--sigma-position", "0", "-o", str(out2)]) == 0
    assert not truth_path(out2).exists()
    meas2, _ = read_measurements(out2, truth.point_names)
    assert not np.any(meas2.has_orientation)
    assert_allclose(meas2.position, exact.forward(truth, meas2.q).point(truth.tool), atol=1e-9)

    bad = tmp_path / "bad.csv"
    capsys.readouterr()
    assert main(["simulate", str(robot), str(poses_path), "--perturb", "1", "--points", "tcp,nope",
                 "-o", str(bad)]) == 1
    assert "unknown point 'nope'" in capsys.readouterr().err
    assert not bad.exists() and not truth_path(bad).exists()


def test_pose_stations_are_blocks_of_whole_poses():
    assert pose_stations(["a", "b"], 5, 2) == ["a"] * 6 + ["b"] * 4
    assert pose_stations(["a", "b", "c"], 3) == ["a", "b", "c"]
    assert pose_stations(["only"], 4, 3) == ["only"] * 12


def test_simulate_two_points_two_stations_keeps_each_pose_in_one_station(tmp_path):
    """Stations went by measurement index: one pose's two reflectors fell in different stations and
    the stations interleaved (issue 21, item 5)."""
    robot = str(MODELS / "bai2015.toml")
    poses, meas, cal = tmp_path / "poses.csv", tmp_path / "meas.csv", tmp_path / "cal.toml"
    assert main(["plan", robot, "--strategy", "doptimal", "--count", "25", "-o", str(poses)]) == 0
    stations = ["--station", "east:1.1,-1.0,35:2680,830,250",
                "--station", "west:-0.6,1.2,-140:-1900,2100,-120"]
    assert main(["simulate", robot, str(poses), "--perturb", "7", "--points", "smr_centre,smr_offset",
                 *stations, "-o", str(meas)]) == 0
    m, _ = read_measurements(meas)
    assert len(m) == 50 and m.point == ["smr_centre", "smr_offset"] * 25
    station = np.array(m.station).reshape(25, 2)
    assert np.all(station[:, 0] == station[:, 1])  # both reflectors of a pose from one place
    assert np.all(m.q[0::2] == m.q[1::2])
    assert station[:, 0].tolist() == ["east"] * 13 + ["west"] * 12  # consecutive pose blocks
    assert main(["identify", robot, str(meas), "--frame", "free", "-o", str(cal)]) == 0

