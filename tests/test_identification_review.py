"""The poor-fit review names a richer model when the one asked for is too simple (issue 20)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

from deltacal import PoorFitError, Tolerances
from deltacal.cli import main
from deltacal.identification import identify
from deltacal.io import write_measurements
from deltacal.planning import d_optimal
from deltacal.simulation import Metrology, simulate_measurements

TOOL = np.array([0.0, 0.0, -180.0])  # a tool 180 mm below the plate


@pytest.fixture(scope="module")
def tool_poses(bai):
    """Pose data (position and orientation of the TCP) of a real robot with a 180 mm tool."""
    rng = np.random.default_rng(180)
    start = bai.geometry().with_tool(TOOL)
    truth = start.perturbed(Tolerances.bai2015(), rng)
    q = d_optimal(bai, "complete", 60, rng=rng).poses.q
    return start, simulate_measurements(truth, q, rng, Metrology())


@pytest.mark.slow
def test_the_classical_model_is_refused_naming_the_complete_model(tool_poses, tmp_path, capsys):
    start, measurements = tool_poses
    with pytest.raises(PoorFitError) as caught:
        identify(start, measurements, "classical")
    error = caught.value
    assert error.result.variance_factor > 100.0  # the case: s0² in the thousands
    assert error.codes == (PoorFitError.RICHER_MODEL,) and error.model == "complete"
    assert "the complete model fits these data, s0² = " in str(error) and "use --model complete" in str(error)
    assert "no single cause stands out" not in str(error)
    complete = identify(start, measurements, "complete")  # and it does fit them
    assert complete.inlier_variance_factor < 2.0
    path = tmp_path / "poses.csv"
    write_measurements(path, measurements)
    robot = tmp_path / "robot.toml"
    robot.write_text((MODELS / "bai2015.toml").read_text().replace(
        "tool_mm = [0.0, 0.0, 0.0]", "tool_mm = [0.0, 0.0, -180.0]"))
    code = main(["identify", str(robot), str(path), "--model", "classical", "-o", str(tmp_path / "c.toml")])
    err = capsys.readouterr().err
    assert code == 1 and len(err.strip().splitlines()) == 1 and "use --model complete" in err
    assert not (tmp_path / "c.toml").exists()


def test_large_residuals_with_the_complete_model_name_no_cause(tool_poses):
    """σ given 20 times too small: no reading and no richer model fits; the code says so."""
    start, measurements = tool_poses
    with pytest.raises(PoorFitError) as caught:
        identify(start, measurements, "complete", sigma_position=0.005 / 20,
                 sigma_angle=np.radians(0.003) / 20)
    assert caught.value.codes == (PoorFitError.LARGE_RESIDUALS,) and caught.value.model == ""
    assert "no single cause stands out" in str(caught.value)


def test_an_accepted_poor_fit_warns_with_the_richer_model(tool_poses):
    """A Bai model too simple for pose data (bai24: s0² 1.0e3 here, where bai42 fits) is told too."""
    start, measurements = tool_poses
    assert identify(start, measurements, "bai42").warnings == ()
    result = identify(start, measurements, "bai24", accept_poor_fit=True)
    assert any("use --model complete" in w and "poor fit accepted" in w for w in result.warnings)
