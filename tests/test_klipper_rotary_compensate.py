"""``deltacal compensate --controller`` with a rotary_delta printer.cfg: a rotary Delta printer's commands
corrected through Klipper's rotary kinematics.

The truth: the printer imported from Klipper's example-rotary-delta.cfg with the complete error model's
small deviations. The corrected commands, run as Klipper runs them (its inverse kinematics: the arm angles
it commands, q = -theta) through the true geometry, put the nozzle on the targets.
"""

from __future__ import annotations

import numpy as np
import pytest

from deltacal.cli import main
from deltacal.controller import corrected_targets
from deltacal.errormodels import get_model
from deltacal.io.geometry_file import save_geometry
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.robots import load_robot
from tests.test_klipper_rotary import EXAMPLE

KLIPPER_DIR = EXAMPLE.parents[1]
#: The example's effector radius, rod spacing and nozzle drop (not in a printer.cfg) [mm].
MEASURED = ("--effector-radius", "25", "--rod-spacing", "45", "--nozzle-drop", "40")


def _truth(tmp_path, seed: int = 3):
    """The imported example printer (in {O}) and it with the complete model's errors: σ 0.1 mm, 1 mrad."""
    assert main(["import", str(EXAMPLE), "-o", str(tmp_path / "imp"), *MEASURED]) == 0
    nominal = load_nominal(tmp_path / "imp" / "printer.toml").geometry()
    model = get_model("complete")
    sigma = np.where(np.array(model.units) == "rad", 1e-3, 0.1)
    truth = model.apply(nominal, np.random.default_rng(seed).normal(0.0, 1.0, model.size) * sigma)
    return nominal, truth


def _controller() -> KlipperRotaryController:
    return KlipperRotaryController(rotary_from_config(read_klipper_config(EXAMPLE)))


def _targets() -> np.ndarray:
    """Targets of the printable volume in Klipper's frame (the bed's) [mm]."""
    rng = np.random.default_rng(7)
    radius, angle = 60.0 * np.sqrt(rng.uniform(size=40)), rng.uniform(0, 2 * np.pi, 40)
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle), rng.uniform(0.2, 150.0, 40)])


def _nozzle(truth_in_bed, controller, commands) -> np.ndarray:
    """Where the true nozzle goes when Klipper is sent ``commands``: its arm angles, the truth's forward."""
    q = controller.inverse(commands)
    return exact.forward(truth_in_bed, q).point(truth_in_bed.tool)


def test_the_controller_is_klippers_rotary_kinematics():
    """Forward and inverse are Klipper's (kin_rotary_delta.c, its trilateration) in deltacal's readings
    q = -theta; its virtual model (the revolute chain, in Klipper's frame) gives the same nozzle; home and
    limits Klipper's."""
    c = _controller()
    targets = _targets()
    q = c.inverse(targets)
    assert np.max(np.abs(q + c.firmware.shoulder_angles(targets))) == 0.0
    assert np.max(np.abs(c.forward(q) - targets)) < 1e-9
    assert np.max(np.abs(c.virtual.forward(q) - targets)) < 1e-9
    assert np.max(np.abs(c.virtual.inverse(targets) - q)) < 1e-12
    assert c.interpolation == "cartesian" and np.all(c.tool == 0.0)
    np.testing.assert_allclose(c.home, [0.0, 0.0, 252.0], atol=1e-9)
    # Klipper's check_move: below 0, above 252 (the lowest position_endstop), beyond max_xy 203.9, the taper
    codes = c.limits.outside([[0, 0, -0.1], [0, 0, 252.1], [204.0, 0, 10], [30, 0, 230], [30, 0, 10],
                              [0, 0, 252.0]])
    assert codes.tolist() == [1, 2, 3, 4, 0, 0]
    assert "minimum_z_position: -0.10" in c.limits.refusal([[0, 0, -0.1]])


def test_corrected_commands_put_the_true_nozzle_on_the_targets(tmp_path):
    """Through Klipper's rotary kinematics and the true geometry: on the targets within 1e-6 mm; the
    uncorrected commands miss by the errors' size (over 0.1 mm)."""
    _, truth = _truth(tmp_path)
    c = _controller()
    in_bed = c.in_bed_frame(truth)
    targets = _targets()
    commands = corrected_targets(in_bed, c, targets).commands
    assert np.max(np.linalg.norm(_nozzle(in_bed, c, commands) - targets, axis=1)) < 1e-6
    assert np.max(np.linalg.norm(_nozzle(in_bed, c, targets) - targets, axis=1)) > 0.1


