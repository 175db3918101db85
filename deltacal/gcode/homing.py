"""The first move after a homing: from where the printer really is, the correction blended in.

After G28 every carriage is at its endstop: the controller stands at its own home, and the real
nozzle at the real printer's home, which is not the controller's (the printer's errors move it,
on kit printers by up to a few mm). The first move then goes from there to its corrected end.
Near the top, the intended path's first points may have no corrected target at all: the real
printer reaches them only with a carriage above its endstop (its home is offset from the
controller's, and a Delta can only go down from its home). Such points are not refused when
the real printer can make the move as it is: every point of the move up to the last one that
has no correction is sent as it is (the printer goes where the controller's own model takes
it, as without deltacal), then the correction is blended in linearly over
:data:`HOME_BLEND_MM` of the move's path, and sent in full beyond. The real path thus starts at
the real home, follows the uncorrected line (off the intended one by the printer's own errors)
and joins the intended line :data:`HOME_BLEND_MM` later. A point refused further than
:data:`HOME_ZONE_MM` along the move is refused as any other. A move whose every point has a
correction is sent corrected in full, as any other. A point near the home whose corrected target the
controller's limits refuse (a printer's radius tapers to its axis near the top: a few mm of
correction across it are refused there) is taken as one without correction. Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import AssemblyError, UnreachableError
from .moves import SingleMove, SplitMove

__all__ = ["HOME_BLEND_MM", "HOME_ZONE_MM", "FromHome", "blend_from_home"]

#: Path length over which the correction is blended in after the last uncorrectable point [mm].
HOME_BLEND_MM = 10.0
#: Path length from the home within which a point without correction is sent as it is [mm].
HOME_ZONE_MM = 10.0
#: Calls of ``correct`` at most (each may name more refused points at a later check).
_TRIES = 8


@dataclass(frozen=True, slots=True)
class FromHome:
    """The plan of the first move after a homing (absolute, from the controller's home).

    Attributes:
        plan: The move, as any other.
        home: Where the homing left the controller (its own home) [mm].
    """

    plan: SingleMove | SplitMove
    home: tuple[float, float, float]


def blend_from_home(correct, points: np.ndarray, home, outside=None) -> np.ndarray:
    """The targets to send for the points of a move from the home (see the module's documentation).

    Args:
        correct: ``correct(points)`` -> targets to send, both (N, 3) [mm].
        points: The move's points, in order [mm], (N, 3).
        home: The move's start, the controller's home [mm], (3,).
        outside: The controller's limits, ``outside(commands)`` -> (N,) (0: accepted), or None. A
            point within :data:`HOME_ZONE_MM` of the home whose corrected (or blended) target the
            controller refuses (near the top of a printer, where its radius tapers to its axis)
            is taken as one without correction: the blend starts after it.

    Returns:
        The targets to send [mm], (N, 3).

    Raises:
        UnreachableError: points without correction further than :data:`HOME_ZONE_MM` along the
            move, by their indices in ``points``.
    """
    n = len(points)
    sent = np.full((n, 3), np.nan)
    refused = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    error: UnreachableError | AssemblyError | None = None
    for _ in range(_TRIES):
        try:
            sent[todo] = correct(points[todo])
            break
        except (UnreachableError, AssemblyError) as exc:
            if not len(exc.indices):
                raise
            error = exc
            refused[todo[np.asarray(exc.indices, dtype=int)]] = True
            todo = np.flatnonzero(~refused)
    else:
        raise error  # type: ignore[misc]
    path = np.vstack([np.asarray(home, dtype=float)[None, :], points])
    along = np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))  # path length from the home
    far = refused & (along > HOME_ZONE_MM)
    if far.any():
        reason = error.reason if isinstance(error, UnreachableError) else \
            UnreachableError.CONTROLLER_OUT_OF_REACH
        raise UnreachableError.from_mask(far, points, reason)
    blended = _blend(points, sent, refused, along)
    near = along <= HOME_ZONE_MM
    for _ in range(_TRIES if outside is not None else 0):  # the controller's limits near the home
        denied = near & ~refused & (outside(blended) != 0)
        if not denied.any():
            break
        refused |= denied
        blended = _blend(points, sent, refused, along)
    return blended


def _blend(points: np.ndarray, sent: np.ndarray, refused: np.ndarray, along: np.ndarray) -> np.ndarray:
    """The points up to the last refused one as they are, then the correction blended in."""
    if not refused.any():
        return sent
    last = int(np.flatnonzero(refused)[-1])
    weight = np.clip((along - along[last]) / HOME_BLEND_MM, 0.0, 1.0)
    weight[: last + 1] = 0.0
    return np.where(weight[:, None] > 0.0, points + weight[:, None] * (np.nan_to_num(sent) - points), points)
