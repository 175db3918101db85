"""Targets and joints CSV files (compensate's input and output), whole or streamed in chunks.

A targets file of a million rows is read, checked and written in chunks of
:data:`CHUNK_BYTES`, so memory stays flat in the file's length. The reader takes a
fast path where a chunk can only hold plain numbers (``numpy.loadtxt`` after a byte
check: 1.1 s for 10^6 rows here, against 4.1 s for the csv module with ``float`` and
4.3 s more for the per-field pattern check); any chunk the fast path is unsure of goes
through the per-row checks of :func:`~deltacal.io.tables.parse_rows`, which name the line.
"""

from __future__ import annotations

import io
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

import numpy as np

from ..exceptions import InputError
from .atomic import atomic_output, atomic_write_text
from .tables import (
    JOINT_COLUMNS,
    MAX_MAGNITUDE,
    TARGET_COLUMNS,
    CsvTable,
    data_row,
    format_rows,
    parse_header,
    parse_rows,
    read_csv_table,
    unit_warnings,
)

#: Bytes read at a time (about 30,000 targets): memory is a few times this, whatever the file's length.
#: 1 MB against 4 MB: no slower (12.4 s against 13.5 s for 10^6 targets, savoure, one noisy run
#: each) and a third of the peak memory (150 MB against 380 MB).
CHUNK_BYTES = 1 << 20
#: Decimals of the readings written [deg]: 1e-12 deg, far below any encoder's resolution.
JOINT_DECIMALS = 12
#: Columns of the corrected targets written after the targets (``compensate --controller``).
COMMAND_COLUMNS = ["x_cmd_mm", "y_cmd_mm", "z_cmd_mm"]
#: Decimals of the corrected targets written [mm]: 1e-9 mm (a picometre), far below any
#: controller's resolution; values up to 9e6 mm are written exactly to it.
COMMAND_DECIMALS = 9
#: The bytes a chunk of plain numbers may hold (no quotes, names, nan, inf, underscores).
_PLAIN = b"0123456789+-.eE, \r\n"


def read_target_table(path: str | Path) -> CsvTable:
    """Read a targets CSV as a validated table: its ``lines`` let errors name a target's line."""
    return read_csv_table(path, TARGET_COLUMNS)


def write_joints(path: str | Path, targets: np.ndarray, q: np.ndarray) -> None:
    """Write the joints CSV: targets [mm] then readings to command [deg], atomically."""
    qd = np.degrees(q)
    atomic_write_text(path, format_rows([*targets.T, *qd.T], TARGET_COLUMNS + JOINT_COLUMNS))


@dataclass(frozen=True)
class TargetChunk:
    """Consecutive rows of a targets file.

    Attributes:
        targets: Positions [mm], shape (n, 3).
        lines: Line of each row in the file, shape (n,).
        first_row: Data-row number of the first row (the first data row is 1).
        text: The rows as written (``x,y,z``) to copy to the joints file, or None.
        read: Bytes of the file read so far.
    """

    targets: np.ndarray
    lines: np.ndarray
    first_row: int
    text: np.ndarray | None
    read: int

    def __len__(self) -> int:
        return self.targets.shape[0]

    def where(self, k: int) -> str:
        """Where row k of the chunk is: its line in the file and its data-row number."""
        return data_row(int(self.lines[k]), self.first_row + k)


