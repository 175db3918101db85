"""Programs as Klipper reads them: its macros, G91 and E, arcs' P, and the first move after a homing.

The configuration is Klipper's own example delta with its sample START_PRINT and END_PRINT
(tests/data/klipper/printer.cfg, GPLv3 like Klipper); the programs are excerpts of the shape real
slicers write (OrcaSlicer's spiral lift, ideaMaker's start).
"""

from __future__ import annotations

import math
import re
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS
from numpy.testing import assert_allclose

from deltacal import InputError
from deltacal.cli.main import main
from deltacal.controller import corrected_targets
from deltacal.exceptions import UnreachableError
from deltacal.gcode import filter_lines
from deltacal.gcode.dialect import GENERIC, ArcP
from deltacal.gcode.homing import HOME_BLEND_MM, HOME_ZONE_MM
from deltacal.gcode.marker import MARKER
from deltacal.printer.files.measurements import write_probe_heights
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.calibrate import probe_points
from deltacal.printer.firmware.klipper.config import load_klipper
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.simulation import nozzle_positions, probe_heights, random_printer, typical_kit

CONFIG = Path(__file__).parent / "data" / "klipper" / "printer.cfg"
XYZ = re.compile(r"^G1 X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})", re.MULTILINE)


def shifted(points: np.ndarray) -> np.ndarray:
    """A correction standing for a controller's: a fixed shift [mm]."""
    return points + np.array([0.1, -0.2, 0.05])


def run(lines: list[str], correct=shifted, **kwargs) -> str:
    return "".join(filter_lines([line + "\n" for line in lines], correct, **kwargs))


def sent(out: str) -> np.ndarray:
    return np.array(XYZ.findall(out), dtype=float).reshape(-1, 3)


@pytest.fixture(scope="module")
def klipper():
    return KLIPPER.dialect(CONFIG)


def test_klipper_dialect_of_a_configuration(klipper):
    assert klipper.g91_moves_e and klipper.arc_p is ArcP.IGNORED
    assert_allclose(klipper.home, KLIPPER.read_config(CONFIG).positions(np.zeros((1, 3)))[0])
    assert klipper.home[2] > 290.0  # position_endstop 297.05: the nozzle at the top
    assert not GENERIC.g91_moves_e and GENERIC.arc_p is ArcP.REFUSED and not GENERIC.macros
    macros = {name for name, m in klipper.macros.items() if not m.builtin}  # not BED_MESH_CALIBRATE ...
    assert macros == {"START_PRINT", "END_PRINT", "PRINT_START", "PURGE", "START_PURGED", "PARK",
                                   "HEAT_ONLY"}
    assert not klipper.macros["HEAT_ONLY"].moves  # heating under a condition leaves the position
    assert "G28 under a Jinja condition" in klipper.macros["PRINT_START"].unknown
    assert not klipper.macros["START_PURGED"].unknown  # nested PURGE, called in lower case


def test_a_start_macro_leaves_the_nozzle_where_its_moves_end(klipper):
    program = ["START_PRINT EXTRUDER_TEMP=220 BED_TEMP=60", "G1 X30 Y40 F3000", "G1 X31 Y40 E0.5"]
    with pytest.raises(InputError, match=r"line 2: move before X, Y and Z are all known \(Z unknown at the "):
        run(program)  # a generic controller knows no macro
    out = run(program, dialect=klipper)
    home = np.array(klipper.home)
    start = np.array([home[0], home[1], 0.15])  # G28, G1 Z5, G1 Z0.15: the sample's moves
    n = math.ceil(math.dist(start, (30.0, 40.0, 0.15)) / 5.0)
    points = sent(out)
    assert len(points) == n + 1
    path = start + np.outer(np.arange(1, n + 1) / n, [30.0, 40.0, 0.15] - start)
    assert_allclose(points[:n], shifted(path), atol=1e-4)
    assert out.splitlines()[0] == program[0]  # the macro's line kept as it is


