"""Klipper's rotary_delta values that fit an identified rotary Delta printer best.

Klipper's rotary model (:class:`~.rotary_model.KlipperRotaryDelta`) has horizontal shoulder axes
tangent to one circle, a point effector and one rod per arm; a real printer differs in every element.
For each target t of a grid over the printable volume (Klipper's frame, the bed's) Klipper with
values K commands each arm ``n = (θ_end(K) − θ_K(t)) / d`` steps from its endstop; the printer's
arm, homed at its own endstop, turns by ``n d``. The geometry's readings are those of the
configuration it was identified with, S (``q = −θ_S``, as :mod:`.rotary_controller` compensates
through it), so the reading K commands is

    ``q_K(t) = θ_end(K) − θ_end(S) − θ_K(t)``

(the step distance cancels: it is the printer's, held), and the residual is the true nozzle
``T(q_K(t)) − t``, the geometry put in Klipper's frame by the configuration's shoulder height
(the bed at ``z = −(shoulder_height + nozzle drop)`` in {O}, :mod:`.rotary_importer`). The values
fitted: ``shoulder_height``, ``shoulder_radius``, each stepper's ``angle``, ``upper_arm_length``,
``lower_arm_length`` and ``position_endstop``; the loop is the linear printers'
(:func:`~..fitting.gauss_newton`, then :func:`~..fitting.least_largest`), the first layer weighted as
the export weights it, the volume's errors judged in the printed part's frame (so stepper C's
``angle``, the part's turn, is held, as for a linear printer).

Units: mm and rad (the dataclass's angles).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ....geometry import DeltaGeometry, Workspace
from ..fitting import (
    EXPORT_FIRST_LAYER_WEIGHT,
    ErrorStats,
    ValueVector,
    error_stats,
    gauss_newton,
    printable_grid,
)
from .config import STEPPERS
from .rotary_controller import KlipperRotaryController
from .rotary_model import KlipperRotaryDelta

#: Klipper's rotary values in the order of the fit's unknowns (its keys, ``_a``.. per stepper).
ROTARY_NAMES = ("shoulder_height", "shoulder_radius",
                *(f"{key}_{s[-1]}" for key in ("angle", "upper_arm_length", "lower_arm_length",
                                               "position_endstop") for s in STEPPERS))
#: The index of ``angle_c`` in :data:`ROTARY_NAMES`: the printed part's turn, held in its frame.
_ANGLE_C = 4


@dataclass(frozen=True, eq=False)
class RotaryCommands:
    """Klipper's rotary values as the readings they command of a printer identified under other values.

    Attributes:
        klipper: The values Klipper runs.
        reference: The endstop angles θ_end of the configuration the readings are counted in [rad], (3,).
    """

    klipper: KlipperRotaryDelta
    reference: np.ndarray

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float = 0.0,
                check: bool = True) -> np.ndarray:
        """The readings ``θ_end(K) − θ_end(S) − θ_K(t)`` commanded for nozzle targets [rad], (N, 3).

        ``step_distance`` is not used: the printer's, it cancels.
        """
        return self.klipper.endstop_angles - self.reference - self.klipper.shoulder_angles(targets, check)


def values_of(commands: RotaryCommands) -> np.ndarray:
    """The values in the order of :data:`ROTARY_NAMES` (angles in rad) [mm, rad], (14,)."""
    k = commands.klipper
    return np.concatenate([[k.shoulder_height, k.shoulder_radius], k.angle, k.upper_arm, k.lower_arm,
                           k.position_endstop])


def with_values(commands: RotaryCommands, values: np.ndarray) -> RotaryCommands:
    """The commands of the 14 values of :data:`ROTARY_NAMES` [mm, rad]."""
    v = np.asarray(values, dtype=float)
    klipper = replace(commands.klipper, shoulder_height=float(v[0]), shoulder_radius=float(v[1]),
                      angle=v[2:5], upper_arm=v[5:8], lower_arm=v[8:11], position_endstop=v[11:14])
    return RotaryCommands(klipper, commands.reference)


#: Klipper's rotary values as the fit's unknowns: central-difference steps [mm, rad], none relative.
ROTARY_VALUES: ValueVector[RotaryCommands] = ValueVector(
    ROTARY_NAMES, (1e-4, 1e-4) + (1e-7,) * 3 + (1e-4,) * 9, len(ROTARY_NAMES), values_of, with_values)


@dataclass(frozen=True)
class RotaryFit:
    """Klipper's rotary values fitted to a rotary printer, and what they leave.

    Attributes:
        values: The fitted values (the start's name, step distances and ``minimum_z_position``).
        fitted: Names (:data:`ROTARY_NAMES`) of the values fitted.
        held: Names held at the start's values (asked, the part's turn, or not identifiable).
        unidentifiable: The held values the grid cannot tell apart from the others.
        singular_values: Singular values of the column-scaled Jacobian, largest first.
        before: Errors with the start's values [mm].
        after: Errors with the fitted values [mm].
        iterations: Gauss-Newton iterations.
        points: Number of grid points.
    """

    values: KlipperRotaryDelta
    fitted: list[str]
    held: list[str]
    unidentifiable: list[str]
    singular_values: np.ndarray
    before: ErrorStats
    after: ErrorStats
    iterations: int
    points: int


def fit_klipper_rotary(geometry: DeltaGeometry, start: KlipperRotaryDelta, volume: Workspace,
                       nozzle_drop_of: DeltaGeometry | None = None, grid: np.ndarray | None = None,
                       first_layer_weight: float = EXPORT_FIRST_LAYER_WEIGHT, minimax: bool = True,
                       part_frame: bool = True, hold: Sequence[str] = (), max_iter: int = 30) -> RotaryFit:
    """Klipper's rotary values whose model puts the nozzle closest to where the printer puts it (the module).

    Args:
        geometry: The printer, a rotary chain in its base frame {O} (the shoulders' centre), its readings
            those ``start`` commands (``q = −θ``).
        start: The configuration the printer runs (the one it was identified with).
        volume: The printable cylinder in Klipper's frame (radius; heights 0.2 mm to its ``top_z``).
        nozzle_drop_of: The robot whose nozzle drop places the bed (the nominal one the geometry was
            identified from); by default ``geometry`` itself.
        grid: Targets in Klipper's frame [mm], (N, 3) (default :func:`~..fitting.printable_grid`).
        first_layer_weight: Weight of the first layer's z errors (default the export's).
        minimax: Then the least largest error over the grid, the first layer no less flat.
        part_frame: Judge the volume's errors in the printed part's frame (``angle_c`` held).
        hold: Values (:data:`ROTARY_NAMES`) kept at the start's.
        max_iter: Gauss-Newton iterations at most.

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a target out of Klipper's reach.
    """
    bed = KlipperRotaryController(start).in_bed_frame(geometry, nozzle_drop_of)
    grid = printable_grid(volume) if grid is None else np.atleast_2d(np.asarray(grid, dtype=float))
    begun = RotaryCommands(start, start.endstop_angles)
    wanted = [c for c, name in enumerate(ROTARY_NAMES)
              if not (part_frame and c == _ANGLE_C) and name not in hold]
    found = gauss_newton(bed, begun, ROTARY_VALUES, 0.0, volume, grid, wanted, max_iter, first_layer_weight,
                         part_frame, "Klipper rotary_delta", minimax)
    fitted = [ROTARY_NAMES[c] for c in found.columns]
    return RotaryFit(
        values=found.model.klipper,
        fitted=fitted,
        held=[n for n in ROTARY_NAMES if n not in set(fitted)],
        unidentifiable=found.unidentifiable,
        singular_values=found.singular_values,
        before=error_stats(bed, begun, 0.0, volume, grid, part_frame),
        after=error_stats(bed, found.model, 0.0, volume, grid, part_frame),
        iterations=found.iterations,
        points=grid.shape[0],
    )
