"""RepRapFirmware's values that fit an identified linear Delta printer best.

As Klipper's (:mod:`..klipper.fit`), by the same loop (:mod:`..fitting`): for each target t of a
grid over the printable volume RRF commands steps ``n(t)`` (its ``Transform``); the real printer
(its identified geometry, the true bed as z = 0) puts the nozzle at ``T(n d)``; :func:`fit_rrf`
minimises the sum of squared residuals ``T − t`` by Gauss-Newton over RRF's values
(:data:`RRF_NAMES`): ``M665 R``, the angle corrections ``X Y`` (``Z`` held: the towers' common turn
turns the printed part on the bed, and RRF's own ``G32`` auto-calibration holds it,
``LinearDeltaKinematics::Adjust``), the diagonals ``L a:b:c``, ``H``, the endstop adjustments
``M666 X Y Z`` (``H`` and their mean are one value: the result is written with adjustments averaging zero,
as ``NormaliseEndstopAdjustments()`` leaves them), the tilt ``M666 A B`` and (unless held) the steps
per mm ``M92 X Y Z``. The Jacobian is ``dT/dq · dq/dk``, ``dq/dk`` by central differences of RRF's
closed form; the volume's errors are judged in the printed part's frame (less the in-plane motion
that fits them best, fitted with the values). Units: mm and rad (the dataclass's angles), tilt as a
fraction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ....geometry import DeltaGeometry, Workspace
from .. import fitting
from ..base import FirmwareFit, Flatness
from ..fitting import ErrorStats, ValueVector, gauss_newton, printable_grid
from .model import RRFDelta

#: RRF's values in the order of the fit's unknowns (steps last).
RRF_NAMES = (
    "M665 R",
    "M665 X",
    "M665 Y",
    "M665 Z",
    "M665 L a",
    "M665 L b",
    "M665 L c",
    "M665 H",
    "M666 X",
    "M666 Y",
    "M666 Z",
    "M666 A",
    "M666 B",
    "step_distance_a",
    "step_distance_b",
    "step_distance_c",
)
#: RRF's value of each classical one (:data:`~..base.CLASSICAL_NAMES`).
CLASSICAL_OF = {"delta_radius": "M665 R", "angle_a": "M665 X", "angle_b": "M665 Y", "angle_c": "M665 Z",
                "arm_length_a": "M665 L a", "arm_length_b": "M665 L b", "arm_length_c": "M665 L c",
                "position_endstop_a": "M666 X", "position_endstop_b": "M666 Y",
                "position_endstop_c": "M666 Z",
                "step_distance_a": "step_distance_a", "step_distance_b": "step_distance_b",
                "step_distance_c": "step_distance_c"}
#: The index of ``M665 Z`` (held: the part's turn) and of the step distances.
_ANGLE_Z = 3
_STEPS = 13
#: Central-difference steps per value [mm, rad, fraction; relative for step distances].
_STEP = (1e-4, 1e-7, 1e-7, 1e-7, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-7, 1e-7, 1e-7, 1e-7, 1e-7)


def values_of(rrf: RRFDelta) -> np.ndarray:
    """RRF's values in the order of :data:`RRF_NAMES` [mm, rad, fraction], (16,)."""
    return np.concatenate(
        [
            [rrf.radius],
            rrf.angle_correction,
            rrf.diagonal,
            [rrf.homed_height],
            rrf.endstop_adjustment,
            rrf.tilt,
            rrf.step_distance,
        ]
    )


def with_values(rrf: RRFDelta, values: np.ndarray) -> RRFDelta:
    """The values of :data:`RRF_NAMES` [mm, rad, fraction] in ``rrf``."""
    v = np.asarray(values, dtype=float)
    return replace(
        rrf,
        radius=float(v[0]),
        angle_correction=v[1:4],
        diagonal=v[4:7],
        homed_height=float(v[7]),
        endstop_adjustment=v[8:11],
        tilt=v[11:13],
        step_distance=v[13:16],
    )


def normalised(rrf: RRFDelta) -> RRFDelta:
    """The same model with endstop adjustments averaging zero, ``H`` taking their mean.

    As RRF's ``NormaliseEndstopAdjustments()``.
    """
    mean = float(np.mean(rrf.endstop_adjustment))
    return replace(
        rrf, endstop_adjustment=rrf.endstop_adjustment - mean, homed_height=rrf.homed_height + mean
    )


#: RRF's values as the fit's unknowns (relative steps for the step distances).
RRF_VALUES: ValueVector[RRFDelta] = ValueVector(RRF_NAMES, _STEP, _STEPS, values_of, with_values)


def error_stats(
    geometry: DeltaGeometry,
    rrf: RRFDelta,
    step_distance: np.ndarray | float,
    workspace: Workspace,
    grid: np.ndarray | None = None,
    part_frame: bool = True,
) -> ErrorStats:
    """3-D errors over the printable volume (in the part's frame) and the first layer's flatness [mm].

    :func:`~..fitting.error_stats`, in the part's frame unless asked otherwise.
    """
    return fitting.error_stats(geometry, rrf, step_distance, workspace, grid, part_frame)


def fit_rrf(
    geometry: DeltaGeometry,
    start: RRFDelta,
    step_distance: np.ndarray | float,
    workspace: Workspace,
    hold_step_distance: bool = False,
    grid: np.ndarray | None = None,
    max_iter: int = 30,
    first_layer_weight: float = 0.0,
    minimax: bool = False,
    flatness: Flatness = None,
    hold: Sequence[str] = (),
) -> FirmwareFit[RRFDelta]:
    """RRF's values that leave the least squared nozzle error over the printable volume (the part's frame).

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The values to start from (its print radius and limits are kept).
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (radius; heights 0.2 mm to its top).
        hold_step_distance: Keep the start's steps per mm (``M92``).
        grid: Targets [mm], (N, 3) (default :func:`~..fitting.printable_grid`).
        max_iter: Gauss-Newton iterations at most.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        minimax: Then the least largest error over the grid, the first layer no less flat
            (:func:`~..fitting.least_largest`).
        flatness: With ``minimax``, the first layer's largest |z error| allowed instead [mm].
        hold: Values kept at the start's, by their classical names (:data:`CLASSICAL_OF`).

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a target out of RRF's reach.
    """
    grid = printable_grid(workspace) if grid is None else np.atleast_2d(np.asarray(grid, dtype=float))
    held = {RRF_NAMES.index(CLASSICAL_OF[name]) for name in hold if name in CLASSICAL_OF}
    wanted = [c for c in range(_STEPS if hold_step_distance else len(RRF_NAMES))
              if c != _ANGLE_Z and c not in held]
    found = gauss_newton(geometry, start, RRF_VALUES, step_distance, workspace, grid, wanted, max_iter,
                         first_layer_weight, True, "RepRapFirmware", minimax, flatness)
    rrf = normalised(found.model)
    fitted = [RRF_NAMES[c] for c in found.columns]
    return FirmwareFit(
        values=rrf,
        fitted=fitted,
        held=[n for n in RRF_NAMES if n not in fitted],
        unidentifiable=found.unidentifiable,
        singular_values=found.singular_values,
        before=error_stats(geometry, start, step_distance, workspace, grid),
        after=error_stats(geometry, rrf, step_distance, workspace, grid),
        iterations=found.iterations,
        points=grid.shape[0],
    )
