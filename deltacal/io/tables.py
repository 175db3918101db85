"""CSV tables: columns by name, finite plain numbers, one-line errors naming file, line and column."""

from __future__ import annotations

import csv
import difflib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import AssemblyError, InputError
from .toml import not_utf8

# --------------------------------------------------------------------------- CSV
MEASUREMENT_COLUMNS = ["q1_deg", "q2_deg", "q3_deg", "x_mm", "y_mm", "z_mm"]


ORIENTATION_COLUMNS = ["rx_deg", "ry_deg", "rz_deg"]


TARGET_COLUMNS = ["x_mm", "y_mm", "z_mm"]


JOINT_COLUMNS = ["q1_deg", "q2_deg", "q3_deg"]


@dataclass
class CsvTable:
    """Columns of a validated CSV file.

    Attributes:
        numbers: Numeric columns by name, each of shape (rows,).
        text: Text columns by name.
        lines: Line number in the file of each data row (the header is line 1).
        warnings: Things worth telling the user that are not errors.
    """

    numbers: dict[str, np.ndarray]
    text: dict[str, list[str]]
    lines: np.ndarray
    warnings: list[str]


#: A plain decimal number: what a CSV numeric field may hold (no "1_000", "0x10", "١٢").
_NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")

#: Largest magnitude of a number read from a CSV file: mm, deg and their σ of any robot are far
#: below; above, squares and products overflow and the message would show 'inf'.
MAX_MAGNITUDE = 1e12

#: What a numeric field may hold, as said in the messages.
ACCEPTED = ("plain decimal numbers with ASCII digits, '.' as decimal point and an optional exponent: "
            "-12.5, 1e-3")


def _csv_fields(line: str, source: str, line_no: int) -> list[str]:
    if "\r" in line.rstrip("\r\n") and '"' not in line:
        raise InputError("the lines end in CR alone (an old Mac format): save the file with LF or CRLF "
                         "line endings", source, f"line {line_no}")
    try:
        return next(csv.reader([line]))
    except (csv.Error, StopIteration) as exc:
        raise InputError(f"not a valid CSV line ({exc})", source, f"line {line_no}") from None


def _parse_number(value: str, source: str, where: str) -> float:
    """A numeric CSV field: a finite decimal number, or an error naming the field and value."""
    if _NUMBER_RE.fullmatch(value) is None:
        if value.strip().lower().lstrip("+-") in ("nan", "inf", "infinity"):
            raise InputError(f"value {value!r} is not a finite number", source, where)
        hint = " (a decimal comma?)" if re.fullmatch(r"[+-]?[0-9]+,[0-9]+", value) else ""
        raise InputError(f"value {value!r} is not a number{hint}: only {ACCEPTED}", source, where)
    number = float(value)
    if not math.isfinite(number):  # 1e999
        raise InputError(f"value {value!r} is not a finite number", source, where)
    if abs(number) > MAX_MAGNITUDE:
        raise InputError(f"value {value!r} is out of range: numbers are read up to ±{MAX_MAGNITUDE:g}",
                         source, where)
    return number


def data_row(line: int, row: int) -> str:
    """Where a CSV data row is: its line in the file (as an editor counts) and its row number."""
    return f"line {int(line)} (data row {int(row)})"


def lines_text(lines: Sequence[int], limit: int = 10) -> str:
    """``"3, 5, 9"`` (and ``"and N more"`` past ``limit``)."""
    shown = ", ".join(str(int(n)) for n in lines[:limit])
    return shown + (f" and {len(lines) - limit} more" if len(lines) > limit else "")


def unassembled_rows(exc: AssemblyError, source: str | Path, lines: np.ndarray, q: np.ndarray,
                     robot: str) -> InputError:
    """The error naming the file's lines whose readings ``robot`` cannot assemble.

    Args:
        exc: The kinematics' error; its ``indices`` index the rows of ``q`` and ``lines``.
        source: The file the readings came from.
        lines: The line of each row in the file.
        q: The readings of each row [rad], shape (N, 3).
        robot: Which robot, as the message says it (``"the true robot"``, ``"the robot 'x'"``).
    """
    at = np.asarray(lines)[np.asarray(exc.indices, dtype=int)].tolist()
    k = int(exc.indices[0])
    shown = np.round(np.degrees(q[k]), 6).tolist()
    more = f"; {len(at)} rows in all, lines {lines_text(at)}" if len(at) > 1 else ""
    return InputError(f"{robot} cannot be assembled at the readings q = {shown} deg{more}",
                      str(source), f"{data_row(at[0], k + 1)}, columns q1_deg..q3_deg")


