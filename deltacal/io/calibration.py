"""Calibration files: one reader and one writer of :class:`~deltacal.calibration.Calibration`."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..calibration import BaseParameter, Calibration, FrameRecord, kind_of
from ..compensation import LinearCalibration
from ..errormodels import get_model
from ..exceptions import InputError
from ..identification import IdentificationResult
from ..identification.frames import InstrumentFrame
from .atomic import atomic_write_text
from .geometry_file import (
    CALIBRATION_FORMAT,
    GEOMETRY_FORMAT,
    check_format,
    geometry_from_dict,
    geometry_to_dict,
)
from .names import check_names, check_robot_name
from .toml import _shown, _Table, exact_degrees, read_toml, toml_dumps

#: Tolerance on the correlation matrix read from a file (it is written rounded to 6 decimals).
CORRELATION_ATOL = 1e-5


def save_calibration(
    calibration: Calibration | IdentificationResult, path: str | Path,
    lines: Sequence[int] | np.ndarray | None = None,
) -> None:
    """Write a calibration file: the identified geometry in full and the identification report.

    ``compensate`` needs only this file: its ``[geometry]`` table is a complete
    DeltaGeometry. :func:`load_calibration` reads it back into the same value.

    Args:
        calibration: The calibration (or the identification it comes from).
        path: The file to write (atomically).
        lines: The line of each measurement in the measurements file it came from: the
            outliers are then also saved by line (``outlier_lines``).
    """
    if isinstance(calibration, IdentificationResult):
        result = calibration
        calibration = calibration_from_result(result)
        if lines is not None:
            calibration = replace(calibration, outlier_lines=[int(lines[k]) for k in result.outliers])
    for geometry in (calibration.geometry, calibration.nominal):
        check_robot_name(geometry.name, str(path))
        check_names(geometry.points, "point", str(path))
    check_names(calibration.frames, "station", str(path))
    header = "# deltacal calibration: identified geometry (mm, deg) and identification report\n"
    atomic_write_text(path, header + toml_dumps(calibration_to_dict(calibration)))


def calibration_from_result(result: IdentificationResult) -> Calibration:
    """The calibration an identification found."""
    kinds = {c.name: c.kind for c in result.columns}
    base = []
    for label, name, v, s, u in zip(result.labels, result.base.base_names, result.values, result.sigma,
                                    result.units, strict=True):
        kind = kinds.get(name, kind_of(name))
        if u == "rad":
            base.append(BaseParameter(name, label, math.degrees(v), math.degrees(s), "deg", kind))
        else:
            base.append(BaseParameter(name, label, float(v), float(s), "mm", kind))
    frames = {
        name: FrameRecord(name, np.degrees(f.rotation_vector), np.asarray(f.translation, dtype=float),
                          np.degrees(f.rotation_sigma), np.asarray(f.translation_sigma, dtype=float))
        for name, f in result.frames.items()
    }
    return Calibration(
        geometry=result.geometry, nominal=result.start, model=get_model(result.model), base=base,
        correlation=np.asarray(result.correlation, dtype=float), method=result.method, rank=result.rank,
        parameters=len(result.base.names), condition_number=float(result.condition_number),
        iterations=result.iterations, variance_factor=float(result.variance_factor),
        unidentifiable=list(result.base.unidentifiable_names), residuals_before=result.before.as_dict(),
        residuals_after=result.after.as_dict(), outlier_rows=[int(k) + 1 for k in result.outliers],
        frames=frames,
    )


def calibration_to_dict(calibration: Calibration) -> dict:
    """A calibration as the file's plain data (angles in degrees)."""
    cal = calibration
    params = [
        {"name": p.name, "kind": p.kind, "regrouping": p.regrouping, f"value_{p.unit}": float(p.value),
         f"sigma_{p.unit}": float(p.sigma)}
        for p in cal.base
    ]
    report: dict = {
        "model": cal.model.name, "method": cal.method, "rank": cal.rank, "parameters": cal.parameters,
        "condition_number": cal.condition_number, "iterations": cal.iterations,
        "variance_factor": cal.variance_factor, "unidentifiable": list(cal.unidentifiable),
        "residuals_before": dict(cal.residuals_before), "residuals_after": dict(cal.residuals_after),
        "outlier_rows": list(cal.outlier_rows),
    }
    if cal.outlier_lines:
        report["outlier_lines"] = list(cal.outlier_lines)
    report["base_parameter"] = params
    # correlation matrix of the base parameters, in the order of base_parameter
    report["correlation"] = np.round(cal.correlation, 6).tolist()
    data: dict = {"format": CALIBRATION_FORMAT, "calibration": report,
                  "geometry": geometry_to_dict(cal.geometry), "nominal": geometry_to_dict(cal.nominal)}
    if cal.frames:
        # pose of {O} in each station's frame {T}: y_T = R(rotation) y_O + translation
        data["instrument"] = {
            name: {
                "rotation_deg": [exact_degrees(math.radians(v)) for v in f.rotation_deg],
                "translation_mm": [float(v) for v in f.translation_mm],
                "rotation_sigma_deg": [float(v) for v in f.rotation_sigma_deg],
                "translation_sigma_mm": [float(v) for v in f.translation_sigma_mm],
            }
            for name, f in cal.frames.items()
        }
    return data


