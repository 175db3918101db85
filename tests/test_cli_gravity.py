"""Gravity and payload on the command line: simulate --payload/--compliance, identify --compliance,
compensate --payload, and their refusals (one line, status, nothing written)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import MODELS, read_joints, write_targets
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.compensation import compensate
from deltacal.io import load_calibration, load_geometry, load_nominal, read_measurements
from deltacal.kinematics import exact
from deltacal.robots import load_controller
from deltacal.simulation import compliant_forward

MASSES = "\n[masses]\narm_kg = 0.35\nrod_kg = 0.04\nplate_kg = 0.4\n"


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A flexpicker with masses, 30 planned poses simulated at 0 and 3 kg, identified with compliances."""
    folder = tmp_path_factory.mktemp("gravity")
    robot = folder / "robot.toml"
    robot.write_text((MODELS / "flexpicker.toml").read_text() + MASSES)
    poses, meas, cal = folder / "poses.csv", folder / "meas.csv", folder / "cal.toml"
    assert main(["plan", str(robot), "--strategy", "doptimal", "--count", "30", "-o", str(poses)]) == 0
    assert main(["simulate", str(robot), str(poses), "--perturb", "5", "--payload", "0,3", "--compliance",
                 "2e-5,1.8e-5,2.2e-5", "-o", str(meas)]) == 0
    assert main(["identify", str(robot), str(meas), "--compliance", "-o", str(cal)]) == 0
    return folder, robot, meas, cal


def test_simulate_writes_the_payloads_and_a_compliant_truth(session):
    folder, robot, meas, _ = session
    measured, _ = read_measurements(meas)
    assert len(measured) == 60
    assert_allclose(measured.payload_kg, np.repeat([0.0, 3.0], 30))
    assert_allclose(measured.q[:30], measured.q[30:])
    truth = load_geometry(folder / "meas.truth.toml")
    assert_allclose(truth.compliance, [2e-5, 1.8e-5, 2.2e-5])
    assert truth.masses == load_nominal(robot).masses
    # the loaded robot stood where its equilibrium puts it: 3 kg moved the TCP by micrometres
    moved = np.linalg.norm(measured.position[30:] - measured.position[:30], axis=1)
    assert 0.002 < moved.max() < 0.2


def test_identify_and_compensate_with_a_payload(session, capsys):
    folder, _, _, cal = session
    data = tomllib.loads(cal.read_text())
    assert len(data["compliance"]["actuator_rad_per_nm"]) == 3
    calibration = load_calibration(cal)
    truth = load_geometry(folder / "meas.truth.toml")
    assert calibration.compliance_sigma is not None
    assert np.all(np.abs(calibration.compliance - truth.compliance) < 4.0 * calibration.compliance_sigma)
    targets = np.array([[0.0, 0.0, -600.0], [150.0, -80.0, -700.0]])
    write_targets(folder / "t.csv", targets)
    assert main(["compensate", str(cal), str(folder / "t.csv"), "--payload", "3", "-o",
                 str(folder / "j.csv")]) == 0
    q = read_joints(folder / "j.csv")
    assert_allclose(q, compensate(calibration.geometry, targets, payload=3.0), rtol=0.0, atol=1e-13)
    reached = compliant_forward(truth, q, 3.0, exact.forward).point(truth.tool)
    assert np.linalg.norm(reached - targets, axis=1).max() < 0.03  # mm: the loaded TCP on target
    # through a controller: its corrected targets make it command those readings
    controller = load_controller(MODELS / "flexpicker.toml")
    assert main(["compensate", str(cal), str(folder / "t.csv"), "--payload", "3", "--controller",
                 str(MODELS / "flexpicker.toml"), "-o", str(folder / "c.csv")]) == 0
    rows = np.loadtxt(folder / "c.csv", delimiter=",", skiprows=1)
    assert_allclose(controller.inverse(rows[:, 3:6]), q, rtol=0.0, atol=1e-9)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--payload", "3", "--method", "bai"], "--payload: the bai method cannot represent a payload"),
        (["--payload", "-1"], "argument --payload: must be a finite non-negative number"),
    ],
)
def test_compensate_payload_refusals(session, capsys, extra, message):
    folder, _, _, cal = session
    write_targets(folder / "t2.csv", np.array([[0.0, 0.0, -600.0]]))
    out = folder / "refused.csv"
    try:
        status = main(["compensate", str(cal), str(folder / "t2.csv"), "-o", str(out), *extra])
    except SystemExit as exc:  # argparse's own refusals
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not out.exists()


