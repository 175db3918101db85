"""A rotary Delta printer's full geometry identified from probe heights and printed distances (library level):
simulated printers measured as Klipper measures them, identified with the rotary printer model from the
nominal start, corrected through Klipper's rotary kinematics; against Klipper's own extended calibration
on the same data.

The object: the linear printer's planned object (:mod:`deltacal.printer.printed`: its layout for a
printable cylinder of radius 80 mm and 100 mm high, its candidate pairs for a 150 mm caliper, the 40
distances its D-optimal selection picks with the rotary printer model's rows at the nominal printer,
through Klipper's nominal inverse). The probe: Klipper's round 9 x 9 mesh over r <= 64 mm (49 points).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from deltacal.controller import corrected_targets
from deltacal.geometry import Tolerances, Workspace
from deltacal.printer.firmware.fitting import printable_grid
from deltacal.printer.firmware.klipper.config import read_klipper_config
from deltacal.printer.firmware.klipper.rotary_calibrate import klipper_rotary_basic, klipper_rotary_extended
from deltacal.printer.firmware.klipper.rotary_config import rotary_from_config
from deltacal.printer.firmware.klipper.rotary_controller import KlipperRotaryController
from deltacal.printer.identification.errormodels import RotaryPrinterModel
from deltacal.printer.identification.fit import PrinterMeasurements, identify_printer, residuals_and_regressor
from deltacal.printer.printed.object import blocking, candidate_pairs, object_layout, probe_grid
from deltacal.printer.printed.plan import select_pairs
from deltacal.printer.robot import less_bed_motion
from deltacal.printer.rotary_simulation import RotaryPrinter, nozzle_errors, printed_distances, probe_triggers
from tests.test_klipper_rotary import EXAMPLE

#: The effector deltacal's geometry gives Klipper's point effector (radius, rod spacing, nozzle drop).
EFFECTOR = (30.0, 50.0, 40.0)
#: The volume judged, as the rotary calibrate tests': r <= 50 mm, z 0.2 to 100 mm.
VOLUME = printable_grid(Workspace(radius=50.0, height=100.0, top_z=100.0))
#: The object's printable cylinder (the linear object's pads need more than 50 mm of radius).
OBJECT = Workspace(radius=80.0, height=100.0, top_z=100.0)
#: Rotary build tolerances (the rotary robot's defaults, :class:`Tolerances`, rods as a printer kit's and
#: gear ratios to 0.2 %), and a well-built printer's (balls, rods, shoulders 4-5 times better; the endstop
#: switches the same).
KIT = Tolerances(ball_centre=0.05, rod_length=0.1, axis_position=0.2, axis_direction=math.radians(0.1),
                 encoder_offset=math.radians(0.3), joint_scale=0.002)
WELL_BUILT = Tolerances(ball_centre=0.01, rod_length=0.02, axis_position=0.05,
                        axis_direction=math.radians(0.02), encoder_offset=math.radians(0.3),
                        joint_scale=0.0005)


def _nominal():
    k = rotary_from_config(read_klipper_config(EXAMPLE))
    return k, k.geometry(*EFFECTOR).moved_rigidly(np.eye(3), np.array([0.0, 0.0, k.base_height(EFFECTOR[2])]))


def _plan(k, nominal, tolerances) -> tuple[np.ndarray, np.ndarray]:
    """The probe points (49, 2) and the planned object's 40 pairs, commanded (40, 6) [mm]."""
    model = RotaryPrinterModel()
    probe = probe_grid(0.8 * OBJECT.radius, 9)
    layout = object_layout(OBJECT, k.angle, 150.0)
    pairs = candidate_pairs(layout, 150.0)
    ends = layout.centres[pairs]
    data = PrinterMeasurements(k.readings(k.shoulder_angles(probe)),
                               k.readings(k.shoulder_angles(ends.reshape(-1, 3))).reshape(-1, 2, 3),
                               np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1))
    _, W, kind = residuals_and_regressor(nominal, model, data)
    W = W * model.prior_sigma(tolerances)
    information = np.eye(W.shape[1]) + W[kind == 0].T @ W[kind == 0]
    chosen = select_pairs(W[kind == 1], information, 40, layout, pairs, blocking(layout, pairs), at_least=1)
    return probe[:, :2], ends[chosen].reshape(-1, 6)


