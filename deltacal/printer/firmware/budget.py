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

from typing import Any

import numpy as np

from ...geometry import DeltaGeometry, Workspace
from .base import ErrorFigures, Firmware, FirmwareModel

#: Error groups of :func:`error_budget`: label -> a test on an error name of a prismatic chain.
ERROR_GROUPS = {
    "tower position": lambda n: ".axis_point." in n,
    "tower lean": lambda n: ".axis_tilt_" in n,
    "endstops": lambda n: n.endswith("encoder_offset"),
    "step distances": lambda n: n.endswith("joint_scale"),
    "ball positions": lambda n: "_ball" in n,
    "rod lengths": lambda n: n.endswith(".length"),
}
#: The label of the bed's rigid motion in :func:`error_budget` (no error name: the bed's motion).
BED_TILT = "bed tilt"


def _rod_split(errors: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """Rod errors split into each pair's common part and its difference (rods of a pair that differ)."""
    common, differ = {}, {}
    for i in range(1, 4):
        a, b = errors.get(f"limb{i}.rod1.length", 0.0), errors.get(f"limb{i}.rod2.length", 0.0)
        mean = 0.5 * (a + b)
        common.update({f"limb{i}.rod1.length": mean, f"limb{i}.rod2.length": mean})
        differ.update({f"limb{i}.rod1.length": a - mean, f"limb{i}.rod2.length": b - mean})
    return common, differ


def error_groups(errors: dict[str, float]) -> dict[str, dict[str, float]]:
    """A printer's errors by name split into the groups of :func:`error_budget`, by label.

    The rods are split into each pair's common length ("rod lengths") and the pair's difference
    ("rods of a pair that differ", which tilts the effector); the last group, :data:`BED_TILT`,
    has no error names (it is the bed's rigid motion).
    """
    rods = {n: v for n, v in errors.items() if n.endswith(".length")}
    common, differ = _rod_split(rods)
    groups: dict[str, dict[str, float]] = {
        label: {n: v for n, v in errors.items() if test(n)} for label, test in ERROR_GROUPS.items()
        if label != "rod lengths"}
    groups["rod lengths"] = common
    groups["rods of a pair that differ"] = differ
    groups[BED_TILT] = {}
    return groups


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
    mode: str = "alone",
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
        mode: ``"alone"`` or ``"removed"``.

    Returns:
        Group label -> the fitted values' errors with only that group (without it).

    Raises:
        ValueError: an unknown mode.
        ConvergenceError: a fit did not converge.
        UnreachableError: a target of the volume out of the firmware's reach.
    """
    if mode not in ("alone", "removed"):
        raise ValueError(f"mode must be 'alone' or 'removed', got {mode!r}")
    out = {}
    for label, group in error_groups(errors).items():
        if mode == "alone":
            printer = nominal.with_errors(group)
            bed = label == BED_TILT
        else:
            printer = nominal.with_errors({n: v - group.get(n, 0.0) for n, v in errors.items()})
            bed = label != BED_TILT
        if bed:
            printer = printer.moved_rigidly(bed_rotation, bed_translation)
        out[label] = firmware.fit(printer, start, step_distance, workspace, hold_step_distance).after
    return out
