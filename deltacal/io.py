"""Reading and writing deltacal's files: robot TOML, geometry TOML, atomic writes.

Files are in millimetres and degrees; the library works in millimetres and
radians. Every reader validates what it reads and raises
:class:`~deltacal.exceptions.InputError` naming the file and the key (or row
and column). Every writer writes a temporary file in the destination folder and
renames it, so a failure never leaves a half-written output.
"""

from __future__ import annotations

import contextlib
import csv
import difflib
import math
import os
import re
import tempfile
import tomllib
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from decimal import Decimal, localcontext
from pathlib import Path
from typing import Any
from warnings import warn

import numpy as np

from .exceptions import GeometryError, InputError, InputWarning
from .kinematics.closed_form import VirtualDelta
from .observations import DEFAULT_STATION
from .planning import PoseSet

GEOMETRY_FORMAT = "deltacal-geometry-1"
CALIBRATION_FORMAT = "deltacal-calibration-1"


# --------------------------------------------------------------------------- writing
@contextlib.contextmanager
def atomic_output(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it replaces ``path`` when the block succeeds.

    The one place where deltacal writes an output file. If anything fails, an
    existing file at ``path`` is left exactly as it was and the temporary file is
    removed. The new file gets the permissions of the file it replaces, or the
    usual ones (``0o666`` less the umask) for a new file.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=folder)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        # mkstemp creates the file 0o600: give the output the mode a plain open() would
        try:
            mode = path.stat().st_mode & 0o7777
        except OSError:
            mode = 0o666 & ~_umask()
        os.chmod(tmp, mode)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write bytes to ``path`` atomically (see :func:`atomic_output`); returns the path."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 text to ``path`` atomically (see :func:`atomic_output`); returns the path."""
    with atomic_output(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return Path(path)


def _umask() -> int:
    """The process's file creation mask (read without leaving it changed)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


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
        return RawToml(_toml_value(float(angle)))
    with localcontext() as ctx:
        ctx.prec = 50
        deg = Decimal(angle) * 180 / _PI
        text = format(deg, ".25e")
    return RawToml(text.replace("E", "e"))


def radians_from_text(value: Decimal | float) -> float:
    """Degrees read from a file (Decimal keeps every digit) to radians, rounded once."""
    if isinstance(value, float):
        return math.radians(value)
    with localcontext() as ctx:
        ctx.prec = 50
        return float(Decimal(value) * _PI / 180)


def _toml_value(value: Any) -> str:
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
        escaped = (
            value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t")
        )
        return f'"{escaped}"'
    if isinstance(value, np.ndarray):
        return _toml_value(value.tolist())
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def _toml_key(key: str) -> str:
    if key and all(c.isalnum() or c in "_-" for c in key):
        return key
    return _toml_value(key)


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
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
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


def _shown(value: Any, limit: int = 80) -> str:
    """A value read from TOML as the user wrote it (Decimal numbers without their class name)."""
    if isinstance(value, Decimal):
        text = str(value)
    elif isinstance(value, list):
        text = "[" + ", ".join(_shown(v, limit) for v in value) + "]"
    else:
        try:
            text = repr(value)
        except ValueError:  # an integer with more digits than Python converts
            text = "<an integer too large to show>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(i, Mapping) for i in v)


# --------------------------------------------------------------------------- reading
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
    try:
        return tomllib.loads(raw.decode("utf-8"), parse_float=Decimal)
    except UnicodeDecodeError as exc:
        raise _not_utf8(raw, exc, str(path)) from None
    except (tomllib.TOMLDecodeError, ValueError) as exc:  # ValueError: an integer too long to read
        raise InputError(f"not valid TOML ({exc})", str(path)) from None


def _not_utf8(raw: bytes, exc: UnicodeDecodeError, source: str) -> InputError:
    """The error for a file that is not UTF-8, naming the line and the first bad byte."""
    line = raw[: exc.start].count(b"\n") + 1
    hint = " (UTF-16? save it as UTF-8)" if raw[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
    return InputError(f"file is not UTF-8 text: byte 0x{raw[exc.start]:02x}{hint}", source, f"line {line}")


class _Table:
    """A TOML table read with checks that name the file and the key."""

    def __init__(self, data: Mapping[str, Any], source: str, prefix: str = "") -> None:
        self.data = data
        self.source = source
        self.prefix = prefix
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.prefix}{name}"

    def error(self, name: str, detail: str) -> InputError:
        return InputError(detail, self.source, f"key {self.key(name)}")

    def has(self, name: str) -> bool:
        return name in self.data

    def raw(self, name: str) -> Any:
        if name not in self.data:
            raise self.error(name, "missing required key")
        self.used.add(name)
        return self.data[name]

    def table(self, name: str, required: bool = True) -> _Table | None:
        if name not in self.data:
            if required:
                raise self.error(name, "missing required table")
            return None
        value = self.raw(name)
        if not isinstance(value, Mapping):
            raise self.error(name, f"must be a table, got {_shown(value)}")
        return _Table(value, self.source, f"{self.key(name)}.")

    def string(self, name: str, default: str | None = None) -> str:
        if default is not None and name not in self.data:
            return default
        value = self.raw(name)
        if not isinstance(value, str):
            raise self.error(name, f"must be a string, got {_shown(value)}")
        return value

    def number(self, name: str, positive: bool = False) -> float:
        value = self.raw(name)
        return self._check_number(name, value, positive)

    def _check_number(self, name: str, value: Any, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float, Decimal)):
            raise self.error(name, f"must be a number, got {_shown(value)}")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond the float range
            number = math.inf
        if not math.isfinite(number):
            raise self.error(name, f"must be finite, got {_shown(value)}")
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
        value = self.raw(name)
        return self.array_value(name, value, shape)

    def array_value(self, name: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
        def flat(v: Any, depth: int) -> list[float]:
            if depth == len(shape):
                return [self._check_number(name, v)]
            if not isinstance(v, list) or len(v) != shape[depth]:
                raise self.error(name, f"must be an array of shape {list(shape)}, got {_shown(value)}")
            out: list[float] = []
            for item in v:
                out += flat(item, depth + 1)
            return out

        return np.array(flat(value, 0), dtype=float).reshape(shape)

    def check_unknown(self, allowed: Iterable[str]) -> None:
        allowed = set(allowed)
        for k in self.data:
            if k not in allowed:
                raise self.error(k, "unknown key")


def load_nominal(path: str | Path):  # -> NominalDelta
    """Read and validate a nominal robot file (format of the project's conventions).

    Raises:
        InputError: naming the file and the key of the first problem found.
    """
    from .geometry import NominalDelta, Workspace

    source = str(path)
    top = _Table(read_toml(path), source)
    if top.data.get("format") in (GEOMETRY_FORMAT, CALIBRATION_FORMAT):
        raise top.error("format", f"this is a deltacal {top.data['format']!r} file, not a nominal "
                                  "robot file (such as deltacal/models/bai2015.toml)")
    top.check_unknown(["name", "description", "geometry", "points", "workspace"])
    name = top.string("name")
    description = top.string("description")
    geo = top.table("geometry")
    assert geo is not None
    geo.check_unknown(
        [
            "base_radius_mm",
            "plate_radius_mm",
            "arm_length_mm",
            "rod_length_mm",
            "rod_spacing_mm",
            "limb_azimuth_deg",
            "tool_mm",
        ]
    )
    values = {
        "base_radius": geo.number("base_radius_mm", positive=True),
        "plate_radius": geo.number("plate_radius_mm", positive=True),
        "arm_length": geo.number("arm_length_mm", positive=True),
        "rod_length": geo.number("rod_length_mm", positive=True),
        "rod_spacing": geo.number("rod_spacing_mm", positive=True),
    }
    azimuth_deg = geo.vector("limb_azimuth_deg", (3,))
    if len({round(float(a) % 360.0, 9) for a in azimuth_deg}) < 3:
        raise geo.error("limb_azimuth_deg", f"the three azimuths must differ, got {azimuth_deg.tolist()}")
    if np.max(np.abs(azimuth_deg)) <= 2.0 * math.pi and np.ptp(azimuth_deg) > 1.0:
        warn(
            f"{source}: key geometry.limb_azimuth_deg: azimuths {azimuth_deg.tolist()} are within "
            "±2π and put the limbs a few degrees apart: are these radians? deltacal reads degrees",
            InputWarning, stacklevel=2,
        )
    tool = geo.vector("tool_mm", (3,))
    points: dict[str, np.ndarray] = {}
    pts = top.table("points", required=False)
    if pts is not None:
        for k in pts.data:
            if k == "tcp":
                raise pts.error(k, "'tcp' is reserved for the tool centre point")
            points[k] = pts.vector(k, (3,))
    workspace = None
    ws = top.table("workspace", required=False)
    if ws is not None:
        ws.check_unknown(["radius_mm", "height_mm", "top_z_mm"])
        workspace = Workspace(
            radius=ws.number("radius_mm", positive=True),
            height=ws.number("height_mm", positive=True),
            top_z=ws.number("top_z_mm"),
        )
        if workspace.top_z >= 0.0:
            raise ws.error("top_z_mm", f"the plate works below the base: must be < 0, got {workspace.top_z}")
    b, a, L, l_rod = (values[k] for k in ("base_radius", "plate_radius", "arm_length", "rod_length"))
    if l_rod <= abs(b - a) * 0.5 or l_rod + L <= abs(b - a):
        raise geo.error("rod_length_mm", f"rods of {l_rod} mm cannot reach the plate")
    if l_rod <= 0.25 * L:
        raise geo.error("rod_length_mm", f"rods of {l_rod} mm are too short for arms of {L} mm "
                                         "(at least a quarter of the arm length)")
    try:
        nominal = NominalDelta(
            name=name,
            description=description,
            limb_azimuth=np.radians(azimuth_deg),
            tool=tool,
            points=points,
            workspace=workspace,
            **values,
        )
    except GeometryError as exc:
        raise InputError(str(exc), source) from None
    if workspace is not None:
        _check_workspace_reachable(nominal, source)
    return nominal


def _check_workspace_reachable(nominal, source: str) -> None:
    """The workspace cylinder's rim must be reachable by the nominal robot."""
    from .kinematics.closed_form import VirtualDelta

    ws = nominal.workspace
    ang = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    rim = []
    for z in (ws.top_z, ws.bottom_z):
        rim.append(np.stack([ws.radius * np.cos(ang), ws.radius * np.sin(ang), np.full_like(ang, z)], 1))
    pts = np.concatenate(rim)
    q = VirtualDelta.from_nominal(nominal).inverse(pts - nominal.tool, check=False)
    bad = ~np.all(np.isfinite(q), axis=1)
    if np.any(bad):
        p = pts[np.argmax(bad)]
        raise InputError(
            f"the workspace reaches {np.round(p, 3).tolist()} mm, out of reach of the robot",
            source,
            "key workspace",
        )


def geometry_to_dict(geometry) -> dict[str, Any]:
    """The TOML tables of a DeltaGeometry (mm, deg), as written by :func:`save_geometry`."""
    limbs = []
    for i in range(3):
        limbs.append(
            {
                "azimuth_deg": exact_degrees(float(geometry.limb_azimuth[i])),
                "axis_point_mm": geometry.axis_point[i].tolist(),
                "axis_direction": geometry.axis_direction[i].tolist(),
                "encoder_offset_deg": exact_degrees(float(geometry.encoder_offset[i])),
                "arm_ball_mm": geometry.arm_ball[i].tolist(),
                "plate_ball_mm": geometry.plate_ball[i].tolist(),
                "rod_length_mm": geometry.rod_length[i].tolist(),
            }
        )
    out: dict[str, Any] = {
        "format": GEOMETRY_FORMAT,
        "name": geometry.name,
        "tool_mm": geometry.tool.tolist(),
        "limb": limbs,
    }
    if geometry.points:
        out["points"] = {k: v.tolist() for k, v in geometry.points.items()}
    return out


def geometry_from_dict(data: Mapping[str, Any], source: str, prefix: str = ""):  # -> DeltaGeometry
    """Build a DeltaGeometry from tables written by :func:`geometry_to_dict`."""
    from .geometry import DeltaGeometry

    top = _Table(data, source, prefix)
    top.check_unknown(["format", "name", "tool_mm", "limb", "points"])
    fmt = top.string("format")
    if fmt != GEOMETRY_FORMAT:
        raise top.error("format", f"expected {GEOMETRY_FORMAT!r}, got {fmt!r}")
    name = top.string("name", default="")
    tool = top.vector("tool_mm", (3,))
    limbs = top.raw("limb")
    if not isinstance(limbs, list) or len(limbs) != 3 or not all(isinstance(x, Mapping) for x in limbs):
        raise top.error("limb", "must be an array of exactly 3 tables [[limb]]")
    fields: dict[str, list[Any]] = {k: [] for k in (
        "limb_azimuth", "axis_point", "axis_direction", "encoder_offset", "arm_ball", "plate_ball",
        "rod_length")}
    for i, limb_data in enumerate(limbs):
        t = _Table(limb_data, source, f"{prefix}limb[{i + 1}].")
        t.check_unknown([
            "azimuth_deg", "axis_point_mm", "axis_direction", "encoder_offset_deg", "arm_ball_mm",
            "plate_ball_mm", "rod_length_mm"])
        fields["limb_azimuth"].append(t.angle("azimuth_deg"))
        fields["axis_point"].append(t.vector("axis_point_mm", (3,)))
        w = t.vector("axis_direction", (3,))
        if abs(float(np.linalg.norm(w)) - 1.0) > 1e-9:
            raise t.error("axis_direction", f"must be a unit vector, got {w.tolist()}")
        fields["axis_direction"].append(w)
        fields["encoder_offset"].append(t.angle("encoder_offset_deg"))
        fields["arm_ball"].append(t.vector("arm_ball_mm", (2, 3)))
        fields["plate_ball"].append(t.vector("plate_ball_mm", (2, 3)))
        rods = t.vector("rod_length_mm", (2,))
        if np.any(rods <= 0):
            raise t.error("rod_length_mm", f"must be positive, got {rods.tolist()}")
        fields["rod_length"].append(rods)
    points = {}
    pts = top.table("points", required=False)
    if pts is not None:
        for k in pts.data:
            points[k] = pts.vector(k, (3,))
    try:
        return DeltaGeometry(
            **{k: np.array(v) for k, v in fields.items()}, tool=tool, points=points, name=name
        )
    except GeometryError as exc:
        raise InputError(str(exc), source) from None


def save_geometry(geometry, path: str | Path) -> None:
    """Write a DeltaGeometry to TOML (mm, deg), atomically; it reads back bit for bit."""
    header = "# deltacal geometry: every element of a real Delta robot (mm, deg)\n"
    atomic_write_text(path, header + toml_dumps(geometry_to_dict(geometry)))


def load_geometry(path: str | Path):  # -> DeltaGeometry
    """Read a geometry TOML file, or the ``[geometry]`` part of a calibration file."""
    data = read_toml(path)
    _check_not_nominal(data, str(path))
    if data.get("format") == CALIBRATION_FORMAT:
        if not isinstance(data.get("geometry"), Mapping):
            raise InputError("missing required table", str(path), "key geometry")
        return geometry_from_dict(data["geometry"], str(path), "geometry.")
    return geometry_from_dict(data, str(path))


def _check_not_nominal(data: Mapping[str, Any], source: str) -> None:
    """A nominal robot file where a geometry or calibration file is expected gets a clear error."""
    geo = data.get("geometry")
    if "format" not in data and isinstance(geo, Mapping) and "base_radius_mm" in geo:
        raise InputError(
            "this is a nominal robot file, not a geometry or calibration file "
            "(give the calibration file written by 'deltacal identify')",
            source, "key format",
        )


def save_calibration(result, path: str | Path) -> None:
    """Write a calibration file: the identified geometry in full and the identification report.

    ``compensate`` needs only this file: its ``[geometry]`` table is a complete
    DeltaGeometry (see :func:`load_geometry`).
    """
    data = {
        "format": CALIBRATION_FORMAT,
        "calibration": result.to_dict(),
        "geometry": geometry_to_dict(result.geometry),
        "nominal": geometry_to_dict(result.start),
    }
    if result.frames:
        # pose of {O} in each station's frame {T}: y_T = R(rotation) y_O + translation
        data["instrument"] = {
            name: {
                "rotation_deg": [exact_degrees(v) for v in frame.rotation_vector],
                "translation_mm": [float(v) for v in frame.translation],
                "rotation_sigma_deg": [float(np.degrees(v)) for v in frame.rotation_sigma],
                "translation_sigma_mm": [float(v) for v in frame.translation_sigma],
            }
            for name, frame in result.frames.items()
        }
    header = "# deltacal calibration: identified geometry (mm, deg) and identification report\n"
    atomic_write_text(path, header + toml_dumps(data))


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
_NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _csv_fields(line: str, source: str, line_no: int) -> list[str]:
    try:
        return next(csv.reader([line]))
    except (csv.Error, StopIteration) as exc:
        raise InputError(f"not a valid CSV line ({exc})", source, f"line {line_no}") from None


def _parse_number(value: str, source: str, where: str) -> float:
    """A numeric CSV field: a finite decimal number, or an error naming the field and value."""
    if _NUMBER_RE.fullmatch(value) is None:
        try:
            float(value)
        except ValueError:
            hint = " (a decimal comma?)" if re.fullmatch(r"[+-]?\d+,\d+", value) else ""
            raise InputError(f"value {value!r} is not a number{hint}", source, where) from None
        raise InputError(f"value {value!r} is not a finite number", source, where)
    number = float(value)
    if not math.isfinite(number):
        raise InputError(f"value {value!r} is not a finite number", source, where)
    return number


def data_row(line: int, row: int) -> str:
    """Where a CSV data row is: its line in the file (as an editor counts) and its row number."""
    return f"line {int(line)} (data row {int(row)})"


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
        raise _not_utf8(raw, exc, source) from None
    if "\x00" in text:
        raise InputError("file holds NUL bytes: a binary or UTF-16 file? deltacal reads UTF-8 CSV",
                         source)
    rows = [(n + 1, line.rstrip("\r")) for n, line in enumerate(text.split("\n")) if line.strip()]
    if not rows:
        raise InputError("file is empty", source)
    header_line, header_text = rows[0]
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
            close = difflib.get_close_matches(c, unknown, n=1, cutoff=0.6)
            close = close or [h for h in unknown if h.lower() == c.lower()]
            if close:
                hints.append(f"{close[0]!r} for {c}?")
        hint = f"; did you mean {', '.join(hints)}" if hints else ""
        raise InputError(
            f"missing required column(s) {', '.join(missing)} (header: {','.join(header)}){hint}",
            source, f"line {header_line}",
        )
    warnings = [f"{source}: column {h!r} is not used by deltacal and is ignored" for h in header
                if h not in known]
    if len(rows) == 1:
        raise InputError("no data rows after the header", source)
    index = {h: k for k, h in enumerate(header)}
    wanted = [c for c in known if c in index]
    numbers: dict[str, list[float]] = {c: [] for c in wanted if c not in text_columns}
    texts: dict[str, list[str]] = {c: [] for c in wanted if c in text_columns}
    lines = []
    for row_no, (line_no, line) in enumerate(rows[1:], start=1):
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
    warnings += _unit_warnings(arrays, source)
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


def _unit_warnings(arrays: Mapping[str, np.ndarray], source: str) -> list[str]:
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


def read_measurements(path: str | Path, point_names: list[str] | None = None):  # -> Measurements, warnings
    """Read a measurements CSV (conventions: q, position, optional orientation and point).

    Args:
        path: The file.
        point_names: Names of the plate's points (``tcp`` and the robot's named points);
            a row naming another point is an error.

    Returns:
        The measurements (radians inside) and the warnings to show.
    """
    from .observations import Measurements

    table = read_csv_table(
        path, MEASUREMENT_COLUMNS, ORIENTATION_COLUMNS + ["point", "station"],
        text_columns=("point", "station"),
        all_or_none=(tuple(ORIENTATION_COLUMNS),),
    )
    n = len(table.lines)
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
    return Measurements(q=q, position=pos, point=points, rotation_vector=rv, station=stations,
                        lines=table.lines, source=str(path)), table.warnings


def _format_rows(columns: list[np.ndarray], header: list[str], extra: list[list[str]] | None = None) -> str:
    data = np.column_stack(columns) if columns else np.zeros((0, 0))
    out = [",".join(header)]
    for k, row in enumerate(data):
        fields = [("" if math.isnan(v) else repr(float(v))) for v in row]
        if extra is not None:
            fields += extra[k]
        out.append(",".join(fields))
    return "\n".join(out) + "\n"


def write_measurements(path: str | Path, measurements) -> None:
    """Write measurements in the CSV format of the conventions (mm, deg), atomically."""
    q = np.degrees(measurements.q)
    cols = [q[:, 0], q[:, 1], q[:, 2], *measurements.position.T]
    header = JOINT_COLUMNS + TARGET_COLUMNS
    has = measurements.has_orientation
    if np.any(has):
        rv = np.degrees(np.where(has[:, None], measurements.rotation_vector, np.nan))
        cols += list(rv.T)
        header = header + ORIENTATION_COLUMNS
    if any(s != DEFAULT_STATION for s in measurements.station):
        extra = [[p, s] for p, s in zip(measurements.point, measurements.station, strict=True)]
        atomic_write_text(path, _format_rows(cols, header + ["point", "station"], extra))
        return
    extra = [[p] for p in measurements.point]
    atomic_write_text(path, _format_rows(cols, header + ["point"], extra))


def read_targets(path: str | Path) -> tuple[np.ndarray, list[str]]:
    """Read a targets CSV (``x_mm,y_mm,z_mm``): positions [mm] (N, 3) and warnings."""
    table = read_target_table(path)
    return np.column_stack([table.numbers[c] for c in TARGET_COLUMNS]), table.warnings


def read_target_table(path: str | Path) -> CsvTable:
    """Read a targets CSV as a validated table: its ``lines`` let errors name a target's line."""
    return read_csv_table(path, TARGET_COLUMNS)


def write_joints(path: str | Path, targets: np.ndarray, q: np.ndarray) -> None:
    """Write the joints CSV: targets [mm] then readings to command [deg], atomically."""
    qd = np.degrees(q)
    atomic_write_text(path, _format_rows([*targets.T, *qd.T], TARGET_COLUMNS + JOINT_COLUMNS))


def load_instrument(path: str | Path) -> dict:
    """The instrument frames of a calibration file (``[instrument]``), by station; empty if none.

    Returns:
        Station name -> :class:`~deltacal.identification.frames.InstrumentFrame`.
    """
    from .identification.frames import InstrumentFrame

    source = str(path)
    data = read_toml(path)
    _check_not_nominal(data, source)
    if data.get("format") == GEOMETRY_FORMAT:
        return {}  # a geometry file: the robot alone, measured in its own base frame
    if data.get("format") != CALIBRATION_FORMAT:
        raise InputError(f"not a calibration file (format {_shown(data.get('format'))})", source,
                         "key format")
    raw = data.get("instrument", {})
    if not isinstance(raw, Mapping):
        raise InputError("must be a table of stations [instrument.NAME]", source, "key instrument")
    frames = {}
    for name, item in raw.items():
        if not isinstance(item, Mapping):
            raise InputError("must be a table", source, f"key instrument.{name}")
        t = _Table(item, source, f"instrument.{name}.")
        rotation = np.radians(t.vector("rotation_deg", (3,)))
        translation = t.vector("translation_mm", (3,))
        frames[str(name)] = InstrumentFrame.from_vectors(rotation, translation)
    return frames


def load_linear_calibration(path: str | Path):  # -> LinearCalibration
    """What the linear compensators need from a calibration file.

    The file's ``[nominal]`` table is the geometry identification started from, its
    ``[calibration]`` table names the model and the identified base parameters.
    """
    from .compensation import LinearCalibration
    from .errormodels import get_model

    source = str(path)
    data = read_toml(path)
    _check_not_nominal(data, source)
    if data.get("format") != CALIBRATION_FORMAT:
        raise InputError(f"not a calibration file (format {_shown(data.get('format'))})", source,
                         "key format")
    if not isinstance(data.get("nominal"), Mapping):
        raise InputError("missing required table", source, "key nominal")
    nominal = geometry_from_dict(data["nominal"], source, "nominal.")
    top = _Table(data, source)
    cal = top.table("calibration")
    assert cal is not None
    try:
        model = get_model(cal.string("model"))
    except ValueError as exc:
        raise cal.error("model", str(exc)) from None
    deviation = np.zeros(model.size)
    params = cal.raw("base_parameter") if cal.has("base_parameter") else []
    if not isinstance(params, list) or not all(isinstance(x, Mapping) for x in params):
        raise cal.error("base_parameter", "must be an array of tables [[calibration.base_parameter]]")
    for k, item in enumerate(params):
        t = _Table(item, source, f"calibration.base_parameter[{k + 1}].")
        name = t.string("name")
        if name.startswith("T["):  # an instrument frame's parameter, not the robot's
            continue
        if name not in model.names:
            raise t.error("name", f"{name!r} is not a parameter of model {model.name}")
        if t.has("value_deg"):
            value = math.radians(t.number("value_deg"))
        else:
            value = t.number("value_mm")
        deviation[model.names.index(name)] = value
    return LinearCalibration(nominal=nominal, model=model, deviation=deviation)


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


def read_poses(
    path: str | Path,
    nominal=None,
    tolerance: float = POSES_TOLERANCE,
) -> tuple[PoseSet, list[str]]:
    """Read and validate a POSES file.

    Checks the CSV (:func:`deltacal.io.read_csv_table`: every column present,
    finite numbers, one clear error naming the file, line and column) and, with a
    nominal robot, that each row's readings put its nominal TCP on the row's target.

    Args:
        path: The file.
        nominal: The robot the file was planned for (optional check).
        tolerance: Largest target mismatch of that check [mm].

    Returns:
        The poses and the warnings to show (ignored columns, duplicate rows...).

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
    return PoseSet(q, targets), table.warnings


# --------------------------------------------------------------------------- command line
