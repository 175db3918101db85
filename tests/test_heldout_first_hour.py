"""Issue 39's "done when" on held-out real firmware files, end to end, as a printer owner goes.

Each file of ``tests/data/heldout/`` (its header names its source) is one no other test reads: two
Marlin ``M503`` captures, two RepRapFirmware config sets, two Klipper ``printer.cfg`` files. Each goes
through ``import`` (the robot file's numbers worked out by hand from the file's), ``plan --object``
(``probe.gcode`` travels above the probe's trigger height, at the firmware's own travel height where
it has one), ``simulate`` (a printer with a kit's errors measured with that plan), ``identify`` (the
identified printer's first layer flat on the true bed), ``export`` and ``compensate`` of a slicer's
program (with the step an owner takes when a refusal says what to do). A Marlin ``Configuration.h``
is refused wherever a capture is asked for.
"""

from __future__ import annotations

import math
import re
import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.controller import corrected_targets
from deltacal.controller.targets import aligned_to_controller
from deltacal.gcode import filter_lines, read_lines
from deltacal.io import load_calibration, load_geometry
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware import firmware_named
from deltacal.printer.firmware.probing import MIN_TRAVEL_MARGIN

DATA = Path(__file__).resolve().parent / "data"
HELD = DATA / "heldout"
SLICERS = DATA / "slicers"
ANYCUBIC_LOG = HELD / "marlin" / "anycubic-kossel-plus-marlin110-octoprint.log"
ANYCUBIC_H = HELD / "marlin" / "anycubic-kossel-plus-Configuration.h"
_Z = re.compile(r"^G1 .*\bZ(-?[\d.]+)", re.MULTILINE)
_XYZ = re.compile(r"^G[01] X(-?[\d.]+) Y(-?[\d.]+) Z(-?[\d.]+)", re.MULTILINE)
#: Heights below which no move of a slicer's program is the first after a homing (blended in near the top).
HOME_CLEAR_MM = 100.0


@dataclass(frozen=True)
class Held:
    """A held-out file and what its numbers give, worked out by hand.

    Attributes:
        name: The case's id.
        files: The files, the first the one given (``config.g`` first, then the files it runs).
        firmware: ``--firmware``'s name of the file.
        program: The slicer's program to correct (one written for that firmware's flavour).
        rods: Each tower's rod [mm].
        radius: The delta radius [mm] (the robot file's tower radius less the 30 mm effector).
        endstops: Each tower's endstop height, with the 30 mm nozzle drop [mm].
        azimuths: Each tower's azimuth [deg].
        step: The step distance [mm].
        workspace: The workspace radius [mm] (None: not one of the file's numbers).
        trigger: The probe's trigger height: the nozzle's height above the bed at the trigger [mm].
        travel: The height ``probe.gcode`` travels at [mm].
        added: A line the owner adds to the file when its import says to (appended).
        exports: Whether export writes the firmware's values (else it refuses, saying why).
    """

    name: str
    files: tuple[Path, ...]
    firmware: str
    program: Path
    rods: tuple[float, ...]
    radius: float
    endstops: tuple[float, ...]
    azimuths: tuple[float, ...]
    step: float
    workspace: float | None
    trigger: float
    travel: float
    added: str = ""
    exports: bool = True

    @property
    def config(self) -> Path:
        return self.files[0]


def _root(rod: float, radius: float) -> float:
    """The carriage's height above the nozzle's plane with the effector centred: sqrt(L² − R²) [mm]."""
    return float(np.sqrt(rod * rod - radius * radius))


def _tevo() -> Held:
    # [printer] delta_radius = 159.53, arm_length 397.19, SAVE_CONFIG position_endstop = 520.270,
    # rotation_distance 40 / (200 full steps x 16 microsteps), [delta_calibrate] radius 140,
    # horizontal_move_z 10; SAVE_CONFIG [bltouch] z_offset = 0.315
    top = 520.270 + _root(397.19, 159.53) + 30.0
    return Held("klipper-tevo-little-monster", (HELD / "klipper" / "tevo-little-monster-unknowdata.cfg",),
                "klipper", SLICERS / "ideamaker-4.4.gcode", (397.19,) * 3, 159.53, (top,) * 3,
                (210.0, 330.0, 90.0), 40.0 / 3200.0, 140.0, 0.315, 10.0)


