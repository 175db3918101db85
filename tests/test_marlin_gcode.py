"""Programs as Marlin 2 reads them: G90/G91 and E, arcs' P circles, G28's home, G29 and G33.

The settings are an ``M503`` capture (tests/data/marlin_m503.txt); the programs are of the shape
Marlin slicers write (a start with G28 and G29, M82 or M83, arcs).
"""

from __future__ import annotations

import math
import re
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal import InputError
from deltacal.gcode import filter_lines
from deltacal.gcode.dialect import ArcP
from deltacal.printer.firmware.klipper.firmware import KLIPPER
from deltacal.printer.firmware.marlin.firmware import MARLIN
from deltacal.printer.firmware.marlin.settings import load_marlin

M503 = Path(__file__).parent / "data" / "marlin_m503.txt"
KLIPPER_CFG = Path(__file__).parent / "data" / "klipper" / "printer.cfg"
XYZ = re.compile(r"^G1 X(-?\d+\.\d{4}) Y(-?\d+\.\d{4}) Z(-?\d+\.\d{4})", re.MULTILINE)


def same(points: np.ndarray) -> np.ndarray:
    return points.copy()


def run(lines: list[str], dialect=None, correct=same) -> str:
    return "".join(filter_lines([line + "\n" for line in lines], correct, dialect=dialect))


def sent(out: str) -> np.ndarray:
    return np.array(XYZ.findall(out), dtype=float).reshape(-1, 3)


@pytest.fixture(scope="module")
def marlin():
    return MARLIN.dialect(M503)


def test_marlin_dialect_of_an_m503_capture(marlin):
    settings = load_marlin(M503)
    assert marlin.arc_p is ArcP.CIRCLES and marlin.distance_sets_e and not marlin.macros
    assert marlin.home == (0.0, 0.0, 295.6 + 1.2)  # H - M851 Z
    assert_allclose(marlin.home, MARLIN.controller(settings, settings.step_distance).home, atol=0.0)
    out = run(["G28", "G1 Z0.3 F3000"], marlin)  # straight down from the home
    points = sent(out)
    assert len(points) == math.ceil((296.8 - 0.3) / 5.0)
    assert_allclose(points[:, :2], 0.0, atol=0.0)
    assert_allclose(points[0, 2], 296.8 - (296.8 - 0.3) / len(points), atol=1e-4)


def test_g91_makes_e_relative_and_g90_absolute_in_marlin(marlin):
    # absolute E (M82), then G91 for a lift and a retraction, without M83
    program = ["G90", "M82", "G92 E0", "G1 X0 Y0 Z10 F3000", "G91", "G1 X12 E2.4 F1200", "G90"]
    with pytest.raises(InputError, match="line 6: E is split here, but its mode is ambiguous"):
        run(program)
    e = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", run(program, marlin))]
    assert len(e) == 3 and sum(e) == Decimal("2.4")  # increments
    # M83, then G90: Marlin 2 forgets M83 (set_relative_mode clears the E override)
    program = ["G90", "M83", "G92 E5", "G1 X0 Y0 Z10 F3000", "G90", "G1 X12 E7.4 F1200"]
    with pytest.raises(InputError, match="line 6: E is split here, but its mode is ambiguous"):
        run(program)
    e = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", run(program, marlin))]
    assert len(e) == 3 and e[-1] == Decimal("7.4") and e[0] > Decimal(5) and e == sorted(e)  # positions
    # Klipper reads the same program with E relative (G90 leaves M83's)
    klipper = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", run(program, KLIPPER.dialect(KLIPPER_CFG)))]
    assert sum(klipper) == Decimal("7.4")


def test_an_arc_with_p_turns_p_full_circles_first(marlin):
    program = ["G90", "M83", "G1 X0 Y0 Z1 F3000", "G2 X10 Y0 Z2 I5 J0 P2 E3"]
    with pytest.raises(InputError, match="line 4: word P2 on an arc line is not supported"):
        run(program)
    out = run(program, marlin)
    arc = np.vstack([[0.0, 0.0, 1.0], sent(out)[1:]])
    angles = np.unwrap(np.arctan2(arc[:, 1], arc[:, 0] - 5.0))
    assert_allclose(angles[-1] - angles[0], -5.0 * math.pi, atol=1e-9)  # a half turn after two circles
    assert np.all(np.diff(angles) < 0.0)  # clockwise all the way
    assert_allclose(np.hypot(arc[:, 0] - 5.0, arc[:, 1]), 5.0, atol=1e-4)
    assert_allclose(arc[:, 2], 1.0 + (angles - angles[0]) / (-5.0 * math.pi), atol=1e-4)  # Z over the sweep
    e = [Decimal(v) for v in re.findall(r" E(-?\d+\.\d+)", out)]
    assert sum(e) == Decimal("3")
    klipper = sent(run(program, KLIPPER.dialect(KLIPPER_CFG)))[1:]  # Klipper never reads P: a half turn
    assert_allclose(np.arctan2(klipper[0, 1], klipper[0, 0] - 5.0), math.pi, atol=0.2)
    for p in ("P1.5", "P101", "P-1"):
        with pytest.raises(InputError, match=rf"line 3: word {re.escape(p)} on an arc: Marlin takes P as"):
            run(["G90", "G1 X0 Y0 Z1", f"G2 X10 Y0 I5 J0 {p}"], marlin)


