"""``compensate`` through a printer's firmware (issue 24 item 4): corrected targets and G-code for Klipper.

The firmware is emulated on the true printer: a printer perturbed with a kit's tolerances (seeded),
Klipper's model of it from the nominal values or from a printer.cfg text, the true geometry as the
calibration. What Klipper is sent goes through Klipper's own inverse (steps), then through the true
printer's exact forward kinematics; the Pinocchio model checks the landed positions on a few points.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli import main
from deltacal.compensation import compensate
from deltacal.controller import Controller, corrected_targets
from deltacal.exceptions import GeometryError, InputError, UnreachableError
from deltacal.gcode import ARC_TOLERANCE_RATIO, DEFAULT_SEGMENT_MM, filter_lines
from deltacal.geometry import DeltaGeometry, Tolerances
from deltacal.io import load_nominal
from deltacal.io.geometry_file import save_geometry
from deltacal.kinematics import exact
from deltacal.kinematics.closed_form import VirtualDelta
from deltacal.kinematics.multibody import DeltaMultibody
from deltacal.kinematics.singularity import singularity_measures
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.model import KlipperController, KlipperDelta
from deltacal.printer.robot import NominalLinearDelta
from deltacal.robots import load_controller

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"

#: A Kossel's printer.cfg after the firmware's own calibration: its values differ from the nominal
#: printer's by millimetres (delta_radius, endstops, one arm), as a user's file does.
PRINTER_CFG = """[printer]
kinematics: delta
delta_radius: 133.1
max_velocity: 300

[stepper_a]
microsteps: 16
rotation_distance: 40
position_endstop: 295.2
arm_length: 269.3
angle: 210.2

[stepper_b]
microsteps: 16
rotation_distance: 40
position_endstop: 296.4
angle: 329.7