def _qqs_pro_klipper() -> Held:
    # [printer] delta_radius 130, [stepper_a] arm_length 280.0 and position_endstop 370 (stepper_b and
    # _c take a's), rotation_distance 32 / 3200, [delta_calibrate] radius 120, horizontal_move_z 10;
    # [bltouch] z_offset -2.3 ([probe] commented out)
    top = 370.0 + _root(280.0, 130.0) + 30.0
    return Held("klipper-flsun-qqs-pro-bltouch", (HELD / "klipper" / "flsun-qqs-pro-bltouch-cobrapi.cfg",),
                "klipper", SLICERS / "ideamaker-4.4.gcode", (280.0,) * 3, 130.0, (top,) * 3,
                (210.0, 330.0, 90.0), 32.0 / 3200.0, 120.0, -2.3, 10.0)


def _dc42_kossel() -> Held:
    # config.g: M665 L361.676:361.676:361.676 R180.679 H470.070 B150.0 Y0.161 Z0.000,
    # M666 Y-0.006 Z0.755 (A0.11 B-0.08: the bed's tilt, not a robot file value), M92 X200 Y200
    # Z200, M558 P8 H6, G31 Z-0.10; M501 with no config-override.g beside it (warned, values as they are)
    rod, radius, height = 361.676, 180.679, 470.070
    tops = tuple(height + _root(rod, radius) + adj + 30.0 for adj in (-0.748, -0.006, 0.755))
    folder = HELD / "rrf" / "duet3d-dc42kossel"
    files = tuple(folder / name for name in ("config.g", "homedelta.g", "bed.g"))
    return Held("rrf-duet3d-dc42-kossel", files, "rrf", SLICERS / "cura-5.6.gcode", (rod,) * 3, radius, tops,
                (210.0 - 0.105, 330.0 + 0.161, 90.0), 1.0 / 200.0, 150.0, -0.10, -0.10 + 6.0)


def _super_racer_rrf() -> Held:
    # config.g: M665 R151.67 L315 B132 H330, M92 X80 Y80 Z80, M558 P8 H8, G31 Z20, then M501: its
    # config-override.g's M665 L315.000:315.000:315.000 R151.654 H335.853 B132.0 Y-0.450
    # Z0.000, M666 X0.631 Y-0.228 Z-0.403 and G31 Z17.54 are the ones RRF ends with
    rod, radius, height = 315.0, 151.654, 335.853
    tops = tuple(height + _root(rod, radius) + adj + 30.0 for adj in (0.631, -0.228, -0.403))
    folder = HELD / "rrf" / "flsun-sr-qianqin"
    files = tuple(folder / name for name in ("config.g", "config-override.g", "homedelta.g"))
    return Held("rrf-flsun-super-racer", files, "rrf", SLICERS / "cura-5.6.gcode", (rod,) * 3, radius, tops,
                (210.0 - 0.041, 330.0 - 0.450, 90.0), 1.0 / 80.0, 132.0, 17.54, 17.54 + 8.0)


def _qqs_marlin() -> Held:
    # M665 L280.0000 R141.9439 H354.3339 X0.0353 Y0.2565 Z-0.2919 A0 B0 C0, M666 X0 Y-2.7082 Z-3.1732,
    # M92 X100 Y100 Z100, M851 Z-19.3200 (G28 puts the nozzle at H - M851 Z; each M666 moves its carriage
    # down from the endstop after homing); no M211 line (Marlin's default 140 mm, held to the rods' reach)
    rod, radius, home = 280.0, 141.9439, 354.3339 + 19.32
    tops = tuple(home + _root(rod, radius) - adj + 30.0 for adj in (0.0, -2.7082, -3.1732))
    return Held("marlin-flsun-qqs", (HELD / "marlin" / "flsun-qqs-marlin2-m503.txt",), "marlin",
                SLICERS / "cura-5.6.gcode", (rod,) * 3, radius, tops, (210.0353, 330.2565, 90.0 - 0.2919),
                1.0 / 100.0, None, 19.32, 19.32 + 5.0)


