"""Measurements CSV files (conventions: readings, positions, orientations, point, station)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import InputError
from ..observations import DEFAULT_STATION, Measurements
from .atomic import atomic_write_text
from .names import check_names, name_problem
from .tables import (
    JOINT_COLUMNS,
    MEASUREMENT_COLUMNS,
    ORIENTATION_COLUMNS,
    TARGET_COLUMNS,
    data_row,
    format_rows,
    read_csv_table,
)

#: The optional column of the mass carried at the TCP [kg] (conventions, "Gravity and payload").
PAYLOAD_COLUMN = "payload_kg"


@dataclass(frozen=True)
class MeasurementFile:
    """A measurements file as read: the data and where each row stands in the file.

    Attributes:
        measurements: The measurements (radians inside).
        lines: The line of each measurement in the file (as an editor counts), shape (M,).
        warnings: What the reader noticed and the user should see.
        path: The file.
    """

    measurements: Measurements
    lines: np.ndarray
    warnings: list[str]
    path: str


def read_measurements(
    path: str | Path, point_names: list[str] | None = None
) -> tuple[Measurements, list[str]]:
    """Read a measurements CSV (conventions: q, position, optional orientation and point).

    Args:
        path: The file.
        point_names: Names of the plate's points (``tcp`` and the robot's named points);
            a row naming another point is an error.

    Returns:
        The measurements (radians inside) and the warnings to show.
    """
    read = read_measurement_file(path, point_names)
    return read.measurements, read.warnings


def read_measurement_file(path: str | Path, point_names: list[str] | None = None) -> MeasurementFile:
    """Read a measurements CSV and keep each row's line (for messages); see :func:`read_measurements`."""
    table = read_csv_table(
        path, MEASUREMENT_COLUMNS, ORIENTATION_COLUMNS + ["point", "station", PAYLOAD_COLUMN],
        text_columns=("point", "station"),
        all_or_none=(tuple(ORIENTATION_COLUMNS),),
    )
    n = len(table.lines)
    for column, values in table.text.items():
        _check_column_names(values, column, str(path), table.lines)
    points = table.text.get("point", ["tcp"] * n)
    points = [p if p else "tcp" for p in points]
    stations = [s if s else DEFAULT_STATION for s in table.text.get("station", [DEFAULT_STATION] * n)]
    if point_names is not None:
        for k, p in enumerate(points):
            if p not in point_names:
                raise InputError(f"unknown point {p!r}; the robot's points are {', '.join(point_names)}",
                                 str(path), f"{data_row(table.lines[k], k + 1)}, column point")
    q = np.radians(np.column_stack([table.numbers[c] for c in JOINT_COLUMNS]))
    pos = np.column_stack([table.numbers[c] for c in TARGET_COLUMNS])
    rv = None
    if "rx_deg" in table.numbers:
        rv = np.radians(np.column_stack([table.numbers[c] for c in ORIENTATION_COLUMNS]))
    payload = table.numbers.get(PAYLOAD_COLUMN, np.zeros(n))
    _check_payloads(payload, str(path), table.lines)
    measurements = Measurements(q=q, position=pos, point=points, rotation_vector=rv, station=stations,
                                payload=payload)
    warnings = list(table.warnings) + _station_warnings(table.text.get("station"), measurements)
    return MeasurementFile(measurements, np.asarray(table.lines), warnings, str(path))


def _check_payloads(payload: np.ndarray, source: str, lines: np.ndarray) -> None:
    """Refuse the first empty or negative ``payload_kg`` cell, naming its line and value."""
    bad = np.flatnonzero(~(payload >= 0.0))  # NaN: an empty cell
    if not bad.size:
        return
    k = int(bad[0])
    where = f"{data_row(lines[k], k + 1)}, column {PAYLOAD_COLUMN}"
    more = f"; {bad.size} empty or negative payloads in all" if bad.size > 1 else ""
    if np.isnan(payload[k]):
        raise InputError(f"empty value: a payload is the mass at the TCP [kg], 0 for none{more}",
                         source, where)
    raise InputError(f"a payload is a mass: must be >= 0 kg, got {float(payload[k]):g}{more}",
                     source, where)


def _check_column_names(values: list[str], column: str, source: str, lines: np.ndarray) -> None:
    """Refuse the first non-empty name of a text column that is not a name (control characters)."""
    bad = {v for v in set(values) if v and name_problem(v) is not None}
    if bad:
        k = next(k for k, v in enumerate(values) if v in bad)
        check_names([values[k]], column, source, f"{data_row(lines[k], k + 1)}, column {column}")


def _station_warnings(column: list[str] | None, measurements: Measurements) -> list[str]:
    """Stations that look like typing slips, as warnings.

    Names differing only in case or spaces, empty cells beside named stations, stations holding
    fewer than 3 poses (a frame of their own needs them).
    """
    if column is None:
        return []
    out = []
    if any(not s for s in column) and any(s for s in column):
        out.append(f"{sum(1 for s in column if not s)} row(s) have an empty station: they form the station "
                   f"{DEFAULT_STATION!r} beside the named ones; name their station")
    names = measurements.stations
    folded: dict[str, list[str]] = {}
    for name in names:
        folded.setdefault(name.strip().casefold(), []).append(name)
    for same in folded.values():
        if len(same) > 1:
            out.append(f"stations {', '.join(repr(s) for s in same)} differ only in case or spaces: "
                       "each is a station of its own (one frame each); one station?")
    poses = {s: len(set(map(tuple, measurements.q[[k for k, t in enumerate(measurements.station) if t == s]]
                            .round(9).tolist()))) for s in names}
    few = [s for s, n in poses.items() if n < 3]
    if len(names) > 1 and few:
        out.append(f"station(s) {', '.join(repr(s) for s in few)} hold fewer than 3 poses: too few for a "
                   "frame of their own (with --frame free); a typing slip in the station column?")
    return out


def write_measurements(path: str | Path, measurements: Measurements) -> None:
    """Write measurements in the CSV format of the conventions (mm, deg), atomically.

    Raises:
        InputError: a point or station name that the file could not carry (see
            :func:`~deltacal.io.names.name_problem`); nothing is written.
    """
    check_names(dict.fromkeys(measurements.point), "point", str(path))
    check_names(dict.fromkeys(measurements.station), "station", str(path))
    q = np.degrees(measurements.q)
    cols = [q[:, 0], q[:, 1], q[:, 2], *measurements.position.T]
    header = JOINT_COLUMNS + TARGET_COLUMNS
    has = measurements.has_orientation
    if np.any(has):
        assert measurements.rotation_vector is not None
        rv = np.degrees(np.where(has[:, None], measurements.rotation_vector, np.nan))
        cols += list(rv.T)
        header = header + ORIENTATION_COLUMNS
    if measurements.loaded:
        cols.append(measurements.payload_kg)
        header = header + [PAYLOAD_COLUMN]
    if any(s != DEFAULT_STATION for s in measurements.station):
        extra = [[p, s] for p, s in zip(measurements.point, measurements.station, strict=True)]
        atomic_write_text(path, format_rows(cols, header + ["point", "station"], extra))
        return
    extra = [[p] for p in measurements.point]
    atomic_write_text(path, format_rows(cols, header + ["point"], extra))