class TargetFile:
    """A targets CSV read in chunks: the header is checked on opening, the rows as they come.

    Iterate :meth:`chunks` once to check the whole file (:attr:`rows` and :attr:`warnings`
    are then known), and again to use it.
    """

    def __init__(self, path: str | Path, chunk_bytes: int | None = None) -> None:
        self.path = Path(path)
        self.source = str(path)
        self.chunk_bytes = CHUNK_BYTES if chunk_bytes is None else int(chunk_bytes)
        try:
            self.size = self.path.stat().st_size
            with open(self.path, "rb") as f:
                line_no, header = 0, b""
                while not header.strip():
                    raw = f.readline()
                    if not raw:
                        raise InputError("file is empty", self.source)
                    line_no += 1
                    header = raw[3:] if line_no == 1 and raw.startswith(b"\xef\xbb\xbf") else raw
                self._data_offset = f.tell()
        except FileNotFoundError:
            raise InputError("file not found", self.source) from None
        except IsADirectoryError:
            raise InputError("is a folder, not a file", self.source) from None
        except OSError as exc:
            raise InputError(f"cannot read file ({exc.strerror})", self.source) from None
        text = self._decode(header, line_no)
        self._data_line = line_no + 1
        self.header, self.warnings = parse_header(text.rstrip("\r\n"), self.source, line_no,
                                                  TARGET_COLUMNS, [])
        self._plain = self.header == TARGET_COLUMNS
        self.rows = 0
        self._low, self._high = np.inf, -np.inf  # the least and greatest position value

    def _decode(self, block: bytes, first_line: int) -> str:
        if b"\x00" in block:
            raise InputError("file holds NUL bytes: a binary or UTF-16 file? deltacal reads UTF-8 CSV",
                             self.source)
        try:
            return block.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = first_line + block[: exc.start].count(b"\n")
            hint = " (UTF-16? save it as UTF-8)" if block[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
            raise InputError(f"file is not UTF-8 text: byte 0x{block[exc.start]:02x}{hint}", self.source,
                             f"line {line}") from None

    def _blocks(self) -> Iterator[tuple[int, bytes, int]]:
        """(first line, whole lines, bytes read) of the data, chunk by chunk."""
        with open(self.path, "rb") as f:
            f.seek(self._data_offset)
            line, rest = self._data_line, b""
            while True:
                block = f.read(self.chunk_bytes)
                if not block:
                    yield line, rest, self.size
                    return
                block = rest + block
                cut = block.rfind(b"\n") + 1
                if cut == 0:
                    rest = block
                    continue
                yield line, block[:cut], f.tell()
                line += block.count(b"\n", 0, cut)
                rest = block[cut:]

    def chunks(self) -> Iterator[TargetChunk]:
        """The file's rows, checked, chunk by chunk (errors name the file, line and column).

        Raises:
            InputError: a bad row (naming its line and column), or no data rows at all.
        """
        row = 1
        checked = self.rows > 0
        for first_line, block, read in self._blocks():
            targets, lines, text = self._parse(block, first_line, row)
            if targets.shape[0]:
                self._low = min(self._low, float(targets.min()))
                self._high = max(self._high, float(targets.max()))
                yield TargetChunk(targets, lines, row, text, read)
            row += targets.shape[0]
        if row == 1:
            raise InputError("no data rows after the header", self.source)
        self.rows = row - 1
        if not checked:
            # the whole file's values, as read_csv_table judges them (metres for millimetres?)
            extremes = np.array([self._low, self._high])
            self.warnings += unit_warnings({c: extremes for c in TARGET_COLUMNS}, self.source)

    def _parse(self, block: bytes, first_line: int, first_row: int):
        fast = self._fast(block, first_line) if self._plain else None
        if fast is not None:
            return fast
        text = self._decode(block, first_line)
        rows = [(first_line + n, s.rstrip("\r")) for n, s in enumerate(text.split("\n")) if s.strip()]
        numbers, _, lines = parse_rows(rows, self.header, TARGET_COLUMNS, (), self.source, first_row)
        targets = np.column_stack([np.array(numbers[c], dtype=float) for c in TARGET_COLUMNS]).reshape(-1, 3)
        empty = np.isnan(targets)
        if np.any(empty):
            k, c = np.argwhere(empty)[0]
            raise InputError("empty value in a required column", self.source,
                             f"{data_row(lines[k], first_row + k)}, column {TARGET_COLUMNS[c]}")
        return targets, np.array(lines, dtype=np.int64), None

    def _fast(self, block: bytes, first_line: int):
        """The chunk parsed by numpy where it can only hold plain numbers; None where unsure."""
        if block.translate(None, _PLAIN) or block.count(b"\r") != block.count(b"\r\n"):
            return None
        block = block.replace(b"\r\n", b"\n")
        pieces = block.split(b"\n")
        if pieces and pieces[-1] == b"":
            pieces.pop()
        kept = [k for k, s in enumerate(pieces) if s.strip()]
        if not kept:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.int64), np.zeros(0, dtype="S1")
        try:
            targets = np.loadtxt(io.BytesIO(block), delimiter=",", comments=None, ndmin=2, dtype=float)
        except ValueError:
            return None
        if targets.shape != (len(kept), 3) or not np.all(np.abs(targets) <= MAX_MAGNITUDE):
            return None  # the row-by-row reading names the row (NaN, infinities, out of range)
        if len(kept) < len(pieces):
            pieces = [pieces[k] for k in kept]
        return targets, first_line + np.array(kept, dtype=np.int64), np.array(pieces)


