"""Klipper's move limits (``klippy/kinematics/delta.py``, ``DeltaKinematics.check_move``), a point each side.

The facts are Klipper's, computed here from its source's formulas: ``max_z`` the lowest
``position_endstop``; ``minimum_z_position`` (default 0); ``max_xy = min(print_radius (default
delta_radius), min arm - radius, ratio_to_xy(4 * SLOW_RATIO))`` with ``ratio_to_xy(r) = r sqrt(arm² /
(r² + 1) - h²) + h - radius``, h half the smallest step distance; above ``limit_z = min(abs_endstop -
arm)`` the radius at most ``max_z - z``; a move to the home position's X, Y between the minimum Z and
the home's Z passes (a homing move).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from deltacal.exceptions import InputError
from deltacal.printer.firmware.klipper.config import klipper_config_text, load_klipper
from deltacal.printer.firmware.klipper.model import (
    ABOVE_MAX_Z,
    BELOW_MIN_Z,
    BEYOND_RADIUS,
    BEYOND_TAPER,
)

RADIUS, ARM, ENDSTOPS, ROTATION, MICROSTEPS = 134.4, 269.0, (295.6, 295.0, 295.3), 40.0, 16
EPS = 1e-6  # [mm] each side of a limit: far above the limits' rounding, far below any test's margin


def _cfg(tmp_path, printer_extra: str = "", name: str = "printer.cfg"):
    text = ("[printer]\nkinematics: delta\nmax_velocity: 300\nmax_accel: 3000\n"
            f"delta_radius: {RADIUS}\n{printer_extra}")
    for tower, endstop in zip("abc", ENDSTOPS, strict=True):
        text += (f"\n[stepper_{tower}]\nmicrosteps: {MICROSTEPS}\nrotation_distance: {ROTATION}\n"
                 f"arm_length: {ARM}\nposition_endstop: {endstop}\n")
    path = tmp_path / name
    path.write_text(text)
    return path


def _facts(print_radius: float = RADIUS) -> dict[str, float]:
    """Klipper's limits of the test's printer, from delta.py's formulas."""
    half = 0.5 * ROTATION / (200 * MICROSTEPS)
    ratio = 12.0
    ratio_xy = ratio * math.sqrt(ARM**2 / (ratio**2 + 1.0) - half**2) + half - RADIUS
    abs_endstops = [e + math.sqrt(ARM**2 - RADIUS**2) for e in ENDSTOPS]
    return {"max_z": min(ENDSTOPS), "limit_z": min(a - ARM for a in abs_endstops),
            "max_xy": min(print_radius, ARM - RADIUS, ratio_xy)}


def test_the_limits_are_klippers(tmp_path):
    klipper = load_klipper(_cfg(tmp_path))
    facts = _facts()
    assert klipper.max_z == facts["max_z"]
    assert klipper.limit_z == pytest.approx(facts["limit_z"], abs=1e-12)
    assert klipper.max_radius == pytest.approx(facts["max_xy"], abs=1e-12)
    assert klipper.minimum_z_position == 0.0 and klipper.print_radius is None
    # the home: every carriage at its endstop, each rod's length from its carriage point
    tops = np.column_stack([klipper.towers, klipper.carriage_top])
    assert np.linalg.norm(tops - klipper.home_position, axis=1) == pytest.approx([ARM] * 3, abs=1e-9)


def test_a_point_each_side_of_each_limit(tmp_path):
    klipper = load_klipper(_cfg(tmp_path))
    facts = _facts()
    max_z, limit_z, max_xy = facts["max_z"], facts["limit_z"], facts["max_xy"]
    direction = np.array([math.cos(1.0), math.sin(1.0)])
    taper_z = limit_z + 1.0
    taper = max_z - taper_z  # the taper's radius at that height, within max_xy
    assert taper < max_xy
    inside = [[0.0, 0.0, 0.0], [0.0, 0.0, max_z - EPS], [*((max_xy - EPS) * direction), 10.0],
              [*((taper - EPS) * direction), taper_z],
              [*((max_xy - EPS) * direction), limit_z - EPS]]  # no taper at or below limit_z
    outside = [([0.0, 0.0, -EPS], BELOW_MIN_Z), ([0.0, 0.0, max_z + EPS], ABOVE_MAX_Z),
               ([*((max_xy + EPS) * direction), 10.0], BEYOND_RADIUS),
               ([*((taper + EPS) * direction), taper_z], BEYOND_TAPER)]
    assert klipper.outside(np.array(inside)).tolist() == [0] * len(inside)
    assert klipper.outside(np.array([p for p, _ in outside])).tolist() == [code for _, code in outside]


