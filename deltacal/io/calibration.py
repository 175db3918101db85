"""Calibration files: one reader and one writer of :class:`~deltacal.calibration.Calibration`.

The value holds the library's units (mm, rad, rad/N m); the file holds angles in degrees. Both
directions convert here and only here: a file read and written again is the same file, to the
last digit (see :func:`~deltacal.io.toml.radians_written_as` and
:func:`~deltacal.io.toml.exact_degrees`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import cast, get_args

import numpy as np

from ..calibration import BaseParameter, BaseUnit, Calibration, FrameRecord, kind_of
from ..chains import Chain
from ..compensation import LinearCalibration
from ..controller_record import ControllerRecord
from ..errormodels import get_model
from ..exceptions import InputError
from ..holds import WhereItHolds
from ..identification import IdentificationResult, ResidualStats
from ..identification.frames import InstrumentFrame
from ..identification.options import Method
from ..measured_record import MeasuredRecord
from .atomic import atomic_write_text
from .geometry_file import (
    CALIBRATION_FORMAT,
    GEOMETRY_FORMAT,
    check_format,
    geometry_from_dict,
    geometry_to_dict,
)
from .names import check_names, check_robot_name
from .toml import (
    TomlTable,
    exact_degrees,
    radians_from_text,
    radians_written_as,
    read_toml,
    shown_value,
    toml_dumps,
)

#: The key suffix of each unit of a base parameter in the file (``value_deg``, ``value_rad_per_nm``...).
_UNIT_KEYS = {"mm": "mm", "rad": "deg", "rad/Nm": "rad_per_nm"}

#: The statistics of a residual summary (:class:`~deltacal.identification.ResidualStats`' fields).
_STATISTICS = tuple(f.name for f in fields(ResidualStats))

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
        lines: With an identification: the line of each measurement in the measurements file it
            came from; the outliers are then also saved by line (``outlier_lines``).
    """
    if isinstance(calibration, IdentificationResult):
        calibration = Calibration.from_result(calibration, lines)
    for geometry in (calibration.geometry, calibration.nominal):
        check_robot_name(geometry.name, str(path))
        check_names(geometry.points, "point", str(path))
    check_names(calibration.frames, "station", str(path))
    header = "# deltacal calibration: identified geometry (mm, deg) and identification report\n"
    atomic_write_text(path, header + toml_dumps(calibration_to_dict(calibration)))


def calibration_from_result(result: IdentificationResult) -> Calibration:
    """The calibration an identification found (:meth:`~deltacal.calibration.Calibration.from_result`)."""
    return Calibration.from_result(result)


def _shown_value(value: float, unit: BaseUnit) -> float:
    """A base parameter's value or σ in the file's unit (degrees for an angle)."""
    return math.degrees(value) if unit == "rad" else float(value)


def calibration_to_dict(calibration: Calibration) -> dict:
    """A calibration as the file's plain data (angles in degrees)."""
    cal = calibration
    params = [
        {"name": p.name, "kind": p.kind, "regrouping": p.regrouping,
         f"value_{_UNIT_KEYS[p.unit]}": _shown_value(p.value, p.unit),
         f"sigma_{_UNIT_KEYS[p.unit]}": _shown_value(p.sigma, p.unit)}
        for p in cal.base
    ]
    report: dict = {"model": cal.model.name}
    if cal.method is not None:
        report["method"] = cal.method
    report.update({
        "rank": cal.rank, "parameters": cal.parameters,
        "condition_number": cal.condition_number, "iterations": cal.iterations,
        "variance_factor": cal.variance_factor, "unidentifiable": list(cal.unidentifiable),
        "residuals_before": cal.residuals_before.as_dict(), "residuals_after": cal.residuals_after.as_dict(),
        "outlier_rows": list(cal.outlier_rows),
    })
    if cal.outlier_lines:
        report["outlier_lines"] = list(cal.outlier_lines)
    report["base_parameter"] = params
    # correlation matrix of the base parameters, in the order of base_parameter
    report["correlation"] = np.round(cal.correlation, 6).tolist()
    data: dict = {"format": CALIBRATION_FORMAT, "calibration": report,
                  "geometry": geometry_to_dict(cal.geometry), "nominal": geometry_to_dict(cal.nominal)}
    if cal.compliance_sigma is not None:
        data["compliance"] = {"actuator_rad_per_nm": [float(v) for v in cal.geometry.compliance],
                              "sigma_rad_per_nm": [float(v) for v in cal.compliance_sigma]}
    if cal.holds is not None:
        data["holds"] = holds_to_dict(cal.holds)
    if cal.controller is not None:
        data["controller"] = controller_to_dict(cal.controller)
    if cal.measured is not None:
        data["measured"] = measured_to_dict(cal.measured, cal.geometry.chain)
    if cal.frames:
        # pose of {O} in each station's frame {T}: y_T = R(rotation) y_O + translation
        data["instrument"] = {
            name: {
                "rotation_deg": [exact_degrees(float(v)) for v in f.rotation],
                "translation_mm": [float(v) for v in f.translation],
                "rotation_sigma_deg": [math.degrees(v) for v in f.rotation_sigma],
                "translation_sigma_mm": [float(v) for v in f.translation_sigma],
            }
            for name, f in cal.frames.items()
        }
    return data