def test_a_payload_for_a_rigid_calibration_is_warned(session, tmp_path, capsys):
    folder, robot, meas, _ = session
    rigid = tmp_path / "rigid.toml"
    assert main(["identify", str(robot), str(meas), "--rigid", "--accept-poor-fit", "-o", str(rigid)]) == 0
    capsys.readouterr()
    write_targets(tmp_path / "t.csv", np.array([[0.0, 0.0, -600.0]]))
    assert main(["compensate", str(rigid), str(tmp_path / "t.csv"), "--payload", "3", "-o",
                 str(tmp_path / "j.csv")]) == 0
    assert "--payload 3 changes nothing" in capsys.readouterr().err


def test_payloads_that_vary_identify_the_compliances_by_default(session, tmp_path, capsys):
    """Measured at 0 and 3 kg with [masses] known: the calibration --compliance gives, said on stdout."""
    _, robot, meas, cal = session
    capsys.readouterr()
    default = tmp_path / "default.toml"
    assert main(["identify", str(robot), str(meas), "-o", str(default)]) == 0
    assert "payload_kg varies from 0 to 3 kg" in capsys.readouterr().out
    assert default.read_text() == cal.read_text()
    assert np.all(load_calibration(default).geometry.compliance > 0.0)


def test_rigid_is_the_opt_out(session, tmp_path, capsys):
    _, robot, meas, _ = session
    out = tmp_path / "c.toml"
    assert main(["identify", str(robot), str(meas), "--rigid", "--compliance", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--rigid and --compliance: choose one" in err[0]
    assert not out.exists()


def test_payloads_that_vary_without_masses_are_refused(session, tmp_path, capsys):
    """No [masses]: the rigid fit is not taken silently; the line names --compliance and --rigid."""
    _, _, meas, _ = session
    robot = tmp_path / "robot.toml"
    robot.write_text((MODELS / "flexpicker.toml").read_text())
    out = tmp_path / "c.toml"
    out.write_text("earlier")
    assert main(["identify", str(robot), str(meas), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert f"{meas}: column payload_kg: payload_kg varies from 0 to 3 kg but {robot} has no [masses]" \
        in err[0]
    assert "--compliance" in err[0] and "--rigid" in err[0]
    assert out.read_text() == "earlier"


def test_plan_for_the_compliances(session, tmp_path, capsys):
    _, robot, _, _ = session
    capsys.readouterr()
    assert main(["plan", str(robot), "--strategy", "doptimal", "--count", "20", "--pool", "200", "--payload",
                 "0,3", "-o", str(tmp_path / "p.csv")]) == 0
    assert "compliances c1, c2, c3 identifiable" in capsys.readouterr().out


def test_a_negative_mass_is_refused_naming_the_key(tmp_path, capsys):
    robot = tmp_path / "robot.toml"
    robot.write_text((MODELS / "flexpicker.toml").read_text() + MASSES.replace("0.4", "-0.4"))
    assert main(["plan", str(robot), "-o", str(tmp_path / "p.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "key masses.plate_kg: a mass cannot be negative" in err[0]


@pytest.mark.long
def test_report_shows_the_compliances_and_a_deflection_map(session):
    folder, _, _, cal = session
    out = folder / "report.html"
    assert main(["report", str(cal), "-o", str(out), "--no-view", "--payload", "3", "--truth",
                 str(folder / "meas.truth.toml")]) == 0
    page = out.read_text()
    assert "Actuator compliances and deflections" in page
    assert "a payload of 3 kg at the TCP" in page
    calibration = load_calibration(cal)
    assert calibration.compliance is not None
    shown = f"{1e6 * calibration.compliance[0]:.6g}"
    assert shown in page  # c1 in µrad/N m


@pytest.mark.parametrize("cell, message", [
    ("", "column payload_kg: empty value: a payload is the mass at the TCP [kg], 0 for none"),
    ("-3", "column payload_kg: a payload is a mass: must be >= 0 kg, got -3"),
])
def test_a_bad_payload_cell_is_named_on_one_short_line(session, tmp_path, capsys, cell, message):
    """6,000 rows, one bad payload: the line names the file, line, column and value, not every row."""
    _, robot, meas, _ = session
    header, *rows = meas.read_text().splitlines()
    column = header.split(",").index("payload_kg")
    rows = rows * 100
    fields = rows[4].split(",")
    fields[column] = cell
    rows[4] = ",".join(fields)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join([header, *rows]) + "\n")
    assert main(["identify", str(robot), str(bad), "-o", str(tmp_path / "c.toml")]) == 1
    err = capsys.readouterr().err.strip().splitlines()  # the duplicate rows are warned
    assert [line for line in err if not line.startswith("warning")] == [
        f"deltacal identify: error: {bad}: line 6 (data row 5), {message}"]
    assert not (tmp_path / "c.toml").exists()


def test_measurements_name_the_first_bad_payload_only():
    from deltacal.observations import Measurements

    q, position = np.zeros((3, 3)), np.zeros((3, 3))
    with pytest.raises(ValueError, match=r"got nan in row 1 \(2 in all\)$"):
        Measurements(q=q, position=position, payload=np.array([0.0, np.nan, -1.0]))