def test_print_radius_and_minimum_z_position_are_read_and_bind(tmp_path):
    klipper = load_klipper(_cfg(tmp_path, "print_radius: 100\nminimum_z_position: -0.5\n"))
    assert klipper.print_radius == 100.0 and klipper.minimum_z_position == -0.5
    assert klipper.max_radius == _facts(100.0)["max_xy"] == 100.0
    points = np.array([[100.0 - EPS, 0, 5], [100.0 + EPS, 0, 5], [0, 0, -0.5], [0, 0, -0.5 - EPS]])
    assert klipper.outside(points).tolist() == [0, BEYOND_RADIUS, 0, BELOW_MIN_Z]
    assert "set [printer] print_radius: 100.01" in klipper.refusal(points[1:2])


def test_a_homing_move_passes_above_max_z(tmp_path):
    """Klipper lets a move end at the home's X, Y exactly up to the home's Z (its endstops differ)."""
    klipper = load_klipper(_cfg(tmp_path))
    home = klipper.home_position
    assert home[2] > klipper.max_z + 0.1
    z = klipper.max_z + 0.1
    points = np.array([[home[0], home[1], z], [home[0] + 1e-3, home[1], z], [home[0], home[1], home[2] + 0.1],
                       [home[0], home[1], -EPS]])
    assert klipper.outside(points).tolist() == [0, ABOVE_MAX_Z, ABOVE_MAX_Z, BELOW_MIN_Z]


def test_the_refusal_names_the_key_and_a_value_that_admits_every_command(tmp_path):
    klipper = load_klipper(_cfg(tmp_path))
    commands = np.array([[10.0, 0.0, -0.016], [0.0, 5.0, -0.003], [0.0, 0.0, -0.0199]])
    text = klipper.refusal(commands)
    assert text.startswith("corrected Z -0.0160 mm is below minimum_z_position 0 of printer.cfg: set "
                           "[printer] minimum_z_position: -0.02")
    assert np.all(klipper.with_minimum_z(-0.02).outside(commands) == 0)
    # the value asked, as its text reads back, admits the lowest command and is within 0.01 mm of it
    for z in np.random.default_rng(7).uniform(-1.0, -1e-6, 200):
        value = float(klipper.refusal(np.array([[0.0, 0.0, z]])).rsplit(": ", 1)[1])
        assert z - 0.01 <= value <= z
        assert klipper.with_minimum_z(value).outside(np.array([[0.0, 0.0, z]]))[0] == 0
    far = np.array([[200.0, 0.0, 5.0]])
    assert "the arms' reach" in klipper.refusal(far) and "no key admits it" in klipper.refusal(far)


def test_minimum_z_position_above_the_lowest_endstop_is_refused(tmp_path):
    with pytest.raises(InputError, match=r"section \[printer\], key minimum_z_position: value 296 must be at "
                                         r"most 295, the lowest position_endstop"):
        load_klipper(_cfg(tmp_path, "minimum_z_position: 296\n"))


def test_the_writer_writes_the_limits_set_and_reads_them_back(tmp_path):
    klipper = load_klipper(_cfg(tmp_path, "print_radius: 120.5\nminimum_z_position: -0.03\n"))
    for complete in (True, False):
        text = klipper_config_text(klipper, _cfg(tmp_path), complete=complete)
        assert "print_radius: 120.5" in text and "minimum_z_position: -0.03" in text
    back_file = tmp_path / "back.cfg"
    back_file.write_text(klipper_config_text(klipper, complete=True))
    back = load_klipper(back_file)
    assert back.print_radius == 120.5 and back.minimum_z_position == -0.03
    default = load_klipper(_cfg(tmp_path))
    assert "print_radius" not in klipper_config_text(default, complete=True)
    assert "minimum_z_position" not in klipper_config_text(default, complete=True)
