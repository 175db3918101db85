"""The command line end to end: error messages, exit statuses, atomic outputs, a full round trip.

Every test runs ``deltacal.cli.main`` in-process on files written in a temporary
folder; the measurements are simulated with the exact kinematics of a perturbed
bai2015 robot (noise free, so the round trip is exact to the solvers' precision).
"""

from __future__ import annotations

import math
import os
import re
import stat
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, workspace_points
from numpy.testing import assert_allclose

from deltacal import ConvergenceError, InputError, NominalDelta, Tolerances
from deltacal.cli import main
from deltacal.errormodels import get_model
from deltacal.identification import identify
from deltacal.io import atomic_write_text, load_nominal, save_geometry, write_measurements
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.observations import Measurements

NOMINAL = MODELS / "bai2015.toml"
HEADER = "q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,point"


def simulate(nominal: NominalDelta, truth, targets: np.ndarray, orientation: bool = True) -> Measurements:
    """Exact pose measurements of the true robot at the readings of nominal IK for the targets."""
    q = VirtualDelta.from_nominal(nominal).inverse(targets - nominal.tool)
    pose = exact.forward(truth, q)
    return Measurements(
        q=q,
        position=pose.point(truth.tool),
        rotation_vector=pose.rotation_vector() if orientation else None,
    )


@pytest.fixture(scope="module")
def data(tmp_path_factory, bai):
    """A true robot, its measurements (30 poses), targets, and a calibration file."""
    folder = tmp_path_factory.mktemp("cli")
    rng = np.random.default_rng(7)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    meas = folder / "meas.csv"
    write_measurements(meas, simulate(bai, truth, workspace_points(bai, 30, rng)))
    targets = folder / "targets.csv"
    t = workspace_points(bai, 8, rng)
    targets.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in t.tolist()))
    cal = folder / "cal.toml"
    assert main(["identify", str(NOMINAL), str(meas), "--model", "complete", "-o", str(cal)]) == 0
    return {"folder": folder, "truth": truth, "meas": meas, "targets": targets, "target_values": t,
            "cal": cal}


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def error_line(err: str) -> str:
    """The one error line of stderr (warnings may precede it)."""
    lines = [s for s in err.splitlines() if "error:" in s]
    assert len(lines) == 1, err
    return lines[0]


def mutate(path: Path, out: Path, edit) -> Path:
    lines = path.read_text().splitlines()
    out.write_text("\n".join(edit(lines)) + "\n")
    return out


def set_field(line_no: int, column: str, value: str):
    """An edit: the field of a column on a line (1-based, header = line 1) set to a value."""

    def edit(lines: list[str]) -> list[str]:
        header = lines[0].split(",")
        fields = lines[line_no - 1].split(",")
        fields[header.index(column)] = value
        lines[line_no - 1] = ",".join(fields)
        return lines

    return edit


# --------------------------------------------------------------------------- round trip
def test_identify_then_compensate_puts_the_true_tcp_on_the_targets(data, capsys, tmp_path):
    joints = tmp_path / "joints.csv"
    code, out, err = run(capsys, "compensate", data["cal"], data["targets"], "-o", joints)
    assert code == 0, err
    assert err == ""
    table = np.loadtxt(joints, delimiter=",", skiprows=1)
    assert joints.read_text().splitlines()[0] == "x_mm,y_mm,z_mm,q1_deg,q2_deg,q3_deg"
    assert_allclose(table[:, :3], data["target_values"], atol=0.0)
    reached = exact.forward(data["truth"], np.radians(table[:, 3:])).point(data["truth"].tool)
    # noise-free measurements: the identified complete model reproduces the true robot to under
    # a micrometre (0.19 µm measured). Not to 1e-9: Savoure's model moves the plate balls for an
    # actuator-point error (Eq. 13), the same only while the plate is parallel; the true robot's
    # tilt (up to 0.25 deg) times its actuator-point errors (0.15 mm) leaves up to ~0.6 µm
    assert_allclose(reached, data["target_values"], atol=5e-4)


def test_identify_report_and_permissions(data, capsys, tmp_path):
    cal = tmp_path / "cal.toml"
    code, out, err = run(capsys, "identify", NOMINAL, data["meas"], "--model", "bai42", "-o", cal)
    assert code == 0, err
    assert "rank 42 of 42" in out and "outliers: none" in out
    assert f"wrote {cal}" in out
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(cal.stat().st_mode) == 0o666 & ~umask  # not mkstemp's 0o600


