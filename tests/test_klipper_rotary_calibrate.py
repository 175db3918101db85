"""Klipper's own rotary DELTA_CALIBRATE (basic and extended), emulated: against the pinned Klipper's own
calibration code on the same inputs, and on simulated rotary printers.
"""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.printer.firmware.klipper.calibrate import delta_analyze_distances, object_pairs, probe_points
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import (
    klipper_rotary_basic,
    klipper_rotary_extended,
)
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta

ROTARY = Path(__file__).resolve().parent / "data" / "klipper" / "rotary"
EXAMPLE = ROTARY / "example-rotary-delta.cfg"


def _example() -> KlipperRotaryDelta:
    return rotary_from_config(read_klipper_config(EXAMPLE))


def _uneven() -> KlipperRotaryDelta:
    """Values off the example's (every value Klipper fits and holds differs per arm)."""
    k = _example()
    return KlipperRotaryDelta(34.6, 410.3, np.radians([30.4, 149.1, 270.7]), [170.0, 171.3, 168.8],
                              [320.0, 318.7, 321.9], [251.2, 252.9, 250.6], k.step_distance)


#: Klipper's own calculate_params (extras/delta_calibrate.py) on RotaryDeltaCalibration
#: (kinematics/rotary_delta.py), with mathutil's coordinate descent run in this process (not its
#: background process), from the commanded probe positions (calc_stable_position) and, for the
#: extended method, DELTA_ANALYZE's readings (measurements_to_distances).
_KLIPPY_SCRIPT = """
import json, sys
import mathutil
from kinematics import rotary_delta
from extras import delta_calibrate
data = json.load(sys.stdin)
mathutil.background_coordinate_descent = (
    lambda printer, adj, params, func: mathutil.coordinate_descent(adj, params, func))
cal = rotary_delta.RotaryDeltaCalibration(
    data["radius"], data["height"], data["angles"], data["upper"], data["lower"], data["endstops"],
    data["stepdists"])
class Kin:
    def get_calibration(self):
        return cal
class Toolhead:
    def get_kinematics(self):
        return Kin()
class Printer:
    def lookup_object(self, name):
        return Toolhead()
class Gcode:
    def respond_info(self, msg, log=True):
        pass
class Driver:
    printer, gcode, manual_heights = Printer(), Gcode(), []
    def save_state(self, probe_positions, distances, new):
        self.new = new
driver = Driver()
probes = [(data["z_offset"], cal.calc_stable_position(p)) for p in data["probe"]]
distances = []
if data["analyze"]:
    entry = dict(data["analyze"], SCALE=[1.0])
    distances = delta_calibrate.measurements_to_distances(entry, cal)
delta_calibrate.DeltaCalibrate.calculate_params(driver, probes, distances)
new = driver.new
json.dump({"shoulder_height": new.shoulder_height, "shoulder_radius": new.shoulder_radius,
           "angles": list(new.angles), "endstops": list(new.endstops)}, sys.stdout)
"""


def _klippers_own(klipper: Path, k: KlipperRotaryDelta, probe: np.ndarray, z_offset: float,
                  analyze: dict | None) -> dict:
    data = {"radius": k.shoulder_radius, "height": k.shoulder_height, "angles": np.degrees(k.angle).tolist(),
            "upper": k.upper_arm.tolist(), "lower": k.lower_arm.tolist(),
            "endstops": k.position_endstop.tolist(), "stepdists": k.step_distance.tolist(),
            "probe": probe.tolist(), "z_offset": z_offset, "analyze": analyze}
    done = subprocess.run([sys.executable, "-c", _KLIPPY_SCRIPT], cwd=klipper / "klippy",
                          input=json.dumps(data), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


def _off(k: KlipperRotaryDelta) -> KlipperRotaryDelta:
    """A printer whose 7 values Klipper fits are off k's: shoulder height +0.8, radius +0.4, angles A, B
    +0.2, -0.3 deg, endstops +0.3, -0.5, +0.2 mm."""
    return replace(k, shoulder_height=k.shoulder_height + 0.8, shoulder_radius=k.shoulder_radius + 0.4,
                   angle=k.angle + np.radians([0.2, -0.3, 0.0]),
                   position_endstop=k.position_endstop + [0.3, -0.5, 0.2])


def _probe(k: KlipperRotaryDelta) -> np.ndarray:
    """Commanded triggers at Klipper's 7 probe points (radius 50) of :func:`_off`'s bed, probed through k."""
    bed = np.column_stack([probe_points(50.0), np.zeros(7)])
    return k.step_positions(_off(k).steps(bed))


#: DELTA_ANALYZE readings of a printed calibrate_size.stl (as a user types them).
ANALYZE = {"CENTER_DISTS": [74.12, 73.86, 74.31, 73.95, 74.02, 74.20],
           "CENTER_PILLAR_WIDTHS": [9.05, 8.97, 9.02],
           "OUTER_DISTS": [73.91, 74.18, 74.07, 73.83, 74.26, 73.99],
           "OUTER_PILLAR_WIDTHS": [9.01, 8.96, 9.04, 9.00, 8.98, 9.03]}


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize("model", [_example, _uneven], ids=["example", "uneven"])
def test_basic_is_klippers_own_calibration(klipper, model):
    """The pinned Klipper's DeltaCalibrate.calculate_params on RotaryDeltaCalibration, from the same
    commanded probe triggers (z_offset 0.25): the same 4 values to 1e-6 (mm), the rest held."""
    k = model()
    probe = _probe(k)
    theirs = _klippers_own(klipper, k, probe, 0.25, None)
    ours = klipper_rotary_basic(k, probe, 0.25)
    assert abs(ours.shoulder_height - theirs["shoulder_height"]) < 1e-6
    assert_allclose(ours.position_endstop, theirs["endstops"], rtol=0, atol=1e-6)
    assert ours.shoulder_radius == k.shoulder_radius == theirs["shoulder_radius"]
    assert_allclose(np.degrees(ours.angle), theirs["angles"], rtol=0, atol=1e-9)
    # the calibration moved the values (the comparison is not of the start)
    assert abs(ours.shoulder_height - k.shoulder_height) > 0.01


@pytest.mark.long
@pytest.mark.slow
@pytest.mark.parametrize("model", [_example, _uneven], ids=["example", "uneven"])
def test_extended_is_klippers_own_calibration(klipper, model):
    """The same with DELTA_ANALYZE's readings (CALIBRATE=extended): the same 7 values to 1e-6 (mm, deg)."""
    k = model()
    probe = _probe(k)
    theirs = _klippers_own(klipper, k, probe, 0.0, ANALYZE)
    distances = delta_analyze_distances(ANALYZE["CENTER_DISTS"], ANALYZE["CENTER_PILLAR_WIDTHS"],
                                        ANALYZE["OUTER_DISTS"], ANALYZE["OUTER_PILLAR_WIDTHS"])
    ours = klipper_rotary_extended(k, probe, object_pairs(), distances)
    assert abs(ours.shoulder_height - theirs["shoulder_height"]) < 1e-6
    assert abs(ours.shoulder_radius - theirs["shoulder_radius"]) < 1e-6
    assert_allclose(ours.position_endstop, theirs["endstops"], rtol=0, atol=1e-6)
    assert_allclose(np.degrees(ours.angle), theirs["angles"], rtol=0, atol=1e-6)
    assert abs(ours.shoulder_radius - k.shoulder_radius) > 0.01
    assert np.degrees(ours.angle[2]) == pytest.approx(np.degrees(k.angle[2]), abs=1e-9)