def test_a_macro_whose_end_is_unknown_is_named_with_start(klipper):
    program = ["PRINT_START Z=5", "G1 X10 Y10 F3000"]
    with pytest.raises(InputError, match=r"line 2: .*Z unknown since the macro PRINT_START \(G28 under a "
                                         r"Jinja condition\) on line 1.*\(--start X,Y,Z\)"):
        run(program, dialect=klipper)
    out = run(program, dialect=klipper, start=(0.0, 0.0, 5.0))
    assert_allclose(sent(out)[-1], shifted(np.array([[10.0, 10.0, 5.0]]))[0], atol=1e-4)


def test_a_programs_own_probing_command_leaves_the_position_unknown(klipper):
    # Cura's start G-code for a Klipper printer: home, a bed mesh (the nozzle ends over its last
    # probe point), then a lift that gives Z alone: its start is not the home
    program = ["G28", "BED_MESH_CALIBRATE", "G1 Z15.0 F4800", "G1 X0 Y0 Z0.3"]
    with pytest.raises(InputError, match=r"line 3: move before X, Y and Z are all known \(X, Y unknown since "
                                         r"BED_MESH_CALIBRATE \(it leaves the nozzle where only the printer"):
        run(program, dialect=klipper)
    out = run(["G28", "bed_mesh_calibrate PROFILE=x", "G1 X0 Y0 Z15.0 F4800", "G1 Z5"], dialect=klipper)
    assert len(sent(out)) == 1 + 2  # straight to its end, then cut from there
    assert out.splitlines()[1] == "bed_mesh_calibrate PROFILE=x"
    # Klipper's own command, not a macro; PAUSE / RESUME go back where they were
    assert not klipper.macros["PROBE"].steps and klipper.macros["PROBE"].builtin
    out = run(["G28", "G1 X0 Y0 Z5", "PAUSE", "RESUME", "G1 Z1"], dialect=klipper)
    assert_allclose(sent(out)[-1], shifted(np.array([[0.0, 0.0, 1.0]]))[0], atol=1e-4)
    with pytest.raises(InputError, match="line 3: move before X, Y and Z"):
        run(["G1 X0 Y0 Z1", "BED_MESH_CALIBRATE", "G1 Z5"], dialect=klipper)
    assert len(sent(run(["G1 X0 Y0 Z1", "BED_MESH_CALIBRATE", "G1 Z5"]))) == 2  # generic: a mere command


def test_nested_macros_modes_and_saved_states(klipper):
    # START_PURGED: G28, PURGE (G92 E0, moves, G92 E0), M83: E is relative after it, the nozzle at X60 Y-60
    out = run(["START_PURGED", "G1 X60 Y60 E10 F1200"], dialect=klipper)
    e = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", out)]
    assert len(e) == math.ceil(120.0 / 5.0) and sum(e) == Decimal("10")  # relative shares
    # PARK: G91 lift inside SAVE/RESTORE_GCODE_STATE: G90 again after it, the nozzle 20 mm higher
    with pytest.raises(InputError, match=r"relative move \(G91\) right after the macro PARK on line 3"):
        run(["G90", "G1 X0 Y0 Z10", "PARK", "G91", "G1 X1"], dialect=klipper)
    out = run(["G90", "G1 X0 Y0 Z10", "PARK", "G1 X0 Y0 Z0"], dialect=klipper)
    assert len(sent(out)) == 1 + math.ceil(30.0 / 5.0)  # from Z30 down to Z0


def test_g91_makes_e_relative_in_klipper():
    # ideaMaker: absolute E (M82), then G91 for a lift and a retraction, without M83
    program = ["G90", "M82", "G92 E0", "G1 X0 Y0 Z10 F3000", "G91", "G1 X12 E2.4 F1200", "G90"]
    with pytest.raises(InputError, match="line 6: E is split here, but its mode is ambiguous"):
        run(program)
    out = run(program, dialect=KLIPPER.dialect(CONFIG))
    e = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", out)]
    assert len(e) == 3 and sum(e) == Decimal("2.4")  # shares of an increment, as Klipper reads G91's E