# --------------------------------------------------------------------------- bad measurements
MEASUREMENT_ERRORS = [
    # (edit of the valid file, pieces the error line must hold)
    (set_field(3, "q1_deg", "abc"), ["line 3", "column q1_deg", "'abc'", "not a number"]),
    (set_field(4, "y_mm", "nan"), ["line 4", "column y_mm", "'nan'", "not a finite number"]),
    (set_field(5, "z_mm", "-inf"), ["line 5", "column z_mm", "'-inf'", "not a finite number"]),
    (set_field(6, "x_mm", "1e999"), ["line 6", "column x_mm", "'1e999'", "not a finite number"]),
    (set_field(7, "q2_deg", "1_000"), ["line 7", "column q2_deg", "'1_000'"]),
    (set_field(8, "q3_deg", ""), ["line 8", "column q3_deg", "empty value"]),
    (set_field(9, "rx_deg", ""), ["line 9", "column rx_deg", "given together"]),
    (set_field(10, "point", "smr_middle"), ["line 10", "column point", "'smr_middle'", "smr_offset"]),
    (lambda ls: [ls[0].replace("z_mm", "Z_mm"), *ls[1:]],
     ["line 1", "missing required column(s) z_mm", "did you mean 'Z_mm'"]),
    (lambda ls: [ls[0].replace("rz_deg", "rzdeg"), *ls[1:]], ["rx_deg, ry_deg, rz_deg go together"]),
    (lambda ls: [ls[0].replace("point", "q1_deg"), *ls[1:]], ["line 1", "'q1_deg' appears twice"]),
    (lambda ls: [s.replace(",", ";") for s in ls], ["line 1", "separated by ';'"]),
    (lambda ls: [*ls[:4], ls[4].replace(",", ";"), *ls[5:]], ["line 5", "1 fields where the header has 10"]),
    (lambda ls: [*ls[:5], re.sub(r"(\d)\.(\d)", r"\1,\2", ls[5], count=1), *ls[6:]],
     ["line 6", "11 fields where the header has 10", "decimal comma"]),
    (lambda ls: [*ls[:6], ls[6] + ",", *ls[7:]], ["line 7", "trailing comma"]),
    (lambda ls: [], ["file is empty"]),
    (lambda ls: ["", "   "], ["file is empty"]),
    (lambda ls: ls[:1], ["no data rows after the header"]),
    (lambda ls: ls[:4], ["too few measurements", "3 give 18 equations", "at least 7 poses"]),
]


@pytest.mark.parametrize(("edit", "pieces"), MEASUREMENT_ERRORS)
def test_bad_measurements_name_file_line_column_value(data, capsys, tmp_path, edit, pieces):
    bad = mutate(data["meas"], tmp_path / "bad.csv", edit)
    out = tmp_path / "cal.toml"
    code, _, err = run(capsys, "identify", NOMINAL, bad, "-o", out)
    assert code == 1
    line = error_line(err)
    assert line.startswith(f"deltacal identify: error: {bad}")
    for piece in pieces:
        assert piece in line, line
    assert not out.exists()


def test_binary_latin1_and_utf16_files(data, capsys, tmp_path):
    cases = (
        ("bin.csv", b"\x00\x01\x02garbage", "file holds NUL bytes"),
        ("latin1.csv", data["meas"].read_bytes().replace(b"tcp", "tcp\u00b0".encode("latin-1"), 3),
         "line 2: file is not UTF-8 text: byte 0xb0"),
        ("utf16.csv", data["meas"].read_text().encode("utf-16"), "line 1: file is not UTF-8 text: byte 0xff "
                                                                 "(UTF-16? save it as UTF-8)"),
    )
    for name, content, piece in cases:
        bad = tmp_path / name
        bad.write_bytes(content)
        code, _, err = run(capsys, "identify", NOMINAL, bad, "-o", tmp_path / "cal.toml")
        assert code == 1
        assert f"{bad}: {piece}" in error_line(err)