def read_csv_table(
    path: str | Path,
    required: list[str],
    optional: list[str] = (),  # type: ignore[assignment]
    text_columns: tuple[str, ...] = (),
    all_or_none: tuple[tuple[str, ...], ...] = (),
) -> CsvTable:
    """Read and validate a comma-separated file with a header row.

    Checks: the file exists, is UTF-8 text and is not empty, has data rows, has
    every required column, no duplicate column, each row has as many fields as the
    header, every numeric value is a finite decimal number, and groups of columns in
    ``all_or_none`` are either all present or all absent in a row. Warnings (not
    errors): unknown columns are ignored; joint columns in degrees holding only
    values within ±π may be radians; position columns in millimetres holding only
    values within ±5 may be metres; duplicate data rows.

    Line numbers are those an editor shows (the header is line 1 unless blank lines
    precede it; blank lines are skipped but counted).

    Raises:
        InputError: naming the file, the line, the column and the value.
    """
    source = str(path)
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", source) from None
    except OSError as exc:
        raise InputError(f"cannot read file ({exc.strerror})", source) from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise not_utf8(raw, exc, source) from None
    if "\x00" in text:
        raise InputError("file holds NUL bytes: a binary or UTF-16 file? deltacal reads UTF-8 CSV",
                         source)
    rows = [(n + 1, line.rstrip("\r")) for n, line in enumerate(text.split("\n")) if line.strip()]
    if not rows:
        raise InputError("file is empty", source)
    header_line, header_text = rows[0]
    header, warnings = parse_header(header_text, source, header_line, required, optional)
    if len(rows) == 1:
        raise InputError("no data rows after the header", source)
    known = list(required) + list(optional)
    wanted = [c for c in known if c in header]
    numbers, texts, lines = parse_rows(rows[1:], header, wanted, text_columns, source, 1)
    arrays = {c: np.array(v, dtype=float) for c, v in numbers.items()}
    line_arr = np.array(lines)
    for c in required:
        if c in arrays and np.any(np.isnan(arrays[c])):
            k = int(np.flatnonzero(np.isnan(arrays[c]))[0])
            raise InputError("empty value in a required column", source,
                             f"{data_row(line_arr[k], k + 1)}, column {c}")
    for group in all_or_none:
        present = [c for c in group if c in arrays]
        if not present:
            continue
        if len(present) != len(group):
            absent = [c for c in group if c not in arrays]
            raise InputError(f"columns {', '.join(group)} go together; missing {', '.join(absent)}",
                             source, f"line {header_line}")
        filled = np.stack([~np.isnan(arrays[c]) for c in group], axis=1)
        partial = np.any(filled, axis=1) & ~np.all(filled, axis=1)
        if np.any(partial):
            k = int(np.flatnonzero(partial)[0])
            col = group[int(np.flatnonzero(~filled[k])[0])]
            raise InputError(f"empty value while {', '.join(group)} are given together", source,
                             f"{data_row(line_arr[k], k + 1)}, column {col}")
    warnings += unit_warnings(arrays, source)
    numeric = np.column_stack([arrays[c] for c in arrays]) if arrays else np.zeros((len(lines), 0))
    keys = [tuple(np.round(numeric[k], 12)) + tuple(texts[c][k] for c in texts) for k in range(len(lines))]
    first: dict[tuple, int] = {}
    repeats = []
    for k, key in enumerate(keys):
        if key in first:
            repeats.append(f"line {line_arr[k]} repeats line {line_arr[first[key]]}")
        else:
            first[key] = k
    if repeats:
        more = f" and {len(repeats) - 5} more" if len(repeats) > 5 else ""
        warnings.append(f"{source}: {len(repeats)} duplicate row(s): {'; '.join(repeats[:5])}{more}")
    return CsvTable(arrays, texts, line_arr, warnings)


def parse_header(
    header_text: str, source: str, header_line: int, required: list[str], optional: list[str]
) -> tuple[list[str], list[str]]:
    """The column names of a header line, checked; and the warnings about unused columns.

    Raises:
        InputError: another separator than commas, an empty or repeated name, a missing
            required column (with the closest name as a hint).
    """
    header = [h.strip() for h in _csv_fields(header_text, source, header_line)]
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        sep = "';'" if ";" in header[0] else "a tab"
        raise InputError(f"fields are separated by {sep}; deltacal reads comma-separated files",
                         source, f"line {header_line}")
    seen: set[str] = set()
    for h in header:
        if not h:
            raise InputError("empty column name in the header (a trailing comma?)", source,
                             f"line {header_line}")
        if h in seen:
            raise InputError(f"column {h!r} appears twice", source, f"line {header_line}")
        seen.add(h)
    known = list(required) + list(optional)
    missing = [c for c in required if c not in header]
    if missing:
        unknown = [h for h in header if h not in known]
        hints = []
        for c in missing:
            # the same name in another case first: difflib compares case-sensitively
            close = [h for h in unknown if h.lower() == c.lower()]
            close = close or difflib.get_close_matches(c, unknown, n=1, cutoff=0.6)
            if close:
                hints.append(f"{close[0]!r} for {c}?")
        hint = f"; did you mean {', '.join(hints)}" if hints else ""
        raise InputError(
            f"missing required column(s) {', '.join(missing)} (header: {','.join(header)}){hint}",
            source, f"line {header_line}",
        )
    unused = [h for h in header if h not in known]
    shown = ", ".join(repr(h) for h in unused[:5]) + (f" and {len(unused) - 5} more" * (len(unused) > 5))
    warnings = [f"{source}: {len(unused)} column(s) not used by deltacal and ignored: {shown}"] * bool(unused)
    return header, warnings


