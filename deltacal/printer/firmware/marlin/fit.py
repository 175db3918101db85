"""Marlin's values (``M665``, ``M666``, ``M92``) that fit an identified linear Delta printer best.

Marlin's delta model is Klipper's with other names (:mod:`.values`: one radius; per tower an
angle, a rod, a carriage height at the endstop, a step distance), so the values that leave the
least nozzle error over the printable volume, judged in the printed part's frame, are those of
:func:`~..klipper.fit.fit_klipper` (Gauss-Newton on the exact forward kinematics of the identified
printer, the first layer's height errors optionally weighted), written by Marlin's rules
(:func:`~.values.marlin_values`: ``M666`` <= 0 and ``H`` lowered accordingly, ``L`` the mean rod).
The angle gauge is held as ``G33`` holds it, the trims' sum at 0: the fit holds tower C's angle (the
towers' common turn is the part's), then is run again with tower C's trim moved by minus the
trims' mean, which the other two follow; the small sum left (about 1e-5 deg) is taken off by
turning the model. What the written values leave is computed with their carriage heights as
Marlin homes them (``M666`` within its skipped steps included).
Units: mm; trims in degrees.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ....geometry import DeltaGeometry, Workspace
from ..fitting import ErrorStats, error_stats, printable_grid
from ..klipper.fit import KLIPPER_NAMES, KlipperFit, fit_klipper
from .model import MarlinDelta
from .values import from_klipper, to_klipper

#: Marlin's values in the fit's order (the step distances are ``M92``'s).
MARLIN_NAMES = ("M665 R", "M665 X", "M665 Y", "M665 Z", "M665 L+A", "M665 L+B", "M665 L+C",
                "M666 X", "M666 Y", "M666 Z", "M92 X", "M92 Y", "M92 Z")


@dataclass(frozen=True)
class MarlinFit:
    """Marlin's values fitted to a printer, and what they leave.

    Attributes:
        marlin: The fitted values, as Marlin's rules write them.
        fitted: Names (:data:`MARLIN_NAMES`) of the values fitted.
        held: Names held at the start's values (asked, the angle gauge, or not identifiable).
        before: Errors with the start's values [mm].
        after: Errors with the fitted values, through Marlin's model [mm].
        klipper: The fit of the same model in Klipper's names (its singular values, iterations).
    """

    marlin: MarlinDelta
    fitted: list[str]
    held: list[str]
    before: ErrorStats
    after: ErrorStats
    klipper: KlipperFit

    @property
    def values(self) -> MarlinDelta:
        """The fitted values (:attr:`marlin`), by the firmware interface's name."""
        return self.marlin


def _names(klipper_names: list[str]) -> list[str]:
    """Klipper's value names as Marlin's (:data:`MARLIN_NAMES`)."""
    return [MARLIN_NAMES[KLIPPER_NAMES.index(name)] for name in klipper_names]


def fit_marlin(geometry: DeltaGeometry, start: MarlinDelta, step_distance: np.ndarray | float,
               workspace: Workspace, hold_step_distance: bool = False,
               first_layer_weight: float = 0.0, hold: Sequence[str] = ()) -> MarlinFit:
    """Marlin's values that leave the least squared nozzle error over the printable volume.

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The values to start from; its ``M851``, ``M211``, ``M665 S`` and ``M92 E`` are kept.
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (heights 0.2 mm to its top).
        hold_step_distance: Keep the start's ``M92``.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        hold: Values kept at the start's, by their classical names (Klipper's, ``KLIPPER_NAMES``).

    Raises:
        ConvergenceError: Gauss-Newton did not converge.
        UnreachableError: a target out of Marlin's reach.
    """
    grid = printable_grid(workspace)

    def fit(klipper_start):
        return fit_klipper(geometry, klipper_start, step_distance, workspace, hold_step_distance, grid,
                           first_layer_weight=first_layer_weight, hold=hold)

    first = fit(to_klipper(start))
    mean = float(np.mean(from_klipper(first.klipper, start).angle_trim))
    restart = first.klipper.angle.copy()
    restart[2] -= np.radians(mean)
    result = fit(replace(first.klipper, angle=restart))
    marlin = from_klipper(result.klipper, start, turn=True)
    return MarlinFit(
        marlin=marlin,
        fitted=_names(result.fitted),
        held=_names(result.held),
        before=error_stats(geometry, to_klipper(start), step_distance, workspace, grid, part_frame=True),
        after=error_stats(geometry, to_klipper(marlin), step_distance, workspace, grid, part_frame=True),
        klipper=result,
    )