def test_radians_in_a_degree_column_warn_then_fail_as_implausible(data, capsys, tmp_path):
    def to_radians(lines):
        out = [lines[0]]
        for s in lines[1:]:
            f = s.split(",")
            f[:3] = [repr(math.radians(float(v))) for v in f[:3]]
            out.append(",".join(f))
        return out

    bad = mutate(data["meas"], tmp_path / "rad.csv", to_radians)
    code, _, err = run(capsys, "identify", NOMINAL, bad, "-o", tmp_path / "cal.toml")
    assert code == 1
    assert f"warning: {bad}: column q1_deg holds only values within ±π: are these radians?" in err
    assert "check the units" in error_line(err)


def test_metres_in_a_millimetre_column_warn(capsys, tmp_path):
    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(NOMINAL).geometry(), geometry)
    targets = tmp_path / "targets.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0.1,0.0,-0.9\n0.0,0.2,-1.0\n-0.1,0.0,-0.8\n")
    code, _, err = run(capsys, "compensate", geometry, targets, "-o", tmp_path / "j.csv")
    assert f"warning: {targets}: columns x_mm, y_mm, z_mm hold only values within ±5: are these metres?" \
        in err
    assert code == 1  # and the targets, 1 mm under the base, are out of reach


def test_duplicate_rows_warn_once(data, capsys, tmp_path):
    dup = mutate(data["meas"], tmp_path / "dup.csv", lambda ls: [*ls, ls[3], ls[5]])
    code, _, err = run(capsys, "identify", NOMINAL, dup, "--model", "classical",
        "--accept-poor-fit", "-o", tmp_path / "c.toml")
    assert code == 0
    assert f"warning: {dup}: 2 duplicate row(s): line 32 repeats line 4; line 33 repeats line 6" in err


def test_unused_column_warns(data, capsys, tmp_path):
    extra = mutate(data["meas"], tmp_path / "extra.csv",
                   lambda ls: [ls[0] + ",operator", *[s + ",bob" for s in ls[1:]]])
    code, _, err = run(capsys, "identify", NOMINAL, extra, "--model", "classical",
        "--accept-poor-fit", "-o", tmp_path / "c.toml")
    assert code == 0
    assert "1 column(s) not used by deltacal and ignored: 'operator'" in err


def test_readings_the_robot_cannot_assemble_name_the_line(capsys, tmp_path, bai):
    # short rods: with every arm straight up the plate would be above the actuators
    robot = tmp_path / "short.toml"
    robot.write_text(NOMINAL.read_text().replace("rod_length_mm = 950.0", "rod_length_mm = 400.0")
                     .split("[workspace]")[0])
    nominal = load_nominal(robot)
    rng = np.random.default_rng(3)
    q = np.radians(rng.uniform(60.0, 80.0, (20, 3)))
    q[12] = np.radians([-90.0, -90.0, -90.0])
    ok = np.arange(20) != 12
    pose = exact.forward(nominal.geometry(), q[ok])
    position = np.zeros((20, 3))
    position[ok] = pose.position
    meas = tmp_path / "meas.csv"
    write_measurements(meas, Measurements(q=q, position=position))
    code, _, err = run(capsys, "identify", robot, meas, "--model", "classical",
        "--accept-poor-fit", "-o", tmp_path / "c.toml")
    assert code == 1
    line = error_line(err)
    assert f"{meas}: line 14 (data row 13), columns q1_deg..q3_deg" in line
    assert "cannot be assembled at the readings q = [-90.0, -90.0, -90.0] deg" in line


def test_gross_error_names_its_line(data, capsys, tmp_path):
    # a reading typed 10 times too large: the fit would spread it over every parameter
    def typo(lines):
        f = lines[11].split(",")
        f[2] = repr(10.0 * float(f[2]))
        lines[11] = ",".join(f)
        return lines

    bad = mutate(data["meas"], tmp_path / "typo.csv", typo)
    code, _, err = run(capsys, "identify", NOMINAL, bad, "-o", tmp_path / "c.toml")
    assert code == 1
    assert f"{bad}: line 12: the measured position is up to" in error_line(err)
    assert "typing error" in error_line(err)


def test_outlier_is_flagged_in_the_report(data, capsys, tmp_path):
    bad = mutate(data["meas"], tmp_path / "outlier.csv",
                 lambda ls: set_field(9, "x_mm", repr(float(ls[8].split(",")[3]) + 0.5))(ls))
    code, out, err = run(capsys, "identify", NOMINAL, bad, "--model", "bai42", "-o", tmp_path / "c.toml")
    assert code == 0
    assert "outliers (data snooping at 4 σ): line 9\n" in out
    assert f"warning: {bad}: line(s) 9 look like outliers" in err
    # the file keeps the line (the io layer knows it) and the 1-based row (the data know it)
    saved = tomllib.loads((tmp_path / "c.toml").read_text())["calibration"]
    assert saved["outlier_lines"] == [9]
    assert saved["outlier_rows"] == [8]