#: Decimals of the σ written in ``[holds]`` [mm].
HOLDS_DECIMALS = 7


def holds_to_dict(holds: WhereItHolds) -> dict:
    """A calibration's ``[holds]`` table: its grid (mm, degrees) and the σ at each node [mm]."""
    return {"radius_mm": [float(v) for v in holds.radius],
            "azimuth_deg": [float(np.round(math.degrees(v), 9)) for v in holds.azimuth],
            "height_mm": [float(v) for v in holds.height], "measured_top_mm": float(holds.measured_top),
            "horizontal_sigma_mm": np.round(holds.horizontal, HOLDS_DECIMALS).tolist(),
            "vertical_sigma_mm": np.round(holds.vertical, HOLDS_DECIMALS).tolist(),
            "value_names": list(holds.values), "value_sigma_ratio": [float(v) for v in holds.values.values()],
            **({} if holds.along_bed is None else {"along_bed": geometry_to_dict(holds.along_bed)})}


def holds_from_dict(data: Mapping, source: str) -> WhereItHolds | None:
    """The ``[holds]`` table of a calibration file, checked; None when it has none."""
    if "holds" not in data:
        return None
    t = TomlTable(data, source).table("holds")
    assert t is not None
    t.check_unknown(["radius_mm", "azimuth_deg", "height_mm", "measured_top_mm", "horizontal_sigma_mm",
                     "vertical_sigma_mm", "value_names", "value_sigma_ratio", "along_bed"])
    names = _names(t, "value_names", str, "an array of names") if t.has("value_names") else []
    ratios = t.vector("value_sigma_ratio", (len(names),)) if names else np.zeros(0)
    axes = {}
    for key in ("radius_mm", "azimuth_deg", "height_mm"):
        raw = t.raw(key)
        axes[key] = t.vector(key, (len(raw) if isinstance(raw, list) else -1,))
    shape = (axes["radius_mm"].size, axes["azimuth_deg"].size, axes["height_mm"].size)
    sigma = {key: t.vector(key, shape) for key in ("horizontal_sigma_mm", "vertical_sigma_mm")}
    for key, value in sigma.items():
        if np.any(value < 0.0):
            raise t.error(key, f"must not be negative, got {float(np.min(value))!r}")
    along = data["holds"].get("along_bed")
    if along is not None and not isinstance(along, Mapping):
        raise t.error("along_bed", f"must be a table (a printer's geometry), got {along!r}")
    along_bed = None if along is None else geometry_from_dict(along, source, "holds.along_bed.")
    try:
        return WhereItHolds(axes["radius_mm"], np.radians(axes["azimuth_deg"]), axes["height_mm"],
                            sigma["horizontal_sigma_mm"], sigma["vertical_sigma_mm"],
                            t.number("measured_top_mm"), dict(zip(names, ratios.tolist(), strict=True)),
                            along_bed)
    except ValueError as exc:
        raise t.error("radius_mm", str(exc)) from None