[stepper_c]
microsteps: 16
rotation_distance: 40
position_endstop: 295.9
"""
#: The real path's distance from the intended one within 1.3 µm at the default 5 mm segments on
#: kit printers (measured: 0.31, 0.48 and 1.26 µm for seeds 1-3; 5-15 µm at 20 mm): 2 µm allowed.
PATH_TOLERANCE = 2e-3
MOVE = re.compile(r"^G[01] X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})")


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def true_printer(kossel: NominalLinearDelta, seed: int) -> DeltaGeometry:
    return kossel.geometry().perturbed(Tolerances.printer_kit(), np.random.default_rng(seed))


def printable(kossel: NominalLinearDelta, n: int, rng: np.random.Generator) -> np.ndarray:
    ws = kossel.workspace
    assert ws is not None
    r = ws.radius * np.sqrt(rng.random(n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.column_stack([r * np.cos(a), r * np.sin(a), ws.height * rng.random(n)])


def firmware_of(kossel: NominalLinearDelta, tmp_path: Path | None = None) -> KlipperController:
    """Klipper from the nominal values, or (tmp_path given) read from :data:`PRINTER_CFG`."""
    if tmp_path is None:
        return KlipperController(KlipperDelta.from_printer(kossel), kossel.step_distance)
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(PRINTER_CFG)
    controller = load_controller(cfg)
    assert isinstance(controller, KlipperController)
    return controller


def landed(truth: DeltaGeometry, firmware: KlipperController, commands: np.ndarray) -> np.ndarray:
    """Where the true nozzle goes when Klipper is sent ``commands``: its steps, run on the true printer."""
    steps = firmware.firmware.steps(commands)
    return exact.forward(truth, steps * firmware.step_distance).point(truth.tool)


@pytest.mark.parametrize(("seed", "from_cfg"), [(1, False), (2, True), (3, True)])
def test_corrected_targets_through_klipper_land_on_the_targets(kossel, tmp_path, seed, from_cfg):
    truth = true_printer(kossel, seed)
    firmware = firmware_of(kossel, tmp_path if from_cfg else None)
    targets = printable(kossel, 400, np.random.default_rng(100 + seed))
    commands, readings = corrected_targets(truth, firmware, targets)
    assert_allclose(firmware.inverse(commands), readings, atol=1e-9)  # Klipper commands those readings
    reached = landed(truth, firmware, commands)
    assert np.max(np.linalg.norm(reached - targets, axis=1)) < 1e-6
    uncorrected = landed(truth, firmware, targets)  # what the printer does without the correction
    assert np.max(np.linalg.norm(uncorrected - targets, axis=1)) > 0.2
    # the Pinocchio closed-loop model of the true printer agrees on a few points
    pin = DeltaMultibody(truth).forward(firmware.inverse(commands[:4])).point(truth.tool)
    assert_allclose(pin, targets[:4], atol=1e-6)


def test_klippers_home_and_readings_count_in_the_printers_step_distance(kossel, tmp_path):
    firmware = firmware_of(kossel, tmp_path)
    assert firmware.step_distance.tolist() == [40.0 / 3200.0] * 3 and firmware.name == "printer.cfg"
    assert_allclose(firmware.inverse(firmware.home[None]), 0.0, atol=1e-9)  # every carriage at its endstop
    # readings in another step distance: the same steps, so the same commands
    other = KlipperController(firmware.firmware, 0.01)
    q = np.array([[250.0, 260.0, 255.0]])
    assert_allclose(other.forward(q * 0.8), firmware.forward(q), atol=1e-9)
    assert firmware.virtual.joint == "prismatic" and firmware.interpolation == "cartesian"
    assert_allclose(firmware.virtual.forward(q), firmware.forward(q), atol=1e-9)
    with pytest.raises(GeometryError, match="step_distance must be a positive length"):
        KlipperController(firmware.firmware, 0.0)


def test_refusals_named_by_index(kossel):
    truth = true_printer(kossel, 4)
    firmware = firmware_of(kossel)
    targets = printable(kossel, 6, np.random.default_rng(5))
    for k, where, reason in [(1, [400.0, 0.0, 10.0], UnreachableError.OUT_OF_REACH),  # beyond the rods
                             (4, [0.0, 0.0, 350.0], UnreachableError.OUT_OF_REACH)]:  # above the endstops
        far = targets.copy()
        far[k] = where
        with pytest.raises(UnreachableError) as caught:
            corrected_targets(truth, firmware, far)
        assert list(caught.value.indices) == [k] and caught.value.reason == reason
    # the true printer reaches them, a firmware's model with arms 100 mm short cannot command them
    short = KlipperController(KlipperDelta(
        firmware.firmware.delta_radius, firmware.firmware.angle, firmware.firmware.arm_length - 100.0,
        firmware.firmware.position_endstop, firmware.firmware.step_distance), kossel.step_distance)
    edge = np.array([[0.0, 0.0, 20.0], [-110.0, 30.0, 2.0], [0.0, 0.0, 100.0], [0.0, -115.0, 2.0]])
    with pytest.raises(UnreachableError) as caught:
        corrected_targets(truth, short, edge)
    assert list(caught.value.indices) == [1, 3]
    assert caught.value.reason == UnreachableError.CONTROLLER_OUT_OF_REACH
    rotary = Controller.from_geometry(load_nominal(MODELS / "bai2015.toml"))
    with pytest.raises(GeometryError, match="a revolute Delta's model, the robot 'kossel' is a prismatic"):
        corrected_targets(truth, rotary, targets)


def test_a_printers_transmission_angle_is_its_rods_to_the_tower(kossel):
    """Klipper's point effector centred: every rod at asin(sqrt(ℓ² − ρ²) / ℓ) to the horizontal."""
    virtual: VirtualDelta = firmware_of(kossel).virtual
    x = np.array([[0.0, 0.0, 50.0]])
    angle, conditioning = singularity_measures(virtual, virtual.inverse(x), x)
    rho, arm = 134.4, 269.0
    assert_allclose(angle, math.asin(math.sqrt(arm**2 - rho**2) / arm), atol=1e-12)
    assert 0.0 < conditioning[0] <= 1.0
    # and compensation refuses a pose with a rod within 3 deg of square to its tower (2 deg here)
    tower_b = (kossel.tower_radius - kossel.effector_radius) * np.array([math.cos(math.radians(330.0)),
                                                                        math.sin(math.radians(330.0))])
    nozzle = tower_b * (1.0 - kossel.rod_length[1] * math.cos(math.radians(2.0)) / np.linalg.norm(tower_b))
    with pytest.raises(UnreachableError) as caught:
        compensate(kossel.geometry(), np.array([[nozzle[0], nozzle[1], 10.0]]))
    assert caught.value.reason == UnreachableError.SINGULAR