def test_g33_is_refused_and_g29_leaves_the_position_unknown(marlin):
    with pytest.raises(InputError, match=r"line 2: G33: Marlin's delta auto-calibration changes M665"):
        run(["G28", "G33 P4 V3", "G1 X0 Y0 Z10"], marlin)
    with pytest.raises(InputError, match=r"line 3: move before X, Y and Z are all known"):
        run(["G28", "G29", "G1 X10 Y0 F3000"], marlin)
    out = run(["G28", "G29", "G1 X10 Y0 Z0.3 F3000", "G1 X20 Y0"], marlin)
    assert_allclose(sent(out)[0], [10.0, 0.0, 0.3], atol=0.0)  # the first move after G29 sent whole


# ------------------------------------------------------------------ M211: the program's own soft endstops
BELOW_BED = ["G28", "G90", "G1 X0 Y0 Z5 F3000", "G1 X10 Y0 Z-0.1", "G1 X20 Y0 Z0.2"]


def test_the_programs_own_m211_s0_lets_its_moves_below_min_z(marlin):
    """The refusal's advice followed: M211 S0 at the program's start switches Marlin's soft endstops off."""
    limits = load_marlin(M503)
    with pytest.raises(InputError, match=r"line 4: corrected Z -0.1000 mm is below the soft endstop Min Z 0 "
                                         r".*send M211 S0 \(soft endstops off\)"):
        "".join(filter_lines([line + "\n" for line in BELOW_BED], same, dialect=marlin, limits=limits))
    program = ["M211 S0 ; soft endstops off", *BELOW_BED]
    out = "".join(filter_lines([line + "\n" for line in program], same, dialect=marlin, limits=limits))
    assert "G1 X10.0000 Y0.0000 Z-0.1000" in out and out.startswith("M211 S0 ; soft endstops off\n")


@pytest.mark.parametrize(("switch", "line"), [
    (["M211 S0", "M211 S1"], 7),  # on again: the moves after S1 are checked, named by their line
    (["M211", ""], 5),  # M211 alone reports the soft endstops, switches nothing
    (["M211 ; S0 in a comment", ""], 5),
    (["M117 S0", ""], 5),  # another M code's S
])
def test_m211_s1_switches_the_soft_endstops_on_again(marlin, switch, line):
    limits = load_marlin(M503)
    program = [switch[0], "G28", "G90", "G1 X0 Y0 Z5 F3000", "G1 X10 Y0 Z-0.1", switch[1], "G1 X20 Y0 Z-0.2"]
    program = [text for text in program if text]
    with pytest.raises(InputError, match=rf"line {line}: corrected Z -0.\d+ mm is below the soft endstop"):
        "".join(filter_lines([text + "\n" for text in program], same, dialect=marlin, limits=limits))


def test_compensate_follows_a_programs_m211_s0(tmp_path, capsys):
    """``compensate PART.gcode --controller m503.txt``: refused with the advice, then run with it followed."""
    from deltacal.cli import main
    from deltacal.io.geometry_file import save_geometry
    from deltacal.printer.files.robot_file import load_printer

    printer = load_printer(Path(__file__).resolve().parents[1] / "deltacal" / "models" / "kossel.toml")
    capture = MARLIN.save_config(tmp_path / "m503.txt", MARLIN.nominal(printer), complete=True)
    cal = tmp_path / "cal.toml"
    save_geometry(printer.geometry(), cal)
    part, out = tmp_path / "part.gcode", tmp_path / "out.gcode"
    part.write_text("\n".join(BELOW_BED) + "\n")
    argv = ["compensate", str(cal), str(part), "--controller", str(capture), "--firmware", "marlin",
            "-o", str(out)]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "part.gcode: line 4: corrected Z -0.1000 mm" in err and "send M211 S0" in err and not out.exists()
    part.write_text("M211 S0\n" + part.read_text())
    assert main(argv) == 0
    assert "G1 X10.0000 Y0.0000 Z-0.1000" in out.read_text()
