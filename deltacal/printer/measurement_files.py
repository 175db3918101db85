"""A printer's measurement files (conventions, "Linear Delta printers"): probe heights and printed distances.

* probe heights: ``x_mm,y_mm,z_mm``, the commanded nozzle position at which the probe triggered on
  the bed;
* distances: ``x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm``, the distance measured between two
  features of a printed object, printed at those commanded positions.

``plan --object`` writes both as templates, the measured column (``z_mm``, ``distance_mm``) empty
for the user to fill in; a file read with that column still empty is refused, naming its first
empty row. Errors are one line naming the file, line, row, column and value (:mod:`.tables`).
Writes are atomic. Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..exceptions import InputError
from ..io.atomic import atomic_write_text
from ..io.tables import TARGET_COLUMNS, _format_rows, data_row, read_csv_table

#: A distance measured further than this fraction from the distance commanded between its features is
#: no printer's: a kit's step distances are within 0.3 %, its uncalibrated nozzle within 2-4 mm.
DISTANCE_RTOL = 0.05
#: Units a whole distances file may be in, by the ratio of its distances to those commanded.
OTHER_UNITS = ((0.1, "centimetres"), (0.001, "metres"), (1.0 / 25.4, "inches"), (1000.0, "micrometres"))

#: The columns of a probe heights file; the last is the one measured.
PROBE_COLUMNS = TARGET_COLUMNS
#: The columns of a distances file; the last is the one measured.
PAIR_COLUMNS = ["x1_mm", "y1_mm", "z1_mm", "x2_mm", "y2_mm", "z2_mm"]
DISTANCE_COLUMNS = [*PAIR_COLUMNS, "distance_mm"]


@dataclass(frozen=True)
class ProbeHeights:
    """Probe heights: the commanded nozzle positions at which the probe triggered on the bed.

    Attributes:
        commanded: Commanded positions [mm], (N, 3).
        lines: The line of each row in the file it was read from (empty when not read), (N,).
    """

    commanded: np.ndarray
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


@dataclass(frozen=True)
class PrintedDistances:
    """Distances measured between features of a printed object.

    Attributes:
        pairs: Commanded positions of each pair's features ``x1, y1, z1, x2, y2, z2`` [mm], (M, 6).
        distance: The measured distances [mm], (M,).
        lines: The line of each row in the file it was read from (empty when not read), (M,).
    """

    pairs: np.ndarray
    distance: np.ndarray
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


def _read(path: str | Path, given: list[str], measured: str, what: str, filled: bool = True):
    """The table of a printer's file, its measured column filled in on every row (``filled``)."""
    source = str(path)
    table = read_csv_table(path, given, [measured])
    if not filled:
        if measured not in table.numbers:
            table.numbers[measured] = np.full(len(table.lines), np.nan)
        return table
    if measured not in table.numbers:
        raise InputError(f"missing required column {measured} (the {what})", source, "line 1")
    values = table.numbers[measured]
    empty = np.flatnonzero(np.isnan(values))
    if empty.size:
        k = int(empty[0])
        template = " (a template as plan wrote it?)" if empty.size == values.size else ""
        raise InputError(f"fill in {measured}: the {what} is empty on {empty.size} of {values.size} rows"
                         f"{template}", source, f"{data_row(table.lines[k], k + 1)}, column {measured}")
    return table


def read_probe_heights(path: str | Path, filled: bool = True) -> ProbeHeights:
    """Read a probe heights CSV (``x_mm,y_mm,z_mm``, every ``z_mm`` filled in).

    Args:
        path: The file.
        filled: False: a template (``z_mm`` absent or empty on some rows: NaN there).

    Raises:
        InputError: naming the file, line, row, column and value of the first bad cell.
    """
    table = _read(path, PROBE_COLUMNS[:2], PROBE_COLUMNS[2], "height at which the probe triggered", filled)
    return ProbeHeights(np.column_stack([table.numbers[c] for c in PROBE_COLUMNS]), np.asarray(table.lines))