def load_instrument(path: str | Path) -> dict[str, InstrumentFrame]:
    """The instrument frames of a calibration file (``[instrument]``), by station; empty if none.

    Returns:
        Station name -> :class:`~deltacal.identification.frames.InstrumentFrame`.
    """
    return load_calibration(path).instrument


def instrument_tables(data: Mapping, source: str) -> dict[str, dict[str, np.ndarray]]:
    """The stations of a calibration file's ``[instrument]`` table, checked, as written.

    Args:
        data: The file's parsed TOML.
        source: The file, for messages.

    Returns:
        Station name -> ``rotation_deg``, ``translation_mm`` and their σ
        (``rotation_sigma_deg``, ``translation_sigma_mm``; zeros where the file has none).
    """
    raw = data.get("instrument", {})
    if not isinstance(raw, Mapping):
        raise InputError("must be a table of stations [instrument.NAME]", source, "key instrument")
    check_names(raw, "station", source, "key instrument")
    out = {}
    for name, item in raw.items():
        if not isinstance(item, Mapping):
            raise InputError(f"must be a table, got {_shown(item)}", source, f"key instrument.{name}")
        t = _Table(item, source, f"instrument.{name}.")
        record = {key: t.vector(key, (3,)) for key in ("rotation_deg", "translation_mm")}
        for key in ("rotation_sigma_deg", "translation_sigma_mm"):
            record[key] = t.vector(key, (3,)) if t.has(key) else np.zeros(3)
        out[str(name)] = record
    return out


def load_linear_calibration(path: str | Path) -> LinearCalibration:
    """What the linear compensators need from a calibration file (:meth:`Calibration.linear`)."""
    return load_calibration(path).linear()


