"""Klipper as a controller (issue 24): printer.cfg read with Klipper's meaning, and Klipper's delta
model of the nominal printer against deltacal's exact kinematics of the linear Delta."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.exceptions import GeometryError, InputError, InputWarning
from deltacal.kinematics import exact
from deltacal.printer.files.robot_file import load_printer
from deltacal.printer.firmware.klipper.config import load_klipper, read_klipper_config
from deltacal.printer.firmware.klipper.model import KlipperDelta
from deltacal.printer.robot import NominalLinearDelta

MODELS = Path(__file__).resolve().parents[1] / "deltacal" / "models"

#: A printer.cfg as a Kossel owner has it after DELTA_CALIBRATE and SAVE_CONFIG: the values
#: SAVE_CONFIG wrote commented out above, the block at the end ({block}).
PRINTER_CFG = """# This file contains common pin mappings for the SKR 1.4 board on a Kossel.
[include mainsail.cfg]
[include macros/*.cfg]

[mcu]
serial: /dev/serial/by-id/usb-Klipper_lpc1768_1070FF13261136AF3EF05F5BC32000F5-if00

[printer]
kinematics: delta
max_velocity: 300
max_accel: 3000
max_z_velocity: 150
#delta_radius: 132.0
minimum_z_position: -5

[stepper_a]
step_pin: P2.2
dir_pin: !P2.6
enable_pin: !P2.1
microsteps: 16
rotation_distance: 40
endstop_pin: ^P1.29
homing_speed: 60
#position_endstop: 297.0
#arm_length: 269.0

[stepper_b]
step_pin: P0.19
dir_pin: !P0.20
enable_pin: !P2.8
microsteps = 16    ; '=' works as ':' does
rotation_distance = 40
full_steps_per_rotation: 200
endstop_pin: ^P1.27

[stepper_c]
step_pin: P0.22
dir_pin: !P2.11
enable_pin: !P0.21
microsteps: 16
rotation_distance: 40
endstop_pin: ^P1.25

[probe]
pin: ^P1.24
z_offset: 15.9

[delta_calibrate]
radius: 115
horizontal_move_z: 10
{block}"""

MAINSAIL_CFG = """[virtual_sdcard]
path: ~/printer_data/gcodes
[pause_resume]
"""

MACRO_CFG = """[gcode_macro START_PRINT]
gcode:
    G28
    G1 Z10 F600
"""

HEADER = """
#*# <---------------------- SAVE_CONFIG ---------------------->
#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.
#*#
"""


def save_config_block(klipper: KlipperDelta, fmt: str = "{!r}") -> str:
    """The SAVE_CONFIG block of a configuration, as Klipper writes it (its values as ``fmt`` gives them)."""
    lines = ["[printer]", f"delta_radius = {fmt.format(klipper.delta_radius)}", ""]
    for k, axis in enumerate("abc"):
        lines += [f"[stepper_{axis}]", f"angle = {fmt.format(float(np.degrees(klipper.angle[k])))}",
                  f"arm_length = {fmt.format(float(klipper.arm_length[k]))}",
                  f"position_endstop = {fmt.format(float(klipper.position_endstop[k]))}", ""]
    lines += ["[delta_calibrate]", "height0 = 15.0", "height0_pos = 23756.000,23756.000,23756.000"]
    return HEADER + "\n".join(("#*# " + line).strip() for line in lines) + "\n"


def write_config(tmp_path: Path, block: str, main: str = PRINTER_CFG) -> Path:
    (tmp_path / "mainsail.cfg").write_text(MAINSAIL_CFG)
    (tmp_path / "macros").mkdir(exist_ok=True)
    (tmp_path / "macros" / "start.cfg").write_text(MACRO_CFG)
    path = tmp_path / "printer.cfg"
    path.write_text(main.replace("{block}", block))
    return path


@pytest.fixture(scope="module")
def kossel() -> NominalLinearDelta:
    return load_printer(MODELS / "kossel.toml")


def printable_points(n: int, rng: np.random.Generator, radius: float = 115.0, height: float = 200.0):
    r = radius * np.sqrt(rng.random(n))
    a = rng.uniform(0.0, 2.0 * np.pi, n)
    return np.column_stack([r * np.cos(a), r * np.sin(a), height * rng.random(n)])


# ------------------------------------------------------------------ reading printer.cfg
def test_printer_cfg_is_read_with_klippers_meaning(tmp_path, kossel):
    nominal = KlipperDelta.from_printer(kossel)
    path = write_config(tmp_path, save_config_block(nominal, "{:.6f}"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no value both in the file and in its block
        config = read_klipper_config(path)
        klipper = load_klipper(path)
    # includes, a glob among them, read where they stand
    assert config.sections["virtual_sdcard"]["path"] == "~/printer_data/gcodes"
    assert "G1 Z10 F600" in config.sections["gcode_macro START_PRINT"]["gcode"]
    assert config.origin[("gcode_macro START_PRINT", "gcode")].endswith("start.cfg")
    # the SAVE_CONFIG block's values, the commented ones above ignored
    assert config.origin[("printer", "delta_radius")].endswith("(SAVE_CONFIG block)")
    assert klipper.delta_radius == 134.4
    assert_allclose(np.degrees(klipper.angle), [210.0, 330.0, 90.0], atol=1e-12)
    assert_allclose(klipper.arm_length, 269.0)
    assert_allclose(klipper.position_endstop, round(float(nominal.position_endstop[0]), 6))
    # rotation_distance / (full_steps_per_rotation x microsteps)
    assert_allclose(klipper.step_distance, 40.0 / (200 * 16), rtol=1e-15)
    assert config.sections["stepper_b"]["microsteps"] == "16"  # the inline ';' comment removed


def test_tower_b_and_c_take_tower_a_values_and_default_angles(tmp_path):
    main = PRINTER_CFG.replace("#delta_radius: 132.0", "delta_radius: 140.5").replace(
        "#position_endstop: 297.0\n#arm_length: 269.0", "position_endstop: 297.25\narm_length: 250.0"
    ).replace("rotation_distance: 40\nendstop_pin: ^P1.25", "rotation_distance: 40\ngear_ratio: 5:1, 2:1\n"
              "full_steps_per_rotation: 400\nendstop_pin: ^P1.25")
    klipper = load_klipper(write_config(tmp_path, "", main))
    assert klipper.delta_radius == 140.5
    assert_allclose(klipper.arm_length, 250.0)
    assert_allclose(klipper.position_endstop, 297.25)
    assert_allclose(np.degrees(klipper.angle), [210.0, 330.0, 90.0], atol=1e-12)
    assert_allclose(klipper.step_distance, [0.0125, 0.0125, 40.0 / (400 * 16 * 10)], rtol=1e-15)


def test_a_value_both_in_the_file_and_its_block_keeps_the_files(tmp_path, kossel):
    block = save_config_block(KlipperDelta.from_printer(kossel))
    main = PRINTER_CFG.replace("#delta_radius: 132.0", "delta_radius: 132.0")
    path = write_config(tmp_path, block, main)
    with pytest.warns(InputWarning, match=r"section \[printer\], key delta_radius: set both .* keeps the "
                                          r"configuration's value '132.0'"):
        klipper = load_klipper(path)
    assert klipper.delta_radius == 132.0
    assert_allclose(klipper.arm_length, 269.0)  # the block's other values hold


def test_an_edited_block_is_ignored_as_klipper_does(tmp_path, kossel):
    block = save_config_block(KlipperDelta.from_printer(kossel)) + "delta_radius = 1.0\n"
    main = PRINTER_CFG.replace("#delta_radius: 132.0", "delta_radius: 132.0").replace(
        "#position_endstop: 297.0\n#arm_length: 269.0", "position_endstop: 297.0\narm_length: 269.0")
    with pytest.warns(InputWarning, match="the SAVE_CONFIG block was edited"):
        klipper = load_klipper(write_config(tmp_path, block, main))
    assert klipper.delta_radius == 132.0 and klipper.position_endstop[2] == 297.0


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("kinematics: delta", "kinematics: corexy", r"section \[printer\], key kinematics: value 'corexy'"),
        ("#delta_radius: 132.0", "delta_radius: 13O.0",
         r"section \[printer\], key delta_radius: value '13O.0' is "
                                                        r"not a number"),
        ("#delta_radius: 132.0", "delta_radius: 300",
         r"\(SAVE_CONFIG block\): section \[stepper_a\], key arm_length: value '269.000000' must be "
         r"above 300"),
        ("#delta_radius: 132.0", "", r"section \[printer\]: missing required key 'delta_radius'"),
        ("microsteps: 16\nrotation_distance: 40\nendstop_pin: ^P1.25",
         "microsteps: 16.5\nrotation_distance: 40",
         r"section \[stepper_c\], key microsteps: value '16.5' is not an integer"),
        ("full_steps_per_rotation: 200", "full_steps_per_rotation: 202",
         r"section \[stepper_b\], key full_steps_per_rotation: value 202 must be a multiple of 4"),
        ("rotation_distance: 40\nendstop_pin: ^P1.25", "rotation_distance: 40\ngear_ratio: 5-1",
         r"section \[stepper_c\], key gear_ratio: value '5-1' is not a list of ratios"),
        ("[stepper_c]", "[stepper_d]", r"section \[stepper_c\]: missing required key 'rotation_distance'"),
        ("max_accel: 3000", "max_accel 3000", r"printer.cfg: line 11: not an option .* 'max_accel 3000'"),
    ],
)
def test_printer_cfg_errors_are_one_line(tmp_path, kossel, old, new, message):
    assert old in PRINTER_CFG
    block = save_config_block(KlipperDelta.from_printer(kossel), "{:.6f}")
    if "delta_radius" in new or old == "#delta_radius: 132.0":
        block = block.replace("#*# delta_radius = 134.400000\n", "")
    path = write_config(tmp_path, block, PRINTER_CFG.replace(old, new))
    with pytest.raises(InputError, match=message) as err:
        load_klipper(path)
    assert "\n" not in str(err.value)


def test_an_error_in_an_included_file_names_that_file(tmp_path, kossel):
    path = write_config(tmp_path, save_config_block(KlipperDelta.from_printer(kossel)))
    (tmp_path / "macros" / "start.cfg").write_text(MACRO_CFG + "\n[include ../printer.cfg]\n")
    with pytest.raises(InputError, match=r"printer.cfg: recursive include of this file"):
        load_klipper(path)
    (tmp_path / "macros" / "start.cfg").write_text("gcode: G28\n")
    with pytest.raises(InputError, match=r"start.cfg: line 1: an option outside any \[section\]"):
        load_klipper(path)


# ------------------------------------------------------------------ Klipper's model
def test_klippers_model_follows_its_documented_formulas():
    k = KlipperDelta(134.4, np.radians([210.0, 330.0, 90.0]), np.full(3, 269.0),
                     np.array([295.0, 296.0, 297.0]),
                     np.full(3, 0.0125))
    # at the endstops with the nozzle centred, the nozzle is at each tower's position_endstop
    top = np.sqrt(269.0**2 - 134.4**2)
    assert_allclose(k.carriage_top, np.array([295.0, 296.0, 297.0]) + top, rtol=1e-15)
    assert_allclose(k.steps(np.array([[0.0, 0.0, 0.0]])), [[295.0 / 0.0125, 296.0 / 0.0125, 297.0 / 0.0125]],
                    rtol=1e-12)
    # a carriage straight above the nozzle stands a whole rod above it
    above_a = np.array([[134.4 * np.cos(np.radians(210.0)), 134.4 * np.sin(np.radians(210.0)), 10.0]])
    assert_allclose(k.carriage_heights(above_a)[0, 0], 279.0, rtol=1e-14)
    targets = printable_points(50, np.random.default_rng(1))
    assert_allclose(k.positions(k.steps(targets)), targets, atol=1e-9)
    with pytest.raises(GeometryError, match="arm_length must be above delta_radius"):
        KlipperDelta(300.0, k.angle, k.arm_length, k.position_endstop)


def test_klipper_model_of_the_nominal_printer_is_deltacals_exact_kinematics(tmp_path, kossel):
    """Klipper's model read from a printer.cfg (every digit) is deltacal's linear Delta to 1e-9 mm."""
    klipper = load_klipper(write_config(tmp_path, save_config_block(KlipperDelta.from_printer(kossel))))
    assert klipper.delta_radius == pytest.approx(kossel.tower_radius - kossel.effector_radius, abs=1e-12)
    geometry = kossel.geometry()
    targets = printable_points(400, np.random.default_rng(2))
    readings = exact.inverse(geometry, targets)
    assert_allclose(klipper.inverse(targets, kossel.step_distance), readings, atol=1e-9)
    assert_allclose(klipper.forward(readings, kossel.step_distance), targets, atol=1e-9)
    # and the other way: deltacal's forward kinematics of what Klipper commands
    commanded = klipper.inverse(targets, kossel.step_distance)
    assert_allclose(exact.forward(geometry, commanded).point(geometry.tool), targets, atol=1e-9)


def test_klippers_model_has_no_horizontal_nozzle_offset(kossel):
    from dataclasses import replace

    with pytest.raises(GeometryError, match="no horizontal nozzle offset"):
        KlipperDelta.from_printer(replace(kossel, tool=np.array([5.0, 0.0, -30.0])))


def test_a_missing_tower_section_is_named(tmp_path, kossel):
    main = PRINTER_CFG.replace("#delta_radius: 132.0", "delta_radius: 134.4").replace(
        "#position_endstop: 297.0\n#arm_length: 269.0", "position_endstop: 297.0\narm_length: 269.0")
    start = main.index("[stepper_c]")
    main = main[:start] + main[main.index("[probe]"):]
    with pytest.raises(InputError, match=r"printer.cfg: missing section \[stepper_c\] \(a delta printer"):
        load_klipper(write_config(tmp_path, "", main))
