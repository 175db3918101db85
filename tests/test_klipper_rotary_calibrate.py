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

from deltacal.geometry import Tolerances, Workspace
from deltacal.printer.firmware.fitting import printable_grid
from deltacal.printer.firmware.klipper.calibrate import delta_analyze_distances, object_pairs, probe_points
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import (
    klipper_rotary_basic,
    klipper_rotary_extended,
    stable_positions,
)
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_model import KlipperRotaryDelta
from deltacal.printer.rotary_simulation import (
    RotaryPrinter,
    klipper_truth,
    nozzle_errors,
    printed_distances,
    probe_triggers,
)

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


# ------------------------------------------------------------------ on simulated rotary printers
#: The effector deltacal's geometry gives Klipper's point effector (radius, rod spacing, nozzle drop).
EFFECTOR = (30.0, 50.0, 40.0)
#: The volume judged: the example's probe radius (50 mm), z 0.2 to 100 mm.
VOLUME = printable_grid(Workspace(radius=50.0, height=100.0, top_z=100.0))


def _klipper_only(seed: int) -> tuple[KlipperRotaryDelta, RotaryPrinter]:
    """The example with Klipper-model errors only: shoulder height (σ 1 mm), endstops (σ 0.5 mm) off."""
    k = _example()
    rng = np.random.default_rng(seed)
    true = replace(k, shoulder_height=k.shoulder_height + rng.normal(0.0, 1.0),
                   position_endstop=k.position_endstop + rng.normal(0.0, 0.5, 3))
    return k, klipper_truth(true, k, *EFFECTOR)


def test_the_simulated_printer_is_klippers_model_with_its_values():
    """The printer built from true values, commanded with them, lands on the targets (1e-9 mm); commanded
    with the nominal ones it does not (the errors are there, mm); the nominal readings are -theta; the
    probe triggers put the true nozzle on the bed and Klipper's stable positions of them through the true
    values are on the bed."""
    k, printer = _klipper_only(0)
    assert_allclose(printer.readings(k, VOLUME), k.readings(k.shoulder_angles(VOLUME)), rtol=0, atol=1e-12)
    assert np.max(np.abs(nozzle_errors(printer, k, VOLUME))) > 0.5
    probe = probe_triggers(printer, k, probe_points(50.0))
    assert_allclose(probe[:, :2], probe_points(50.0), rtol=0, atol=0)
    assert np.max(np.abs(printer.nozzle(k, probe)[:, 2])) < 1e-9
    assert np.max(np.abs(probe[:, 2])) > 0.1


def test_basic_calibration_recovers_klippers_own_errors():
    """Klipper-model errors only (seed 0: shoulder height and endstops off): the nominal values leave
    1.51 mm 3-D max over the volume; Klipper's basic calibration leaves the probe heights within 0.002 mm
    and 0.032 mm 3-D max (its shoulder height and endstops trade: 0.12 mm off together, the descent's
    answer)."""
    k, printer = _klipper_only(0)
    probe = probe_triggers(printer, k, probe_points(50.0))
    new = klipper_rotary_basic(k, probe)
    assert np.max(np.abs(stable_positions(new, k.steps(probe))[:, 2])) < 0.002
    before = np.linalg.norm(nozzle_errors(printer, k, VOLUME), axis=1).max()
    after = np.linalg.norm(nozzle_errors(printer, new, VOLUME), axis=1).max()
    assert before > 1.0
    assert after < 0.05


@pytest.mark.long
@pytest.mark.slow
def test_klippers_calibrations_leave_the_errors_its_model_lacks():
    """Three printers with Klipper-model errors only (seeds 0-2) and three perturbed in deltacal's
    complete model (default rotary tolerances, seeds 100-102): the 3-D max over the volume.

    Klipper-only: nominal 1.51, 4.26, 4.65; basic 0.032, 0.138, 0.180 (probe heights within 0.009:
    the descent stops at 10000 rounds on the shoulder height / endstops valley); extended 0.018, 0.081,
    0.054. Complete model: nominal 1.75, 2.93, 3.47; basic 0.21, 0.30, 0.32; extended 0.44, 0.41, 0.49.
    """
    pairs = object_pairs()
    k = _example()
    g0 = k.geometry(*EFFECTOR)
    printers = [_klipper_only(seed)[1] for seed in range(3)]
    for seed in range(100, 103):
        g = g0.perturbed(Tolerances(), np.random.default_rng(seed))
        up = np.array([0.0, 0.0, k.base_height(EFFECTOR[2])])
        printers.append(RotaryPrinter(g.moved_rigidly(np.eye(3), up), k))
    figures = []
    for printer in printers:
        probe = probe_triggers(printer, k, probe_points(50.0))
        basic = klipper_rotary_basic(k, probe)
        extended = klipper_rotary_extended(k, probe, pairs, printed_distances(printer, k, pairs))
        figures.append([np.linalg.norm(nozzle_errors(printer, c, VOLUME), axis=1).max()
                        for c in (k, basic, extended)])
    f = np.array(figures)
    assert_allclose(f, [[1.509, 0.032, 0.018], [4.261, 0.138, 0.081], [4.649, 0.180, 0.054],
                        [1.754, 0.211, 0.443], [2.927, 0.304, 0.407], [3.465, 0.324, 0.488]],
                    rtol=0, atol=0.002)