def controller_to_dict(record: ControllerRecord) -> dict:
    """A calibration's ``[controller]`` table and its ``[controller.values]``."""
    return {"firmware": record.firmware, "source": record.source, "digest": record.digest,
            "values": dict(record.values)}


def controller_from_dict(data: Mapping, source: str) -> ControllerRecord | None:
    """The ``[controller]`` table of a calibration file, checked; None when it has none (an older file)."""
    if "controller" not in data:
        return None
    t = TomlTable(data, source).table("controller")
    assert t is not None
    t.check_unknown(["firmware", "source", "digest", "values"])
    values = t.table("values")
    assert values is not None
    raw = data["controller"]["values"]
    digest = t.string("digest")
    if len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest):
        raise t.error("digest", f"must be a sha256 in 64 lower-case hex digits, got {digest!r}")
    return ControllerRecord(t.string("firmware"), t.string("source"), digest,
                            {str(key): values.number(str(key)) for key in raw})


#: ``[measured]`` keys but the readings': the distances, the σ given, the fit's choices.
MEASURED_KEYS = ("trigger_height_mm", "distance_mm", "probe_offset_mm", "height_sigma_mm",
                 "distance_sigma_mm", "tolerance_scale", "calibrated_start", "method", "workspace_mm")


def readings_keys(chain: Chain) -> tuple[str, str]:
    """``[measured]``'s keys of the probe's and the pairs' readings, in the chain's file unit.

    ``probe_readings_mm`` and ``pair_readings_mm`` for a linear printer's carriages, ``..._deg`` for a
    rotary printer's arms (:attr:`~deltacal.chains.ChainWords.reading_unit`).
    """
    unit = chain.words.reading_unit
    return f"probe_readings_{unit}", f"pair_readings_{unit}"


def measured_to_dict(record: MeasuredRecord, chain: Chain) -> dict:
    """A calibration's ``[measured]`` table (each pair's readings as one row of 6, in the chain's unit)."""
    probe_key, pairs_key = readings_keys(chain)
    out = {probe_key: chain.reading_to_file(record.probe).tolist(),
           "trigger_height_mm": record.trigger_height.tolist(),
           pairs_key: chain.reading_to_file(record.pairs).reshape(-1, 6).tolist(),
           "distance_mm": record.distance.tolist(),
           "probe_offset_mm": record.probe_offset.tolist(), "height_sigma_mm": float(record.height_sigma),
           "distance_sigma_mm": float(record.distance_sigma),
           "tolerance_scale": float(record.tolerance_scale),
           "calibrated_start": bool(record.calibrated_start), "method": record.method}
    if record.workspace is not None:
        out["workspace_mm"] = list(record.workspace)
    return out


