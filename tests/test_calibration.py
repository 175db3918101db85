"""One calibration value, one reader, one writer (issue 20, item 4; issue 21, item 10)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from conftest import MODELS, complete_fit
from numpy.testing import assert_allclose

from deltacal import Tolerances, identify
from deltacal.calibration import Calibration
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


@pytest.mark.long
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


def test_the_value_holds_the_library_units(fitted):
    cal = Calibration.from_result(fitted)
    assert {p.unit for p in cal.base} == {"mm", "rad"} and cal.method == fitted.method
    # the identified values themselves (mm, rad), not their degrees
    assert [p.value for p in cal.base] == [float(v) for v in fitted.values]
    assert [p.sigma for p in cal.base] == [float(s) for s in fitted.sigma]
    assert cal.residuals_before == fitted.before and cal.residuals_after == fitted.after
    assert cal.compliance is None and cal.compliance_sigma is None
    alias = calibration_from_result(fitted)
    assert alias.base == cal.base and alias.geometry is cal.geometry


def test_the_file_converts_degrees_both_ways_to_the_last_digit(fitted, tmp_path):
    save_calibration(fitted, tmp_path / "a.toml")
    back = load_calibration(tmp_path / "a.toml")
    text = (tmp_path / "a.toml").read_text()
    angles = [p for p in back.base if p.unit == "rad"]
    assert angles and all(f"value_deg = {math.degrees(p.value)!r}\n" in text for p in angles)
    assert back.residuals_after.as_dict() == fitted.after.as_dict()


def test_what_an_earlier_file_lacks_reads_as_not_recorded(fitted, tmp_path):
    save_calibration(fitted, tmp_path / "a.toml")
    text = (tmp_path / "a.toml").read_text()
    start = text.index("\n[calibration.residuals_before]")
    end = text.index("\n[[calibration.base_parameter]]")
    old = tmp_path / "old.toml"
    old.write_text(text[:start] + text[end:])
    _edit(old, 'method = "iterated"\n', "", old)
    cal = load_calibration(old)
    assert cal.method is None and not cal.residuals_before.as_dict() and not cal.residuals_after.as_dict()
    save_calibration(cal, tmp_path / "b.toml")  # written back without a method (not a placeholder)
    assert "method =" not in (tmp_path / "b.toml").read_text()
    assert load_calibration(tmp_path / "b.toml").method is None
    # the placeholder earlier versions wrote back for a missing method reads as not recorded
    assert load_calibration(_edit(tmp_path / "a.toml", 'method = "iterated"', 'method = "?"',
                                  tmp_path / "q.toml")).method is None
    with pytest.raises(InputError, match="key calibration.method: must be 'linear' or 'iterated'"):
        load_calibration(_edit(tmp_path / "a.toml", 'method = "iterated"', 'method = "magic"',
                               tmp_path / "m.toml"))
    bad = _edit(tmp_path / "a.toml", "position_rms_mm = ", "positoin_rms_mm = ", tmp_path / "bad.toml")
    with pytest.raises(InputError, match="key calibration.residuals_before.positoin_rms_mm: unknown key"):
        load_calibration(bad)


@pytest.mark.long
def test_the_report_takes_the_value_or_its_file(fitted, tmp_path):
    from deltacal.kinematics.workspace import default_workspace
    from deltacal.report import accuracy_map, write_report

    save_calibration(fitted, tmp_path / "cal.toml")
    by_file = write_report(tmp_path / "cal.toml", tmp_path / "a.html", view=False, grid=7)
    by_value = write_report(load_calibration(tmp_path / "cal.toml"), tmp_path / "b.html", view=False, grid=7)
    assert by_file.worst_sigma == by_value.worst_sigma

    def page(name: str) -> str:  # the figures' element ids count the figures drawn in this process
        return re.sub(r"\bf\d+-", "f-", (tmp_path / name).read_text())

    assert page("a.html") == page("b.html")
    # built in memory: the same map, but for the correlations, which the file rounds to 6 decimals
    in_memory = Calibration.from_result(fitted)
    amap = accuracy_map(in_memory, default_workspace(in_memory.nominal), n=7)  # the report's map
    assert amap.worst == pytest.approx(by_file.worst_sigma, rel=1e-4)
