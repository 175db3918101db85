"""Real rotary Delta printers' Klipper configurations (tests/data/klipper/real/rotary-*.cfg), each
imported with its numbers worked out by hand.

One real ``kinematics: rotary_delta`` configuration is public as a file: Egris89's printer
(github.com/Egris89/Rotary-Delta, 2021; the file's header names the commit). Its non-default arm
angles (A at 270, B at 30, C at 150) and its per-arm endstops (197.5, 197.5, 197.2) are Klipper's
per-stepper keys in real use.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.cli.main import main
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config

EGRIS89 = Path(__file__).resolve().parent / "data" / "klipper" / "real" / "rotary-egris89-2021.cfg"

# ------------------------------------------------------------------ Egris89's printer, by hand
# [printer] shoulder_radius r = 45, shoulder_height h = 411.45; every arm upper u = 190, lower l = 393.
# Step: 2 pi / (200 full steps x 128 microsteps x 21.88125) = 2 pi / 560160 = 1.1216769e-5 rad.
EGRIS89_STEP_RAD = 2.0 * math.pi / 560160.0
# Endstop angle t (nozzle at (0, 0, p), in the arm's plane): the nozzle is -r out and p - h up from the
# shoulder, the elbow (u cos t, u sin t) is l from it:
#   2 u r cos t - 2 u (p - h) sin t = l^2 - u^2 - r^2 - (p - h)^2.
# A and B, p = 197.5: p - h = -213.95; 17100 cos t + 81301 sin t = 154449 - 36100 - 2025 - 45774.6025
#   = 70549.3975; R = hypot(17100, 81301) = 83079.857, atan2(81301, 17100) = 78.1221 deg,
#   acos(70549.3975 / 83079.857) = 31.8779 deg, t = 78.1221 - 31.8779 = 46.2443 deg (the outer elbow).
# C, p = 197.2: p - h = -214.25; 17100 cos t + 81415 sin t = 154449 - 36100 - 2025 - 45903.0625
#   = 70420.9375; R = 83191.419, atan2 = 78.1383 deg, acos(70420.9375 / 83191.419) = 32.1678 deg,
#   t = 45.9705 deg.
# The source's README gives "about 46.50 deg" as the arm angle when homed, measured: within 0.55 deg.
EGRIS89_ENDSTOP_DEG = [46.2443, 46.2443, 45.9705]
# limit_z = min(h + u sin t - l): A, B 411.45 + 190 sin(46.2443) - 393 = 155.686; C 411.45 + 190
#   sin(45.9705) - 393 = 155.057: 155.057. max_xy = min(r + u, l - r) = min(235, 348) = 235;
#   max_z = min(position_endstop) = 197.2.
EGRIS89_LIMIT_Z = 155.0567


def test_egris89_reads_with_klippers_meaning():
    """Every value of the real file with Klipper's meaning, by hand (above): no default taken."""
    k = rotary_from_config(read_klipper_config(EGRIS89))
    assert (k.shoulder_radius, k.shoulder_height) == (45.0, 411.45)
    assert_allclose(np.degrees(k.angle), [270.0, 30.0, 150.0], rtol=0, atol=1e-12)
    assert_allclose(k.upper_arm, [190.0] * 3, rtol=0, atol=0)
    assert_allclose(k.lower_arm, [393.0] * 3, rtol=0, atol=0)
    assert_allclose(k.position_endstop, [197.5, 197.5, 197.2], rtol=0, atol=0)
    assert_allclose(k.step_distance, [EGRIS89_STEP_RAD] * 3, rtol=1e-12)
    assert k.minimum_z_position == -5.0
    assert_allclose(np.degrees(k.endstop_angles), EGRIS89_ENDSTOP_DEG, rtol=0, atol=1e-4)
    assert_allclose(np.degrees(k.endstop_angles), [46.5] * 3, rtol=0, atol=0.55)  # the README's measured
    assert k.limit_z == pytest.approx(EGRIS89_LIMIT_Z, abs=1e-4)
    assert k.max_radius == pytest.approx(235.0, abs=1e-9)
    assert k.max_z == 197.2  # Klipper's max_z: the lowest position_endstop (rotary_delta.py)