def test_orca_spiral_lift_is_klippers_full_turn(klipper):
    # OrcaSlicer / Bambu Studio's spiral z-hop: a G3 from the current point to itself, P1
    program = ["G90", "M83", "G1 X10 Y20 Z0.6 F3000", "G17", "G3 Z.8 I.044 J-1.216 P1  F30000",
               "G1 X12 Y22 Z.8", "G1 Z.6"]
    with pytest.raises(InputError, match="line 5: word P1 on an arc line is not supported"):
        run(program)
    out = run(program, dialect=klipper, correct=lambda p: p.copy())
    arc = sent(out)[1:-2]
    centre = np.array([10.044, 20.0 - 1.216])
    assert_allclose(np.hypot(*(arc[:, :2] - centre).T), math.hypot(0.044, 1.216), atol=2e-4)
    angles = np.unwrap(np.arctan2(arc[:, 1] - centre[1], arc[:, 0] - centre[0]))
    start_angle = math.atan2(1.216, -0.044)
    assert_allclose(angles[-1] - start_angle, 2.0 * math.pi, atol=1e-3)  # one turn, counter-clockwise
    assert np.all(np.diff(angles) > 0.0) and np.all(np.diff(arc[:, 2]) > 0.0)
    assert_allclose(arc[-1], [10.0, 20.0, 0.8], atol=1e-9)
    assert " P1" not in out and "F30000" in out


@pytest.fixture(scope="module")
def printer_route():
    printer = load_printer(MODELS / "kossel.toml")
    truth = random_printer(printer, np.random.default_rng(0))
    firmware = KLIPPER.nominal(printer)
    controller = KLIPPER.controller(firmware, printer.step_distance)
    return truth, firmware, controller, printer.step_distance


def test_the_first_move_after_homing_starts_at_the_real_home(printer_route):
    truth, firmware, controller, step = printer_route
    home = controller.home

    def correct(points):
        return corrected_targets(truth, controller, points).commands

    with pytest.raises(UnreachableError):  # just below the controller's home: no corrected target
        correct(np.array([[home[0], home[1], home[2] - 0.2]]))
    out = run(["G28", "G1 Z0 F500"], correct, segment_mm=0.2, home=home)  # ideaMaker's travel down
    points = sent(out)
    n = len(points)
    assert n == math.ceil(home[2] / 0.2 - 1e-9)
    down = home[2] * (1.0 - np.arange(1, n + 1) / n)
    intended = np.column_stack([np.full(n, home[0]), np.full(n, home[1]), down])
    along = home[2] - intended[:, 2]
    as_is = np.all(np.abs(points - intended) < 1e-4, axis=1)
    first = int(np.argmin(as_is))  # the points sent as they are: the first ones, a few
    assert as_is[0] and not as_is[first:].any() and first < HOME_ZONE_MM / 0.2
    full = along > along[first] + HOME_BLEND_MM + 0.2
    assert_allclose(points[full], correct(intended[full]), atol=0.6e-4)  # then corrected in full
    real = nozzle_positions(truth, firmware, step, points)
    assert_allclose(real[full], intended[full], atol=1e-3)  # on the intended line
    assert_allclose(real[-1], [home[0], home[1], 0.0], atol=1e-3)


def test_a_refusal_far_from_home_stays_a_refusal(printer_route):
    truth, _, controller, _ = printer_route

    def correct(points):
        return corrected_targets(truth, controller, points).commands

    with pytest.raises(InputError, match="line 2: point .* of this move is"):
        run(["G28", "G1 X400 Y0 Z0 F500"], correct, home=controller.home)


# ------------------------------------------------------------------ compensate --controller printer.cfg
#: A slicer's program (CRLF) starting with the configuration's START_PRINT: extrusion, fan, retraction.
PROGRAM = ("; generated by a slicer\r\nM107\r\nSTART_PRINT EXTRUDER_TEMP=215 BED_TEMP=60\r\nG92 E0\r\n"
           "M106 S255\r\nG1 X30 Y40 Z0.5 F3000\r\nG1 X31.5 Y40 E0.52 F1200 ; wall\r\nG1 E-0.8 F2100\r\n"
           "M204 S500\r\nG1 X-20 Y10 F6000\r\nG1 E0.8\r\nG1 X-20 Y12 E0.1234\r\nEND_PRINT\r\n")
