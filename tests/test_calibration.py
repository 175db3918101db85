"""One calibration value, one reader, one writer (issue 20, item 4; issue 21, item 10)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS, complete_fit
from numpy.testing import assert_allclose

from deltacal import Tolerances, identify
from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.io import calibration_from_result, load_calibration, save_calibration
from deltacal.kinematics import exact
from deltacal.observations import Measurements
from deltacal.planning import bai_poses

NOMINAL = MODELS / "bai2015.toml"


@pytest.fixture(scope="module")
def fitted(bai):
    return complete_fit(bai, 31)


def _same(a, b) -> None:
    assert a.model.name == b.model.name and a.method == b.method and a.rank == b.rank
    assert a.geometry.allclose(b.geometry, atol=0.0) and a.nominal.allclose(b.nominal, atol=0.0)
    assert [p.name for p in a.base] == [p.name for p in b.base]
    assert [p.kind for p in a.base] == [p.kind for p in b.base]
    assert_allclose([p.value for p in a.base], [p.value for p in b.base], rtol=1e-15, atol=0.0)
    assert_allclose([p.sigma for p in a.base], [p.sigma for p in b.base], rtol=1e-15, atol=0.0)
    assert_allclose(a.correlation, b.correlation, atol=5e-7)
    assert a.variance_factor == b.variance_factor and a.unidentifiable == b.unidentifiable
    assert a.residuals_after == b.residuals_after and a.outlier_rows == b.outlier_rows


def test_save_then_load_gives_the_same_calibration(fitted, tmp_path):
    cal = calibration_from_result(fitted)
    save_calibration(fitted, tmp_path / "a.toml")
    first = load_calibration(tmp_path / "a.toml")
    _same(cal, first)
    save_calibration(first, tmp_path / "b.toml")  # a Calibration written back: the same file's value
    _same(first, load_calibration(tmp_path / "b.toml"))
    assert (tmp_path / "a.toml").read_text() == (tmp_path / "b.toml").read_text()
    # the linear compensators' view: the base values expanded over the model
    assert_allclose(first.linear().deviation, fitted.base.expand(fitted.values), rtol=1e-15, atol=0.0)


def test_free_frame_calibration_refuses_the_linear_view_in_the_library(bai, tmp_path):
    rng = np.random.default_rng(3)
    g0 = bai.geometry()
    truth = g0.perturbed(Tolerances.bai2015(), rng)
    q = bai_poses(bai, 9).q
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    position = exact.forward(truth, q).point(truth.tool) @ turn.T + [1500.0, 200.0, 100.0]
    result = identify(g0, Measurements(q, position + rng.normal(0.0, 0.005, position.shape)), "complete",
                      frame="free")
    save_calibration(result, tmp_path / "c.toml")
    cal = load_calibration(tmp_path / "c.toml")
    assert list(cal.instrument) == ["default"]
    with pytest.raises(InputError, match="free instrument frame.*exact method"):
        cal.linear()


def _edit(path, old: str, new: str, out):
    text = path.read_text()
    assert old in text
    out.write_text(text.replace(old, new, 1))
    return out


@pytest.mark.parametrize("old,new,key", [
    ("variance_factor = ", "variance_factor = -3.0 # ", "calibration.variance_factor"),
    ("rank = ", "rank = 500 # ", "calibration.rank"),
    ("condition_number = ", "condition_number = 0.5 # ", "calibration.condition_number"),
])
def test_hand_edited_reports_are_refused_by_every_command(fitted, tmp_path, capsys, old, new, key):
    save_calibration(fitted, tmp_path / "cal.toml")
    bad = _edit(tmp_path / "cal.toml", old, new, tmp_path / "bad.toml")
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-850\n")
    for argv in (["compensate", bad, targets, "-o", tmp_path / "j.csv"],
                 ["report", bad, "-o", tmp_path / "r.html", "--no-view"],
                 ["export", bad, "--mjcf", tmp_path / "m.xml"]):
        assert main([str(a) for a in argv]) == 1
        err = capsys.readouterr().err
        assert f"bad.toml: key {key}" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not any((tmp_path / n).exists() for n in ("j.csv", "r.html", "m.xml"))


def test_geometry_edited_in_one_place_is_refused_by_report_and_export(fitted, tmp_path, capsys):
    save_calibration(fitted, tmp_path / "cal.toml")
    text = (tmp_path / "cal.toml").read_text()
    start = text.index("[geometry]")
    tool = text.index("tool_mm = ", start)
    end = text.index("\n", tool)
    (tmp_path / "bad.toml").write_text(text[:tool] + "tool_mm = [0.0, 0.0, -5.0]" + text[end:])
    for argv in (["report", tmp_path / "bad.toml", "-o", tmp_path / "r.html", "--no-view"],
                 ["export", tmp_path / "bad.toml", "--mjcf", tmp_path / "m.xml"]):
        assert main([str(a) for a in argv]) == 1
        assert "[geometry] and [nominal] disagree: key geometry.tool_mm" in capsys.readouterr().err


def test_report_of_another_robot_is_refused(fitted, tmp_path, capsys):
    """Issue 21, item 13: --robot or --truth of another robot gave "actual error 5.9e5 µm", exit 0."""
    from deltacal.io import load_nominal, save_geometry

    save_calibration(fitted, tmp_path / "cal.toml")
    other = tmp_path / "flex.toml"
    save_geometry(load_nominal(MODELS / "flexpicker.toml").geometry(), other)
    same = tmp_path / "truth.toml"
    save_geometry(fitted.geometry, same)
    cal, out = str(tmp_path / "cal.toml"), str(tmp_path / "r.html")
    for option, path in (("--truth", other), ("--robot", MODELS / "flexpicker.toml")):
        assert main(["report", cal, option, str(path), "--no-view", "-o", out]) == 1
        err = capsys.readouterr().err
        assert "is not the calibration's robot" in err and len(err.strip().splitlines()) == 1
    assert main(["report", cal, "--truth", str(same), "--robot", str(NOMINAL), "--no-view", "-o", out]) == 0