def check_calibration(path: str | Path) -> None:
    """Refuse a calibration file that :func:`load_calibration` refuses (sections that disagree...)."""
    load_calibration(path)


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration file (or a geometry file: the robot alone), checked once for every command.

    Every value is checked where it is read (one line naming the file, key and value), and the
    sections against each other (:meth:`~deltacal.calibration.Calibration.check`). A geometry
    file (``format = 'deltacal-geometry-1'``) gives a calibration without base parameters.

    Raises:
        InputError: naming the file, the key and the value that is wrong.
    """
    source = str(path)
    data = read_toml(path)
    if check_format(data, source) == GEOMETRY_FORMAT:
        geometry = geometry_from_dict(data, source)
        return Calibration(geometry=geometry, nominal=geometry, model=get_model("complete"), base=[],
                           correlation=np.zeros((0, 0)), source=source)
    cal = _Table(data, source).table("calibration")
    assert cal is not None
    for key in ("geometry", "nominal"):
        if not isinstance(data.get(key), Mapping):
            raise InputError("missing required table", source, f"key {key}")
    try:
        model = get_model(cal.string("model"))
    except ValueError as exc:
        raise cal.error("model", str(exc)) from None
    base = _base_parameters(cal, model, source)
    calibration = Calibration(
        geometry=geometry_from_dict(data["geometry"], source, "geometry."),
        nominal=geometry_from_dict(data["nominal"], source, "nominal."),
        model=model, base=base, correlation=_correlation(cal, len(base)),
        method=cal.string("method", default="?"),
        rank=_count(cal, "rank", len(base), exactly=len(base)),
        parameters=_count(cal, "parameters", model.size, at_least=len(base)),
        condition_number=_positive(cal, "condition_number", minimum=1.0),
        iterations=_count(cal, "iterations", 0),
        variance_factor=_positive(cal, "variance_factor", minimum=0.0),
        unidentifiable=_names(cal, "unidentifiable", str, "an array of names"),
        residuals_before=_summary(cal, "residuals_before"),
        residuals_after=_summary(cal, "residuals_after"),
        outlier_lines=_names(cal, "outlier_lines", int, "an array of line numbers"),
        outlier_rows=_names(cal, "outlier_rows", int, "an array of row numbers"),
        frames={name: FrameRecord(name=name, **item)
                for name, item in instrument_tables(data, source).items()},
        source=source,
    )
    calibration.check()
    return calibration


def _base_parameters(cal: _Table, model, source: str) -> list[BaseParameter]:
    """The ``[[calibration.base_parameter]]`` tables, checked."""
    raw = cal.raw("base_parameter")
    if not isinstance(raw, list) or not raw or not all(isinstance(x, Mapping) for x in raw):
        raise cal.error("base_parameter",
                        "must be a non-empty array of tables [[calibration.base_parameter]]")
    base = []
    for k, item in enumerate(raw):
        t = _Table(item, source, f"calibration.base_parameter[{k + 1}].")
        name = t.string("name")
        kind = t.string("kind", default=kind_of(name))
        if kind not in ("geometry", "frame", "point"):
            raise t.error("kind", f"must be 'geometry', 'frame' or 'point', got {kind!r}")
        unit = "deg" if t.has("value_deg") else "mm"
        value, sigma = t.number(f"value_{unit}"), t.number(f"sigma_{unit}")
        if not sigma >= 0.0:
            raise t.error(f"sigma_{unit}", f"must not be negative, got {sigma!r}")
        if kind == "geometry" and name not in model.names:
            raise t.error("name", f"{name!r} is not a parameter of model {model.name}")
        base.append(BaseParameter(name, t.string("regrouping", default=f"δ{name}"), value, sigma, unit,
                                  kind))  # type: ignore[arg-type]
    return base


def _correlation(cal: _Table, r: int) -> np.ndarray:
    """The correlation matrix of r base parameters, checked (symmetric, unit diagonal, within [-1, 1])."""
    C = cal.vector("correlation", (r, r))
    if np.max(np.abs(C - C.T)) > CORRELATION_ATOL or np.max(np.abs(np.diag(C) - 1.0)) > CORRELATION_ATOL:
        raise cal.error("correlation", "must be symmetric with ones on the diagonal")
    if np.max(np.abs(C)) > 1.0 + CORRELATION_ATOL:
        raise cal.error("correlation", f"values must lie within [-1, 1], got {float(np.max(np.abs(C)))!r}")
    return 0.5 * (C + C.T)


def _count(cal: _Table, key: str, default: int, exactly: int | None = None, at_least: int = 0) -> int:
    """A whole number of the report (rank, parameters, iterations), checked against the file."""
    if not cal.has(key):
        return default
    value = cal.number(key)
    if value != int(value) or value < at_least or (exactly is not None and value != exactly):
        want = (f"{exactly} (the number of base parameters)" if exactly is not None
                else f"a whole number >= {at_least}")
        raise cal.error(key, f"must be {want}, got {_shown(cal.raw(key))}")
    return int(value)


def _positive(cal: _Table, key: str, minimum: float) -> float:
    """A statistic of the report (s0², condition number), checked; nan when absent."""
    if not cal.has(key):
        return math.nan
    value = cal.number(key)
    if not value >= minimum:
        raise cal.error(key, f"must be at least {minimum:g}, got {_shown(cal.raw(key))}")
    return value


def _names(cal: _Table, key: str, kind: type, what: str) -> list:
    """An array of names or numbers of the report, checked; empty when absent."""
    raw = cal.raw(key) if cal.has(key) else []
    if not isinstance(raw, list) or not all(isinstance(x, kind) and not isinstance(x, bool) for x in raw):
        raise cal.error(key, f"must be {what}, got {_shown(raw)}")
    return list(raw)


def _summary(cal: _Table, name: str) -> dict[str, float]:
    t = cal.table(name, required=False)
    if t is None:
        return {}
    return {str(k): t.number(str(k)) for k in t.data}