MOVE_LINE = re.compile(r"^G1 X(-?[\d.]+) Y(-?[\d.]+)( Z-?[\d.]+)?")


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """The printer of printer.cfg imported, probed on a simulated kit and identified: (CAL, truth, folder)."""
    folder = tmp_path_factory.mktemp("startprint")
    assert main(["import", str(CONFIG), "-o", str(folder / "imported")]) == 0
    printer, klipper = load_printer(folder / "imported" / "printer.toml"), load_klipper(CONFIG)
    rng = np.random.default_rng(3)
    truth = random_printer(printer, rng, typical_kit())
    xy = np.vstack([probe_points(100.0), probe_points(50.0)[1:]])
    probe = probe_heights(truth, klipper, printer.step_distance, xy, 0.005, rng)
    write_probe_heights(folder / "probe.csv", probe[:, :2], probe[:, 2])
    cal = folder / "cal.toml"
    assert main(["identify", str(folder / "imported" / "printer.toml"), str(folder / "probe.csv"),
                 "--controller", str(CONFIG), "-o", str(cal)]) == 0
    return cal, truth, klipper, printer.step_distance, folder


def test_compensate_a_program_starting_with_start_print_needs_no_start(calibrated, tmp_path, capsys):
    cal, truth, klipper, step, _ = calibrated
    program, out = tmp_path / "part.gcode", tmp_path / "out.gcode"
    program.write_bytes(PROGRAM.encode())
    assert main(["compensate", str(cal), str(program), "--controller", str(CONFIG), "-o", str(out)]) == 0
    assert "corrected for the controller" in capsys.readouterr().out
    given, (marker, *written) = PROGRAM.split("\r\n"), out.read_bytes().decode().split("\r\n")
    assert marker.startswith(MARKER)  # the corrected program says it is one, with the program's line ending
    assert "\n" not in "".join(written)  # CRLF kept
    moves = [line for line in given if MOVE_LINE.match(line)]
    assert [line for line in written if not MOVE_LINE.match(line)] == [x for x in given if x not in moves]
    # each move's words after its position (E, F, comment) kept byte for byte, once, on one of its segments
    segments = [line for line in written if MOVE_LINE.match(line)]
    tails = [MOVE_LINE.sub("", line) for line in segments]
    assert [t for t in tails if t] == [MOVE_LINE.sub("", x) for x in moves if MOVE_LINE.sub("", x)]
    # the true printer's nozzle reaches each move's end, at the height meant (the heights identify the
    # height; x, y they leave to the build tolerances: within 2 mm here)
    ends = [line for line, after in zip(written, written[1:], strict=False)
            if MOVE_LINE.match(line) and not MOVE_LINE.match(after)]
    sent_points = np.array([[float(v) for v in MOVE_LINE.match(line).groups()[:2]]
                            + [float(MOVE_LINE.match(line).group(3)[2:])] for line in ends])
    real = nozzle_positions(truth, klipper, step, sent_points)
    # (z 0.5: this kit's bed needs commands 0.31 mm lower at (-20, 10), below z 0 at a 0.3 mm layer,
    # which minimum_z_position 0 refuses, rightly, since the correction keeps the part where it is)
    meant = np.array([[31.5, 40.0, 0.5], [-20.0, 10.0, 0.5], [-20.0, 12.0, 0.5]])
    assert np.max(np.linalg.norm(real[:, :2] - meant[:, :2], axis=1)) < 2.5  # measured 1.96
    assert_allclose(real[:, 2], meant[:, 2], atol=0.01)
    uncorrected = nozzle_positions(truth, klipper, step, meant)
    assert np.max(np.abs(uncorrected[:, 2] - meant[:, 2])) > 0.1


def test_compensate_refuses_a_start_macro_homing_under_a_condition_naming_it_and_start(calibrated, tmp_path,
                                                                                         capsys):
    cal = calibrated[0]
    program, out = tmp_path / "part.gcode", tmp_path / "out.gcode"
    program.write_text("PRINT_START Z=5\nG1 X10 Y10 F3000\nG1 X12 Y10 E0.1\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(CONFIG), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{program}: line 2: " in err
    assert "macro PRINT_START (G28 under a Jinja condition) on line 1" in err and "--start X,Y,Z" in err
    assert not out.exists()
    assert main(["compensate", str(cal), str(program), "--controller", str(CONFIG), "--start", "0,0,5",
                 "-o", str(out)]) == 0
    assert out.read_text().splitlines()[1] == "PRINT_START Z=5"  # after the marker line
