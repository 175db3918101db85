"""A printer's measurement files (conventions, "Linear Delta printers"): probe heights and printed distances.

* probe heights: ``x_mm,y_mm,z_mm``, the commanded nozzle position at which the probe triggered on
  the bed, and optionally ``trigger_height_mm``: the height of the probe point (the nozzle, or the
  nozzle plus ``--probe-offset``) above the bed when it triggered (a probe's ``z_offset``; an
  empty cell or no column: 0);
* distances: ``x1_mm,y1_mm,z1_mm,x2_mm,y2_mm,z2_mm,distance_mm``, the distance measured between two
  features of a printed object, printed at those commanded positions; optional ``ball1,ball2``, the
  labels printed beside the two balls (``plan --object`` writes them before ``distance_mm``), read
  back and checked: two different balls on a row, one label for one position throughout the file.

``plan --object`` writes both as templates, the measured column (``z_mm``, ``distance_mm``) empty
for the user to fill in; a file read with that column still empty is refused, naming its first
empty row. Errors are one line naming the file, line, row, column and value (:mod:`.tables`).
Writes are atomic. Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...exceptions import InputError
from ...io.atomic import atomic_write_text
from ...io.tables import TARGET_COLUMNS, csv_field, data_row, format_rows, read_csv_table

#: A distance measured further than this fraction from the distance commanded between its features is
#: no printer's: a kit's step distances are within 0.3 %, its uncalibrated nozzle within 2-4 mm.
DISTANCE_RTOL = 0.05
#: Units a whole distances file may be in, by the ratio of its distances to those commanded.
OTHER_UNITS = ((0.1, "centimetres"), (0.001, "metres"), (1.0 / 25.4, "inches"), (1000.0, "micrometres"))

#: The columns of a probe heights file; the last is the one measured.
PROBE_COLUMNS = TARGET_COLUMNS
#: The optional column of a probe heights file: the probe point's height above the bed at its trigger.
TRIGGER_COLUMN = "trigger_height_mm"
#: The columns of a distances file; the last is the one measured.
PAIR_COLUMNS = ["x1_mm", "y1_mm", "z1_mm", "x2_mm", "y2_mm", "z2_mm"]
DISTANCE_COLUMNS = [*PAIR_COLUMNS, "distance_mm"]
#: The optional columns of a distances file: the labels of the pair's balls on the printed object.
BALL_COLUMNS = ["ball1", "ball2"]


@dataclass(frozen=True)
class ProbeHeights:
    """Probe heights: the commanded nozzle positions at which the probe triggered on the bed.

    Attributes:
        commanded: Commanded positions [mm], (N, 3).
        lines: The line of each row in the file it was read from (empty when not read), (N,).
        trigger_height: The probe point's height above the bed when it triggered [mm], (N,) (empty:
            0 on every row).
    """

    commanded: np.ndarray
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    trigger_height: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def heights(self) -> np.ndarray:
        """The trigger height of every row [mm], (N,): 0 where the file gives none."""
        if self.trigger_height.size == 0:
            return np.zeros(len(self.commanded))
        return np.nan_to_num(self.trigger_height, nan=0.0)


@dataclass(frozen=True)
class PrintedDistances:
    """Distances measured between features of a printed object.

    Attributes:
        pairs: Commanded positions of each pair's features ``x1, y1, z1, x2, y2, z2`` [mm], (M, 6).
        distance: The measured distances [mm], (M,).
        lines: The line of each row in the file it was read from (empty when not read), (M,).
        balls: The labels of each pair's balls (``ball1``, ``ball2``), empty when the file has none.
    """

    pairs: np.ndarray
    distance: np.ndarray
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    balls: list[tuple[str, str]] = field(default_factory=list)


def _read(path: str | Path, given: list[str], measured: str, what: str, filled: bool = True,
          optional: tuple[str, ...] = (), texts: tuple[str, ...] = ()):
    """The table of a printer's file, its measured column filled in on every row (``filled``)."""
    source = str(path)
    table = read_csv_table(path, given, [measured, *optional, *texts], text_columns=texts)
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
    """Read a probe heights CSV (``x_mm,y_mm,z_mm``, every ``z_mm`` filled in; ``trigger_height_mm`` too).

    Args:
        path: The file.
        filled: False: a template (``z_mm`` absent or empty on some rows: NaN there).

    Raises:
        InputError: naming the file, line, row, column and value of the first bad cell.
    """
    table = _read(path, PROBE_COLUMNS[:2], PROBE_COLUMNS[2], "height at which the probe triggered", filled,
                  (TRIGGER_COLUMN,))
    trigger = table.numbers.get(TRIGGER_COLUMN, np.zeros(0))
    return ProbeHeights(np.column_stack([table.numbers[c] for c in PROBE_COLUMNS]), np.asarray(table.lines),
                        np.asarray(trigger, dtype=float))


def read_printed_distances(path: str | Path, filled: bool = True) -> PrintedDistances:
    """Read a distances CSV (``x1_mm..z2_mm,distance_mm``, every distance filled in and positive).

    The optional ``ball1,ball2`` columns (the balls' labels) go together and are checked
    (:func:`_check_balls`).

    Args:
        path: The file.
        filled: False: a template (``distance_mm`` absent or empty on some rows: NaN there).

    Raises:
        InputError: naming the file, line, row, column and value of the first bad cell; a pair whose
            two features are at the same commanded position; a distance not above zero; labels
            that contradict the positions.
    """
    source = str(path)
    table = _read(path, PAIR_COLUMNS, "distance_mm", "distance measured between the features", filled,
                  texts=tuple(BALL_COLUMNS))
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
    balls = _check_balls(table.text, pairs, lines, source)
    return PrintedDistances(pairs, distance, lines, balls)