def _anycubic_marlin_1_1_0() -> Held:
    # M665 L271.50 R135.40 S80.00 A0 B0 C0 (no H: Marlin 1.1.0), M666 X0 Y0 Z0, M206 Z0, M92 X80 Y80 Z80,
    # M851 Z-15.80; the owner adds 'M665 H270' as import says: MANUAL_Z_HOME_POS 270 of the same
    # firmware's Configuration.h + M206 Z0, where its G28 puts the nozzle (it homes up: M851 Z apart)
    rod, radius = 271.5, 135.4
    top = 270.0 + _root(rod, radius) + 30.0
    return Held("marlin-1.1.0-anycubic-kossel-plus", (ANYCUBIC_LOG,), "marlin", SLICERS / "cura-5.6.gcode",
                (rod,) * 3, radius, (top,) * 3, (210.0, 330.0, 90.0), 1.0 / 80.0, None, 15.8, 15.8 + 5.0,
                added="M665 H270", exports=False)


def _anycubic_rrf() -> Held:
    # config.g: M665 R134.67 L271.5 B120 H305, M666 X0 Y0 Z0, M92 X80 Y80 Z80, M558 P4 H10, G31 Z17.941 and
    # no M501: the config-override.g beside it (M665 ... H290.000) is never run, so not read
    rod, radius = 271.5, 134.67
    top = 305.0 + _root(rod, radius) + 30.0
    folder = HELD / "rrf" / "anycubic-kossel-citruspers"
    files = tuple(folder / name for name in ("config.g", "config-override.g", "homedelta.g"))
    return Held("rrf-anycubic-kossel-no-m501", files, "rrf", SLICERS / "cura-5.6.gcode", (rod,) * 3, radius,
                (top,) * 3, (210.0, 330.0, 90.0), 1.0 / 80.0, 120.0, 17.941, 17.941 + 10.0)


CASES = [_qqs_marlin(), _tevo(), _qqs_pro_klipper(), _dc42_kossel(), _super_racer_rrf(),
         _anycubic_marlin_1_1_0(), _anycubic_rrf()]


def _ids(case: Held) -> str:
    return case.name


def _given(case: Held, folder: Path) -> Path:
    """The file as the owner gives it: its folder copied (a config.g's files beside it), the added line."""
    copied = folder / "given"
    copied.mkdir()
    for path in case.files:
        shutil.copy(path, copied / path.name)
    config = copied / case.config.name
    if case.added:
        config.write_text(config.read_text() + case.added + "\n")
    return config


# ------------------------------------------------------------------ import: the file's numbers
def _imported(case: Held, tmp_path: Path, capsys) -> Path:
    config = _given(case, tmp_path)
    assert main(["import", str(config), "-o", str(tmp_path / "robot")]) == 0, capsys.readouterr().err
    capsys.readouterr()
    return tmp_path / "robot" / "printer.toml"


@pytest.mark.parametrize("case", CASES, ids=_ids)
def test_import_gives_the_files_numbers(case, tmp_path, capsys):
    printer = load_printer(_imported(case, tmp_path, capsys))
    assert_allclose(printer.rod_length, case.rods, rtol=0, atol=1e-9)
    assert_allclose(printer.tower_radius, case.radius + 30.0, rtol=0, atol=1e-9)
    assert_allclose(printer.endstop_height, case.endstops, rtol=0, atol=1e-6)
    assert_allclose(np.degrees(printer.tower_azimuth), case.azimuths, rtol=0, atol=1e-9)
    assert_allclose(printer.step_distance, case.step, rtol=1e-12, atol=0)
    assert printer.workspace is not None
    if case.workspace is not None:
        assert printer.workspace.radius == pytest.approx(case.workspace, abs=1e-9)


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    return err


def test_marlin_1_1_0s_log_is_refused_saying_where_its_homed_height_is(tmp_path, capsys):
    """OctoPrint's terminal of an Anycubic Marlin 1.1.0: the report at start and M503's, no M665 H."""
    assert main(["import", str(ANYCUBIC_LOG), "-o", str(tmp_path / "robot")]) == 1
    err = _one_line(capsys)
    assert f"{ANYCUBIC_LOG}: line 80: no M665 H: the report of a Marlin without it (1.1.0 or older" in err
    assert "MANUAL_Z_HOME_POS of its Configuration.h, plus this report's M206 Z0)" in err
    assert "add a line 'M665 H<that height>' to the capture" in err and not (tmp_path / "robot").exists()


