"""Klipper's rotary Delta (``kinematics: rotary_delta``): its values with Klipper's meaning, its kinematics
against deltacal's exact rotary kinematics and against the pinned Klipper's own code, and the import.
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
from deltacal.exceptions import InputError
from deltacal.io.robot import load_nominal
from deltacal.kinematics import exact
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta

ROTARY = Path(__file__).resolve().parent / "data" / "klipper" / "rotary"
EXAMPLE = ROTARY / "example-rotary-delta.cfg"
#: Klipper's example's gearing: gear_ratio 107:16, 60:16 -> 25.078125; 200 full steps x 16 microsteps.
EXAMPLE_STEP_RAD = 2.0 * math.pi / (200 * 16 * (107.0 / 16.0) * (60.0 / 16.0))


def _grid(radius: float, bottom: float, top: float) -> np.ndarray:
    """Nozzle targets in Klipper's frame: the centre and rings at 1/2 and the full radius, 5 heights."""
    points = []
    for z in np.linspace(bottom, top, 5):
        points.append([0.0, 0.0, z])
        for r in (0.5 * radius, radius):
            for phi in np.radians(np.arange(0.0, 360.0, 30.0) + 7.0):
                points.append([r * math.cos(phi), r * math.sin(phi), z])
    return np.array(points)


def _uneven() -> KlipperRotaryDelta:
    """A rotary printer whose arms all differ (every per-stepper override of Klipper's in use)."""
    return KlipperRotaryDelta(35.2, 405.0, np.radians([31.0, 149.2, 271.5]), [170.0, 171.3, 168.8],
                              [320.0, 318.7, 321.9], [252.0, 250.4, 253.1], [EXAMPLE_STEP_RAD] * 3)


def _example() -> KlipperRotaryDelta:
    return rotary_from_config(read_klipper_config(EXAMPLE))


# ---------------------------------------------------------------- Klipper's values, worked by hand
def test_the_example_reads_with_klippers_defaults_and_meaning():
    """Klipper's example-rotary-delta.cfg, by hand.

    [printer] shoulder_radius 33.9, shoulder_height 412.9; [stepper_a] upper 170, lower 320, endstop
    252, B and C without them: A's (Klipper's defaults); no angle anywhere: 30, 150, 270.
    Step: 2 pi / (200 x 16 x 107/16 x 60/16) = 2 pi / 80250 = 7.82947e-5 rad.
    Endstop angle (nozzle at (0, 0, 252)), arm A's plane: the nozzle is sjx = -33.9 out, sjy = 252 -
    412.9 = -160.9 up from the shoulder. Elbow (170 cos t, 170 sin t) at 320 from it:
    67.8 ex + 321.8 ey = 320^2 - 170^2 - 33.9^2 - 160.9^2 = 46461.98, so 11526 cos t + 54706 sin t =
    46461.98: R = 55907.0, phi = atan2(54706, 11526) = 78.102 deg, acos(46461.98 / 55907.0) = 33.785
    deg, t = 78.102 - 33.785 = 44.317 deg (the outer elbow; 111.89 the inner).
    limit_z = 412.9 + 170 sin(44.31) - 320 = 211.65; max_xy = min(33.9 + 170, 320 - 33.9) = 203.9.
    """
    k = _example()
    assert k.shoulder_radius == 33.9 and k.shoulder_height == 412.9
    assert_allclose(np.degrees(k.angle), [30.0, 150.0, 270.0], rtol=0, atol=1e-12)
    assert_allclose(k.upper_arm, [170.0] * 3, rtol=0, atol=0)
    assert_allclose(k.lower_arm, [320.0] * 3, rtol=0, atol=0)
    assert_allclose(k.position_endstop, [252.0] * 3, rtol=0, atol=0)
    assert_allclose(k.step_distance, [2.0 * math.pi / 80250.0] * 3, rtol=1e-12)
    assert_allclose(np.degrees(k.endstop_angles), [44.31] * 3, rtol=0, atol=0.01)
    assert k.limit_z == pytest.approx(211.65, abs=0.01)
    assert k.max_radius == pytest.approx(203.9, abs=1e-9)
    assert k.max_z == 252.0
    assert_allclose(k.home_position, [0.0, 0.0, 252.0], rtol=0, atol=1e-9)  # the arms alike: the centre