def _check_balls(text: dict[str, list[str]], pairs: np.ndarray, lines: np.ndarray,
                 source: str) -> list[tuple[str, str]]:
    """The labels of each pair's balls, checked against the positions; empty without the columns.

    Both columns or neither; each row names two balls, different; a label always at the same
    commanded position and a position always under the same label.

    Raises:
        InputError: naming the row and column of the first label that contradicts the file.
    """
    present = [c for c in BALL_COLUMNS if c in text]
    if not present:
        return []
    if len(present) == 1:
        absent = next(c for c in BALL_COLUMNS if c not in text)
        raise InputError(f"columns ball1, ball2 go together; missing {absent}", source, "line 1")
    at: dict[str, tuple[float, ...]] = {}
    named: dict[tuple[float, ...], str] = {}
    balls = list(zip(text["ball1"], text["ball2"], strict=True))
    for k, pair in enumerate(balls):
        row = data_row(lines[k], k + 1)
        for end, label in enumerate(pair):
            column = BALL_COLUMNS[end]
            position = tuple(float(v) for v in pairs[k, 3 * end:3 * end + 3])
            if not label:
                raise InputError("empty ball label (ball1 and ball2 name the pair's balls)", source,
                                 f"{row}, column {column}")
            if at.setdefault(label, position) != position:
                raise InputError(f"ball {label} is at {list(at[label])} mm on an earlier row and at "
                                 f"{list(position)} mm here", source, f"{row}, column {column}")
            if named.setdefault(position, label) != label:
                raise InputError(f"the ball at {list(position)} mm is {named[position]} on an earlier row "
                                 f"and {label} here", source, f"{row}, column {column}")
    return balls


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


def write_probe_heights(path: str | Path, commanded: np.ndarray, heights: np.ndarray | None = None,
                        trigger_height: np.ndarray | None = None) -> Path:
    """Write probe heights atomically; without ``heights`` a template (``z_mm`` empty) at the (x, y) given.

    Args:
        path: The file.
        commanded: Commanded positions (N, 3) or (N, 2) [mm].
        heights: The commanded z at which the probe triggered [mm], (N,); None: the ``z_mm`` column
            left to fill in.
        trigger_height: The ``trigger_height_mm`` column [mm], (N,); None: no such column.
    """
    commanded = np.atleast_2d(np.asarray(commanded, dtype=float))
    z = np.full(len(commanded), np.nan) if heights is None else np.asarray(heights, dtype=float).reshape(-1)
    columns, header = [commanded[:, 0], commanded[:, 1], z], list(PROBE_COLUMNS)
    if trigger_height is not None:
        columns.append(np.asarray(trigger_height, dtype=float).reshape(-1))
        header.append(TRIGGER_COLUMN)
    return atomic_write_text(path, format_rows(columns, header))


def write_printed_distances(path: str | Path, pairs: np.ndarray, distance: np.ndarray | None = None,
                            balls: list[tuple[str, str]] | None = None) -> Path:
    """Write printed distances atomically; without ``distance`` a template (``distance_mm`` empty).

    Args:
        path: The file.
        pairs: Commanded positions of each pair's features [mm], (M, 6).
        distance: The measured distances [mm], (M,); None: the column left to fill in.
        balls: The labels of each pair's balls, written as ``ball1,ball2`` before ``distance_mm``;
            None: no such columns.
    """
    pairs = np.atleast_2d(np.asarray(pairs, dtype=float)).reshape(-1, 6)
    d = np.full(len(pairs), np.nan) if distance is None else np.asarray(distance, dtype=float).reshape(-1)
    if balls is None:
        return atomic_write_text(path, format_rows([*pairs.T, d], DISTANCE_COLUMNS))
    if len(balls) != len(pairs):
        raise ValueError(f"{len(balls)} pairs of labels for {len(pairs)} pairs")
    lines = [",".join([*PAIR_COLUMNS, *BALL_COLUMNS, "distance_mm"])]
    for row, (one, two), value in zip(pairs, balls, d, strict=True):
        fields = [repr(float(v)) for v in row] + [csv_field(one), csv_field(two)]
        lines.append(",".join([*fields, "" if np.isnan(value) else repr(float(value))]))
    return atomic_write_text(path, "\n".join(lines) + "\n")


def printer_file_kind(path: str | Path) -> str | None:
    """What a printer's measurement file holds, by its header: ``"probe"``, ``"distances"``, or None.

    A file with the pairs' columns (``x1_mm..z2_mm``) holds distances; one with ``x_mm``, ``y_mm``
    probe heights; anything else (a rotary Delta's measurements: ``q1_deg...``) neither. A file that
    cannot be read is None (its reader names the problem).
    """
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            line = next((text for text in handle if text.strip()), "")
    except (OSError, UnicodeDecodeError):
        return None
    columns = {name.strip().strip('"') for name in line.split(",")}
    if set(PAIR_COLUMNS) <= columns:
        return "distances"
    return "probe" if set(PROBE_COLUMNS[:2]) <= columns else None
