"""Targets and joints CSV files (compensate's input and output)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import atomic_write_text
from .tables import (
    JOINT_COLUMNS,
    TARGET_COLUMNS,
    CsvTable,
    _format_rows,
    read_csv_table,
)


def read_target_table(path: str | Path) -> CsvTable:
    """Read a targets CSV as a validated table: its ``lines`` let errors name a target's line."""
    return read_csv_table(path, TARGET_COLUMNS)


def write_joints(path: str | Path, targets: np.ndarray, q: np.ndarray) -> None:
    """Write the joints CSV: targets [mm] then readings to command [deg], atomically."""
    qd = np.degrees(q)
    atomic_write_text(path, _format_rows([*targets.T, *qd.T], TARGET_COLUMNS + JOINT_COLUMNS))
