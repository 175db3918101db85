"""TOML files: reading with one-line errors naming the key, writing with exact angles.

Keys and strings are written by tomli-w (what may stay bare, what must be quoted and how a
character is escaped are its job); numbers and arrays are laid out here, an array on one line,
because tomli-w puts each element of an array on a line of its own (a correlation matrix of 40
base parameters would take 1,700 lines) and cannot write the exact degrees of :class:`RawToml`.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Mapping
from decimal import Decimal, localcontext
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from ..exceptions import InputError
from ..towers import TOWERS

_PI = Decimal("3.141592653589793238462643383279502884197169399375105820974944592307816406286")


class RawToml(str):
    """Text written to TOML as is (a number with more digits than a float's repr)."""


def exact_degrees(angle: float) -> RawToml:
    """An angle [rad] in degrees, as TOML number text that reads back to exactly ``angle``.

    Degrees are computed with 50-digit decimal arithmetic and written with 25
    significant digits; :func:`radians_from_text` converts back with the same
    precision and rounds once, so geometry files round-trip bit for bit (plain
    ``math.degrees``/``math.radians`` do not: they are not exact inverses).
    """
    if not math.isfinite(angle):
        return RawToml(toml_value(float(angle)))
    with localcontext() as ctx:
        ctx.prec = 50
        deg = Decimal(angle) * 180 / _PI
        text = format(deg, ".25e")
    return RawToml(text.replace("E", "e"))


def short_degrees(angle: float) -> RawToml:
    """An angle [rad] in degrees with the fewest digits that read back to it within two ulps.

    ``30.0`` rather than ``29.999999999999996`` for ``math.radians(30.0)`` (which
    :func:`radians_from_text` reads back one ulp, 6e-17 rad, away): for files a person reads and
    types into a controller. :func:`exact_degrees` is the bit-for-bit form.
    """
    if math.isfinite(angle):
        with localcontext() as ctx:
            ctx.prec = 50
            deg = Decimal(angle) * 180 / _PI
        for digits in range(1, 18):
            text = repr(float(format(deg, f".{digits}g")))
            if abs(radians_from_text(Decimal(text)) - angle) <= 2.0 * math.ulp(angle):
                return RawToml(text)
    return exact_degrees(angle)


def radians_written_as(degrees: float) -> float:
    """The angle [rad] that ``math.degrees`` writes as ``degrees``: what a file's plain degrees stand for.

    Values that files hold in degrees to ``repr``'s digits (a base parameter's ``value_deg``...)
    are written as ``math.degrees(angle)``; plain ``math.radians`` does not always give that angle
    back (one value in twenty is an ulp off, and is then written back an ulp off). This returns
    the angle within two ulps of ``math.radians(degrees)`` whose ``math.degrees`` is ``degrees``,
    so a file read and written again is the same to the last digit. Degrees no angle gives (typed
    by hand, about one value in ten) read as ``math.radians(degrees)``.
    """
    near = math.radians(degrees)
    for step in (0, 1, -1, 2, -2):
        angle = near
        for _ in range(abs(step)):
            angle = math.nextafter(angle, math.copysign(math.inf, step))
        if math.degrees(angle) == degrees:
            return angle
    return near


def radians_from_text(value: Decimal | float) -> float:
    """Degrees read from a file (Decimal keeps every digit) to radians, rounded once."""
    if isinstance(value, float):
        return math.radians(value)
    with localcontext() as ctx:
        ctx.prec = 50
        return float(Decimal(value) * _PI / 180)


def toml_value(value: Any) -> str:
    """A value as TOML writes it: exact floats (``repr``), arrays on one line, :class:`RawToml` as is."""
    if isinstance(value, RawToml):
        return str(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        return tomli_w.dumps({"v": value})[len("v = "):-1]
    if isinstance(value, np.ndarray):
        return toml_value(value.tolist())
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _toml_key(key: str) -> str:
    """A key as TOML writes it: bare when it holds only ASCII letters, digits, '_' and '-'."""
    return tomli_w.dumps({key: 0})[: -len(" = 0\n")]


def toml_dumps(data: Mapping[str, Any]) -> str:
    """Serialise nested mappings of numbers, strings and arrays to TOML.

    Floats are written with ``repr`` (shortest exact form), so they read back
    bit for bit. Lists of mappings become arrays of tables.
    """
    lines: list[str] = []

    def emit(table: Mapping[str, Any], prefix: str) -> None:
        scalars = [
            (k, v)
            for k, v in table.items()
            if not isinstance(v, Mapping) and not _is_table_array(v)
        ]
        for k, v in scalars:
            lines.append(f"{_toml_key(k)} = {toml_value(v)}")
        for k, v in table.items():
            name = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
            if isinstance(v, Mapping):
                lines.append("")
                lines.append(f"[{name}]")
                emit(v, name)
            elif _is_table_array(v):
                for item in v:
                    lines.append("")
                    lines.append(f"[[{name}]]")
                    emit(item, name)

    emit(data, "")
    return "\n".join(lines).lstrip("\n") + "\n"


def shown_value(value: Any, limit: int = 80) -> str:
    """A value read from TOML as the user wrote it (Decimal numbers without their class name)."""
    if isinstance(value, Decimal):
        text = str(value)
    elif isinstance(value, list):
        text = "[" + ", ".join(shown_value(v, limit) for v in value) + "]"
    else:
        try:
            text = repr(value)
        except ValueError:  # an integer with more digits than Python converts
            text = "<an integer too large to show>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(i, Mapping) for i in v)


# --------------------------------------------------------------------------- reading
#: The deepest nesting of arrays and tables in deltacal's files (plate_ball_mm: limb, array, array).
MAX_NESTING = 4


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing, unreadable or malformed file raises InputError."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read file ({exc.strerror})", str(path)) from None
    if not raw.strip():
        raise InputError("file is empty", str(path))
    if raw.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte order mark (Windows editors): read, as in CSV files
        raw = raw[3:]
    try:
        return tomllib.loads(raw.decode("utf-8"), parse_float=Decimal)
    except UnicodeDecodeError as exc:
        raise not_utf8(raw, exc, str(path)) from None
    except (tomllib.TOMLDecodeError, ValueError) as exc:  # ValueError: an integer too long to read
        raise InputError(f"not valid TOML ({exc})", str(path)) from None
    except RecursionError:
        raise InputError("not valid TOML for deltacal: arrays or tables nested too deeply "
                         f"(deltacal's files nest {MAX_NESTING} levels at most)", str(path)) from None


def not_utf8(raw: bytes, exc: UnicodeDecodeError, source: str) -> InputError:
    """The error for a file that is not UTF-8, naming the line and the first bad byte."""
    line = raw[: exc.start].count(b"\n") + 1
    hint = " (UTF-16? save it as UTF-8)" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
    return InputError(f"file is not UTF-8 text: byte 0x{raw[exc.start]:02x}{hint}", source, f"line {line}")


class TomlTable:
    """A TOML table read with checks that name the file and the key."""

    def __init__(self, data: Mapping[str, Any], source: str, prefix: str = "") -> None:
        self.data = data
        self.source = source
        self.prefix = prefix
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        """The key's dotted path in the file (``geometry.rod_length_mm``)."""
        return f"{self.prefix}{name}"

    def error(self, name: str, detail: str) -> InputError:
        """The error for key ``name``, naming the file and the key."""
        return InputError(detail, self.source, f"key {self.key(name)}")

    def has(self, name: str) -> bool:
        """Whether the table holds key ``name``."""
        return name in self.data

    def raw(self, name: str) -> Any:
        """The value of a required key as read (marked used)."""
        if name not in self.data:
            raise self.error(name, "missing required key")
        self.used.add(name)
        return self.data[name]

    def table(self, name: str, required: bool = True) -> TomlTable | None:
        """The sub-table ``name`` (None when absent and not required)."""
        if name not in self.data:
            if required:
                raise self.error(name, "missing required table")
            return None
        value = self.raw(name)
        if not isinstance(value, Mapping):
            raise self.error(name, f"must be a table, got {shown_value(value)}")
        return TomlTable(value, self.source, f"{self.key(name)}.")

    def string(self, name: str, default: str | None = None) -> str:
        """A string value (``default`` when absent, if given)."""
        if default is not None and name not in self.data:
            return default
        value = self.raw(name)
        if not isinstance(value, str):
            raise self.error(name, f"must be a string, got {shown_value(value)}")
        return value

    def number(self, name: str, positive: bool = False) -> float:
        """A finite number (above zero if ``positive``), as a float."""
        value = self.raw(name)
        return self._check_number(name, value, positive)

    def _check_number(self, name: str, value: Any, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, Decimal)):
            raise self.error(name, f"must be a number, got {shown_value(value)}")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond the float range
            number = math.inf
        if not math.isfinite(number):
            raise self.error(name, f"must be finite, got {shown_value(value)}")
        value = number
        if positive and value <= 0.0:
            raise self.error(name, f"must be positive, got {value!r}")
        return value

    def angle(self, name: str) -> float:
        """A number in degrees, returned in radians exactly as written (see exact_degrees)."""
        value = self.raw(name)
        self._check_number(name, value)
        return radians_from_text(value)

    def vector(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """An array of finite numbers of the given shape."""
        value = self.raw(name)
        return self.array_value(name, value, shape)

    def array_value(self, name: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
        """``value`` (read from key ``name``) as an array of finite numbers of the given shape."""
        def flat(v: Any, depth: int) -> list[float]:
            if depth == len(shape):
                return [self._check_number(name, v)]
            if not isinstance(v, list) or len(v) != shape[depth]:
                raise self.error(name, f"must be an array of shape {list(shape)}, got {shown_value(value)}")
            out: list[float] = []
            for item in v:
                out += flat(item, depth + 1)
            return out

        return np.array(flat(value, 0), dtype=float).reshape(shape)

    def per_tower(self, name: str, positive: bool = False) -> np.ndarray:
        """A number or ``[a, b, c]`` (towers A, B, C), as one value per tower, (3,).

        Raises:
            InputError: naming the key: neither a number nor three numbers, or (``positive``) a
                value not above zero (and its tower).
        """
        value = self.raw(name)
        if not isinstance(value, list):
            return np.full(3, self._check_number(name, value, positive))
        if len(value) != len(TOWERS):
            raise self.error(name, "must be a number or [a, b, c] (towers A, B, C), "
                                   f"got {shown_value(value)}")
        values = self.array_value(name, value, (3,))
        for tower, v in zip(TOWERS, values, strict=True):
            if positive and v <= 0.0:
                raise self.error(name, f"must be positive, got {float(v)!r} on tower {tower}")
        return values

    def check_unknown(self, allowed: Iterable[str]) -> None:
        """Refuse a key of the table not in ``allowed``, naming it."""
        allowed = set(allowed)
        for k in self.data:
            if k not in allowed:
                raise self.error(k, "unknown key")
