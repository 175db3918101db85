"""Simulated measurements of a linear Delta printer through its firmware.

A true printer (:func:`random_printer`: a perturbed geometry expressed with its true bed as z = 0)
runs a firmware configuration (:class:`~deltacal.printer.firmware.klipper.model.KlipperDelta`): a commanded
position x becomes steps ``n = firmware.steps(x)``, deltacal's readings ``n d`` (d the printer's
nominal step distance), and the real nozzle is at the truth's exact forward kinematics of them.

* :func:`probe_heights`: the commanded z at which the probe touches the bed, found per point by a
  vectorised secant iteration on the commanded z (x, y as commanded), plus the trigger's noise;
* :func:`printed_distances`: the true distance between two features printed at commanded
  positions, plus the caliper's noise.

Tolerance classes (:func:`well_built`, :func:`typical_kit`) match the uncalibrated errors of the
issue's anchor table (3-D max at Klipper's nominal values 1.22 mm and 1.62 mm, mean of 5
printers). Units: mm, rad (degrees where named).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..exceptions import ConvergenceError
from ..geometry import DeltaGeometry, Tolerances
from ..kinematics import exact
from .firmware.base import FirmwareModel
from .robot import NominalLinearDelta

#: The secant iteration on the commanded z stops below this change [mm].
PROBE_TOLERANCE = 1e-10
#: Standard deviation of the bed's height in the nominal frame [mm] (a bed screwed in place).
BED_HEIGHT_SIGMA = 0.5


def well_built() -> Tolerances:
    """Errors of a carefully built printer (the anchor's "well built" class).

    Towers placed to 0.05 mm and leaning 0.01 deg, endstops to 0.55 mm (uncalibrated), step
    distances to 0.03 %, balls to 0.01 mm and rods to 0.02 mm; with
    :data:`WELL_BUILT_BED_TILT_DEG`. Chosen so that Klipper's nominal values leave about the
    anchor's uncalibrated 3-D max error (1.22 mm); most of it is the endstops' and the bed's. The bed's
    tilt is what Klipper's basic calibration leaves most of (it turns it into lean and XY distortion).
    """
    return Tolerances(ball_centre=0.01, rod_length=0.02, axis_position=0.05,
                      axis_direction=math.radians(0.01), encoder_offset=0.55, joint_scale=0.0003)


def typical_kit() -> Tolerances:
    """Errors of a typical kit (the anchor's "typical kit" class).

    Towers placed to 0.12 mm and leaning 0.05 deg, endstops to 0.6 mm, step distances to 0.1 %,
    balls to 0.05 mm and rods to 0.1 mm (the two rods of a pair differ); with
    :data:`KIT_BED_TILT_DEG`. Chosen so that Klipper's nominal values leave about the anchor's
    uncalibrated 3-D max error (1.62 mm). :meth:`Tolerances.printer_kit` (lean 0.15 deg, step
    distances 0.3 %) leaves about 4.2 mm: towers lean about their top (the endstop), so a lean
    moves the carriage's path at the bed by about 1.2 mm.
    """
    return Tolerances(ball_centre=0.05, rod_length=0.1, axis_position=0.12,
                      axis_direction=math.radians(0.05), encoder_offset=0.6, joint_scale=0.001)


#: Standard deviation of each of the bed's two tilts [deg], per class.
WELL_BUILT_BED_TILT_DEG = 0.02
KIT_BED_TILT_DEG = 0.05
#: The build tolerances of a perturbed printer and the σ of its bed's tilts [deg], by the name
#: ``simulate --tolerances`` takes (default ``printer-kit``: :meth:`Tolerances.printer_kit`).
TOLERANCE_CLASSES = {
    "printer-kit": (Tolerances.printer_kit, KIT_BED_TILT_DEG),
    "typical-kit": (typical_kit, KIT_BED_TILT_DEG),
    "well-built": (well_built, WELL_BUILT_BED_TILT_DEG),
}


@dataclass(frozen=True)
class TruePrinter:
    """A simulated printer and how it was made.

    Attributes:
        geometry: The true printer, the true bed as z = 0.
        errors: The manufacturing errors added to the nominal geometry, by name (read back with
            :meth:`DeltaGeometry.deviation_from`: the axis tilts to first order).
        bed_rotation: The rigid motion that put the true bed at z = 0, (3, 3).
        bed_translation: Its translation [mm], (3,).
    """

    geometry: DeltaGeometry
    errors: dict[str, float]
    bed_rotation: np.ndarray
    bed_translation: np.ndarray


def bed_motion(tilt_x: float, tilt_y: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """The rigid motion taking a bed (through (0, 0, height), tilted by these angles [rad]) to z = 0.

    The bed's normal is ``R_y(tilt_y) R_x(tilt_x) z``; the motion turns it back to z and moves the
    bed's centre to the origin: ``x -> R (x − (0, 0, height))``.
    """
    cx, sx, cy, sy = math.cos(tilt_x), math.sin(tilt_x), math.cos(tilt_y), math.sin(tilt_y)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rotation = (ry @ rx).T
    return rotation, -rotation @ np.array([0.0, 0.0, height])


def random_true_printer(nominal: NominalLinearDelta, rng: np.random.Generator,
                        tolerances: Tolerances | None = None, bed_tilt_deg: float = KIT_BED_TILT_DEG,
                        bed_height: float = BED_HEIGHT_SIGMA) -> TruePrinter:
    """A random printer around the nominal one, with what made it (see :func:`random_printer`)."""
    tolerances = Tolerances.printer_kit() if tolerances is None else tolerances
    geometry = nominal.geometry()
    perturbed = geometry.perturbed(tolerances, rng)
    errors = perturbed.deviation_from(geometry)
    tilt = np.radians(rng.normal(0.0, bed_tilt_deg, 2)) if bed_tilt_deg > 0.0 else np.zeros(2)
    height = float(rng.normal(0.0, bed_height)) if bed_height > 0.0 else 0.0
    rotation, translation = bed_motion(float(tilt[0]), float(tilt[1]), height)
    return TruePrinter(perturbed.moved_rigidly(rotation, translation), errors, rotation, translation)


def random_printer(nominal: NominalLinearDelta, rng: np.random.Generator,
                   tolerances: Tolerances | None = None, bed_tilt_deg: float = KIT_BED_TILT_DEG,
                   bed_height: float = BED_HEIGHT_SIGMA) -> DeltaGeometry:
    """A random true printer: its geometry perturbed, then expressed with its true bed as z = 0.

    Args:
        nominal: The nominal printer.
        rng: Random generator (seeded for reproducible printers).
        tolerances: Manufacturing errors (default :meth:`Tolerances.printer_kit`).
        bed_tilt_deg: Standard deviation of each of the bed's two tilts [deg].
        bed_height: Standard deviation of the bed's height [mm].

    Returns:
        The true printer's geometry.
    """
    return random_true_printer(nominal, rng, tolerances, bed_tilt_deg, bed_height).geometry


def nozzle_positions(truth: DeltaGeometry, firmware: FirmwareModel, step_distance: np.ndarray | float,
                     commanded: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
    """Where a plate point (default: the nozzle) of the truth is at commanded positions [mm], (N, 3)."""
    commanded = np.atleast_2d(np.asarray(commanded, dtype=float))
    pose = exact.forward(truth, firmware.inverse(commanded, step_distance))
    return pose.point(truth.tool if point is None else point)


def probe_heights(truth: DeltaGeometry, firmware: FirmwareModel, step_distance: np.ndarray | float,
                  xy: np.ndarray, sigma_mm: float, rng: np.random.Generator,
                  probe_offset: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
                  max_iter: int = 30, trigger_height: np.ndarray | None = None) -> np.ndarray:
    """Commanded nozzle positions at which the probe triggers over the true bed (z = 0), with trigger noise.

    Args:
        truth: The true printer (the true bed is z = 0).
        firmware: The configuration the probing is done with.
        step_distance: The printer's nominal step distance (deltacal's readings) [mm].
        xy: Commanded nozzle x, y [mm], (N, 2).
        sigma_mm: Standard deviation of the trigger's height [mm] (added to the commanded z).
        rng: Random generator.
        probe_offset: The probe's tip relative to the nozzle, in the effector frame [mm], (3,).
        max_iter: Secant iterations at most.
        trigger_height: The probe tip's height above the bed at each trigger [mm], (N,) (None: 0,
            the tip touches the bed).

    Returns:
        Commanded positions (x, y, z) [mm], (N, 3).

    Raises:
        ConvergenceError: the iteration did not converge.
    """
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    tip = truth.tool + np.asarray(probe_offset, dtype=float)

    goal = np.zeros(len(xy)) if trigger_height is None else np.asarray(trigger_height, float).reshape(-1)

    def height(z: np.ndarray) -> np.ndarray:
        return nozzle_positions(truth, firmware, step_distance, np.column_stack([xy, z]), tip)[:, 2] - goal

    z1 = trigger_zeros(height, goal - np.asarray(probe_offset, dtype=float)[2], max_iter)
    return np.column_stack([xy, z1 + rng.normal(0.0, sigma_mm, len(xy)) if sigma_mm > 0.0 else z1])


def trigger_zeros(height: Callable[[np.ndarray], np.ndarray], z0: np.ndarray,
                  max_iter: int = 30) -> np.ndarray:
    """The commanded z at which ``height`` (the probe tip above its trigger) is 0, each point's: a secant.

    From ``z0`` and ``z0 + 1``, to :data:`PROBE_TOLERANCE`; a point already there (equal heights) stays.

    Raises:
        ConvergenceError: not converged in ``max_iter`` iterations.
    """
    z1 = z0 + 1.0
    h0, h1 = height(z0), height(z1)
    for _ in range(max_iter):
        slope = np.where(z1 != z0, (h1 - h0) / np.where(z1 != z0, z1 - z0, 1.0), 1.0)
        # a point already on the bed has h1 = h0: it stays (no 0 / 0)
        z2 = z1 - np.divide(h1, slope, out=np.zeros_like(h1), where=slope != 0.0)
        if np.max(np.abs(z2 - z1)) < PROBE_TOLERANCE:
            return z2
        z0, h0, z1 = z1, h1, z2
        h1 = height(z1)
    raise ConvergenceError(f"probe heights did not converge in {max_iter} iterations", float("nan"))


def printed_distances(truth: DeltaGeometry, firmware: FirmwareModel, step_distance: np.ndarray | float,
                      pairs: np.ndarray, sigma_mm: float, rng: np.random.Generator) -> np.ndarray:
    """True distances between features printed at commanded positions, with caliper noise [mm], (M,).

    Args:
        truth: The true printer.
        firmware: The configuration the object was printed with.
        step_distance: The printer's nominal step distance [mm].
        pairs: Commanded (x1, y1, z1, x2, y2, z2) [mm], (M, 6).
        sigma_mm: Standard deviation of each measured distance [mm].
        rng: Random generator.
    """
    pairs = np.atleast_2d(np.asarray(pairs, dtype=float))
    first = nozzle_positions(truth, firmware, step_distance, pairs[:, :3])
    second = nozzle_positions(truth, firmware, step_distance, pairs[:, 3:])
    distance = np.linalg.norm(second - first, axis=1)
    return distance + rng.normal(0.0, sigma_mm, len(distance)) if sigma_mm > 0.0 else distance
