"""RepRapFirmware configuration sets as found: called files, meta commands, axis scaling, old homing files.

Real-shaped sets under ``tests/data/rrf/`` (each names its source in its header): Duet3D's own Mini
Kossel ``config.g`` and an OpenBeam Kossel Pro's ``config.g`` + ``local.g`` + ``homedelta.g`` of RRF
1.x/2.x. Each case is read as RRF runs it, or refused in one line naming the file and the line.
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.exceptions import InputError, InputWarning
from deltacal.printer.firmware.rrf.config import load_rrf
from deltacal.printer.firmware.rrf.homing import homed_position

DATA = Path(__file__).resolve().parent / "data" / "rrf"
OBKP = DATA / "openbeam-kossel-pro"
BASE = """M665 L300 R153 H270 B135
M666 X0 Y0 Z0
M92 X80 Y80 Z80
"""


def kossel_pro(tmp_path: Path, local: str = "") -> Path:
    """The OpenBeam Kossel Pro's set copied into ``tmp_path/sys``, ``local`` added to its local.g."""
    sys_dir = tmp_path / "sys"
    shutil.copytree(OBKP, sys_dir)
    with open(sys_dir / "local.g", "a", encoding="utf-8") as f:
        f.write(local)
    return sys_dir / "config.g"


def quiet_load(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)  # config-override.g of M501: not in the set
        return load_rrf(path)


# ------------------------------------------------------------------ M98: the files config.g runs
def test_the_kossel_pros_set_reads_its_local_g_and_says_m501s_file_is_missing(tmp_path):
    config = kossel_pro(tmp_path)
    with pytest.warns(InputWarning, match=r"line 38: M501 runs config-override.g, not found"):
        rrf = load_rrf(config)
    assert rrf.radius == 153.0 and rrf.diagonal.tolist() == [300.0] * 3 and rrf.print_radius == 135.0


def test_values_set_in_the_file_m98_runs_are_read(tmp_path):
    config = kossel_pro(tmp_path, "M665 R140 L280 ; this printer's own values\n")
    rrf = quiet_load(config)
    assert rrf.radius == 140.0 and rrf.diagonal.tolist() == [280.0] * 3
    assert rrf.print_radius == 135.0 and rrf.homed_height == 270.0  # config.g's, not set again


@pytest.mark.parametrize("call", ['M98 P"delta.g"', 'M98 P"/sys/delta.g"', 'M98 P"0:/sys/delta.g"',
                                  "M98 Pdelta.g", 'M98 P"config-override.g"'])
def test_m98_finds_the_file_where_rrf_does(tmp_path, call):
    sys_dir = tmp_path / "sys"
    sys_dir.mkdir()
    name = "config-override.g" if "override" in call else "delta.g"
    (sys_dir / name).write_text("M665 R140 L280\nM666 X0.5 Y-0.25 Z-0.25\n")
    (sys_dir / "config.g").write_text(BASE + call + "\nM665 H300\n")
    rrf = load_rrf(sys_dir / "config.g")
    assert rrf.radius == 140.0 and rrf.diagonal.tolist() == [280.0] * 3
    assert rrf.endstop_adjustment.tolist() == [0.5, -0.25, -0.25] and rrf.homed_height == 300.0


def test_m98_of_a_macro_outside_sys_is_under_the_sd_cards_root(tmp_path):
    (tmp_path / "sys").mkdir()
    (tmp_path / "macros").mkdir()
    (tmp_path / "macros" / "geometry.g").write_text("M665 L281.5\n")
    (tmp_path / "sys" / "config.g").write_text(BASE + 'M98 P"/macros/geometry.g"\n')
    assert load_rrf(tmp_path / "sys" / "config.g").diagonal.tolist() == [281.5] * 3


def test_a_missing_macro_is_named_with_its_line(tmp_path):
    (tmp_path / "config.g").write_text(BASE + 'M98 P"delta.g"\n')
    with pytest.warns(InputWarning, match=r"config.g: line 4: M98 runs delta.g, not found at .*values "
                                          r"\(if any\) are not read"):
        assert load_rrf(tmp_path / "config.g").radius == 153.0


