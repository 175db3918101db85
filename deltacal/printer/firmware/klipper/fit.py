"""Klipper's values that fit an identified linear Delta printer best.

Klipper's delta model (:class:`~.model.KlipperDelta`) has vertical towers, one rod
per tower and a point effector; a real printer differs in every element. For each target t of a
grid over the printable volume, Klipper commands steps ``n(t)`` (its closed-form inverse); the real
printer (its identified geometry, the true bed as z = 0) puts the nozzle at ``T(n d)`` (exact
forward kinematics, d the printer's nominal step distance: deltacal's readings); the residual is
``T − t``. :func:`fit_klipper` minimises the sum of squares by Gauss-Newton on Klipper's
``delta_radius``, three ``angle``, three ``arm_length``, three ``position_endstop`` and (unless held)
three step distances (its ``rotation_distance``), with the Jacobian ``dT/dq · dq/dk``: ``dT/dq`` from
the exact forward Jacobian with the nozzle's lever, ``dq/dk`` by central differences of Klipper's
closed form. The printer's frame is fixed by its bed, so no value is a gauge (the towers' common
rotation is not: it turns the printed part on the bed); the scaled pivoted QR and the singular
values of the Jacobian say what the grid cannot tell apart, and those values are held.

What the values leave per error source, for any firmware: :func:`~..budget.error_budget`.

Units: mm and rad (the dataclass's angles), degrees only in reports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ....geometry import DeltaGeometry, Workspace
from ..base import CLASSICAL_NAMES, FirmwareFit, Flatness
from ..fitting import EXPORT_FIRST_LAYER_WEIGHT as EXPORT_FIRST_LAYER_WEIGHT
from ..fitting import FIRST_LAYER as FIRST_LAYER
from ..fitting import TOLERANCE as TOLERANCE
from ..fitting import ErrorStats as ErrorStats
from ..fitting import ValueVector, gauss_newton
from ..fitting import error_stats as error_stats
from ..fitting import first_layer as first_layer
from ..fitting import nozzle_errors as nozzle_errors
from ..fitting import printable_grid as printable_grid
from .model import KlipperDelta

#: Klipper's values in the order of the fit's unknowns (step distances last): the classical names.
KLIPPER_NAMES = CLASSICAL_NAMES
#: The index of ``angle_c`` in :data:`KLIPPER_NAMES`.
_ANGLE_C = 3


def values_of(klipper: KlipperDelta) -> np.ndarray:
    """Klipper's values in the order of :data:`KLIPPER_NAMES` (angles in rad) [mm, rad], (13,)."""
    return np.concatenate([[klipper.delta_radius], klipper.angle, klipper.arm_length,
                           klipper.position_endstop, klipper.step_distance])


def with_values(klipper: KlipperDelta, values: np.ndarray) -> KlipperDelta:
    """The configuration with the 13 values of :data:`KLIPPER_NAMES` [mm, rad]."""
    v = np.asarray(values, dtype=float)
    return replace(klipper, delta_radius=float(v[0]), angle=v[1:4], arm_length=v[4:7],
                   position_endstop=v[7:10], step_distance=v[10:13])


#: Klipper's values as the fit's unknowns: central-difference steps of its closed form per value
#: [mm, rad; relative for the step distances].
KLIPPER_VALUES: ValueVector[KlipperDelta] = ValueVector(
    KLIPPER_NAMES, (1e-4,) + (1e-7,) * 3 + (1e-4,) * 6 + (1e-7,) * 3, 10, values_of, with_values)


#: What :func:`fit_klipper` returns: the firmwares' one fit value, its ``values`` a :class:`KlipperDelta`.
KlipperFit = FirmwareFit


def fit_klipper(
    geometry: DeltaGeometry,
    start: KlipperDelta,
    step_distance: np.ndarray | float,
    workspace: Workspace,
    hold_step_distance: bool = False,
    grid: np.ndarray | None = None,
    max_iter: int = 30,
    first_layer_weight: float = 0.0,
    part_frame: bool = True,
    minimax: bool = False,
    flatness: Flatness = None,
    hold: Sequence[str] = (),
) -> FirmwareFit[KlipperDelta]:
    """Klipper's values that leave the least squared nozzle error over the printable volume.

    With ``first_layer_weight`` w > 0 the sum also has the z errors over the first layer's disc
    (:func:`~..fitting.first_layer`) times w: the first layer's flatness bought with some of the volume's
    error. With ``part_frame`` the volume's errors are those of the printed part: less the shift
    along the bed and the turn about its normal that fit them best (:func:`~...robot.less_bed_motion`:
    no measurement sees them and a part printed so is the same part), fitted with the values;
    the towers' common turn is then (to first order) the part's turn, so ``angle_c`` is held, as
    Klipper's own calibration holds it. The loop is :func:`~..fitting.gauss_newton`.

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The configuration to start from (its step distances are kept when held).
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (radius; heights 0.2 mm to its top).
        hold_step_distance: Keep the configuration's step distances (``rotation_distance``).
        grid: Targets [mm], (N, 3) (default :func:`~..fitting.printable_grid`).
        max_iter: Gauss-Newton iterations at most.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        part_frame: Judge the volume's errors in the printed part's frame (see above).
        minimax: Then the least largest error over the grid, the first layer no less flat
            (:func:`~..fitting.least_largest`).
        flatness: With ``minimax``, the first layer's largest |z error| allowed instead [mm].
        hold: Values (:data:`KLIPPER_NAMES`) kept at the start's.

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a target out of Klipper's reach.
    """
    grid = printable_grid(workspace) if grid is None else np.atleast_2d(np.asarray(grid, dtype=float))
    wanted = [c for c in range(10 if hold_step_distance else 13)
              if not (part_frame and c == _ANGLE_C) and KLIPPER_NAMES[c] not in hold]
    found = gauss_newton(geometry, start, KLIPPER_VALUES, step_distance, workspace, grid, wanted, max_iter,
                         first_layer_weight, part_frame, "Klipper", minimax, flatness)
    fitted = [KLIPPER_NAMES[c] for c in found.columns]
    return FirmwareFit(
        values=found.model,
        fitted=fitted,
        held=[n for n in KLIPPER_NAMES if n not in set(fitted)],
        unidentifiable=found.unidentifiable,
        singular_values=found.singular_values,
        before=error_stats(geometry, start, step_distance, workspace, grid, part_frame),
        after=error_stats(geometry, found.model, step_distance, workspace, grid, part_frame),
        iterations=found.iterations,
        points=grid.shape[0],
    )