class JointsWriter:
    """The joints CSV written chunk by chunk; it replaces an earlier file only once complete.

    Use as a context manager: on an exception, nothing is written and an earlier file at
    the path is left as it was (:func:`~deltacal.io.atomic.atomic_output`).
    """

    #: The columns written after the targets, and their decimals.
    COLUMNS = JOINT_COLUMNS
    DECIMALS = JOINT_DECIMALS

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.rows = 0

    def __enter__(self) -> JointsWriter:
        self._atomic = atomic_output(self.path)
        tmp = self._atomic.__enter__()
        self._file = open(tmp, "wb")  # noqa: SIM115 (closed in __exit__)
        self._file.write((",".join(TARGET_COLUMNS + self.COLUMNS) + "\n").encode())
        return self

    def write(self, chunk: TargetChunk, q: np.ndarray) -> None:
        """Rows of the chunk's targets (as written where possible) and readings q [rad] in degrees."""
        self.write_encoded(self.encode(chunk.text, chunk.targets, q), len(chunk))

    def write_encoded(self, rows: bytes, count: int) -> None:
        """Rows already laid out by :meth:`encode` (``count`` of them)."""
        self._file.write(rows)
        self.rows += count

    @classmethod
    def encode(cls, text: np.ndarray | None, targets: np.ndarray, values: np.ndarray) -> bytes:
        """The rows of a chunk: its targets' text (``None``: from the targets) then the values."""
        if text is None:
            text = np.array([",".join(map(repr, row)).encode() for row in targets.tolist()])
        return joint_rows(text, cls._shown(values), cls.DECIMALS)

    @staticmethod
    def _shown(values: np.ndarray) -> np.ndarray:
        """The values in the file's unit (readings [rad] in degrees)."""
        return np.degrees(values)

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self._file.close()
        self._atomic.__exit__(kind, value, traceback)


class CommandsWriter(JointsWriter):
    """The corrected-targets CSV (targets, then ``x_cmd_mm,y_cmd_mm,z_cmd_mm``), as :class:`JointsWriter`."""

    COLUMNS = COMMAND_COLUMNS
    DECIMALS = COMMAND_DECIMALS

    @staticmethod
    def _shown(values: np.ndarray) -> np.ndarray:
        return values  # mm already


def joint_rows(text: np.ndarray, q_deg: np.ndarray, decimals: int = JOINT_DECIMALS) -> bytes:
    """CSV rows ``TEXT,q1,q2,q3``: each row's text then its readings with ``decimals`` decimals.

    Vectorised: every field is laid out at a fixed width with NUL padding, which is then
    removed (neither the text nor a number holds a NUL).

    Args:
        text: The start of each row, bytes array of shape (n,).
        q_deg: Readings [deg], shape (n, 3), finite, below 9,000 deg in magnitude.
        decimals: Decimals of the readings.
    """
    n = q_deg.shape[0]
    if n == 0:
        return b""
    scaled = np.rint(np.abs(q_deg) * 10.0**decimals)
    if not np.all(scaled < 2.0**53):
        limit = 2.0**53 / 10.0**decimals
        raise ValueError(f"values must be finite and below {limit:,.0f} to be written exactly to {decimals} "
                         "decimals")
    m = scaled.astype(np.int64)
    width = max(decimals + 1, len(str(int(m.max()))))
    digits = (m[..., None] // 10 ** np.arange(width - 1, -1, -1, dtype=np.int64)) % 10
    chars = (digits + ord("0")).astype(np.uint8)
    whole = width - decimals
    leading = np.cumsum(digits[..., : whole - 1], axis=-1) == 0  # zeros before the first digit
    chars[..., : whole - 1][leading] = 0
    sign = np.where(np.signbit(q_deg) & (m > 0), ord("-"), 0).astype(np.uint8)[..., None]
    point = np.full((n, q_deg.shape[1], 1), ord("."), dtype=np.uint8)
    sep = np.full((n, q_deg.shape[1], 1), ord(","), dtype=np.uint8)
    sep[:, -1] = ord("\n")
    fields = np.concatenate([sign, chars[..., :whole], point, chars[..., whole:], sep], axis=-1)
    head = np.ascontiguousarray(text, dtype=f"S{max(1, text.dtype.itemsize)}")
    head_bytes = head.view(np.uint8).reshape(n, -1)
    comma = np.full((n, 1), ord(","), dtype=np.uint8)
    rows = np.concatenate([head_bytes, comma, fields.reshape(n, -1)], axis=1)
    return rows.tobytes().replace(b"\x00", b"")
