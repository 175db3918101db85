"""A real tracker's whole path through the command line (issue 11): simulate in two stations'
frames, identify with --frame free, compensate targets given in a station's frame."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS, read_joints, write_targets

from deltacal.cli import main
from deltacal.io import load_geometry, load_instrument, read_measurements
from deltacal.kinematics import exact
from deltacal.rotations import rotation_from_vector

ROBOT = str(MODELS / "bai2015.toml")
EAST = ("east", [1.1, -1.0, 35.0], [2680.0, 830.0, 250.0])
WEST = ("west", [-0.6, 1.2, -140.0], [-1900.0, 2100.0, -120.0])


def station_option(name, rotation_deg, translation_mm) -> str:
    return f"{name}:{','.join(map(str, rotation_deg))}:{','.join(map(str, translation_mm))}"


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tracker")
    poses, meas, cal = folder / "poses.csv", folder / "meas.csv", folder / "cal.toml"
    assert main(["plan", ROBOT, "--strategy", "doptimal", "--count", "60", "-o", str(poses)]) == 0
    stations = ["--station", station_option(*EAST), "--station", station_option(*WEST)]
    assert main(["simulate", ROBOT, str(poses), "--perturb", "7", "--points", "smr_centre", *stations,
                 "-o", str(meas)]) == 0
    assert main(["identify", ROBOT, str(meas), "--frame", "free", "-o", str(cal)]) == 0
    return folder


def test_simulated_measurements_are_in_the_stations_frames(calibrated):
    meas, _ = read_measurements(calibrated / "meas.csv")
    assert meas.stations == ["east", "west"]
    # metres away: nothing like the robot's own frame
    assert np.min(np.linalg.norm(meas.position, axis=1)) > 1500.0


def test_the_calibration_file_holds_each_station(calibrated):
    frames = load_instrument(calibrated / "cal.toml")
    assert set(frames) == {"east", "west"}
    text = (calibrated / "cal.toml").read_text()
    keys = ("[instrument.east]", "rotation_deg", "translation_mm", "rotation_sigma_deg",
            "translation_sigma_mm")
    for key in keys:
        assert key in text


def test_targets_in_a_station_frame_give_the_joints_of_the_same_targets_in_the_base_frame(calibrated, capsys):
    frames = load_instrument(calibrated / "cal.toml")
    targets = np.array([[0.0, 0.0, -850.0], [120.0, -60.0, -900.0], [-200.0, 150.0, -780.0]])
    write_targets(calibrated / "t_base.csv", targets)
    write_targets(calibrated / "t_east.csv", frames["east"].from_base(targets))
    cal = str(calibrated / "cal.toml")
    base, east = calibrated / "j_base.csv", calibrated / "j_east.csv"
    assert main(["compensate", cal, str(calibrated / "t_base.csv"), "-o", str(base)]) == 0
    assert main(["compensate", cal, str(calibrated / "t_east.csv"), "--frame", "instrument",
                 "--station", "east", "-o", str(east)]) == 0
    q_base, q_east = read_joints(calibrated / "j_base.csv"), read_joints(calibrated / "j_east.csv")
    assert np.max(np.abs(q_base - q_east)) < 1e-10
    # and the true robot puts its TCP there, seen from where the tracker truly stood
    truth = load_geometry(calibrated / "meas.truth.toml")
    true_east = rotation_from_vector(np.radians(EAST[1])), np.array(EAST[2])
    reached = exact.forward(truth, q_east).point(truth.tool)
    in_east = reached @ true_east[0].T + true_east[1]
    assert np.max(np.linalg.norm(in_east - frames["east"].from_base(targets), axis=1)) < 0.05


def test_instrument_frame_usage_errors(calibrated, capsys):
    cal = str(calibrated / "cal.toml")
    write_targets(calibrated / "t.csv", np.array([[0.0, 0.0, -850.0]]))
    out = calibrated / "never.csv"
    for options in (["--frame", "instrument"], ["--frame", "instrument", "--station", "north"],
                    ["--station", "east"], ["--method", "savoure"]):
        assert main(["compensate", cal, str(calibrated / "t.csv"), *options, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_targets_in_the_wrong_frame_get_a_hint(calibrated, capsys):
    """Issue 21, item 12: tracker-frame targets without --frame instrument (and the converse)."""
    frames = load_instrument(calibrated / "cal.toml")
    targets = np.array([[0.0, 0.0, -850.0], [120.0, -60.0, -900.0], [-200.0, 150.0, -780.0]])
    write_targets(calibrated / "t_east2.csv", frames["east"].from_base(targets))
    write_targets(calibrated / "t_base2.csv", targets)
    cal, out = str(calibrated / "cal.toml"), str(calibrated / "never2.csv")
    assert main(["compensate", cal, str(calibrated / "t_east2.csv"), "-o", out]) == 1
    err = capsys.readouterr().err
    assert "out of reach" in err and "use --frame instrument --station east|west" in err
    assert main(["compensate", cal, str(calibrated / "t_base2.csv"), "--frame", "instrument", "--station",
                 "east", "-o", out]) == 1
    assert "leave out --frame instrument" in capsys.readouterr().err