def read_printed_distances(path: str | Path, filled: bool = True) -> PrintedDistances:
    """Read a distances CSV (``x1_mm..z2_mm,distance_mm``, every distance filled in and positive).

    Args:
        path: The file.
        filled: False: a template (``distance_mm`` absent or empty on some rows: NaN there).

    Raises:
        InputError: naming the file, line, row, column and value of the first bad cell; a pair whose
            two features are at the same commanded position; a distance not above zero.
    """
    source = str(path)
    table = _read(path, PAIR_COLUMNS, "distance_mm", "distance measured between the features", filled)
    pairs = np.column_stack([table.numbers[c] for c in PAIR_COLUMNS])
    distance = table.numbers["distance_mm"]
    lines = np.asarray(table.lines)
    bad = np.flatnonzero(distance <= 0.0)
    if bad.size:
        k = int(bad[0])
        raise InputError(f"a distance must be above 0 mm, got {float(distance[k]):g}", source,
                         f"{data_row(lines[k], k + 1)}, column distance_mm")
    same = np.flatnonzero(np.all(pairs[:, :3] == pairs[:, 3:], axis=1))
    if same.size:
        k = int(same[0])
        raise InputError(f"both features of the pair are at {pairs[k, :3].tolist()} mm: a distance needs two "
                         "places", source, f"{data_row(lines[k], k + 1)}, columns x1_mm..z2_mm")
    _check_distances(distance, np.linalg.norm(pairs[:, 3:] - pairs[:, :3], axis=1), lines, source)
    return PrintedDistances(pairs, distance, lines)


def _check_distances(distance: np.ndarray, commanded: np.ndarray, lines: np.ndarray, source: str) -> None:
    """Refuse the first distance further from the commanded one than any printer (:data:`DISTANCE_RTOL`).

    NaN (a template's empty cell) is not checked. A whole file in another unit is said so.
    """
    ratio = distance / commanded
    bad = np.flatnonzero(np.abs(ratio - 1.0) > DISTANCE_RTOL)  # NaN compares False
    if not bad.size:
        return
    k = int(bad[0])
    median = float(np.nanmedian(ratio))
    unit = next((f": {name}? deltacal reads millimetres" for factor, name in OTHER_UNITS
                 if abs(median / factor - 1.0) <= DISTANCE_RTOL and bad.size > distance.size // 2), "")
    off = 100.0 * abs(ratio[k] - 1.0)
    raise InputError(f"the distance measured, {float(distance[k]):g} mm, is {off:.3g} % from the "
                     f"{float(commanded[k]):.6g} mm commanded between the features: no printer is so far off "
                     f"({100.0 * DISTANCE_RTOL:g} % at most){unit or ' (a typo? another file of pairs?)'}; "
                     f"{bad.size} of {distance.size} rows", source,
                     f"{data_row(lines[k], k + 1)}, column distance_mm")


def write_probe_heights(path: str | Path, commanded: np.ndarray, heights: np.ndarray | None = None) -> Path:
    """Write probe heights atomically; without ``heights`` a template (``z_mm`` empty) at the (x, y) given.

    Args:
        path: The file.
        commanded: Commanded positions (N, 3) or (N, 2) [mm].
        heights: The trigger heights [mm], (N,); None: the ``z_mm`` column left to fill in.
    """
    commanded = np.atleast_2d(np.asarray(commanded, dtype=float))
    z = np.full(len(commanded), np.nan) if heights is None else np.asarray(heights, dtype=float).reshape(-1)
    return atomic_write_text(path, _format_rows([commanded[:, 0], commanded[:, 1], z], PROBE_COLUMNS))


def write_printed_distances(path: str | Path, pairs: np.ndarray, distance: np.ndarray | None = None) -> Path:
    """Write printed distances atomically; without ``distance`` a template (``distance_mm`` empty).

    Args:
        path: The file.
        pairs: Commanded positions of each pair's features [mm], (M, 6).
        distance: The measured distances [mm], (M,); None: the column left to fill in.
    """
    pairs = np.atleast_2d(np.asarray(pairs, dtype=float)).reshape(-1, 6)
    d = np.full(len(pairs), np.nan) if distance is None else np.asarray(distance, dtype=float).reshape(-1)
    return atomic_write_text(path, _format_rows([*pairs.T, d], DISTANCE_COLUMNS))