@pytest.mark.parametrize("command", ["import", "plan"])
def test_the_same_printers_configuration_h_is_refused_as_a_capture(command, tmp_path, capsys):
    robot = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
    argv = {"import": ["import", str(ANYCUBIC_H)],
            "plan": ["plan", str(robot), "--object", "--controller", str(ANYCUBIC_H)]}[command]
    assert main([*argv, "-o", str(tmp_path / "out")]) == 1
    err = _one_line(capsys)
    assert f"{ANYCUBIC_H}: line 54: a Marlin Configuration.h holds the compiled defaults" in err
    assert "send M503 to the printer and save its whole answer" in err and not (tmp_path / "out").exists()


# ------------------------------------------------------------------ the route: plan to compensate
def _program_heights(program: str) -> list[float]:
    return [float(z) for z in _Z.findall(program)]


def _planned(case: Held, robot: Path, config: Path, folder: Path, capsys) -> Path:
    plan = folder / "plan"
    assert main(["plan", str(robot), "--object", "--controller", str(config), "-o", str(plan)]) == 0
    said = capsys.readouterr().err.splitlines()
    assert len(said) == len(set(said)), said  # each warning once (RRF's missing config-override.g: 3 times)
    program = (plan / "probe.gcode").read_text()
    heights = _program_heights(program)
    points = len((plan / "probe.csv").read_text().splitlines()) - 1
    assert len(heights) == 1 + 2 * points  # the rise after G28, then a travel and a rise per point
    assert_allclose(heights, case.travel, rtol=0, atol=5e-4)  # written with 3 decimals
    assert case.travel >= case.trigger + MIN_TRAVEL_MARGIN - 1e-9
    # a trigger below the bed said so (not "-2.3 mm above")
    side = f"{case.trigger:g} mm above" if case.trigger >= 0 else f"{-case.trigger:g} mm below"
    assert f"the probe triggers with the nozzle {side} the bed (" in program
    return plan


def test_a_missing_file_config_g_runs_is_warned_of_once_by_plan():
    """plan reads config.g for the model, then again for the probe's travel: one warning, as Klipper's."""
    config = HELD / "rrf" / "duet3d-dc42kossel" / "config.g"
    firmware = firmware_named("rrf")
    assert firmware is not None
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("default")
        firmware.read_config(config)
        firmware.probe_travel(config)
    assert [str(w.message).split(": ", 2)[-1] for w in said] == [
        "M501 runs config-override.g, not found at "
        f"{config.parent / 'config-override.g'}: its values (if any) are not read"]


def _identified(case: Held, robot: Path, config: Path, plan: Path, folder: Path, capsys) -> Path:
    probe, distances, cal = folder / "probe.csv", folder / "d.csv", folder / "cal.toml"
    assert main(["simulate", str(robot), str(plan / "probe.csv"), str(plan / "distances.csv"),
                 "--controller", str(config), "--firmware", case.firmware, "--perturb", "7", "-o", str(probe),
                 "--distances-output", str(distances)]) == 0
    assert main(["identify", str(robot), str(probe), str(distances), "--controller", str(config),
                 "-o", str(cal)]) == 0
    capsys.readouterr()
    truth, geometry = load_geometry(folder / "probe.truth.toml"), load_calibration(cal).geometry
    xy = np.loadtxt(plan / "probe.csv", delimiter=",", skiprows=1, usecols=(0, 1))
    layer = np.column_stack([xy * 0.8, np.full(len(xy), 0.2)])
    landed = exact.forward(truth, exact.inverse(geometry, layer)).point(truth.tool)
    assert np.ptp(landed[:, 2]) < 0.05  # the identified printer's first layer is flat on the true bed
    return cal


