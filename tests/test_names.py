"""Names of points and stations in every file deltacal writes (issue 21, item 3).

A station ``süd`` or ``ταυ``, a point ``smr_ö`` or a control character in a name: what deltacal
writes must read back equal, or the name is refused where it enters, by its file and place.
"""

from __future__ import annotations

import tomllib
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
from conftest import MODELS, complete_fit
from hypothesis import given, settings
from hypothesis import strategies as st

from deltacal.calibration import FrameRecord
from deltacal.cli import main
from deltacal.exceptions import InputError
from deltacal.io import (
    calibration_from_result,
    load_calibration,
    load_geometry,
    load_nominal,
    name_problem,
    read_measurements,
    save_calibration,
    save_geometry,
    toml_dumps,
    write_measurements,
)
from deltacal.observations import Measurements

NAMES = settings(max_examples=60, deadline=None, derandomize=True)

#: Any Unicode text, control characters and lone surrogates included.
any_text = st.text(st.characters(codec=None, exclude_categories=()), max_size=12)
#: Names deltacal accepts: no control character, no surrogate, no space at either end.
names = st.text(st.characters(exclude_categories=("Cc", "Cs")), min_size=1, max_size=12).filter(
    lambda s: s == s.strip())
HOSTILE = ["süd", "ταυ", "smr_ö", "a,b", 'say "x"', "a.b", "[x]", "東京", "a = b", "#", "'", "x\u200dy"]


@pytest.fixture(scope="module")
def fitted(bai):
    return complete_fit(bai, 5)


def _measurements(points: list[str], stations: list[str]) -> Measurements:
    n = len(points)
    rng = np.random.default_rng(n)
    return Measurements(q=rng.normal(0.0, 0.3, (n, 3)), position=rng.normal(0.0, 300.0, (n, 3)),
                        point=points, station=stations)


def test_the_toml_writer_quotes_what_is_not_a_bare_key():
    data = {"name": "süd", "instrument": {name: {"v": [1.0, -2.5]} for name in HOSTILE + ["east", "a-b_1"]}}
    text = toml_dumps(data)
    assert tomllib.loads(text) == data
    assert "[instrument.east]" in text and "[instrument.a-b_1]" in text  # bare where TOML allows
    assert '[instrument."süd"]' in text and "v = [1.0, -2.5]" in text  # arrays stay on one line


@NAMES
@given(key=any_text, value=any_text)
def test_any_key_and_string_read_back(key, value):
    data = {"s": value, "t": {key: {"k": value, "x": [0.5]}}, "a": [{key: 1}]}
    try:
        text = toml_dumps(data)
        text.encode("utf-8")
    except UnicodeEncodeError:  # a lone surrogate: no UTF-8 text holds it, the name rules refuse it
        assert any(name_problem(s) and "surrogate" in name_problem(s) for s in (key, value))
        return
    assert tomllib.loads(text) == data


@NAMES
@given(point=any_text, station=any_text)
def test_measurements_with_any_names_read_back_or_are_refused(tmp_path_factory, point, station):
    path = tmp_path_factory.mktemp("names") / "meas.csv"
    meas = _measurements([point, "tcp", point], [station, station, "other"])
    problem = name_problem(point) or name_problem(station)
    if problem is not None:
        with pytest.raises(InputError, match="name .* " + problem.split(" ")[0]):
            write_measurements(path, meas)
        assert not path.exists()  # nothing half-written
        return
    write_measurements(path, meas)
    back, _ = read_measurements(path)
    assert back.point == meas.point and back.station == meas.station


@NAMES
@given(points=st.lists(names, min_size=1, max_size=3), stations=st.lists(names, min_size=1, max_size=3))
def test_measurements_with_names_read_back(tmp_path_factory, points, stations):
    path = tmp_path_factory.mktemp("names") / "meas.csv"
    n = max(len(points), len(stations))
    meas = _measurements([points[k % len(points)] for k in range(n)],
                         [stations[k % len(stations)] for k in range(n)])
    write_measurements(path, meas)
    back, _ = read_measurements(path)
    assert back.point == meas.point and back.station == meas.station
    np.testing.assert_array_equal(back.position, meas.position)


@NAMES
@given(stations=st.lists(names, min_size=1, max_size=3, unique=True), point=names)
@pytest.mark.slow
def test_a_calibration_with_any_names_reads_back_equal(fitted, tmp_path_factory, stations, point):
    folder = tmp_path_factory.mktemp("cal")
    cal = calibration_from_result(fitted)
    frames = {name: FrameRecord(name, np.array([0.1 * k, 0.0, 1.0]), np.array([10.0, 0.0, -k]),
                                np.full(3, 1e-3), np.full(3, 0.01)) for k, name in enumerate(stations)}
    geometry = replace(cal.geometry, points={point: np.array([1.0, 2.0, 3.0])})
    nominal = replace(cal.nominal, points={point: np.array([1.0, 2.0, 3.0])})
    cal = replace(cal, frames=frames, geometry=geometry, nominal=nominal)
    save_calibration(cal, folder / "a.toml")
    back = load_calibration(folder / "a.toml")
    assert list(back.frames) == stations and list(back.geometry.points) == [point]
    for name in stations:
        np.testing.assert_array_equal(back.frames[name].translation, frames[name].translation)
    save_calibration(back, folder / "b.toml")
    assert (folder / "a.toml").read_bytes() == (folder / "b.toml").read_bytes()
    save_geometry(geometry, folder / "g.toml")
    assert list(load_geometry(folder / "g.toml").points) == [point]