def test_per_stepper_overrides_and_the_save_config_block(tmp_path):
    """B's arms and C's angle overridden; the SAVE_CONFIG block's values, the rest's copies commented out
    as Klipper's SAVE_CONFIG writes them (a key both places keeps the rest's value, tests/test_import.py)."""
    text = EXAMPLE.read_text().replace("shoulder_height: 412.900", "#shoulder_height: 412.900", 1)
    text = text.replace("position_endstop: 252", "#position_endstop: 252", 1)
    text = text.replace("[stepper_b]\n", "[stepper_b]\nupper_arm_length: 171\nlower_arm_length: 321\n", 1)
    text = text.replace("[stepper_c]\n", "[stepper_c]\nangle: 271\n", 1)
    text += ("\n#*# <---------------------- SAVE_CONFIG ---------------------->\n"
             "#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n"
             "#*# [printer]\n#*# shoulder_height = 413.500000\n#*#\n"
             "#*# [stepper_a]\n#*# angle = 30.200000\n#*# position_endstop = 252.400000\n")
    (tmp_path / "printer.cfg").write_text(text)
    k = rotary_from_config(read_klipper_config(tmp_path / "printer.cfg"))
    assert k.shoulder_height == 413.5
    assert_allclose(np.degrees(k.angle), [30.2, 150.0, 271.0], rtol=0, atol=1e-12)
    assert_allclose(k.upper_arm, [170.0, 171.0, 170.0], rtol=0, atol=0)
    assert_allclose(k.lower_arm, [320.0, 321.0, 320.0], rtol=0, atol=0)
    # B and C take A's position_endstop, the saved one
    assert_allclose(k.position_endstop, [252.4] * 3, rtol=0, atol=0)


# ------------------------------------------------------------- Klipper's kinematics = deltacal's
@pytest.mark.parametrize("model", [_example, _uneven], ids=["example", "uneven"])
def test_klippers_inverse_kinematics_is_deltacals_exact_one(model):
    """At 125 targets of the printable volume, Klipper's arm angles (written from kin_rotary_delta.c)
    are deltacal's exact inverse kinematics of the converted geometry, q = -theta, to 1e-9 rad; and
    Klipper's forward kinematics (its trilateration) returns the targets."""
    k = model()
    targets = _grid(50.0, 0.0, k.limit_z)
    theta = k.shoulder_angles(targets)
    for a, c, drop in ((30.0, 50.0, 30.0), (22.5, 40.0, 41.0)):
        geometry = k.geometry(a, c, drop)
        q = exact.inverse(geometry, k.to_base(targets, drop), tol=1e-12)
        assert np.max(np.abs(q - k.readings(theta))) < 1e-9
    assert np.max(np.abs(k.positions(theta) - targets)) < 1e-9
    assert_allclose(k.step_positions(k.steps(targets)), targets, rtol=0, atol=1e-9)


def test_the_frames_signs_and_branch():
    """Arm A (angle 30) points outward along 30 deg; theta > 0 raises the elbow (deltacal's q lowers it);
    the outer elbow is taken: at the centre top every arm is raised, at the bed lowered."""
    k = _example()
    elbow = k.elbows(np.zeros((1, 3)))[0]
    assert_allclose(elbow[0], [203.9 * math.cos(math.radians(30)), 203.9 * math.sin(math.radians(30)), 412.9],
                    rtol=0, atol=1e-9)
    assert k.elbows(np.full((1, 3), 0.1))[0, 0, 2] > 412.9
    top, bed = k.shoulder_angles([[0.0, 0.0, 252.0], [0.0, 0.0, 0.0]])
    assert np.all(top > 0.0) and np.all(bed < 0.0)
    assert np.all(k.readings(bed) > 0.0)
    # a target beyond the arms is refused, or NaN without the check
    assert np.all(np.isnan(k.shoulder_angles([[0.0, 0.0, -400.0]], check=False)))


_KLIPPY_SCRIPT = """
import json, math, sys
import chelper
ffi_main, ffi_lib = chelper.get_ffi()
data = json.load(sys.stdin)
out = []
for i, (a, ua, la) in enumerate(zip(data["angles"], data["upper"], data["lower"])):
    sk = ffi_main.gc(ffi_lib.rotary_delta_stepper_alloc(
        data["radius"], data["height"], math.radians(a), ua, la), ffi_lib.free)
    out.append([ffi_lib.itersolve_calc_position_from_coord(sk, x, y, z) for x, y, z in data["targets"]])
json.dump(out, sys.stdout)
"""