def test_poses_too_alike_say_what_is_lost_and_what_helps(bai, capsys, tmp_path):
    rng = np.random.default_rng(5)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    # forty poses on the vertical axis only
    targets = np.stack([np.zeros(40), np.zeros(40), np.linspace(-750.0, -950.0, 40)], axis=1)
    meas = tmp_path / "axis.csv"
    write_measurements(meas, simulate(bai, truth, targets))
    code, _, err = run(capsys, "identify", NOMINAL, meas, "-o", tmp_path / "c.toml")
    assert code == 1
    line = error_line(err)
    assert "the 40 measurements identify only 34 of the 42 parameters model complete can identify" in line
    # which parameters are named depends on the base chosen; they are the model's and at least the 8 lost
    found = re.search(r"too alike to separate ((?:\w+, )*\w+?)(?: and (\d+) more)?;", line)
    assert found is not None, line
    listed = found.group(1).split(", ")
    assert set(listed) <= set(get_model("complete").names)
    assert len(listed) + int(found.group(2) or 0) >= 42 - 34
    assert "poses on the workspace's rim" in line


def test_position_only_measurements_get_hints(bai, capsys, tmp_path):
    rng = np.random.default_rng(6)
    truth = bai.geometry().perturbed(Tolerances.bai2015(), rng)
    meas = tmp_path / "pos.csv"
    write_measurements(meas, simulate(bai, truth, workspace_points(bai, 30, rng), orientation=False))
    code, out, _ = run(capsys, "identify", NOMINAL, meas, "-o", tmp_path / "c.toml")
    assert code == 0
    assert "hint: orientation measurements (rx_deg, ry_deg, rz_deg) would identify 4 more" in out
    assert "hint: a second point measured on the plate, off the first would identify 3 more" in out


def test_non_converging_identification_raises_with_the_residual(data, bai):
    from deltacal.io import read_measurements

    measurements, _ = read_measurements(data["meas"])
    with pytest.raises(ConvergenceError, match=r"did not converge in 1 Gauss-Newton.*residual RMS") as info:
        identify(bai.geometry(), measurements, "complete", max_iter=1)
    assert info.value.residual > 0.0