@pytest.mark.parametrize("bad", ["a\x01b", "line\nbreak", " east", "west\t", "", "\x7f"])
def test_names_no_file_carries_are_refused_by_every_writer(fitted, tmp_path, bad):
    meas = _measurements(["tcp", "tcp"], [bad, "b"])
    with pytest.raises(InputError, match="station name"):
        write_measurements(tmp_path / "m.csv", meas)
    cal = calibration_from_result(fitted)
    record = FrameRecord(bad, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(InputError, match="station name"):
        save_calibration(replace(cal, frames={bad: record}), tmp_path / "c.toml")
    with pytest.raises(InputError, match="point name"):
        save_geometry(replace(cal.geometry, points={bad: np.zeros(3)}), tmp_path / "g.toml")
    assert list(tmp_path.iterdir()) == []


def test_control_characters_in_files_are_refused_by_row_and_column_or_key(tmp_path, capsys):
    meas = tmp_path / "meas.csv"
    meas.write_text("q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm,point,station\n"
                    "0,0,0,0,0,-800,tcp,east\n0,1,0,0,0,-800,tcp,ea\x01st\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"line 3 \(data row 2\), column station: station name 'ea\\x01st' "
                                         "holds the control character U\\+0001"):
        read_measurements(meas)
    robot = tmp_path / "robot.toml"
    text = (MODELS / "bai2015.toml").read_text(encoding="utf-8")
    robot.write_text(text.replace("smr_offset =", '"smr\\u0007" ='), encoding="utf-8")
    with pytest.raises(InputError, match=r"key points: point name 'smr\\x07' holds the control character"):
        load_nominal(robot)
    assert main(["simulate", str(robot), str(meas), "--perturb", "1", "-o", str(tmp_path / "o.csv")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "point name 'smr\\x07'" in err and "Traceback" not in err
    option = "a\x01b:0,0,0:0,0,0"
    out = tmp_path / "x.csv"
    args = ["simulate", str(robot), str(meas), "--perturb", "1", "--station", option, "-o", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "argument --station: station name 'a\\x01b' holds the control character U+0001" in err
    assert not out.exists()


@pytest.mark.long
def test_unicode_stations_and_points_go_through_every_command(tmp_path, capsys):
    """simulate and identify wrote bare TOML keys: compensate, report and export then failed."""
    robot = tmp_path / "robot.toml"
    text = (MODELS / "bai2015.toml").read_text(encoding="utf-8").replace("smr_offset =", '"smr_ö" =')
    robot.write_text(text, encoding="utf-8")
    assert "smr_ö" in load_nominal(robot).points
    poses, meas, cal = tmp_path / "poses.csv", tmp_path / "meas.csv", tmp_path / "cal.toml"
    assert main(["plan", str(robot), "--strategy", "doptimal", "--count", "30", "-o", str(poses)]) == 0
    stations = ["--station", "süd:1,-1,35:2680,830,250", "--station", "ταυ:-0.6,1.2,-140:-1900,2100,-120"]
    assert main(["simulate", str(robot), str(poses), "--perturb", "7", "--points", "smr_centre,smr_ö",
                 *stations, "-o", str(meas)]) == 0
    assert main(["identify", str(robot), str(meas), "--frame", "free", "-o", str(cal)]) == 0
    assert list(load_calibration(cal).frames) == ["süd", "ταυ"]
    targets = tmp_path / "targets.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-850\n50,-20,-900\n", encoding="utf-8")
    assert main(["compensate", str(cal), str(targets), "-o", str(tmp_path / "j.csv")]) == 0
    assert main(["report", str(cal), "-o", str(tmp_path / "r.html")]) == 0
    assert main(["export", str(cal), "--mjcf", str(tmp_path / "robot.xml")]) == 0
    err = capsys.readouterr().err
    assert "not valid TOML" not in err and "error" not in err


def test_a_robot_name_with_a_control_character_is_refused_where_it_enters(fitted, tmp_path, capsys):
    """It became the MJCF model's name: raw in an XML attribute, the file was not XML."""
    robot = tmp_path / "robot.toml"
    text = (MODELS / "bai2015.toml").read_text(encoding="utf-8")
    robot.write_text(text.replace('name = "bai2015"', 'name = "bai\\u00012015"'), encoding="utf-8")
    with pytest.raises(InputError, match=r"key name: robot name 'bai\\x012015' holds the control character"):
        load_nominal(robot)
    cal = calibration_from_result(fitted)
    with pytest.raises(InputError, match="robot name"):
        save_geometry(replace(cal.geometry, name="x\x1b[31m"), tmp_path / "g.toml")
    out = tmp_path / "robot.xml"
    assert main(["export", str(MODELS / "bai2015.toml"), "--mjcf", str(out), "--name", "a\x07"]) == 2
    assert "model name 'a\\x07' holds the control character U+0007" in capsys.readouterr().err
    assert not out.exists()
    # any other text names the robot and the model, read back as written
    name = "süd <1> & 'ταυ'"
    assert main(["export", str(MODELS / "bai2015.toml"), "--mjcf", str(out), "--name", name]) == 0
    assert ET.parse(out).getroot().get("model") == name