def _figures(k, nominal, tolerances, seed):
    """3-D max over the volume, raw and less the bed motion: Klipper's nominal, basic, extended; ours."""
    rng = np.random.default_rng(seed)
    truth = nominal.perturbed(tolerances, rng)
    printer = RotaryPrinter(replace(truth, joint_scale=1.0 + rng.normal(0.0, tolerances.joint_scale, 3)), k)
    xy, pairs = _plan(k, nominal, tolerances)
    probe = probe_triggers(printer, k, xy)
    probe[:, 2] += rng.normal(0.0, 0.01, len(probe))  # the probe's repeatability
    distances = printed_distances(printer, k, pairs) + rng.normal(0.0, 0.02, len(pairs))  # the caliper's
    data = PrinterMeasurements(printer.readings(k, probe), np.stack(
        [printer.readings(k, pairs[:, :3]), printer.readings(k, pairs[:, 3:])], axis=1), distances)
    result = identify_printer(nominal, data, RotaryPrinterModel(), tolerances=tolerances)
    controller = KlipperRotaryController(k)
    ours = printer.nozzle(k, corrected_targets(result.geometry, controller, VOLUME).commands) - VOLUME
    errors = [nozzle_errors(printer, c, VOLUME) for c in
              (k, klipper_rotary_basic(k, probe), klipper_rotary_extended(k, probe, pairs, distances))]
    errors.append(ours)
    return [[float(np.linalg.norm(e, axis=1).max()) for e in errors],
            [float(np.linalg.norm(less_bed_motion(VOLUME, e)[0], axis=1).max()) for e in errors]]


@pytest.mark.long
@pytest.mark.slow
def test_identified_rotary_printers_against_klippers_extended_calibration():
    """Three kits and three well-built printers (seeds 200-202), Klipper's example values, the bed frame's
    truth with every error of the complete model and the arms' gear ratios (none of which but the
    endstops Klipper's model holds). 3-D max over r <= 50, z 0.2..100 mm, less the shift along the bed and
    turn about its normal no probe or caliper sees (raw in brackets):

    ========  ==============  ==============  ==============  ==============
    printer   nominal         Klipper basic   Klipper ext.    ours
    ========  ==============  ==============  ==============  ==============
    kit 200   0.561 (0.901)   0.174 (0.517)   0.167 (0.447)   0.035 (0.490)
    kit 201   1.231 (3.370)   0.329 (0.672)   0.310 (0.614)   0.035 (1.403)
    kit 202   1.021 (1.276)   0.458 (0.801)   0.466 (1.311)   0.035 (0.224)
    well 200  0.734 (1.505)   0.041 (0.110)   0.043 (0.103)   0.023 (0.274)
    well 201  0.895 (3.314)   0.085 (0.163)   0.087 (0.130)   0.025 (0.421)
    well 202  1.106 (1.346)   0.117 (0.198)   0.105 (0.301)   0.033 (0.098)
    ========  ==============  ==============  ==============  ==============

    Ours is at most 1/3 of Klipper's extended on 5 of the 6 (0.08-0.31), 0.54 on well-built 200; raw, the
    motion along the bed the identification cannot see dominates ours (the nominal's frame kept).
    """
    k, nominal = _nominal()
    figures = np.array([_figures(k, nominal, tolerances, seed)
                        for tolerances in (KIT, WELL_BUILT) for seed in (200, 201, 202)])
    less = figures[:, 1]
    assert_allclose(less, [[0.561, 0.174, 0.167, 0.035], [1.231, 0.329, 0.310, 0.035],
                           [1.021, 0.458, 0.466, 0.035], [0.734, 0.041, 0.043, 0.023],
                           [0.895, 0.085, 0.087, 0.025], [1.106, 0.117, 0.105, 0.033]], rtol=0, atol=0.002)
    assert_allclose(figures[:, 0, 3], [0.490, 1.403, 0.224, 0.274, 0.421, 0.098], rtol=0, atol=0.002)
    assert np.all(less[:, 3] < 0.6 * less[:, 2])