def test_klipper_itself_gives_the_same_arm_angles(klipper):
    """The pinned Klipper's C kinematics (rotary_delta_stepper_alloc, as RotaryDeltaKinematics sets it
    up) at the same targets: the same angles to 1e-12 rad."""
    k = _uneven()
    targets = _grid(50.0, 0.0, k.limit_z)
    data = {"radius": k.shoulder_radius, "height": k.shoulder_height, "angles": np.degrees(k.angle).tolist(),
            "upper": k.upper_arm.tolist(), "lower": k.lower_arm.tolist(), "targets": targets.tolist()}
    done = subprocess.run([sys.executable, "-c", _KLIPPY_SCRIPT], cwd=klipper / "klippy",
                          input=json.dumps(data), capture_output=True, text=True, check=True, timeout=120)
    theirs = np.array(json.loads(done.stdout)).T
    assert np.max(np.abs(theirs - k.shoulder_angles(targets))) < 1e-12


# ----------------------------------------------------------------------------- deltacal import
def test_import_writes_the_rotary_robot_file_of_klippers_model(tmp_path, capsys):
    """Example, effector radius 25, nozzle drop 40, rod spacing 45, by hand: base radius 33.9 + 25 =
    58.9; bed at z = -(412.9 + 40) = -452.9; workspace radius 50 ([delta_calibrate] radius), height
    limit_z - 0 = 211.65, top 211.65 - 452.9 = -241.25."""
    out = tmp_path / "out"
    assert main(["import", str(EXAMPLE), "-o", str(out), "--effector-radius", "25", "--nozzle-drop", "40",
                 "--rod-spacing", "45"]) == 0
    said = capsys.readouterr().out
    assert "rotary_delta" in said and "bed at z = -452.9 mm" in said
    assert sorted(p.name for p in out.iterdir()) == ["printer.toml"]
    data = tomllib.loads((out / "printer.toml").read_text())
    assert "kind" not in data  # a rotary robot file
    geo = data["geometry"]
    assert geo["base_radius_mm"] == pytest.approx(58.9, abs=1e-12)
    assert (geo["plate_radius_mm"], geo["arm_length_mm"], geo["rod_length_mm"], geo["rod_spacing_mm"]) == \
        (25.0, 170.0, 320.0, 45.0)
    assert geo["limb_azimuth_deg"] == [30.0, 150.0, 270.0]
    assert geo["tool_mm"] == [0.0, 0.0, -40.0]
    ws = data["workspace"]
    assert ws["radius_mm"] == 50.0
    assert ws["height_mm"] == pytest.approx(211.65, abs=0.01)
    assert ws["top_z_mm"] == pytest.approx(-241.25, abs=0.01)
    # the robot file's nominal robot, commanded through Klipper's model, puts the nozzle where commanded
    nominal = load_nominal(out / "printer.toml")
    k = _example()
    targets = _grid(50.0, 0.0, k.limit_z)
    q = exact.inverse(nominal.geometry(), k.to_base(targets, 40.0), tol=1e-12)
    assert np.max(np.abs(q + k.shoulder_angles(targets))) < 1e-9


def test_import_refuses_per_arm_lengths_in_one_line(tmp_path, capsys):
    cfg = tmp_path / "printer.cfg"
    cfg.write_text(EXAMPLE.read_text().replace("[stepper_b]\n", "[stepper_b]\nlower_arm_length: 321\n", 1))
    assert main(["import", str(cfg), "-o", str(tmp_path / "out")]) != 0
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "key lower_arm_length" in err and "320, 321, 320" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("edit", "words"), [
    (("gear_ratio: 107.000:16, 60:16\nendstop_pin: ^PE4", "rotation_distance: 40\nendstop_pin: ^PE4"),
     "section [stepper_a], key rotation_distance"),
    (("shoulder_height: 412.900\n", ""), "missing required key 'shoulder_height'"),
    (("upper_arm_length: 170.000\n", "upper_arm_length: -170\n"), "key upper_arm_length"),
])
def test_bad_rotary_values_are_named(tmp_path, edit, words):
    cfg = tmp_path / "printer.cfg"
    text = EXAMPLE.read_text()
    assert edit[0] in text
    cfg.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(InputError, match=words.replace("[", r"\[").replace("]", r"\]")):
        rotary_from_config(read_klipper_config(cfg))