def test_a_macro_calling_itself_is_refused(tmp_path):
    (tmp_path / "delta.g").write_text('M665 R150\nM98 P"delta.g"\n')
    (tmp_path / "config.g").write_text(BASE + 'M98 P"delta.g"\n')
    with pytest.raises(InputError, match=r"delta.g: line 2, M98 P: delta.g calls itself"):
        load_rrf(tmp_path / "config.g")


def test_a_macro_that_is_not_a_regular_file_is_refused(tmp_path):
    (tmp_path / "delta.g").mkdir()
    (tmp_path / "config.g").write_text(BASE + 'M98 P"delta.g"\n')
    with pytest.raises(InputError, match=r"config.g: line 4: M98 runs .*delta.g, not a regular file"):
        load_rrf(tmp_path / "config.g")


# ------------------------------------------------------------------ meta commands
@pytest.mark.parametrize("block, inside", [
    ('if {boards[0].firmwareVersion} == "3.4"\n  M665 L360\nelse\n  M665 L280\n', 5),
    ("if false\n  M665 L360\n", 5),
    ("while iterations < 2\n    M666 X{iterations}\n", 5),
    ("if true\n  M291 P\"hello\"\nelif false\n  M98 P\"delta.g\"\n", 7),
])
def test_a_delta_setting_inside_a_block_is_refused_naming_its_line(tmp_path, block, inside):
    (tmp_path / "config.g").write_text(BASE + block)
    with pytest.raises(InputError, match=rf"config.g: line {inside}: M\d+ inside the '\w+' block of line "
                                         r"\d+: which branch RRF runs"):
        load_rrf(tmp_path / "config.g")


def test_lines_after_a_block_and_blocks_without_settings_are_read(tmp_path):
    (tmp_path / "config.g").write_text(BASE + "if true\n  M291 P\"hi\" ; a message\n\n"
                                       "M665 L281 ; after the block\n")
    assert load_rrf(tmp_path / "config.g").diagonal.tolist() == [281.0] * 3


def test_plain_number_globals_and_vars_are_read(tmp_path):
    (tmp_path / "config.g").write_text(
        "global rodLength = 280 ; RRF 3.5\nvar radius = 140.25\nset global.rodLength = 281\n"
        "M665 L{global.rodLength} R{var.radius} H{ global.rodLength }\n"
        "global a = 280.5\nglobal b = 281\nM665 L{global.a}:{global.b}:{global.rodLength}\n"
        "M666 X0 Y0 Z0\nM92 X80 Y80 Z80\n")
    rrf = load_rrf(tmp_path / "config.g")
    assert rrf.radius == 140.25 and rrf.homed_height == 281.0
    assert rrf.diagonal.tolist() == [280.5, 281.0, 281.0]


@pytest.mark.parametrize("lines, message", [
    ("global rod = {move.axes[0].max}\nM665 L{global.rod}\n",
     r"line 5, M665 L: value '\{global.rod\}': global.rod \(.*config.g line 4\) is set to "
     r"'\{move.axes\[0\].max\}'"),
    ("if true\n  global rod = 280\nM665 L{global.rod}\n",
     r"line 6, M665 L: .*global.rod \(.*line 5\) is set inside the 'if' block of line 4"),
    ("M665 L{global.rod}\n", r"line 4, M665 L: value '\{global.rod\}': global.rod is not set earlier"),
    ("global rod = 280\nM665 L{global.rod + 1}\n", r"line 5, M665 L: value .* is an expression RRF computes"),
])
def test_other_variables_and_expressions_are_refused_naming_the_line(tmp_path, lines, message):
    (tmp_path / "config.g").write_text(BASE + lines)
    with pytest.raises(InputError, match=message):
        load_rrf(tmp_path / "config.g")


def test_a_var_is_the_files_own(tmp_path):
    (tmp_path / "delta.g").write_text("M665 L{var.rod}\n")
    (tmp_path / "config.g").write_text(BASE + "var rod = 280\nM665 R{var.rod}\n" + 'M98 P"delta.g"\n')
    with pytest.raises(InputError, match=r"delta.g: line 1, M665 L: .*var.rod is not set earlier"):
        load_rrf(tmp_path / "config.g")