# --------------------------------------------------------------------------- bad robot files
ROBOT_ERRORS = [
    ("arm_length_mm = 375.0", "arm_length_mm = -375.0", "key geometry.arm_length_mm", "must be positive"),
    ("arm_length_mm = 375.0", "arm_length_mm = 0", "key geometry.arm_length_mm", "must be positive"),
    ("arm_length_mm = 375.0", 'arm_length_mm = "375"', "key geometry.arm_length_mm", "must be a number"),
    ("arm_length_mm = 375.0", "arm_length_mm = nan", "key geometry.arm_length_mm", "must be finite"),
    ("arm_length_mm = 375.0", "arm_length_mm = 1" + "0" * 400, "key geometry.arm_length_mm",
     "must be finite"),
    ("arm_length_mm = 375.0", "", "key geometry.arm_length_mm", "missing required key"),
    ("arm_length_mm = 375.0", "arm_lenght_mm = 375.0", "key geometry.arm_lenght_mm", "unknown key"),
    ("rod_length_mm = 950.0", "rod_length_mm = 50.0", "key geometry.rod_length_mm", "cannot reach"),
    ("rod_length_mm = 950.0", "rod_length_mm = 90.0", "key geometry.rod_length_mm", "too short"),
    ("tool_mm = [0.0, 0.0, 0.0]", "tool_mm = [0.0, 0.0]", "key geometry.tool_mm", "shape [3]"),
    ("radius_mm = 500.0", "radius_mm = 5000.0", "key workspace", "out of reach"),
    ("top_z_mm = -728.0", "top_z_mm = 728.0", "key workspace.top_z_mm", "below the base"),
    ("[-90.0, 30.0, 150.0]", "[-90.0, 30.0, 270.0]", "key geometry.limb_azimuth_deg", "must differ"),
    ("smr_centre = [0.0, 0.0, -30.0]", "tcp = [0.0, 0.0, -30.0]", "key points.tcp", "reserved"),
    ('name = "bai2015"', "", "key name", "missing required key"),
    ("base_radius_mm = 200.0", "base_radius_mm = 200,0", "not valid TOML", "line 5"),
    # units: masses in grams, a tool in micrometres, azimuths in radians
    ("top_z_mm = -728.0", "top_z_mm = -728.0\n[masses]\narm_kg = 350\nrod_kg = 0.04\nplate_kg = 0.4",
     "key masses.arm_kg", "350 kg is implausible for an arm of 375 mm"),
    ("top_z_mm = -728.0", "top_z_mm = -728.0\n[masses]\narm_kg = 0.35\nrod_kg = 40\nplate_kg = 0.4",
     "key masses.rod_kg", "40 kg is implausible for a rod of 950 mm (heavier than"),
    ("top_z_mm = -728.0", "top_z_mm = -728.0\n[masses]\narm_kg = 0.35\nrod_kg = 0.04\nplate_kg = 400",
     "key masses.plate_kg", "kg of solid steel): grams? deltacal reads kilograms"),
    ("tool_mm = [0.0, 0.0, 0.0]", "tool_mm = [0, 0, 1e6]", "key geometry.tool_mm",
     "[0.0, 0.0, 1000000.0] mm is 1e+06 mm from the plate, implausible for this robot (base radius + arm + "
     "rod = 1525 mm)"),
    ("smr_offset = [60.0, 0.0, -20.0]", "smr_offset = [60000.0, 0.0, -20000.0]", "key points.smr_offset",
     "implausible for this robot"),
    ("[-90.0, 30.0, 150.0]", "[0, 2.09, 4.19]", "key geometry.limb_azimuth_deg",
     "azimuths [0, 2.09, 4.19] put the limbs within 4.19 deg of each other: radians ([0, 119.7, 240.1] deg)? "
     "deltacal reads degrees"),
    ("[-90.0, 30.0, 150.0]", "[-1.5708, 0.5236, 2.618]", "key geometry.limb_azimuth_deg",
     "radians ([-90, 30, 150] deg)?"),
]


@pytest.mark.parametrize(("old", "new", "where", "detail"), ROBOT_ERRORS)
def test_bad_robot_file_names_the_key(data, capsys, tmp_path, old, new, where, detail):
    text = NOMINAL.read_text()
    assert old in text
    robot = tmp_path / "robot.toml"
    robot.write_text(text.replace(old, new))
    code, _, err = run(capsys, "identify", robot, data["meas"], "-o", tmp_path / "c.toml")
    assert code == 1
    line = error_line(err)
    assert line.startswith(f"deltacal identify: error: {robot}: ")
    assert where in line and detail in line, line


def test_swapped_robot_and_calibration_files(data, capsys, tmp_path):
    code, _, err = run(capsys, "identify", data["cal"], data["meas"], "-o", tmp_path / "c.toml")
    assert code == 1
    assert "key format: this is a deltacal 'deltacal-calibration-1' file, not a nominal robot file" in err
    code, _, err = run(capsys, "compensate", NOMINAL, data["targets"], "-o", tmp_path / "j.csv")
    assert code == 1
    assert "key format: this is a nominal robot file, not a geometry or calibration file" in err


# --------------------------------------------------------------------------- bad calibration files
def _in_geometry(key: str, line: str):
    """An edit: the first line starting with ``key`` in the ``[geometry]`` table (limb 1) replaced."""

    def edit(text: str) -> str:
        head, sep, tail = text.partition("\n[geometry]")
        k = tail.index(f"\n{key}") + 1
        return head + sep + tail[:k] + line + tail[tail.index("\n", k):]

    return edit


