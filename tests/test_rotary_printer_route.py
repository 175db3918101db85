"""A rotary Delta printer through the command line: ``import`` of Klipper's rotary configuration, ``identify``
of its probe heights and printed distances (``--controller``), ``compensate`` through Klipper's rotary model.

The truth: Klipper's example rotary printer (imported, in the bed frame) with a rotary printer kit's errors,
the arms' gear ratios too, measured as Klipper measures (:mod:`deltacal.printer.rotary_simulation`) at the
probe points and the object's pairs that ``tests/test_rotary_printer_identification.py`` plans.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from deltacal.calibration import Calibration
from deltacal.cli import main
from deltacal.controller import corrected_targets, weighted_targets
from deltacal.geometry import Tolerances, Workspace
from deltacal.io import load_calibration
from deltacal.io.robot import load_nominal
from deltacal.printer.files.measurements import write_printed_distances, write_probe_heights
from deltacal.printer.firmware import firmware_named
from deltacal.printer.firmware.config_file import RotaryFirmwareConfig
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import klipper_rotary_extended
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.identification.errormodels import RotaryPrinterModel
from deltacal.printer.identification.fit import PrinterFitOptions, PrinterMeasurements, identify_printer
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.rotary_owner import arm_errors, rotary_owner_lines
from deltacal.printer.rotary_simulation import RotaryPrinter, nozzle_errors, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE
from tests.test_klipper_rotary_compensate import MEASURED
from tests.test_rotary_printer_identification import VOLUME, _plan


@pytest.fixture(scope="module")
def route(tmp_path_factory):
    """The example imported, a true printer measured, the files written and identified through the CLI."""
    return identified_route(tmp_path_factory.mktemp("rotary-route"))


def identified_route(folder: Path) -> dict:
    """:func:`route` in ``folder`` (tests/test_klipper_rotary_live.py runs its calibration live too)."""
    assert main(["import", str(EXAMPLE), "-o", str(folder / "imp"), *MEASURED]) == 0
    robot = folder / "imp" / "printer.toml"
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    controller = KlipperRotaryController(k)
    nominal = controller.in_bed_frame(load_nominal(robot).geometry())
    tolerances = Tolerances.rotary_printer_kit()
    rng = np.random.default_rng(4801)
    truth = nominal.perturbed(tolerances, rng)
    printer = RotaryPrinter(replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3)), k)
    xy, pairs = _plan(k, nominal, tolerances)
    probe = probe_triggers(printer, k, xy)
    probe[:, 2] += rng.normal(0.0, 0.01, len(probe))
    distances = np.round(printed_distances(printer, k, pairs) + rng.normal(0.0, 0.02, len(pairs)), 3)
    write_probe_heights(folder / "probe.csv", probe[:, :2], probe[:, 2])
    write_printed_distances(folder / "distances.csv", pairs, distances)
    cal = folder / "cal.toml"
    code = main(["identify", str(robot), str(folder / "probe.csv"), str(folder / "distances.csv"),
                 "--controller", str(EXAMPLE), "-o", str(cal)])
    assert code == 0
    return {"folder": folder, "robot": robot, "k": k, "controller": controller, "nominal": nominal,
            "printer": printer, "probe": probe, "pairs": pairs, "distances": distances, "cal": cal}


@pytest.mark.slow
def test_identify_through_the_cli_is_the_library_fit(route):
    """The calibration the CLI writes (in the robot file's {O}) is the library's fit of the same data in
    Klipper's frame moved down by the bed's height, where it holds kept: put back in Klipper's frame, its
    whole correction's commands equal the library's within 1e-5 mm and its σ grid the library's to the
    file's 5 significant digits. (The readings agree to 1e-15 rad; the evidence's golden-section search
    over the tolerances' scale, on a flat maximum, ends in its last bracket by comparisons that rounding
    may turn: the two fits' balls differ by up to 4e-7 mm, their commands by 2e-6 mm.)"""
    k, controller, printer = route["k"], route["controller"], route["printer"]
    probe, pairs = route["probe"], route["pairs"]
    data = PrinterMeasurements(printer.readings(k, probe), np.stack(
        [printer.readings(k, pairs[:, :3]), printer.readings(k, pairs[:, 3:])], axis=1), route["distances"])
    ours = load_calibration(route["cal"])
    assert ours.model.name == "rotary_printer" and ours.holds is not None
    robot = load_nominal(route["robot"])
    lift = controller.bed_height(robot.geometry())
    assert robot.workspace is not None
    ws = robot.workspace  # the robot file's printable cylinder, in Klipper's frame
    options = PrinterFitOptions(tolerances=Tolerances.rotary_printer_kit(),
                                workspace=Workspace(ws.radius, ws.height, ws.top_z + lift),
                                reach=controller.reach_radius)
    library = identify_printer(route["nominal"], data, RotaryPrinterModel(), options=options)
    theirs = Calibration.from_result(library)
    expected = corrected_targets(theirs, controller, VOLUME, bound=math.inf).commands
    klipper = firmware_named("klipper")
    assert klipper is not None
    moved, _ = RotaryFirmwareConfig(klipper, controller, str(EXAMPLE)).anchor(ours, "cal")
    got = corrected_targets(moved, controller, VOLUME, bound=math.inf).commands
    assert np.max(np.abs(got - expected)) < 1e-5
    assert moved.holds is not None and theirs.holds is not None
    np.testing.assert_allclose(moved.holds.radius, theirs.holds.radius, rtol=1e-12)
    np.testing.assert_allclose(moved.holds.vertical, theirs.holds.vertical, rtol=1e-4)
    np.testing.assert_allclose(moved.holds.horizontal, theirs.holds.horizontal, rtol=1e-4)


@pytest.mark.long
@pytest.mark.slow
def test_compensate_through_the_cli_beats_klippers_extended_calibration(route, tmp_path, capsys):
    """``compensate CAL targets.csv --controller rotary.cfg``: the true nozzle at the commands, less the
    motion along the bed no measurement sees, within a third of Klipper's extended calibration's 3-D max on
    the same data; the part not moved along the bed (the commands' mean shift over the first layer)."""
    k, printer = route["k"], route["printer"]
    np.savetxt(tmp_path / "t.csv", VOLUME, delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    assert main(["compensate", str(route["cal"]), str(tmp_path / "t.csv"), "--controller", str(EXAMPLE),
                 "-o", str(tmp_path / "out.csv")]) == 0
    capsys.readouterr()
    out = np.genfromtxt(tmp_path / "out.csv", delimiter=",", names=True)
    commands = np.column_stack([out["x_cmd_mm"], out["y_cmd_mm"], out["z_cmd_mm"]])
    ours = printer.nozzle(k, commands) - VOLUME
    extended = nozzle_errors(printer, klipper_rotary_extended(k, route["probe"], route["pairs"],
                                                              route["distances"]), VOLUME)
    less = [float(np.max(np.linalg.norm(less_bed_motion(VOLUME, e)[0], axis=1))) for e in (ours, extended)]
    assert less[0] <= less[1] / 3.0, less
    first = np.isclose(VOLUME[:, 2], VOLUME[:, 2].min())
    assert np.linalg.norm(np.mean(commands[first, :2] - VOLUME[first, :2], axis=0)) < 0.05


def test_a_linear_printer_cfg_for_a_rotary_robot_file_is_refused(tmp_path, capsys):
    """One line naming the configuration (as plan and simulate say it), nothing written."""
    assert main(["import", str(EXAMPLE), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    write_probe_heights(tmp_path / "probe.csv", np.zeros((7, 2)), np.zeros(7))
    linear = EXAMPLE.parents[1] / "example-delta.cfg"
    capsys.readouterr()
    assert main(["identify", str(tmp_path / "imp" / "printer.toml"), str(tmp_path / "probe.csv"),
                 "--controller", str(linear), "-o", str(tmp_path / "cal.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "example-delta.cfg" in err and "rotary" in err, err
    assert not (tmp_path / "cal.toml").exists()


def test_another_rotary_printers_configuration_is_refused(tmp_path, capsys):
    """The example's configuration with its upper arms 200 mm (170 in the imported robot file): another
    printer, refused naming the key, the arm and both files, by identify, plan and simulate; nothing
    written."""
    assert main(["import", str(EXAMPLE), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    other = tmp_path / "other.cfg"
    other.write_text(EXAMPLE.read_text().replace("upper_arm_length: 170.000", "upper_arm_length: 200.000"))
    assert other.read_text() != EXAMPLE.read_text()
    write_probe_heights(tmp_path / "probe.csv", np.zeros((7, 2)), np.zeros(7))
    robot = str(tmp_path / "imp" / "printer.toml")
    capsys.readouterr()
    for args in (["identify", robot, str(tmp_path / "probe.csv"), "--controller", str(other), "-o",
                  str(tmp_path / "cal.toml")],
                 ["plan", robot, "--object", "--controller", str(other), "-o", str(tmp_path / "obj")]):
        assert main(args) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1, err
        assert "upper_arm_length (arm A) is 170 mm" in err and "200 mm in" in err and "other.cfg" in err, err
    assert not (tmp_path / "cal.toml").exists() and not (tmp_path / "obj").exists()


@pytest.mark.slow
def test_the_owners_words_name_each_arm_and_find_the_true_gear_ratios(route):
    """Arm by arm in Klipper's keys; each arm's gear ratio error, where determined, within 3 σ of the truth's
    (the arms' step scales the simulated printer was given); the arms' endstops within 3 σ of the truth's
    encoder offsets."""
    calibration = load_calibration(route["cal"])
    lines = rotary_owner_lines(calibration)
    for arm in "ABC":
        key = f"[stepper_{arm.lower()}] position_endstop"
        assert any(line.startswith(f"  arm {arm}: endstop") and key in line for line in lines), lines
    truth, nominal = route["printer"].geometry, route["nominal"]
    found = arm_errors(calibration)
    for i, arm in enumerate(found):
        ratio, _ = arm["gear ratio"]
        assert ratio.determined
        assert abs(ratio.value - 100.0 * (truth.joint_scale[i] - 1.0)) <= 3.0 * ratio.sigma, (i, ratio)
        endstop, _ = arm["endstop"]
        offset = math.degrees(truth.encoder_offset[i] - nominal.encoder_offset[i])
        assert endstop.determined and abs(endstop.value - offset) <= 3.0 * endstop.sigma, (i, endstop, offset)


@pytest.mark.slow
def test_the_report_speaks_of_arms_and_shoulders(route, tmp_path):
    """``report CAL`` of a rotary printer's calibration: the owner's part, arm by arm in Klipper's keys, and
    where it holds, before the engineer's part."""
    page = tmp_path / "r.html"
    assert main(["report", str(route["cal"]), "-o", str(page), "--no-view"]) == 0
    text = page.read_text()
    first = text.index("arm A: endstop")
    assert "[stepper_a] position_endstop" in text and "[stepper_c] gear_ratio" in text
    assert "where it holds" in text[first:] and first < text.index("base parameters")


@pytest.mark.slow
def test_beyond_the_measured_bed_the_rim_is_not_corrected(route):
    """Klipper moves the example's nozzle out to r = 203.9 mm, the measurements cover r <= 64: where it holds
    goes out to Klipper's reach, its σ growing with the distance from what was measured, so that the rim
    gets Klipper's own commands (before, the printable radius's edge σ was taken out there: weight 1, and
    corrections of up to 0.8 mm extrapolated at r 190)."""
    calibration = load_calibration(route["cal"])
    controller = route["controller"]
    assert calibration.holds is not None
    assert calibration.holds.radius[-1] == pytest.approx(controller.reach_radius)
    klipper = firmware_named("klipper")
    assert klipper is not None
    moved, _ = RotaryFirmwareConfig(klipper, controller, str(EXAMPLE)).anchor(calibration, "cal")
    rim = np.array([[r * math.cos(a), r * math.sin(a), 0.2] for r in (180.0, 195.0) for a in (0.3, 2.4, 4.5)])
    sent = weighted_targets(moved, controller, rim)
    assert np.all(sent.weights == 0.0) and np.max(np.abs(sent.commands - rim)) == 0.0
    centre = weighted_targets(moved, controller, np.array([[0.0, 0.0, 0.2]]))
    assert np.all(centre.weights[0] > 0.5)  # the measured bed corrected


@pytest.mark.slow
def test_the_calibration_records_its_configuration_and_measurements(route, tmp_path, capsys):
    """identify records Klipper's rotary values (``[controller]``) and its measurements (``[measured]``: the
    arms' readings, as a linear printer's, to be re-anchored); through a copy of the configuration whose
    values are the same (a comment added: another digest) compensate writes the very bytes it writes
    through the configuration identified with, said nothing of values changed. (Before, no ``[measured]``.)"""
    calibration = load_calibration(route["cal"])
    assert calibration.controller is not None and calibration.controller.firmware == "klipper"
    assert calibration.controller.values["stepper_a.upper_arm_length"] == 170.0
    record = calibration.measured
    assert record is not None and record.probe.shape == (49, 3) and record.pairs.shape == (40, 2, 3)
    measured = tomllib.loads(Path(route["cal"]).read_text())["measured"]  # the arms' angles in degrees
    assert "probe_readings_mm" not in measured and "pair_readings_mm" not in measured
    assert np.allclose(np.radians(measured["probe_readings_deg"]), record.probe, rtol=0.0, atol=1e-12)
    targets = tmp_path / "t.csv"
    np.savetxt(targets, VOLUME[:5], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    same = tmp_path / "same.cfg"
    same.write_text("# the same values\n" + EXAMPLE.read_text())
    for cfg, out in ((EXAMPLE, "a.csv"), (same, "b.csv")):
        assert main(["compensate", str(route["cal"]), str(targets), "--controller", str(cfg), "-o",
                     str(tmp_path / out)]) == 0
    assert "values changed" not in capsys.readouterr().out
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


@pytest.mark.slow
def test_a_changed_endstop_is_re_anchored(route, tmp_path, capsys):
    """Through a copy with arm A's endstop 0.5 mm up, compensate exits 0 and says in one line the key changed
    and that the calibration was re-anchored (before: refused, exit 1, "not re-anchored"); the printer did
    not change, so the true nozzle at the new commands (Klipper running the copy's values) is where it was
    at the commands through the values identified with: on the first layer its height within 0.001 mm (the
    probe heights determine it), in 3-D within 0.02 mm less a shift along the bed no measurement sees
    (measured 0.0018 mm, 0.015 with the correction along the bed weighted by its significance too: what the
    measurements leave follows the prior's centre, now the new values' printer; the arms' readings not
    counted again from the new endstop angles, 0.5 mm)."""
    targets = tmp_path / "t.csv"
    np.savetxt(targets, VOLUME[::40], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    moved = tmp_path / "moved.cfg"
    text = EXAMPLE.read_text()
    moved.write_text(text.replace("position_endstop: 252", "position_endstop: 252.5", 1))
    assert moved.read_text() != text
    capsys.readouterr()
    commands = {}
    for cfg, out in ((EXAMPLE, "same.csv"), (moved, "out.csv")):
        assert main(["compensate", str(route["cal"]), str(targets), "--controller", str(cfg), "-o",
                     str(tmp_path / out)]) == 0
        table = np.genfromtxt(tmp_path / out, delimiter=",", names=True)
        commands[cfg] = np.column_stack([table["x_cmd_mm"], table["y_cmd_mm"], table["z_cmd_mm"]])
    out, err = capsys.readouterr()
    lines = [line for line in out.splitlines() if "values changed" in line]
    assert len(lines) == 1 and "stepper_a.position_endstop 252 -> 252.5" in lines[0], out
    assert "re-anchored" in lines[0] and "measure it again" in lines[0] and err == "", (out, err)
    k, printer = route["k"], route["printer"]
    k2 = rotary_from_config(read_klipper_config(moved))
    before = printer.nozzle(k, commands[EXAMPLE])
    after = printer.nozzle(k2, commands[moved])
    assert np.max(np.abs(commands[moved] - commands[EXAMPLE])) > 0.1  # the commands follow the new values
    first = np.isclose(VOLUME[::40, 2], VOLUME[:, 2].min())
    assert first.sum() >= 3 and np.max(np.abs(after[first, 2] - before[first, 2])) < 0.001
    assert np.max(np.linalg.norm(less_bed_motion(VOLUME[::40], after - before)[0], axis=1)) < 0.02


@pytest.mark.slow
def test_another_printers_values_are_refused(route, tmp_path, capsys):
    """upper_arm_length 10 % longer than the values the calibration recorded (another printer, beyond a
    build's 5 %): compensate refuses in one line naming the key, the arm and both values, nothing
    written."""
    other = tmp_path / "other.cfg"
    other.write_text(EXAMPLE.read_text().replace("upper_arm_length: 170.000", "upper_arm_length: 187.000"))
    targets = tmp_path / "t.csv"
    np.savetxt(targets, VOLUME[:5], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    capsys.readouterr()
    assert main(["compensate", str(route["cal"]), str(targets), "--controller", str(other), "-o",
                 str(tmp_path / "out.csv")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "upper_arm_length (arm A) is 170 mm" in err and "187 mm in" in err and "other.cfg" in err, err
    assert "recorded controller" in err and not (tmp_path / "out.csv").exists()


@pytest.fixture(scope="module")
def recalibrated(route):
    """Klipper's extended DELTA_CALIBRATE run again on the same printer (fresh probing and print, the
    example's values probing), the calibration re-anchored to its values."""
    k, printer, pairs = route["k"], route["printer"], route["pairs"]
    rng = np.random.default_rng(4802)
    probe = probe_triggers(printer, k, route["probe"][:, :2])
    probe[:, 2] += rng.normal(0.0, 0.01, len(probe))
    distances = printed_distances(printer, k, pairs) + rng.normal(0.0, 0.02, len(pairs))
    k2 = klipper_rotary_extended(k, probe, pairs, distances)
    klipper = firmware_named("klipper")
    assert klipper is not None
    calibration = load_calibration(route["cal"])
    anchored, said = RotaryFirmwareConfig(klipper, KlipperRotaryController(k2), "recalibrated.cfg").anchor(
        calibration, "cal.toml")
    same, _ = RotaryFirmwareConfig(klipper, route["controller"], str(EXAMPLE)).anchor(calibration, "cal.toml")
    return {"k2": k2, "anchored": anchored, "said": said, "same": same}


def _layers(printer, config, commands):
    """3-D error less the motion along the bed, its max per layer of VOLUME [mm]."""
    less = less_bed_motion(VOLUME, printer.nozzle(config, commands) - VOLUME)[0]
    z = VOLUME[:, 2]
    return np.array([np.linalg.norm(less[z == h], axis=1).max() for h in np.unique(z)])


@pytest.mark.slow
def test_through_recalibrated_values_never_worse_than_their_own(route, recalibrated):
    """The issue's bound on a rotary printer: calibrated through the example's values, compensated through
    the values Klipper's extended calibration gives the same printer afterwards (shoulder height and radius,
    the endstops, angles A and B changed), re-anchored: at every layer of r <= 50, z 0.2..100 mm, the
    3-D max less the motion along the bed never worse than those values' own + 0.005 mm, and within
    0.01 mm of the calibration through the values it was identified with. Measured, layers z 0.2, 25, 50,
    75, 100 mm: re-anchored 0.029, 0.010, 0.023, 0.030, 0.031 mm; the re-calibrated values' own 0.163,
    0.099, 0.119, 0.187, 0.263; through the example's values as identified 0.019, 0.009, 0.022, 0.035,
    0.045. (Before: refused.)"""
    printer, k2 = route["printer"], recalibrated["k2"]
    said = recalibrated["said"]
    assert len(said) == 2 and "re-anchored" in said[0] and "printer.shoulder_height 412.9 ->" in said[0], said
    ours = _layers(printer, k2, corrected_targets(recalibrated["anchored"], KlipperRotaryController(k2),
                                                  VOLUME).commands)
    own = _layers(printer, k2, VOLUME)
    recorded = _layers(printer, route["k"], corrected_targets(recalibrated["same"], route["controller"],
                                                              VOLUME).commands)
    assert np.all(ours <= own + 0.005), (ours, own)
    assert ours.max() <= recorded.max() + 0.01, (ours, recorded)


def _exported_error(printer, config, out):
    """3-D max over VOLUME less the motion along the bed [mm] of the true printer run by Klipper with the
    values of ``out`` pasted over ``config``."""
    pasted = out.with_suffix(".pasted.cfg")
    pasted.write_text(config.read_text() + "\n" + out.read_text())
    k = rotary_from_config(read_klipper_config(pasted))
    less = less_bed_motion(VOLUME, nozzle_errors(printer, k, VOLUME))[0]
    return float(np.max(np.linalg.norm(less, axis=1)))


@pytest.mark.slow
def test_plain_export_through_changed_values_is_re_anchored(route, tmp_path, capsys):
    """``export CAL --controller klipper --config moved.cfg`` (the endstops 0.5 mm up since the calibration
    was identified: stepper_a's, which B and C take): exit 0, one line naming the key changed and that it
    was re-anchored, and the values written serve the same printer: run by Klipper on it, within 0.01 mm
    of those exported through the configuration identified with (3-D max over r <= 50, z 0.2..100 mm less
    the motion along the bed, measured: 0.1024 against 0.1022 mm). Before, the calibration's readings
    were taken as counted from moved.cfg's endstop angles and the values written left 1.946 mm (moved.cfg's
    own 2.854). Through the configuration identified with: the bytes the export writes of the calibration
    as it is (its Klipper values fitted straight, as before)."""
    klipper = firmware_named("klipper")
    assert klipper is not None
    moved = tmp_path / "moved.cfg"
    text = EXAMPLE.read_text()
    moved.write_text(text.replace("position_endstop: 252", "position_endstop: 252.5", 1))
    assert moved.read_text() != text
    cal = str(route["cal"])
    capsys.readouterr()
    for cfg, out in ((EXAMPLE, "same.cfg"), (moved, "out.cfg")):
        assert main(["export", cal, "--controller", "klipper", "--config", str(cfg), "-o",
                     str(tmp_path / out)]) == 0
    said, err = capsys.readouterr()
    lines = [line for line in said.splitlines() if "values changed" in line]
    assert len(lines) == 1 and "stepper_a.position_endstop 252 -> 252.5" in lines[0] and err == "", said
    assert "re-anchored" in lines[0] and lines[0].startswith(f"{moved}: "), lines
    values = klipper.rotary_export(EXAMPLE, load_calibration(cal), cal)
    assert values is not None
    values.save(tmp_path / "before.cfg")
    assert (tmp_path / "same.cfg").read_bytes() == (tmp_path / "before.cfg").read_bytes()
    printer = route["printer"]
    same = _exported_error(printer, EXAMPLE, tmp_path / "same.cfg")
    ours = _exported_error(printer, moved, tmp_path / "out.cfg")
    assert abs(ours - same) <= 0.01, (ours, same)
