"""Simulated rotary Delta printers run by Klipper's ``rotary_delta`` values, measured as Klipper measures.

The true printer is a deltacal rotary :class:`~deltacal.geometry.DeltaGeometry` in Klipper's bed
frame (the true bed z = 0). Klipper's values ``config`` command a nozzle position x as steps from
the endstops ``n = config.steps(x)`` (:mod:`.firmware.klipper.rotary_model`); deltacal's readings of
them are ``q = n d − θ_end`` with d and θ_end the step distance and endstop angles of a reference,
the printer's nominal values (``q = −θ`` for the nominal values, :meth:`KlipperRotaryDelta.readings`):
what an arm does at the endstop and per step is the truth's (its ``encoder_offset`` and
``joint_scale``), whatever values command it.

* :func:`klipper_truth`: the printer Klipper's model describes exactly, with true values (the
  errors Klipper calibrates: shoulder height, endstops, shoulder radius, angles);
* :func:`probe_triggers`: the commanded positions at which the nozzle touches the true bed at
  commanded x, y (Klipper's probe points), by a secant on the commanded z;
* :func:`printed_distances`: the true distances between features printed at commanded positions;
* :func:`nozzle_errors`: where the true nozzle lands less the target, a configuration commanding it.

Units: mm, rad.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..geometry import DeltaGeometry
from ..kinematics import exact
from .firmware.klipper.rotary_model import KlipperRotaryDelta
from .simulation import trigger_zeros


@dataclass(frozen=True, eq=False)
class RotaryPrinter:
    """A true rotary printer and the reference of its readings.

    Attributes:
        geometry: The true printer in Klipper's bed frame (the true bed z = 0).
        reference: The values whose step distances and endstop angles define the readings (the
            printer's nominal values).
    """

    geometry: DeltaGeometry
    reference: KlipperRotaryDelta

    def readings(self, config: KlipperRotaryDelta, commanded: np.ndarray) -> np.ndarray:
        """The readings (deltacal's) of the steps ``config`` commands for nozzle positions [rad], (N, 3)."""
        steps = config.steps(commanded)
        return steps * self.reference.step_distance - self.reference.endstop_angles

    def nozzle(self, config: KlipperRotaryDelta, commanded: np.ndarray) -> np.ndarray:
        """The true nozzle at commanded positions, ``config`` commanding them [mm], (N, 3)."""
        pose = exact.forward(self.geometry, self.readings(config, np.atleast_2d(commanded)))
        return pose.point(self.geometry.tool)


def klipper_truth(true: KlipperRotaryDelta, reference: KlipperRotaryDelta, effector_radius: float,
                  rod_spacing: float, nozzle_drop: float) -> RotaryPrinter:
    """The printer Klipper's model with the values ``true`` describes, its readings ``reference``'s.

    The arm's true angle at the endstop is ``true``'s endstop angle: the truth's encoder offset is
    ``θ_end,ref − θ_end,true`` (the step distances must be the same).
    """
    geometry = true.geometry(effector_radius, rod_spacing, nozzle_drop)
    geometry = geometry.moved_rigidly(np.eye(3), np.array([0.0, 0.0, true.base_height(nozzle_drop)]))
    offset = reference.endstop_angles - true.endstop_angles
    return RotaryPrinter(_with_offset(geometry, offset), reference)


def _with_offset(geometry: DeltaGeometry, offset: np.ndarray) -> DeltaGeometry:
    return replace(geometry, encoder_offset=np.asarray(geometry.encoder_offset, dtype=float) + offset)


def probe_triggers(printer: RotaryPrinter, config: KlipperRotaryDelta, xy: np.ndarray,
                   max_iter: int = 30, trigger_height: np.ndarray | None = None) -> np.ndarray:
    """Commanded nozzle positions at which the true nozzle touches the bed (z = 0) [mm], (N, 2) -> (N, 3).

    Args:
        printer: The true printer (its tool the point that triggers: the nozzle, or a probe's tip).
        config: Klipper's values commanding it.
        xy: Commanded x, y [mm], (N, 2).
        max_iter: Secant iterations at most.
        trigger_height: The nozzle's height above the bed at each trigger [mm], (N,) (None: 0, it
            touches the bed; a paper test's: the paper's thickness).

    Raises:
        ConvergenceError: the secant on the commanded z did not converge.
    """
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    goal = np.zeros(len(xy)) if trigger_height is None else np.asarray(trigger_height, float).reshape(-1)

    def height(z: np.ndarray) -> np.ndarray:
        return printer.nozzle(config, np.column_stack([xy, z]))[:, 2] - goal

    return np.column_stack([xy, trigger_zeros(height, goal.copy(), max_iter)])


def printed_distances(printer: RotaryPrinter, config: KlipperRotaryDelta, pairs: np.ndarray) -> np.ndarray:
    """True distances between features printed at commanded positions [mm], (M, 6) -> (M,)."""
    pairs = np.atleast_2d(np.asarray(pairs, dtype=float))
    first, second = printer.nozzle(config, pairs[:, :3]), printer.nozzle(config, pairs[:, 3:])
    return np.linalg.norm(second - first, axis=1)


def nozzle_errors(printer: RotaryPrinter, config: KlipperRotaryDelta, targets: np.ndarray) -> np.ndarray:
    """Where the true nozzle lands less the target, ``config`` commanding each target [mm], (N, 3)."""
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    return printer.nozzle(config, targets) - targets