def measured_from_dict(data: Mapping, source: str, chain: Chain) -> MeasuredRecord | None:
    """The ``[measured]`` table of a calibration file, checked; None when it has none (an older file).

    Its readings in ``chain``'s file unit (:func:`readings_keys`: the calibration's geometry's chain).
    """
    if "measured" not in data:
        return None
    t = TomlTable(data, source).table("measured")
    assert t is not None
    probe_key, pairs_key = readings_keys(chain)
    t.check_unknown((probe_key, pairs_key, *MEASURED_KEYS))

    def rows(key: str, width: int) -> np.ndarray:
        raw = t.raw(key)
        return chain.reading_from_file(t.array_value(key, raw, (len(raw) if isinstance(raw, list) else -1,
                                                                width)))

    probe, pairs = rows(probe_key, 3), rows(pairs_key, 6)
    trigger, distance = t.vector("trigger_height_mm", (len(probe),)), t.vector("distance_mm", (len(pairs),))
    flag = t.raw("calibrated_start")
    if not isinstance(flag, bool):
        raise t.error("calibrated_start", f"must be true or false, got {shown_value(flag)}")
    workspace = tuple(t.vector("workspace_mm", (3,)).tolist()) if t.has("workspace_mm") else None
    try:
        return MeasuredRecord(probe, trigger, pairs.reshape(-1, 2, 3), distance,
                              t.vector("probe_offset_mm", (3,)),
                              t.number("height_sigma_mm", positive=True),
                              t.number("distance_sigma_mm", positive=True),
                              t.number("tolerance_scale", positive=True), flag, t.string("method"),
                              cast(tuple[float, float, float] | None, workspace))
    except ValueError as exc:
        raise t.error("method", str(exc)) from None


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
            raise InputError(f"must be a table, got {shown_value(item)}", source, f"key instrument.{name}")
        t = TomlTable(item, source, f"instrument.{name}.")
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
    cal = TomlTable(data, source).table("calibration")
    assert cal is not None
    for key in ("geometry", "nominal"):
        if not isinstance(data.get(key), Mapping):
            raise InputError("missing required table", source, f"key {key}")
    try:
        model = get_model(cal.string("model"))
    except ValueError as exc:
        raise cal.error("model", str(exc)) from None
    base = _base_parameters(cal, model, source)
    geometry = geometry_from_dict(data["geometry"], source, "geometry.")
    calibration = Calibration(
        geometry=geometry,
        nominal=geometry_from_dict(data["nominal"], source, "nominal."),
        model=model, base=base, correlation=_correlation(cal, len(base)),
        method=_method(cal),
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
        frames=_frames(data, source), source=source, compliance_sigma=_compliance_sigma(data, source),
        holds=holds_from_dict(data, source), controller=controller_from_dict(data, source),
        measured=measured_from_dict(data, source, geometry.chain),
    )
    calibration.check()
    return calibration


def _method(cal: TomlTable) -> Method | None:
    """The identification's method; None when the file has none (or the ``"?"`` earlier versions wrote)."""
    method = cal.string("method", default="?")
    if method == "?":
        return None
    if method not in get_args(Method):
        raise cal.error("method", f"must be 'linear' or 'iterated', got {method!r}")
    return cast(Method, method)


def _frames(data: Mapping, source: str) -> dict[str, FrameRecord]:
    """The instrument frames of ``[instrument]`` in the library's units (see :func:`instrument_tables`)."""
    frames = {}
    for name, item in instrument_tables(data, source).items():
        # the rotation is written with every digit (exact_degrees): read back to the same angle
        rotation = np.array([radians_from_text(v) for v in data["instrument"][name]["rotation_deg"]])
        frames[name] = FrameRecord(name, rotation, item["translation_mm"],
                                   np.array([radians_written_as(v) for v in item["rotation_sigma_deg"]]),
                                   item["translation_sigma_mm"])
    return frames


def _compliance_sigma(data: Mapping, source: str) -> np.ndarray | None:
    """The σ of ``[compliance]`` (None: no such table); its values are checked against ``[geometry]``."""
    if "compliance" not in data:
        return None
    t = TomlTable(data, source).table("compliance")
    assert t is not None
    t.check_unknown(["actuator_rad_per_nm", "sigma_rad_per_nm"])
    value = t.vector("actuator_rad_per_nm", (3,))
    sigma = t.vector("sigma_rad_per_nm", (3,)) if t.has("sigma_rad_per_nm") else np.zeros(3)
    if np.any(sigma < 0.0):
        raise t.error("sigma_rad_per_nm", f"must not be negative, got {sigma.tolist()}")
    geometry = data["geometry"].get("compliance", {}).get("actuator_rad_per_nm", [0.0, 0.0, 0.0])
    if not np.allclose(np.asarray(geometry, dtype=float), value, rtol=1e-12, atol=0.0):
        raise t.error("actuator_rad_per_nm", f"{value.tolist()} disagrees with key "
                      f"geometry.compliance.actuator_rad_per_nm = {shown_value(geometry)} (a file edited "
                      "in one place only? edit both, or identify again)")
    return sigma


