"""Limits a program switches on (issue 40 item 11): the commands after the line checked against them.

A capture with Marlin's soft endstops off (``M211 S0``) and a program that switches them on
(``M211 S1``): Marlin clamps a corrected first layer below Min Z from that line on. RRF's ``M564 S1``
and ``M208 S1 Z`` in a program likewise. The refusal names the first command's line, the limit and
the value, as the limits of the configuration do, and the line that set them.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from deltacal import InputError
from deltacal.cli import main
from deltacal.gcode import filter_lines
from deltacal.io.geometry_file import save_geometry
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.settings import load_marlin
from deltacal.printer.firmware.rrf.config import load_rrf
from deltacal.printer.firmware.rrf.firmware import RRF_FIRMWARE

DATA = Path(__file__).parent / "data"
KOSSEL = Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml"
FIRST_LAYER = ["G1 X0 Y0 Z10 F3000", "G1 X20 Y0 Z0.02", "G1 X22 Y0 Z0.02 E0.1"]


def lowered(points: np.ndarray) -> np.ndarray:
    """A correction that lowers the bed by 0.05 mm: a first layer at Z 0.02 is commanded at -0.03."""
    return points - np.array([0.0, 0.0, 0.05])


def soft_endstops_off(model):
    """Marlin's values with the soft endstops off (``M211 S0``)."""
    return replace(model, soft_endstops=replace(model.soft_endstops, enabled=False))


def run(lines: list[str], config: Path, firmware) -> str:
    return "".join(filter_lines([line + "\n" for line in lines], lowered, dialect=firmware.dialect(config),
                                limits=firmware.read_config(config), source="part.gcode"))


@pytest.fixture(scope="module")
def marlin_off(tmp_path_factory):
    """An M503 capture with the soft endstops off (M211 S0), Min Z 0."""
    return MARLIN.save_config(tmp_path_factory.mktemp("m211") / "m503.txt",
                              soft_endstops_off(load_marlin(DATA / "marlin_m503.txt")), complete=True)


@pytest.fixture(scope="module")
def rrf_off(tmp_path_factory):
    """config.g with RRF's limits off (M564 S0), Z minimum 0."""
    model = replace(load_rrf(DATA / "rrf" / "config.g"), limit_axes=False)
    return RRF_FIRMWARE.save_config(tmp_path_factory.mktemp("m564") / "config.g", model, complete=True)


def test_marlins_soft_endstops_switched_on_by_the_program_refuse_what_they_clamp(marlin_off):
    assert run(FIRST_LAYER, marlin_off, MARLIN)  # off, as the capture says: Marlin clamps nothing
    with pytest.raises(InputError, match=r"^part\.gcode: line 3: corrected Z -0\.0300 mm is below the soft "
                                         r"endstop Min Z 0 .*\(the limits line 2 \(M211 S1\) set\); 2 "
                                         r"commands refused in all, on lines 3, 4"):
        run(["G1 X0 Y0 Z10 F3000", "M211 S1", *FIRST_LAYER[1:]], marlin_off, MARLIN)
    with pytest.raises(InputError, match=r"line 3: .*\(the limits line 2 \(M211 S\) set\)"):
        run(["G1 X0 Y0 Z10", "M211 S", "G1 X0 Y0 Z0.02"], marlin_off, MARLIN)  # S alone: on


def test_marlin_limits_follow_the_program_line_by_line(marlin_off):
    # on, then off again before the first layer: nothing is clamped
    assert run(["G1 X0 Y0 Z10", "M211 S1", "G1 X0 Y0 Z5", "M211 S0", *FIRST_LAYER[1:]], marlin_off,
               MARLIN)
    # the capture's on (the test capture): a program's M211 S0 lets the first layer through
    on = DATA / "marlin_m503.txt"
    with pytest.raises(InputError, match=r"line 2: corrected Z -0\.0300 mm is below the soft endstop Min Z"):
        run(FIRST_LAYER, on, MARLIN)
    assert run(["M211 S0", *FIRST_LAYER], on, MARLIN).splitlines()[0] == "M211 S0"


def test_rrfs_limits_switched_on_or_raised_by_the_program_refuse_what_rrf_moves(rrf_off):
    assert run(FIRST_LAYER, rrf_off, RRF_FIRMWARE)
    with pytest.raises(InputError, match=r"^part\.gcode: line 3: corrected Z -0\.0300 mm is below the M208 Z "
                                         r"minimum 0 .*\(the limits line 2 \(M564 S1\) set\)"):
        run(["G1 X0 Y0 Z10", "M564 S1", *FIRST_LAYER[1:]], rrf_off, RRF_FIRMWARE)
    config = DATA / "rrf" / "config.g"  # limits on (M564 H1 keeps them), Z minimum 0
    lifted = ["G1 X0 Y0 Z10", "M208 S1 Z0.5", "G1 X20 Y0 Z0.6", "G1 X20 Y0 Z0.52"]
    with pytest.raises(InputError, match=r"line 4: corrected Z 0\.4700 mm is below the M208 Z minimum 0\.5 "
                                         r".*\(the limits line 2 \(M208 S1 Z0\.5\) set\)"):
        run(lifted, config, RRF_FIRMWARE)
    assert run(["G1 X0 Y0 Z10", "M208 Z200", *lifted[2:]], config, RRF_FIRMWARE)  # Z alone: the maximum
    with pytest.raises(InputError, match=r"\(the limits line 2 \(M208 Z0\.5:300\) set\)"):
        run(["G1 X0 Y0 Z10", "M208 Z0.5:300", *lifted[2:]], config, RRF_FIRMWARE)


def test_compensate_names_the_line_that_switched_the_soft_endstops_on(tmp_path, capsys):
    off = soft_endstops_off(MARLIN.nominal(load_printer(KOSSEL)))
    settings = MARLIN.save_config(tmp_path / "m503.txt", off, complete=True)
    cal, program, out = tmp_path / "cal.toml", tmp_path / "part.gcode", tmp_path / "out.gcode"
    truth = load_printer(KOSSEL).geometry()
    save_geometry(truth, cal)
    program.write_text("G28\nM211 S1\nG1 X0 Y0 Z-0.5\n")  # below Min Z as written: the limit applies
    assert main(["compensate", str(cal), str(program), "--controller", str(settings), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{program}: line 3: corrected Z" in err
    assert "(the limits line 2 (M211 S1) set)" in err and not out.exists()
    program.write_text("G28\nG1 X0 Y0 Z-0.5\n")  # the capture's soft endstops off: Marlin clamps nothing
    assert main(["compensate", str(cal), str(program), "--controller", str(settings), "-o", str(out)]) == 0
