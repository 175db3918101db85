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

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ....exceptions import InputError
from ....geometry import DeltaGeometry, Workspace
from ..base import FirmwareFit, Flatness
from ..fitting import FLATNESS_SLACK, ErrorStats, error_stats, flatness_limits, printable_grid
from ..klipper.fit import KLIPPER_NAMES, fit_klipper
from ..klipper.model import KlipperDelta
from .model import MarlinDelta
from .values import from_klipper, to_klipper

#: Why the values of a Marlin 1.1.0's report are not fitted, and what to do instead.
OLD_MARLIN_REFUSED = ("the report of a Marlin 1.1.0 or older (M665 L R S, no H): its M665 takes L R S A B C "
                      "only, its homed height (MANUAL_Z_HOME_POS) and tower angles are compiled in, so the "
                      "values deltacal fits (Marlin 2's M665 L R H X Y Z A B C, M666, M92) would not be "
                      "taken: update Marlin and capture M503 again, or correct each program with deltacal "
                      "compensate through this capture")
#: Fits of :func:`_turned_least_largest` at most (its bounds lowered each time by what the turn added).
TURN_ROUNDS = 3
#: Marlin's values in the fit's order (the step distances are ``M92``'s).
MARLIN_NAMES = ("M665 R", "M665 X", "M665 Y", "M665 Z", "M665 L+A", "M665 L+B", "M665 L+C",
                "M666 X", "M666 Y", "M666 Z", "M92 X", "M92 Y", "M92 Z")


def _names(klipper_names: list[str]) -> list[str]:
    """Klipper's value names as Marlin's (:data:`MARLIN_NAMES`)."""
    return [MARLIN_NAMES[KLIPPER_NAMES.index(name)] for name in klipper_names]


def fit_marlin(geometry: DeltaGeometry, start: MarlinDelta, step_distance: np.ndarray | float,
               workspace: Workspace, hold_step_distance: bool = False,
               first_layer_weight: float = 0.0, minimax: bool = False,
               grid: np.ndarray | None = None, flatness: Flatness = None,
               hold: Sequence[str] = ()) -> FirmwareFit[MarlinDelta]:
    """Marlin's values that leave the least squared nozzle error over the printable volume.

    The fit's names are :data:`MARLIN_NAMES`; its singular values and iterations are those of the
    second of Klipper's fits (see the module).

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The values to start from; its ``M851``, ``M211``, ``M665 S`` and ``M92 E`` are kept.
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (heights 0.2 mm to its top).
        hold_step_distance: Keep the start's ``M92``.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        minimax: Then the least largest error over the volume, the first layer no less flat
            (:func:`~..fitting.least_largest`; in the second fit, the trims' sum held).
        grid: Targets [mm], (N, 3) (default :func:`~..fitting.printable_grid`).
        flatness: With ``minimax``, the first layer's largest |z error| allowed instead [mm].
        hold: Values kept at the start's, by their classical names (Klipper's, ``KLIPPER_NAMES``).

    Raises:
        InputError: ``start`` is a Marlin 1.1.0's report (:attr:`~.model.MarlinDelta.compiled_height`).
        ConvergenceError: Gauss-Newton did not converge.
        UnreachableError: a target out of Marlin's reach.
    """
    if start.compiled_height:
        raise InputError(OLD_MARLIN_REFUSED, start.name)
    grid = printable_grid(workspace) if grid is None else np.atleast_2d(np.asarray(grid, dtype=float))

    def fit(klipper_start: KlipperDelta, least_largest: bool = False, bounds: Flatness = None) -> FirmwareFit:
        return fit_klipper(geometry, klipper_start, step_distance, workspace, hold_step_distance, grid,
                           first_layer_weight=first_layer_weight, minimax=least_largest, flatness=bounds,
                           hold=hold)

    def judged(values: KlipperDelta) -> tuple[MarlinDelta, ErrorStats]:
        marlin = from_klipper(values, start, turn=True)
        stats = error_stats(geometry, to_klipper(marlin), step_distance, workspace, grid, part_frame=True)
        return marlin, stats

    first = fit(to_klipper(start))
    mean = float(np.mean(from_klipper(first.values, start).angle_trim))
    restart = first.values.angle.copy()
    restart[2] -= np.radians(mean)
    again = replace(first.values, angle=restart)
    result = fit(again)
    marlin, after = judged(result.values)
    if minimax:
        own = np.array([after.flatness, after.flatness_pv])  # the least squares' first layer, turned
        goal = flatness_limits(flatness) if flatness is not None else own
        result, marlin, after = _turned_least_largest(fit, judged, again, goal, (result, marlin, after))
    return FirmwareFit(
        values=marlin,
        fitted=_names(result.fitted),
        held=_names(result.held),
        unidentifiable=_names(result.unidentifiable),
        singular_values=result.singular_values,
        before=error_stats(geometry, to_klipper(start), step_distance, workspace, grid, part_frame=True),
        after=after,
        iterations=result.iterations,
        points=result.points,
    )


def _turned_least_largest(fit: Callable[..., FirmwareFit], judged: Callable[[KlipperDelta], tuple[MarlinDelta,
                          ErrorStats]], start: KlipperDelta, goal: np.ndarray,
                          squares: tuple[FirmwareFit, MarlinDelta, ErrorStats]
                          ) -> tuple[FirmwareFit, MarlinDelta, ErrorStats]:
    """The least largest error whose first layer, once Marlin's values are turned, is within ``goal``.

    Marlin's values are turned after the fit (the trims' sum to zero: the same printed part), which
    samples the first layer at points turned by a few µrad: its largest |z error| and peak to valley
    may end above the bounds the fit held. The bounds are lowered by what the turn added and the fit
    run again (:data:`TURN_ROUNDS` times at most); failing that, the least squares' values
    (``squares``), which are within ``goal`` by its definition or nearest to it.
    """
    bounds = np.array(goal, dtype=float)
    for _ in range(TURN_ROUNDS):
        result = fit(start, True, (float(bounds[0]), float(bounds[1])))
        marlin, after = judged(result.values)
        excess = np.array([after.flatness, after.flatness_pv]) - goal
        if np.all(excess <= FLATNESS_SLACK):
            return result, marlin, after
        bounds = bounds - np.maximum(excess, 0.0) - FLATNESS_SLACK
    return squares