def _base_parameters(cal: TomlTable, model, source: str) -> list[BaseParameter]:
    """The ``[[calibration.base_parameter]]`` tables, checked."""
    raw = cal.raw("base_parameter")
    if not isinstance(raw, list) or not raw or not all(isinstance(x, Mapping) for x in raw):
        raise cal.error("base_parameter",
                        "must be a non-empty array of tables [[calibration.base_parameter]]")
    base = []
    for k, item in enumerate(raw):
        t = TomlTable(item, source, f"calibration.base_parameter[{k + 1}].")
        name = t.string("name")
        kind = t.string("kind", default=kind_of(name))
        if kind not in ("geometry", "frame", "point", "compliance"):
            raise t.error("kind", f"must be 'geometry', 'frame', 'point' or 'compliance', got {kind!r}")
        unit: BaseUnit = "rad/Nm" if kind == "compliance" else "rad" if t.has("value_deg") else "mm"
        key = _UNIT_KEYS[unit]
        value, sigma = t.number(f"value_{key}"), t.number(f"sigma_{key}")
        if not sigma >= 0.0:
            raise t.error(f"sigma_{key}", f"must not be negative, got {sigma!r}")
        if kind == "geometry" and name not in model.names:
            raise t.error("name", f"{name!r} is not a parameter of model {model.name}")
        if unit == "rad":
            value, sigma = radians_written_as(value), radians_written_as(sigma)
        base.append(BaseParameter(name, t.string("regrouping", default=f"δ{name}"), value, sigma, unit,
                                  kind))  # type: ignore[arg-type]
    return base


def _correlation(cal: TomlTable, r: int) -> np.ndarray:
    """The correlation matrix of r base parameters, checked (symmetric, unit diagonal, within [-1, 1])."""
    C = cal.vector("correlation", (r, r))
    if np.max(np.abs(C - C.T)) > CORRELATION_ATOL or np.max(np.abs(np.diag(C) - 1.0)) > CORRELATION_ATOL:
        raise cal.error("correlation", "must be symmetric with ones on the diagonal")
    if np.max(np.abs(C)) > 1.0 + CORRELATION_ATOL:
        raise cal.error("correlation", f"values must lie within [-1, 1], got {float(np.max(np.abs(C)))!r}")
    return 0.5 * (C + C.T)


def _count(cal: TomlTable, key: str, default: int, exactly: int | None = None, at_least: int = 0) -> int:
    """A whole number of the report (rank, parameters, iterations), checked against the file."""
    if not cal.has(key):
        return default
    value = cal.number(key)
    if value != int(value) or value < at_least or (exactly is not None and value != exactly):
        want = (f"{exactly} (the number of base parameters)" if exactly is not None
                else f"a whole number >= {at_least}")
        raise cal.error(key, f"must be {want}, got {shown_value(cal.raw(key))}")
    return int(value)


def _positive(cal: TomlTable, key: str, minimum: float) -> float:
    """A statistic of the report (s0², condition number), checked; nan when absent."""
    if not cal.has(key):
        return math.nan
    value = cal.number(key)
    if not value >= minimum:
        raise cal.error(key, f"must be at least {minimum:g}, got {shown_value(cal.raw(key))}")
    return value


def _names(cal: TomlTable, key: str, kind: type, what: str) -> list:
    """An array of names or numbers of the report, checked; empty when absent."""
    raw = cal.raw(key) if cal.has(key) else []
    if not isinstance(raw, list) or not all(isinstance(x, kind) and not isinstance(x, bool) for x in raw):
        raise cal.error(key, f"must be {what}, got {shown_value(raw)}")
    return list(raw)


def _summary(cal: TomlTable, name: str) -> ResidualStats:
    """A residual summary (``position_rms_mm``..., ``orientation_deg_max``): the statistics it holds."""
    t = cal.table(name, required=False)
    if t is None:
        return ResidualStats()
    keys = ResidualStats(**dict.fromkeys(_STATISTICS, 1.0)).as_dict()  # every key, in the writer's words
    t.check_unknown(keys)
    stats = {}
    for statistic, key in zip(_STATISTICS, keys, strict=True):
        if t.has(key):
            value = t.number(key)
            stats[statistic] = radians_written_as(value) if key.startswith("orientation") else value
    return ResidualStats(**stats)