CALIBRATION_ERRORS = [
    (lambda t: t.replace("[geometry", "[geometri"), "key geometry", "missing required table"),
    (_in_geometry("format", 'format = "deltacal-geometry-0"'), "key geometry.format",
     "expected 'deltacal-geometry-1', got 'deltacal-geometry-0'"),
    (_in_geometry("tool_mm", "tool_mm = [0.0, 0.0, inf]"), "key geometry.tool_mm", "must be finite"),
    (_in_geometry("rod_length_mm", "rod_length_mm = [-1.0, 950.0]"), "key geometry.limb[1].rod_length_mm",
     "must be positive"),
    (_in_geometry("rod_length_mm", "rod_length_mm = [950.0]"), "key geometry.limb[1].rod_length_mm",
     "shape [2]"),
    (_in_geometry("axis_direction", "axis_direction = [0.5, 0.0, 0.0]"),
     "key geometry.limb[1].axis_direction", "unit vector"),
    (_in_geometry("encoder_offset_deg", "encoder_offset_deg = nan"),
     "key geometry.limb[1].encoder_offset_deg", "must be finite"),
    (_in_geometry("encoder_offset_deg", 'encoder_offset_deg = "0.4"'),
     "key geometry.limb[1].encoder_offset_deg", "must be a number, got '0.4'"),
    (_in_geometry("arm_ball_mm", "arm_bal_mm = [[375.0, 50.0, 0.0], [375.0, -50.0, 0.0]]"),
     "key geometry.limb[1].arm_bal_mm", "unknown key"),
    (_in_geometry("plate_ball_mm", "plate_ball_mm = [[50.0, -51.0], [-50.0, -51.0]]"),
     "key geometry.limb[1].plate_ball_mm", "shape [2, 3]"),
]


@pytest.mark.parametrize(("edit", "where", "detail"), CALIBRATION_ERRORS)
def test_bad_calibration_file_names_the_key(data, capsys, tmp_path, edit, where, detail):
    cal = tmp_path / "cal.toml"
    cal.write_text(edit(data["cal"].read_text()))
    out = tmp_path / "joints.csv"
    code, _, err = run(capsys, "compensate", cal, data["targets"], "-o", out)
    assert code == 1
    line = error_line(err)
    assert line.startswith(f"deltacal compensate: error: {cal}: {where}: "), line
    assert detail in line
    assert not out.exists()


def test_linear_method_needs_the_calibration_report(data, capsys, tmp_path):
    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(NOMINAL).geometry(), geometry)
    code, _, err = run(capsys, "compensate", geometry, data["targets"], "--method", "savoure", "-o",
                       tmp_path / "j.csv")
    assert code == 1
    assert "key format: not a calibration file (format 'deltacal-geometry-1')" in error_line(err)


# --------------------------------------------------------------------------- bad targets
def test_unreachable_and_singular_targets_name_their_lines(capsys, tmp_path):
    geometry = tmp_path / "g.toml"
    save_geometry(load_nominal(NOMINAL).geometry(), geometry)  # a calibration of the perfect robot
    targets = tmp_path / "targets.csv"
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-900\n\n100,0,-1000\n0,0,-200\n0,0,-100\n")
    out = tmp_path / "joints.csv"
    code, _, err = run(capsys, "compensate", geometry, targets, "-o", out)
    assert code == 1
    assert error_line(err) == (
        # line 5 of the file is its third data row (the blank line 3 is not a row)
        f"deltacal compensate: error: {targets}: line 5 (data row 3), columns x_mm..z_mm: "
        "target [0.0, 0.0, -200.0] "
        "mm is out of reach of the robot; 2 targets in all, lines 5, 6"
    )
    # 0.5 mm inside the reach of the arms and rods all but stretched: a serial singularity
    targets.write_text("x_mm,y_mm,z_mm\n0,0,-900\n0,0,-1316.5\n")
    code, _, err = run(capsys, "compensate", geometry, targets, "-o", out)
    assert code == 1
    assert error_line(err).endswith(
        "line 3 (data row 2), columns x_mm..z_mm: target [0.0, 0.0, -1316.5] mm is too close to a singularity"
    )
    assert not out.exists()


def test_bad_target_value(data, capsys, tmp_path):
    targets = mutate(data["targets"], tmp_path / "t.csv", set_field(4, "y_mm", "12.5.3"))
    code, _, err = run(capsys, "compensate", data["cal"], targets, "-o", tmp_path / "j.csv")
    assert code == 1
    assert error_line(err) == (f"deltacal compensate: error: {targets}: line 4 (data row 3), column y_mm: "
                               "value '12.5.3' is not a number: only plain decimal numbers with ASCII "
                               "digits, '.' as decimal point and an optional exponent: -12.5, 1e-3")