def test_compensate_cli_targets_and_gcode(tmp_path, capsys):
    """``deltacal compensate TRUTH.toml ... --controller example-rotary-delta.cfg``: the targets CSV's
    commands and every corrected G-code move's end, run through Klipper and the truth, on the targets
    (the CSV's) within 1e-6 mm, on the program's path within its 1e-4 mm digits; the bed placed at
    shoulder height + nozzle drop below {O}."""
    _, truth = _truth(tmp_path)
    save_geometry(truth, tmp_path / "truth.toml")
    targets = _targets()
    np.savetxt(tmp_path / "t.csv", targets, delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    assert main(["compensate", str(tmp_path / "truth.toml"), str(tmp_path / "t.csv"), "--controller",
                 str(EXAMPLE), "-o", str(tmp_path / "out.csv")]) == 0
    said = capsys.readouterr().out
    assert "bed (z = 0) at z = -452.9 mm" in said
    out = np.genfromtxt(tmp_path / "out.csv", delimiter=",", names=True)
    commands = np.column_stack([out["x_cmd_mm"], out["y_cmd_mm"], out["z_cmd_mm"]])
    c = _controller()
    in_bed = truth.moved_rigidly(np.eye(3), np.array([0.0, 0.0, 412.9 + 40.0]))
    assert np.max(np.linalg.norm(_nozzle(in_bed, c, commands) - targets, axis=1)) < 1e-6
    # a program: every corrected move's end lands on the program's path
    path = np.array([[0.0, 0.0, 5.0], [10.0, 10.0, 0.3], [30.0, -20.0, 0.3], [-20.0, 30.0, 10.0]])
    program = "G28\nG90\nM83\nG1 Z5 F3000\n" + "".join(
        f"G1 X{x:g} Y{y:g} Z{z:g} E1\n" for x, y, z in path[1:])
    (tmp_path / "part.gcode").write_text(program)
    assert main(["compensate", str(tmp_path / "truth.toml"), str(tmp_path / "part.gcode"), "--controller",
                 str(EXAMPLE), "-o", str(tmp_path / "out.gcode"), "--segment-mm", "5"]) == 0
    moves = _moves((tmp_path / "out.gcode").read_text())
    landed = _nozzle(in_bed, c, moves)
    landed = landed[np.argmax(np.linalg.norm(landed - path[0], axis=1) < 1e-3):]  # from home's descent's end
    assert len(landed) > 10
    # G-code's numbers are written to 1e-4 mm (XYZ_DECIMALS): the landing within that rounding's reach
    assert np.max(_distance_to_path(landed, path)) < 2e-4
    assert np.linalg.norm(landed[-1] - path[-1]) < 2e-4
    assert np.max(_distance_to_path(_nozzle(in_bed, c, path), path)) > 0.1  # uncorrected: off the path


def _moves(text: str) -> np.ndarray:
    """The X, Y, Z of every G1 line with all three (a corrected program writes them all)."""
    rows = []
    for line in text.splitlines():
        words = dict((w[0], w[1:]) for w in line.split(";")[0].split() if w[0] in "XYZ")
        if line.startswith("G1") and len(words) == 3:
            rows.append([float(words[k]) for k in "XYZ"])
    return np.array(rows)


def _distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's distance to the polyline ``path`` [mm]."""
    best = np.full(len(points), np.inf)
    for a, b in zip(path[:-1], path[1:], strict=True):
        d = b - a
        s = np.clip((points - a) @ d / (d @ d), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + s[:, None] * d), axis=1))
    return best


@pytest.mark.parametrize("which", ["rotary cfg, linear printer", "linear cfg, rotary printer"])
def test_a_controller_of_the_other_kind_is_refused_in_one_line(tmp_path, capsys, which):
    if which.startswith("rotary"):
        assert main(["import", str(KLIPPER_DIR / "example-delta.cfg"), "-o", str(tmp_path / "lin")]) == 0
        save_geometry(load_robot(tmp_path / "lin" / "printer.toml").geometry(), tmp_path / "cal.toml")
        cfg = EXAMPLE
    else:
        _, truth = _truth(tmp_path)
        save_geometry(truth, tmp_path / "cal.toml")
        cfg = KLIPPER_DIR / "example-delta.cfg"
    np.savetxt(tmp_path / "t.csv", [[0.0, 0.0, 1.0]], delimiter=",", header="x_mm,y_mm,z_mm", comments="")
    capsys.readouterr()
    assert main(["compensate", str(tmp_path / "cal.toml"), str(tmp_path / "t.csv"), "--controller", str(cfg),
                 "-o", str(tmp_path / "out.csv")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "--controller" in err and str(cfg) in err
    assert not (tmp_path / "out.csv").exists()