def test_egris89_import_writes_the_robot_file_worked_by_hand(tmp_path, capsys):
    """``deltacal import`` with the README's effector radius 35 (rod spacing, nozzle drop by default: 50,
    30), by hand: base radius 45 + 35 = 80 (the README's base radius); azimuths the file's 270, 30, 150;
    bed at z = -(411.45 + 30) = -441.45; workspace radius 50 ([delta_calibrate] radius), height
    limit_z - minimum_z_position = 155.0567 + 5 = 160.0567, top 155.0567 - 441.45 = -286.3933. No
    [delta_calibrate] measurements saved: the robot file alone. Commanded through Klipper's model, the
    robot file's nominal robot puts the nozzle where commanded (its arms at their own azimuths)."""
    out = tmp_path / "out"
    assert main(["import", str(EGRIS89), "-o", str(out), "--effector-radius", "35"]) == 0
    said = capsys.readouterr().out
    assert "bed at z = -441.45 mm" in said
    assert "defaults taken: rod spacing 50 mm, nozzle drop 30 mm" in said
    assert sorted(p.name for p in out.iterdir()) == ["printer.toml"]
    data = tomllib.loads((out / "printer.toml").read_text())
    geo = data["geometry"]
    assert (geo["base_radius_mm"], geo["plate_radius_mm"], geo["arm_length_mm"], geo["rod_length_mm"],
            geo["rod_spacing_mm"]) == (80.0, 35.0, 190.0, 393.0, 50.0)
    assert geo["limb_azimuth_deg"] == [270.0, 30.0, 150.0]
    assert geo["tool_mm"] == [0.0, 0.0, -30.0]
    ws = data["workspace"]
    assert ws["radius_mm"] == 50.0
    assert ws["height_mm"] == pytest.approx(EGRIS89_LIMIT_Z + 5.0, abs=1e-4)
    assert ws["top_z_mm"] == pytest.approx(EGRIS89_LIMIT_Z - 441.45, abs=1e-4)
    k = rotary_from_config(read_klipper_config(EGRIS89))
    targets = np.array([[x, y, z] for z in (-5.0, 60.0, EGRIS89_LIMIT_Z - 0.01)
                        for x, y in ((0.0, 0.0), (50.0, 0.0), (0.0, -50.0), (-30.0, 35.0))])
    q = exact.inverse(load_nominal(out / "printer.toml").geometry(), k.to_base(targets, 30.0), tol=1e-12)
    assert np.max(np.abs(q + k.shoulder_angles(targets))) < 1e-9


_KLIPPY_ENDSTOPS = """
import json, math, sys
import chelper
ffi_main, ffi_lib = chelper.get_ffi()
d = json.load(sys.stdin)
out = []
for a, p in zip(d["angles"], d["endstops"]):
    sk = ffi_main.gc(ffi_lib.rotary_delta_stepper_alloc(d["radius"], d["height"], math.radians(a),
                                                        d["upper"], d["lower"]), ffi_lib.free)
    out.append(math.degrees(ffi_lib.itersolve_calc_position_from_coord(sk, 0., 0., p)))
json.dump(out, sys.stdout)
"""


def test_egris89_endstop_angles_worked_by_hand_are_klippers_own(klipper):
    """The pinned Klipper's C kinematics (as RotaryDeltaKinematics finds each endstop angle: the arm's
    angle at (0, 0, position_endstop)) gives the hand-worked angles 46.2443, 46.2443, 45.9705 deg."""
    data = {"radius": 45.0, "height": 411.45, "upper": 190.0, "lower": 393.0,
            "angles": [270.0, 30.0, 150.0], "endstops": [197.5, 197.5, 197.2]}
    done = subprocess.run([sys.executable, "-c", _KLIPPY_ENDSTOPS], cwd=klipper / "klippy",
                          input=json.dumps(data), capture_output=True, text=True, check=True, timeout=120)
    assert_allclose(json.loads(done.stdout), EGRIS89_ENDSTOP_DEG, rtol=0, atol=1e-4)