# ----------------------------------------------------------------------------- G-code
PROGRAM = """; sliced for a Kossel
M82
G28 ; home all axes
G1 Z5 F5000 ; lift nozzle
G92 E0
G1 X-100 Y-40 Z0.3 F3000
G1 X100 Y50 E12.5 F1800
G3 X60 Y90 I-40 J0 E15.1
G1 X0 Y110 Z150 E16
M400
"""


def path_deviation(truth, firmware, out: str, lines: list[tuple[np.ndarray, np.ndarray]],
                   arc: tuple[np.ndarray, float] | None = None) -> tuple[float, float]:
    """The true nozzle's largest distance [mm] from the intended lines, and from the arc, running ``out``.

    Klipper interpolates each move in its Cartesian frame and its kinematics maps each step: 33 samples
    between segment ends, through its inverse and the true printer's exact forward kinematics; each
    sample is judged against the nearest element of the path.
    """
    sent = np.array([[float(v) for v in m.groups()] for m in map(MOVE.match, out.splitlines()) if m])
    s = np.linspace(0.0, 1.0, 33)[:, None]
    samples = np.concatenate([sent[k - 1] + s * (sent[k] - sent[k - 1]) for k in range(1, len(sent))])
    real = landed(truth, firmware, samples)
    distances = []
    for a, b in lines:
        u = (b - a) / np.linalg.norm(b - a)
        t = np.clip((real - a) @ u, 0.0, np.linalg.norm(b - a))
        distances.append(np.linalg.norm(real - a - t[:, None] * u, axis=1))
    to_line = np.min(distances, axis=0)
    to_arc = np.full(len(real), np.inf)
    if arc is not None:  # a quarter turn at z 0.3, counter-clockwise from angle 0
        centre, radius = arc
        angle = np.arctan2(real[:, 1] - centre[1], real[:, 0] - centre[0])
        d = np.hypot(np.hypot(real[:, 0] - centre[0], real[:, 1] - centre[1]) - radius, real[:, 2] - 0.3)
        to_arc = np.where((angle >= 0.0) & (angle <= 0.5 * math.pi), d, np.inf)
    on_arc = to_arc < to_line
    return float(np.max(to_line[~on_arc])), float(np.max(to_arc[on_arc], initial=0.0))


def test_a_program_through_klipper_follows_the_intended_path(kossel, tmp_path):
    truth = true_printer(kossel, 3)
    firmware = firmware_of(kossel, tmp_path)

    def correct(points: np.ndarray) -> np.ndarray:
        return corrected_targets(truth, firmware, points).commands

    out = "".join(filter_lines(PROGRAM.splitlines(keepends=True), correct, home=firmware.home))
    lines = out.splitlines()
    assert lines[:3] == ["; sliced for a Kossel", "M82", "G28 ; home all axes"] and lines[-1] == "M400"
    home = firmware.home
    # the lift starts at Klipper's home (every carriage at its endstop): its first point is on the way down
    n = math.ceil((home[2] - 5.0) / DEFAULT_SEGMENT_MM)
    first = np.array([[float(v) for v in MOVE.match(lines[3]).groups()]])
    assert_allclose(landed(truth, firmware, first)[0], home - [0.0, 0.0, (home[2] - 5.0) / n], atol=1e-4)
    assert lines[3].endswith(" F5000 ; lift nozzle")
    a, b, c = np.array([-100.0, -40.0, 0.3]), np.array([100.0, 50.0, 0.3]), np.array([0.0, 110.0, 150.0])
    arc_end = np.array([60.0, 90.0, 0.3])
    lifted = home * [1.0, 1.0, 0.0] + [0.0, 0.0, 5.0]
    path = [(home, lifted), (lifted, a), (a, b), (arc_end, c)]
    line, arc = path_deviation(truth, firmware, out, path, (np.array([60.0, 50.0]), 40.0))
    assert line <= PATH_TOLERANCE, line
    assert 0.0 < arc <= PATH_TOLERANCE + ARC_TOLERANCE_RATIO * DEFAULT_SEGMENT_MM, arc  # + chords' sagitta
    # E split in proportion, absolute (M82): the last segment of each move writes the move's own E
    e = [line for line in lines if " E" in line and MOVE.match(line)]
    ends = [x.rsplit(" E", 1)[1] for x in e]
    assert e[0].endswith(" F1800") and {"12.50000", "15.10000"} < set(ends) and ends[-1] == "16.00000"
    assert [float(v.split()[0]) for v in ends] == sorted(float(v.split()[0]) for v in ends)
    coarse = "".join(filter_lines(PROGRAM.splitlines(keepends=True), correct, 60.0, home=firmware.home))
    assert path_deviation(truth, firmware, coarse, path)[0] > 2.0 * PATH_TOLERANCE  # the check sees