# ------------------------------------------------------------------ M579 and M556
def test_axis_scaling_uncommented_in_local_g_is_refused_naming_its_line(tmp_path):
    config = kossel_pro(tmp_path, "M579 X1.005 Y1.005 ; compensate for delta geometry, grow ~0.5% in X "
                                  "and Y\n")
    with pytest.raises(InputError, match=r"local.g: line 9, M579 X: value '1.005': axis scaling \(M579"):
        quiet_load(config)


@pytest.mark.parametrize("line, refused", [("M556 S78 X0 Y0 Z0", False), ("M556 S78 X0.3 Y0 Z0", True),
                                           ("M556 S78 Y-0.2", True), ("M556 P1", False),
                                           ("M579 X1 Y1 Z1", False), ("M579 Z0.998", True)])
def test_skew_and_scaling_other_than_the_identity_are_refused(tmp_path, line, refused):
    (tmp_path / "config.g").write_text(BASE + line + "\n")
    if refused:
        with pytest.raises(InputError, match=r"config.g: line 4, M5(56|79) [XYZ]: .* not in deltacal's "):
            load_rrf(tmp_path / "config.g")
    else:
        assert load_rrf(tmp_path / "config.g").radius == 153.0


# ------------------------------------------------------------------ homing of RRF 1.x/2.x
def test_an_rrf2_homing_file_with_g1_s1_leaves_the_nozzle_5_mm_below_the_endstops(tmp_path):
    config = kossel_pro(tmp_path)
    rrf = quiet_load(config)
    home, said = homed_position(config, rrf)
    assert said == "homedelta.g"
    assert_allclose(home, [0.0, 0.0, rrf.home_position[2] - 5.0], rtol=0, atol=1e-9)


def test_single_motor_moves_after_the_last_homing_move_the_carriages(tmp_path):
    (tmp_path / "config.g").write_text(BASE)
    (tmp_path / "homedelta.g").write_text(  # SeeMeCNC's RRF 1.x/2.x homedelta.g, its last moves unequal
        "M203 Z15000\nG91\nG1 S1 X750 Y750 Z750 F5000\nG1 S2 X-5 Y-5 Z-5 F500\nG1 S1 X8 Y8 Z8 F500\n"
        "G1 S2 X-5 Y-4 Z-3 F500\nG90\n")
    rrf = load_rrf(tmp_path / "config.g")
    home, _ = homed_position(tmp_path / "config.g", rrf)
    # the nozzle is where each carriage stands that far below its endstop (RRF's inverse kinematics)
    heights = rrf.carriage_heights(home[None])[0]
    assert_allclose(heights, rrf.carriage_top - [5.0, 4.0, 3.0], rtol=0, atol=1e-9)
    equal = tmp_path / "equal"
    equal.mkdir()
    (equal / "config.g").write_text(BASE)
    (equal / "homedelta.g").write_text("G91\nG1 S1 X750 Y750 Z750\nG1 S2 X-5 Y-5 Z-5\nG90\n")
    home, _ = homed_position(equal / "config.g", rrf)
    assert_allclose(home, rrf.home_position - [0.0, 0.0, 5.0], rtol=0, atol=1e-9)


def test_single_motors_to_absolute_positions_are_refused_as_rrf_does(tmp_path):
    (tmp_path / "config.g").write_text(BASE)
    (tmp_path / "homedelta.g").write_text("G91\nG1 H1 X750 Y750 Z750\nG90\nG1 H2 X-5 Y-5 Z-5\n")
    with pytest.raises(InputError, match=r"homedelta.g: line 4: G1 H2 moves single motors to absolute"):
        homed_position(tmp_path / "config.g", load_rrf(tmp_path / "config.g"))


def test_the_rrf3_homing_file_is_read_as_before(tmp_path):
    (tmp_path / "config.g").write_text(BASE)
    (tmp_path / "homedelta.g").write_text("G91\nG1 H1 X750 Y750 Z750 F3000\nG1 H2 X-5 Y-5 Z-5\n"
                                          "G1 H1 X10 Y10 Z10 F300\nG1 Z-5 F6000\nG90\nG1 X0 Y0\n")
    rrf = load_rrf(tmp_path / "config.g")
    home, _ = homed_position(tmp_path / "config.g", rrf)
    assert_allclose(home, [0.0, 0.0, rrf.home_position[2] - 5.0], rtol=0, atol=1e-9)
    assert np.isfinite(home).all()
