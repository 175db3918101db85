"""Fits that refuse to lie (issue 11): the silent wrong answers of the first release now exit 1."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS

from deltacal import Tolerances
from deltacal.cli import main
from deltacal.identification import PoorFitError, identify
from deltacal.identification.quality import POOR_FIT, excess_bound, implausible_deviations
from deltacal.io import write_measurements
from deltacal.planning import d_optimal
from deltacal.simulation import Metrology, simulate_measurements

ROBOT = MODELS / "bai2015.toml"


@pytest.fixture(scope="module")
def session(bai):
    rng = np.random.default_rng(2015)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    poses = d_optimal(bai, "complete", 60, rng=rng).poses
    reflector = simulate_measurements(truth, poses.q, rng, Metrology(points=("smr_centre",)))
    two = simulate_measurements(
        truth, poses.q, rng, Metrology(points=("smr_centre", "smr_offset"), orientation=False)
    )
    return bai, reflector, two


def cli(tmp_path, capsys, meas, *options):
    path = tmp_path / "meas.csv"
    write_measurements(path, meas)
    out = tmp_path / "cal.toml"
    code = main(["identify", str(ROBOT), str(path), "-o", str(out), *options])
    err = capsys.readouterr().err
    return code, err, out


def test_a_good_fit_passes_silently(session, tmp_path, capsys):
    _, reflector, _ = session
    code, err, out = cli(tmp_path, capsys, reflector)
    assert code == 0 and out.exists() and "warning" not in err


def test_reflector_written_without_its_point_column(session, tmp_path, capsys):
    """Read as the TCP: the ball centres absorb the 30 mm, the residuals look fine, the geometry does not."""
    bai, reflector, _ = session
    no_point = replace(reflector, point=["tcp"] * len(reflector))
    result = identify(bai.geometry(), no_point, "complete", accept_poor_fit=True)
    assert implausible_deviations(bai.geometry(), result.geometry)  # plate balls moved by ~30 mm
    code, err, out = cli(tmp_path, capsys, no_point)
    assert code == 1 and not out.exists()
    assert len(err.strip().splitlines()) == 1
    assert "implausible" in err and "point 'smr_centre', not 'tcp'" in err


@pytest.mark.slow
def test_two_reflector_labels_swapped(session, tmp_path, capsys):
    _, _, two = session
    swapped = replace(two, point=["smr_offset" if p == "smr_centre" else "smr_centre" for p in two.point])
    code, err, out = cli(tmp_path, capsys, swapped)
    assert code == 1 and not out.exists() and len(err.strip().splitlines()) == 1
    assert "labels 'smr_offset' and 'smr_centre' are swapped" in err


def test_radians_in_the_degree_columns(session, tmp_path, capsys):
    bai, reflector, _ = session
    radians = replace(reflector, rotation_vector=reflector.rotation_vector * np.pi / 180.0)
    with pytest.raises(PoorFitError) as caught:
        identify(bai.geometry(), radians, "complete")
    # a moderate s0² on its own: the comparison with the values read as radians is what tells
    assert caught.value.result.variance_factor < POOR_FIT
    assert caught.value.causes[0].startswith("the orientation columns rx_deg, ry_deg, rz_deg hold radians")
    code, err, out = cli(tmp_path, capsys, radians)
    assert code == 1 and not out.exists() and "hold radians" in err


@pytest.mark.slow
def test_accept_poor_fit_writes_with_a_warning(session, tmp_path, capsys):
    _, _, two = session
    swapped = replace(two, point=["smr_offset" if p == "smr_centre" else "smr_centre" for p in two.point])
    code, err, out = cli(tmp_path, capsys, swapped, "--accept-poor-fit")
    assert code == 0 and out.exists()
    assert "warning:" in err and "swapped" in err


@pytest.mark.slow
def test_a_moderate_excess_is_reported_not_refused(session, tmp_path, capsys):
    """σ given 0.7 of the real noise: s0² about 2, unmodelled-looking, and no other reading fits better."""
    bai, reflector, _ = session
    result = identify(
        bai.geometry(), reflector, "complete", sigma_position=0.0035, sigma_angle=np.radians(0.0021)
    )
    dof = result.n_rows - result.rank
    assert excess_bound(dof) < result.variance_factor < 10.0
    assert any("exceed the σ given" in w for w in result.warnings)
    code, err, out = cli(tmp_path, capsys, reflector, "--sigma-position", "0.0035", "--sigma-angle", "0.0021")
    assert code == 0 and out.exists() and "warning: variance factor" in err


def test_a_model_too_simple_is_refused_without_a_false_cause(session):
    bai, reflector, _ = session
    with pytest.raises(PoorFitError) as caught:
        identify(bai.geometry(), reflector, "classical")
    assert caught.value.causes == []  # no reading of the data fits: the model does not
    # issue 20: the complete model fits the same data, and the message says so
    message = str(caught.value)
    assert "the complete model fits these data" in message and "use --model complete" in message
    assert caught.value.codes == (PoorFitError.RICHER_MODEL,) and caught.value.model == "complete"
