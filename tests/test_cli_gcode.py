"""``deltacal compensate CAL PROGRAM.gcode --controller C``: the G-code route of the command line.

The calibration is a true geometry (perturbed, seeded); the controller the robot file's nominal
one. Every corrected move, commanded through the controller's inverse kinematics and run on the
true robot's exact forward kinematics, puts the TCP on the program's intended straight line.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import MODELS

from deltacal import Tolerances, __version__
from deltacal.cli import main
from deltacal.io import load_nominal
from deltacal.io.geometry_file import save_geometry
from deltacal.kinematics import exact
from deltacal.robots import load_controller


def test_a_program_is_corrected_for_the_nominal_controller(tmp_path, capsys):
    robot = MODELS / "bai2015.toml"
    truth = load_nominal(robot).geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(8))
    cal, program, out = tmp_path / "true.toml", tmp_path / "p.gcode", tmp_path / "out.gcode"
    save_geometry(truth, cal)
    program.write_text("G21\nG90\n; a comment\nG1 X0 Y0 Z-800 F3000\nG1 X60 Y-30 Z-820\nM400\n")
    assert main(["compensate", str(cal), str(program), "--controller", str(robot), "-o", str(out),
                 "--segment-mm", "10"]) == 0
    marker, *lines = out.read_text().splitlines()  # the first line says the program is corrected
    assert marker == f"; corrected by deltacal {__version__} for {robot} with {cal}"
    assert lines[:3] == ["G21", "G90", "; a comment"] and lines[-1] == "M400"
    moves = np.array([[float(v) for v in re.findall(r"[XYZ](-?[\d.]+)", line)] for line in lines[3:-1]])
    assert len(moves) == 1 + 7  # 67.1 mm in segments of at most 10 mm
    controller = load_controller(robot)
    tcp = exact.forward(truth, controller.inverse(moves)).point(truth.tool)
    start, end = np.array([0.0, 0.0, -800.0]), np.array([60.0, -30.0, -820.0])
    assert np.allclose(tcp[0], start, atol=1e-3) and np.allclose(tcp[-1], end, atol=1e-3)  # 4 decimals
    along = (tcp[1:] - start) @ (end - start) / np.sum((end - start) ** 2)
    on_line = start + along[:, None] * (end - start)
    assert np.max(np.linalg.norm(tcp[1:] - on_line, axis=1)) < 1e-3
    assert np.allclose(np.diff(along), along[0], atol=1e-6)  # equal segments


@pytest.mark.parametrize("extra, message", [
    ([], "a G-code program goes to a controller: give --controller"),
    (["--controller", "ROBOT", "--frame", "instrument"], "--frame instrument applies to a targets CSV"),
])
def test_program_refusals(tmp_path, capsys, extra, message):
    robot = str(MODELS / "bai2015.toml")
    program = tmp_path / "p.gcode"
    program.write_text("G1 X0 Y0 Z-800\n")
    cal = tmp_path / "true.toml"
    save_geometry(load_nominal(robot).geometry(), cal)
    args = ["compensate", str(cal), str(program), "-o", str(tmp_path / "o.gcode")]
    assert main(args + [robot if e == "ROBOT" else e for e in extra]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.gcode").exists()


def test_worker_processes_correct_a_program_as_one_process_does(tmp_path, capsys, monkeypatch):
    """A large program's batches are split among forked workers (``wings.workers.shared_values``):
    the same bytes, and a point refused in the second half named by its own line."""
    from deltacal.wings import workers

    robot = MODELS / "bai2015.toml"
    truth = load_nominal(robot).geometry().perturbed(Tolerances.bai2015(), np.random.default_rng(9))
    cal, program = tmp_path / "true.toml", tmp_path / "p.gcode"
    save_geometry(truth, cal)
    moves = [f"G1 X{20.0 * np.cos(k / 5.0):.3f} Y{20.0 * np.sin(k / 5.0):.3f} Z-{800 + k}" for k in range(40)]
    program.write_text("G21\nG90\n" + "\n".join(moves) + "\n")
    outputs = []
    for pool_rows in (10**9, 0):
        monkeypatch.setattr(workers, "POOL_ROWS", pool_rows)
        out = tmp_path / f"o{pool_rows}.gcode"
        assert main(["compensate", str(cal), str(program), "--controller", str(robot), "-o", str(out)]) == 0
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1]
    moves[30] = "G1 X0 Y0 Z-200"  # line 33: out of reach, in the second worker's half
    program.write_text("G21\nG90\n" + "\n".join(moves) + "\n")
    capsys.readouterr()
    out = tmp_path / "refused.gcode"
    assert main(["compensate", str(cal), str(program), "--controller", str(robot), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "line 33: point" in err and "out of reach" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