# --------------------------------------------------------------------------- usage errors
def test_usage_errors_exit_2(data, capsys, tmp_path):
    cal = tmp_path / "c.toml"
    cases = [
        (["identify", NOMINAL, data["meas"]], "the following arguments are required: -o/--output"),
        (["identify", NOMINAL, data["meas"], "--model", "nope", "-o", cal], "invalid choice: 'nope'"),
        (["identify", NOMINAL, data["meas"], "--sigma-position", "-1", "-o", cal], "must be a positive"),
        (["identify", NOMINAL, tmp_path / "missing.csv", "-o", cal], "missing.csv: file not found"),
        (["identify", NOMINAL, tmp_path, "-o", cal], "not a file"),
        (["identify", NOMINAL, data["meas"], "-o", tmp_path / "no" / "c.toml"],
         "output folder does not exist"),
        (["identify", NOMINAL, data["meas"], "-o", tmp_path], "is a folder"),
        (["identify", NOMINAL, data["meas"], "-o", data["meas"]], "would overwrite an input file"),
        (["compensate", data["cal"], data["targets"], "-o", data["cal"]], "would overwrite an input file"),
        (["compensate", data["cal"], data["targets"], "--method", "magic", "-o", cal], "invalid choice"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        ([], "required"),
    ]
    before = data["meas"].read_bytes(), data["cal"].read_bytes()
    for argv, piece in cases:
        code, out, err = run(capsys, *argv)
        assert code == 2, (argv, err)
        assert len(err.strip().splitlines()) == 1, err
        assert piece in err, err
    assert (data["meas"].read_bytes(), data["cal"].read_bytes()) == before
    assert not cal.exists()


def test_help_and_version_exit_0(capsys):
    assert run(capsys, "--version")[0] == 0
    assert run(capsys, "compensate", "--help")[0] == 0


def test_debug_shows_the_traceback(data, tmp_path):
    bad = mutate(data["meas"], tmp_path / "bad.csv", set_field(3, "q1_deg", "abc"))
    with pytest.raises(InputError, match=r"line 3 \(data row 2\), column q1_deg"):
        main(["--debug", "identify", str(NOMINAL), str(bad), "-o", str(tmp_path / "c.toml")])


# --------------------------------------------------------------------------- atomic outputs
def test_failing_commands_leave_earlier_outputs_alone(data, capsys, tmp_path):
    cal = tmp_path / "cal.toml"
    joints = tmp_path / "joints.csv"
    cal.write_text("earlier calibration\n")
    joints.write_text("earlier joints\n")
    bad_meas = mutate(data["meas"], tmp_path / "bad.csv", set_field(7, "z_mm", "oops"))
    bad_targets = tmp_path / "far.csv"
    bad_targets.write_text("x_mm,y_mm,z_mm\n0,0,-900\n5000,0,-900\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    assert run(capsys, "identify", NOMINAL, bad_meas, "-o", cal)[0] == 1
    assert run(capsys, "identify", NOMINAL, mutate(data["meas"], tmp_path / "few.csv", lambda s: s[:3]),
               "-o", cal)[0] == 1
    assert run(capsys, "compensate", data["cal"], bad_targets, "-o", joints)[0] == 1
    assert run(capsys, "compensate", cal, data["targets"], "-o", joints)[0] == 1  # cal is not TOML
    assert cal.read_text() == "earlier calibration\n"
    assert joints.read_text() == "earlier joints\n"
    # no temporary file left behind
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*before, "few.csv"])


def test_a_write_that_fails_midway_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "out.csv"
    target.write_text("old\n")
    os.chmod(target, 0o640)

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("deltacal.io.atomic.os.replace", broken_replace)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_text(target, "new\n")
    assert target.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]
    monkeypatch.undo()
    atomic_write_text(target, "new\n")
    assert target.read_text() == "new\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640  # the replaced file's permissions are kept


def test_a_failing_save_during_identify_keeps_the_old_calibration(data, capsys, tmp_path, monkeypatch):
    cal = tmp_path / "cal.toml"
    cal.write_text("earlier\n")

    def full_disk(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("deltacal.io.atomic.os.fsync", full_disk)
    code, _, err = run(capsys, "identify", NOMINAL, data["meas"], "--model", "classical",
        "--accept-poor-fit", "-o", cal)
    assert code == 1
    assert "No space left on device" in error_line(err)
    assert cal.read_text() == "earlier\n"
    assert [p.name for p in tmp_path.iterdir()] == ["cal.toml"]
