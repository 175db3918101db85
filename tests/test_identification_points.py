"""Free plate points (issue 11, item 6): a reflector's position on the plate identified with the
geometry where the data can tell it apart, and the confounded combinations named where not.

Ground truth: measurements simulated on the Pinocchio closed-loop model of a perturbed robot whose
reflector ``smr_offset`` sits off the position the robot file gives.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS
from numpy.testing import assert_allclose

from deltacal import Tolerances
from deltacal.cli import main
from deltacal.errormodels import get_model
from deltacal.exceptions import IdentificationError
from deltacal.identification import PoorFitError, identify
from deltacal.identification.points import point_columns, with_points_moved
from deltacal.io import load_geometry, write_measurements
from deltacal.kinematics import exact
from deltacal.observations import SIGMA_ANGLE, SIGMA_POSITION, build_rows
from deltacal.planning import d_optimal
from deltacal.simulation import Metrology, simulate_measurements

#: How far the true reflector sits from where the robot file puts it, plate frame [mm].
SHIFT = np.array([0.4, -0.3, 0.6])
POINTS = ("smr_centre", "smr_offset")


@pytest.fixture(scope="module")
def cell(bai):
    rng = np.random.default_rng(3)
    start = bai.geometry()
    truth = start.perturbed(Tolerances.bai2015(), rng)
    truth = replace(truth, points={**truth.points, "smr_offset": start.points["smr_offset"] + SHIFT})
    q = d_optimal(bai, "complete", 60, rng=rng).poses.q
    poses = simulate_measurements(truth, q, rng, Metrology(points=POINTS))
    positions = simulate_measurements(truth, q, rng, Metrology(points=POINTS, orientation=False))
    return start, truth, poses, positions


def test_point_columns_match_finite_differences_through_the_exact_kinematics(cell):
    start, _, poses, _ = cell
    meas = poses.subset(np.arange(0, len(poses), 7))
    pose = exact.forward(start, meas.q)
    rows = build_rows(start, meas, get_model("classical").sensitivity, SIGMA_POSITION, SIGMA_ANGLE,
                      pose=pose)
    F = point_columns(rows, meas, ["smr_offset", "smr_centre"], pose.rotation)
    h = 1e-4
    numeric = np.zeros_like(F)
    for j, (name, c) in enumerate([(n, c) for n in ("smr_offset", "smr_centre") for c in range(3)]):
        move = np.zeros((2, 3))
        move[0 if name == "smr_offset" else 1, c] = h
        plus = with_points_moved(start, ["smr_offset", "smr_centre"], move)
        minus = with_points_moved(start, ["smr_offset", "smr_centre"], -move)
        # predicted = measured - residual; the regressor is d(predicted)/d(parameter)
        r_plus = build_rows(plus, meas, get_model("classical").sensitivity, SIGMA_POSITION,
                            SIGMA_ANGLE).residual
        r_minus = build_rows(minus, meas, get_model("classical").sensitivity, SIGMA_POSITION,
                             SIGMA_ANGLE).residual
        numeric[:, j] = -(r_plus - r_minus) / (2 * h)
    assert np.max(np.abs(F)) > 0.5  # positions of both points are in the rows
    assert_allclose(F, numeric, atol=1e-7)


def test_a_reflector_off_its_place_is_refused_and_the_offset_is_named(cell):
    start, _, poses, _ = cell
    with pytest.raises(PoorFitError) as caught:
        identify(start, poses, "complete")
    assert caught.value.causes[0].startswith("the position on the plate of 'smr_offset' differs")
    assert "--free-points smr_offset" in str(caught.value)


def test_the_freed_reflector_is_recovered_within_its_sigma(cell):
    start, truth, poses, _ = cell
    result = identify(start, poses, "complete", free_points=["smr_offset"])
    assert 0.7 < result.variance_factor < 1.4
    assert result.confounded == ()
    names = [result.base.names[k] for k in result.base.base]
    found = result.geometry.points["smr_offset"] - start.points["smr_offset"]
    sigma = np.array([result.sigma[names.index(f"P[smr_offset].{c}")] for c in "xyz"])
    assert np.all(sigma < 0.01)
    assert np.all(np.abs(found - SHIFT) < 4 * sigma), (found, sigma)
    # and the robot is right where it matters: the TCP of a 200 mm tool over the workspace
    q = poses.q[::2]
    tool = np.array([0.0, 0.0, -200.0])
    error = exact.forward(result.geometry, q).point(tool) - exact.forward(truth, q).point(tool)
    assert np.max(np.linalg.norm(error, axis=1)) < 0.02


def test_every_point_freed_names_the_common_shift_instead_of_a_number(cell):
    start, _, poses, _ = cell
    result = identify(start, poses, "complete", free_points=["smr_offset", "smr_centre"])
    # one point is enough to fix the plate frame's origin: the other's three coordinates are confounded
    assert result.confounded == ("P[smr_centre].x", "P[smr_centre].y", "P[smr_centre].z")
    assert_allclose(result.geometry.points["smr_centre"], start.points["smr_centre"], atol=0.0)
    assert "confounded with the plate geometry" in result.report()
    assert "P[smr_centre].x" in result.report()


def test_positions_only_say_which_coordinates_they_cannot_tell(cell):
    start, _, _, positions = cell
    result = identify(start, positions, "complete", free_points=["smr_offset"])
    assert 0.7 < result.variance_factor < 1.4
    # without orientations the complete model's plate balls already explain some coordinates:
    # they are named, and held, rather than given a number
    for name in result.confounded:
        assert name.startswith("P[smr_offset].")
        c = "xyz".index(name[-1])
        assert result.geometry.points["smr_offset"][c] == start.points["smr_offset"][c]


def test_a_free_point_must_be_measured(cell):
    start, _, poses, _ = cell
    with pytest.raises(IdentificationError, match="free point 'tcp' is not measured"):
        identify(start, poses, "complete", free_points=["tcp"])


def test_command_line_frees_a_point_and_saves_it(cell, tmp_path, capsys):
    start, _, poses, _ = cell
    robot = str(MODELS / "bai2015.toml")
    meas, cal = tmp_path / "meas.csv", tmp_path / "cal.toml"
    write_measurements(meas, poses)
    assert main(["identify", robot, str(meas), "-o", str(cal)]) == 1
    assert "--free-points smr_offset" in capsys.readouterr().err
    assert not cal.exists()
    assert main(["identify", robot, str(meas), "--free-points", "smr_offset", "-o", str(cal)]) == 0
    found = load_geometry(cal).points["smr_offset"] - start.points["smr_offset"]
    assert np.all(np.abs(found - SHIFT) < 0.02)
    assert main(["identify", robot, str(meas), "--free-points", "smr_nowhere", "-o", str(cal)]) == 1
    err = capsys.readouterr().err
    assert "--free-points: unknown point 'smr_nowhere'" in err
    assert main(["identify", robot, str(meas), "--distances", "--free-points", "smr_offset",
                 "-o", str(tmp_path / "d.toml")]) == 2