def test_a_relative_move_right_after_homing_is_refused(kossel):
    firmware = firmware_of(kossel)
    program = "G28\nG91\nG1 Z-5\n"
    with pytest.raises(InputError, match=r"line 3: relative move \(G91\) right after the homing on line 1"):
        "".join(filter_lines(program.splitlines(keepends=True), lambda p: p.copy(), home=firmware.home))
    without = "G28\nG1 Z5\n"
    with pytest.raises(InputError, match="line 2: move before X, Y and Z are all known"):
        "".join(filter_lines(without.splitlines(keepends=True), lambda p: p.copy()))


# ----------------------------------------------------------------------------- command line
def test_compensate_for_a_printer_on_the_command_line(kossel, tmp_path, capsys):
    truth = true_printer(kossel, 6)
    cal, cfg = tmp_path / "true.toml", tmp_path / "printer.cfg"
    save_geometry(truth, cal)
    cfg.write_text(PRINTER_CFG)
    targets = printable(kossel, 30, np.random.default_rng(7))
    csv = tmp_path / "targets.csv"
    csv.write_text("x_mm,y_mm,z_mm\n" + "".join(f"{x:.4f},{y:.4f},{z:.4f}\n" for x, y, z in targets))
    out = tmp_path / "corrected.csv"
    assert main(["compensate", str(cal), str(csv), "--controller", str(cfg), "-o", str(out)]) == 0
    assert f"wrote 30 corrected targets for the controller {cfg} to {out}" in capsys.readouterr().out
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    firmware = firmware_of(kossel, tmp_path)
    assert np.max(np.linalg.norm(landed(truth, firmware, table[:, 3:]) - table[:, :3], axis=1)) < 1e-6
    # a G-code program, homed by the firmware
    program, gout = tmp_path / "part.gcode", tmp_path / "out.gcode"
    program.write_text(PROGRAM)
    assert main(["compensate", str(cal), str(program), "--controller", str(cfg), "-o", str(gout)]) == 0
    assert "G28 ; home all axes" in gout.read_text()
    # refusals: a target out of reach by its line; a program's point by its line; the wrong kind
    csv.write_text("x_mm,y_mm,z_mm\n0,0,10\n400,0,10\n")
    assert main(["compensate", str(cal), str(csv), "--controller", str(cfg), "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"{csv}: line 3 (data row 2), columns x_mm..z_mm: target [400.0, 0.0, 10.0] mm is out of" in err
    program.write_text("G28\nG1 X0 Y0 Z10\nG1 X0 Y0 Z400\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(cfg), "-o",
                 str(tmp_path / "o2.gcode")]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"{program}: line 3: point" in err
    assert not (tmp_path / "o2.gcode").exists()
    robot = MODELS / "bai2015.toml"
    assert main(["compensate", str(cal), str(csv), "--controller", str(robot), "-o", str(out)]) == 2
    assert "is a rotary Delta's, but the calibration" in capsys.readouterr().err


def test_a_config_whose_towers_step_differently_is_refused(tmp_path):
    cfg = tmp_path / "calibrated.cfg"
    cfg.write_text(PRINTER_CFG.replace("rotation_distance: 40\nposition_endstop: 296.4",
                                       "rotation_distance: 40.1\nposition_endstop: 296.4"))
    with pytest.raises(InputError, match=r"calibrated.cfg: sections \[stepper_a..c\], key rotation_distance: "
                                         r"the towers' step distances differ \(0.0125, 0.01253125, 0.0125"):
        load_controller(cfg)
    assert load_controller(cfg, step_distance=0.0125).step_distance.tolist() == [0.0125] * 3
    # detected by its [printer] section as well as by its name
    other = tmp_path / "printer.conf"
    other.write_text(PRINTER_CFG)
    assert isinstance(load_controller(other), KlipperController)