def parse_rows(
    rows: list[tuple[int, str]],
    header: list[str],
    wanted: list[str],
    text_columns: tuple[str, ...],
    source: str,
    first_row: int,
) -> tuple[dict[str, list[float]], dict[str, list[str]], list[int]]:
    """Fields of data rows ``(line number, text)``, checked: numbers by column, texts, lines.

    Empty numeric fields are NaN (the caller decides whether a column may be empty);
    ``first_row`` is the data-row number of ``rows[0]``.

    Raises:
        InputError: a row with another number of fields than the header, or a value that
            is not a finite decimal number, naming the line, the row and the column.
    """
    index = {h: k for k, h in enumerate(header)}
    numbers: dict[str, list[float]] = {c: [] for c in wanted if c not in text_columns}
    texts: dict[str, list[str]] = {c: [] for c in wanted if c in text_columns}
    lines = []
    for row_no, (line_no, line) in enumerate(rows, start=first_row):
        where = data_row(line_no, row_no)
        fields = _csv_fields(line, source, line_no)
        if len(fields) != len(header):
            if len(fields) < len(header) and (";" in line or "\t" in line):
                hint = " (fields separated by ';' or tabs? deltacal reads commas)"
            elif len(fields) > len(header) and fields[-1].strip() == "":
                hint = " (a trailing comma?)"
            elif len(fields) > len(header):
                hint = " (a decimal comma?)"
            else:
                hint = ""
            raise InputError(
                f"{len(fields)} fields where the header has {len(header)}{hint}", source, where
            )
        for c in wanted:
            value = fields[index[c]].strip()
            if c in text_columns:
                texts[c].append(value)
                continue
            if value == "":
                numbers[c].append(math.nan)
                continue
            numbers[c].append(_parse_number(value, source, f"{where}, column {c}"))
        lines.append(line_no)
    return numbers, texts, lines


def unit_warnings(arrays: Mapping[str, np.ndarray], source: str) -> list[str]:
    """Columns whose values suggest another unit than the column's name says."""
    out = []
    for c, v in arrays.items():
        finite = v[np.isfinite(v)]
        if finite.size < 3:
            continue
        top = float(np.max(np.abs(finite)))
        if re.fullmatch(r"q\d_deg", c) and top <= math.pi and np.ptp(finite) > 0.05:
            out.append(f"{source}: column {c} holds only values within ±π: are these radians? "
                       "deltacal reads degrees")
    positions = [c for c in ("x_mm", "y_mm", "z_mm") if c in arrays]
    if positions:
        both = np.concatenate([arrays[c][np.isfinite(arrays[c])] for c in positions])
        if both.size >= 3 and np.max(np.abs(both)) <= 5.0 and np.ptp(both) > 0.0:
            out.append(f"{source}: columns {', '.join(positions)} hold only values within ±5: are these "
                       "metres? deltacal reads millimetres")
    return out


def csv_field(text: str) -> str:
    """A text field as CSV writes it: quoted (quotes doubled) when it holds a comma or a quote."""
    if any(c in text for c in ',"'):
        return '"' + text.replace('"', '""') + '"'
    return text


def format_rows(columns: list[np.ndarray], header: list[str], extra: list[list[str]] | None = None) -> str:
    """CSV text: the header, then one row per entry of the columns.

    Floats are written with ``repr`` (NaN as an empty field), followed by the ``extra`` text fields
    of that row (quoted as CSV needs).
    """
    data = np.column_stack(columns) if columns else np.zeros((0, 0))
    out = [",".join(header)]
    for k, row in enumerate(data):
        fields = [("" if math.isnan(v) else repr(float(v))) for v in row]
        if extra is not None:
            fields += [csv_field(text) for text in extra[k]]
        out.append(",".join(fields))
    return "\n".join(out) + "\n"