def _exported(case: Held, cal: Path, robot: Path, config: Path, folder: Path, capsys) -> str:
    out = folder / "exported"
    argv = ["export", str(cal), "--controller", case.firmware, "--config", str(config), "--robot", str(robot),
            "-o", str(out)]
    if not case.exports:  # Marlin 1.1.0 takes no M665 H nor X Y Z: export would write what it ignores
        assert main(argv) == 1 and not out.exists()
        err = _one_line(capsys)
        assert f"{config.name}: the report of a Marlin 1.1.0 or older (M665 L R S, no H)" in err
        assert "correct each program with deltacal compensate through this capture" in err
        return ""
    assert main(argv) == 0
    printed = capsys.readouterr().out
    fitted, given = (float(m) for m in re.findall(r"values: 3-D max (\d+\.\d+) mm", printed))
    assert fitted < given
    # how to apply names the lines where the values live: each is that command's line of that file
    named = re.findall(r"the (M\d+) line of (\S+) \(line (\d+)\)", printed)
    assert bool(named) == (case.firmware == "rrf"), printed
    for code, name, line in named:
        assert (config.parent / name).read_text().splitlines()[int(line) - 1].startswith(code + " ")
    if case.firmware == "rrf" and not re.search(r"^M501\b", config.read_text(), flags=re.MULTILINE):
        # a config-override.g beside a config.g that never runs it is not where the values live
        assert {name for _, name, _ in named} == {"config.g"}
        assert "config.g runs no M501, so M500 (config-override.g) would be lost at the next" in printed
    return out.read_text()


def _moves(text: str) -> np.ndarray:
    """The absolute moves of a program as written (X Y Z each), up to its first G91 [mm], (N, 3)."""
    return np.array(_XYZ.findall(text.split("\nG91", 1)[0]), dtype=float).reshape(-1, 3)


def _compensated(case: Held, cal: Path, robot: Path, config: Path, folder: Path, capsys) -> None:
    """compensate the program, with the step the refusal says when the firmware's limits refuse it."""
    program, out = folder / case.program.name, folder / "part.gcode"
    shutil.copy(case.program, program)
    argv = ["compensate", str(cal), str(program), "--controller", str(config), "-o", str(out)]
    code = main(argv)
    if code != 0:
        said = capsys.readouterr().err.splitlines()
        err = "\n".join(line for line in said if not line.startswith("warning: "))
        assert code == 1 and err.count("\n") == 0 and "Traceback" not in err and not out.exists(), err
        if case.firmware == "marlin":  # the corrected first layer is below Marlin's Min Z
            assert "send M211 S0 (soft endstops off) before the program" in err
            program.write_text("M211 S0\n" + program.read_text())
        else:
            assert case.firmware == "rrf", err
            given = re.search(r"set (M208 S1 Z-?\d+\.\d+)", err)
            assert given is not None, err
            config.write_text(config.read_text().rstrip("\n") + f"\n{given.group(1)}\n")
        assert main(argv) == 0, capsys.readouterr().err
    capsys.readouterr()
    firmware = firmware_named(case.firmware)
    assert firmware is not None
    controller = firmware.controller(firmware.read_config(config), load_printer(robot).step_distance)
    # the program as the firmware reads it, cut as compensate cuts it, uncorrected: line for line the output's
    intended = _moves("".join(filter_lines(read_lines(program), lambda points: points, home=controller.home,
                                           dialect=firmware.dialect(config))))
    sent = _moves(out.read_text())
    assert sent.shape == intended.shape and len(sent) > 100
    calibration = load_calibration(cal)
    below = intended[:, 2] < HOME_CLEAR_MM  # off the first move after G28 (the correction blends in)
    assert np.count_nonzero(below) > 100
    # what compensate sends is the library's route where the calibration holds (4 decimals written) ...
    route = corrected_targets(calibration, controller, intended[below]).commands
    assert_allclose(sent[below], route, rtol=0, atol=2e-3)
    # ... and corrected wholly, the identified printer in the firmware's frame lands on the program's points
    whole = corrected_targets(calibration, controller, intended[below], bound=math.inf).commands
    geometry = aligned_to_controller(calibration.geometry, controller, float(calibration.holds.radius[-1]))
    landed = exact.forward(geometry, controller.inverse(whole)).point(geometry.tool)
    assert_allclose(landed, intended[below], rtol=0, atol=1e-6)


@pytest.mark.long
@pytest.mark.parametrize("case", CASES, ids=_ids)
def test_the_owners_route_from_import_to_a_corrected_program(case, tmp_path, capsys):
    robot = _imported(case, tmp_path, capsys)
    config = robot.parent.parent / "given" / case.config.name
    plan = _planned(case, robot, config, tmp_path, capsys)
    cal = _identified(case, robot, config, plan, tmp_path, capsys)
    _exported(case, cal, robot, config, tmp_path, capsys)
    _compensated(case, cal, robot, config, tmp_path, capsys)
