"""POSES files (``deltacal plan``'s output: readings, then the nominal TCP targets)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import InputError
from ..geometry import NominalDelta
from ..kinematics.closed_form import VirtualDelta
from ..planning import PoseSet
from .atomic import atomic_write_text
from .tables import data_row, read_csv_table

#: Columns of a POSES file (written by ``deltacal plan``).
POSES_COLUMNS = ["q1_deg", "q2_deg", "q3_deg", "x_mm", "y_mm", "z_mm"]


#: A POSES file row whose readings put the nominal TCP farther than this from its target
#: is rejected by :func:`read_poses` [mm].
POSES_TOLERANCE = 1e-6


# --------------------------------------------------------------------------- POSES files
def _format_poses(poses: PoseSet) -> str:
    lines = [",".join(POSES_COLUMNS)]
    qd = np.degrees(poses.q)
    for q, t in zip(qd, poses.targets, strict=True):
        lines.append(",".join(repr(float(v)) for v in (*q, *t)))
    return "\n".join(lines) + "\n"


def write_poses(path: str | Path, poses: PoseSet) -> None:
    """Write a POSES file (readings [deg], then nominal TCP targets [mm]), atomically.

    Raises:
        ValueError: a reading or target is not finite (nothing is written).
    """
    finite = np.all(np.isfinite(poses.q), axis=1) & np.all(np.isfinite(poses.targets), axis=1)
    if not np.all(finite):
        raise ValueError(f"pose {int(np.argmin(finite))} is not finite; nothing written to {path}")
    atomic_write_text(path, _format_poses(poses))


@dataclass(frozen=True)
class PosesFile:
    """A POSES file as read: the poses, the line of each, the warnings to show.

    Attributes:
        poses: The poses.
        lines: The line of each pose in the file (as an editor counts), shape (N,).
        warnings: Ignored columns, duplicate rows...
    """

    poses: PoseSet
    lines: np.ndarray
    warnings: list[str]


def read_poses(
    path: str | Path,
    nominal: NominalDelta | None = None,
    tolerance: float = POSES_TOLERANCE,
) -> tuple[PoseSet, list[str]]:
    """Read and validate a POSES file (see :func:`read_poses_file`).

    Returns:
        The poses and the warnings to show (ignored columns, duplicate rows...).
    """
    read = read_poses_file(path, nominal, tolerance)
    return read.poses, read.warnings


def read_poses_file(
    path: str | Path,
    nominal: NominalDelta | None = None,
    tolerance: float = POSES_TOLERANCE,
) -> PosesFile:
    """Read and validate a POSES file, keeping the line of each pose.

    Checks the CSV (:func:`deltacal.io.read_csv_table`: every column present,
    finite numbers, one clear error naming the file, line and column) and, with a
    nominal robot, that each row's readings put its nominal TCP on the row's target.

    Args:
        path: The file.
        nominal: The robot the file was planned for (optional check).
        tolerance: Largest target mismatch of that check [mm].

    Raises:
        InputError: naming the file, the line and the column of the first problem.
    """
    table = read_csv_table(path, POSES_COLUMNS)
    q = np.radians(np.column_stack([table.numbers[c] for c in POSES_COLUMNS[:3]]))
    targets = np.column_stack([table.numbers[c] for c in POSES_COLUMNS[3:]])
    if nominal is not None:
        x = VirtualDelta.from_nominal(nominal).forward(q, check=False) + nominal.tool
        miss = np.linalg.norm(x - targets, axis=1)
        bad = ~(miss <= tolerance)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            detail = (
                "the robot cannot be assembled at these readings"
                if not np.isfinite(miss[k])
                else f"the readings put the TCP of {nominal.name!r} {miss[k]:.6g} mm from the target"
            )
            raise InputError(
                f"{detail} ({int(bad.sum())} row(s); was the file planned for this robot?)",
                str(path),
                f"{data_row(table.lines[k], k + 1)}, columns q1_deg..z_mm",
            )
    return PosesFile(PoseSet(q, targets), np.asarray(table.lines), list(table.warnings))
