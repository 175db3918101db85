"""What a firmware's best values leave of each error source of a printer, for any firmware.

A printer whose errors are known by name (a simulated one, or an identified one read as its
deviation from its nominal geometry) is rebuilt from its nominal geometry with ONE group of its
errors (tower positions, tower lean, endstops, step distances, balls, rods' common length, rods
of a pair that differ, bed tilt) and the firmware's values refitted (:meth:`Firmware.fit
<.base.Firmware.fit>`, the volume alone, the printed part's frame): what the firmware cannot absorb
of that source alone (``mode="alone"``); or with every error but that group (``mode="removed"``):
what the whole printer's leftover would be without it. One small fit per group (about 0.1 s each
for Klipper's model). The groups interact (a lean and a bed tilt can partly cancel): the leftovers
alone do not add up to the whole's, and that is said rather than hidden.

Each firmware's model holds different sources: Klipper's and Marlin's the endstops, the rods'
common lengths, the towers' angles and step distances; RepRapFirmware's the bed's tilt too
(``M666 A B``). Units: mm.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

import numpy as np

from ...geometry import DeltaGeometry, Workspace
from .base import ErrorFigures, Firmware, FirmwareModel


class ErrorSource(StrEnum):
    """A printer's error source :func:`error_budget` tells apart; its value is the label users read."""

    TOWER_POSITION = "tower position"
    TOWER_LEAN = "tower lean"
    ENDSTOPS = "endstops"
    STEP_DISTANCES = "step distances"
    BALL_POSITIONS = "ball positions"
    ROD_LENGTHS = "rod lengths"
    RODS_THAT_DIFFER = "rods of a pair that differ"
    BED_TILT = "bed tilt"


class BudgetMode(StrEnum):
    """How :func:`error_budget` rebuilds the printer for an error source."""

    ALONE = "alone"  #: with that source's errors alone
    REMOVED = "removed"  #: with every error but that source's

    def errors(self, errors: dict[str, float], group: dict[str, float]) -> dict[str, float]:
        """The errors the printer is rebuilt with, by name: the group's, or all but the group's."""
        if self is BudgetMode.ALONE:
            return group
        return {n: v - group.get(n, 0.0) for n, v in errors.items()}

    def moves_bed(self, source: ErrorSource) -> bool:
        """Whether the printer is rebuilt on the bed's rigid motion (which :data:`BED_TILT` is)."""
        return (source is ErrorSource.BED_TILT) == (self is BudgetMode.ALONE)


#: Error sources told by their errors' names: source -> a test on an error name of a prismatic chain
#: (the rods' lengths are then split into each pair's common length and its difference).
ERROR_GROUPS = {
    ErrorSource.TOWER_POSITION: lambda n: ".axis_point." in n,
    ErrorSource.TOWER_LEAN: lambda n: ".axis_tilt_" in n,
    ErrorSource.ENDSTOPS: lambda n: n.endswith("encoder_offset"),
    ErrorSource.STEP_DISTANCES: lambda n: n.endswith("joint_scale"),
    ErrorSource.BALL_POSITIONS: lambda n: "_ball" in n,
    ErrorSource.ROD_LENGTHS: lambda n: n.endswith(".length"),
}
#: The label of the bed's rigid motion in :func:`error_budget` (no error name: the bed's motion).
BED_TILT = ErrorSource.BED_TILT


def _rod_split(errors: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """Rod errors split into each pair's common part and its difference (rods of a pair that differ)."""
    common, differ = {}, {}
    for i in range(1, 4):
        a, b = errors.get(f"limb{i}.rod1.length", 0.0), errors.get(f"limb{i}.rod2.length", 0.0)
        mean = 0.5 * (a + b)
        common.update({f"limb{i}.rod1.length": mean, f"limb{i}.rod2.length": mean})
        differ.update({f"limb{i}.rod1.length": a - mean, f"limb{i}.rod2.length": b - mean})
    return common, differ


def error_groups(errors: dict[str, float]) -> dict[ErrorSource, dict[str, float]]:
    """A printer's errors by name split into the groups of :func:`error_budget`, by source.

    The rods are split into each pair's common length ("rod lengths") and the pair's difference
    ("rods of a pair that differ", which tilts the effector); the last group, :data:`BED_TILT`,
    has no error names (it is the bed's rigid motion).
    """
    groups = {source: {n: v for n, v in errors.items() if test(n)} for source, test in ERROR_GROUPS.items()}
    groups[ErrorSource.ROD_LENGTHS], groups[ErrorSource.RODS_THAT_DIFFER] = _rod_split(
        groups[ErrorSource.ROD_LENGTHS])
    groups[ErrorSource.BED_TILT] = {}
    return {source: groups[source] for source in ErrorSource}


def error_budget(
    firmware: Firmware[Any],
    nominal: DeltaGeometry,
    errors: dict[str, float],
    bed_rotation: np.ndarray,
    bed_translation: np.ndarray,
    start: FirmwareModel,
    step_distance: np.ndarray | float,
    workspace: Workspace,
    hold_step_distance: bool = False,
    mode: str | BudgetMode = "alone",
) -> dict[str, ErrorFigures]:
    """What a firmware's best values leave of each error source [mm].

    The printer is rebuilt from its nominal geometry with one group of its errors
    (:func:`error_groups`; ``"alone"``, the bed's rigid motion only for :data:`BED_TILT`) or with
    all of them but that group (``"removed"``), the firmware's values refitted
    (:meth:`Firmware.fit <.base.Firmware.fit>` from ``start``, the volume alone), and the leftover
    reported.

    Args:
        firmware: The firmware whose values are fitted.
        nominal: The nominal geometry.
        errors: The printer's errors by name (:meth:`DeltaGeometry.with_errors`).
        bed_rotation: The rigid motion that puts the true bed at z = 0, (3, 3).
        bed_translation: Its translation [mm], (3,).
        start: The firmware's values to start each fit from (its nominal values).
        step_distance: The nominal step distance [mm].
        workspace: The printable cylinder.
        hold_step_distance: Keep the start's step distances.
        mode: ``"alone"`` or ``"removed"`` (:class:`BudgetMode`).

    Returns:
        Error source (an :class:`ErrorSource`, a str: its label) -> the fitted values' errors with
        only that group (without it).

    Raises:
        ValueError: an unknown mode.
        ConvergenceError: a fit did not converge.
        UnreachableError: a target of the volume out of the firmware's reach.
    """
    try:
        rebuilt = BudgetMode(mode)
    except ValueError:
        raise ValueError(f"mode must be 'alone' or 'removed', got {mode!r}") from None
    out: dict[str, ErrorFigures] = {}
    for source, group in error_groups(errors).items():
        printer = nominal.with_errors(rebuilt.errors(errors, group))
        if rebuilt.moves_bed(source):
            printer = printer.moved_rigidly(bed_rotation, bed_translation)
        out[source] = firmware.fit(printer, start, step_distance, workspace, hold_step_distance).after
    return out
