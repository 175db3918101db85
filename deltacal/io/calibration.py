"""Calibration files: the identified geometry, the report, the start geometry, instrument frames."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..compensation import LinearCalibration
from ..errormodels import get_model
from ..exceptions import InputError
from ..identification import IdentificationResult
from ..identification.frames import InstrumentFrame, axes_motion
from .atomic import atomic_write_text
from .geometry_file import (
    CALIBRATION_FORMAT,
    GEOMETRY_FORMAT,
    check_format,
    geometry_from_dict,
    geometry_to_dict,
)
from .toml import _shown, _Table, exact_degrees, read_toml, toml_dumps


def save_calibration(
    result: IdentificationResult, path: str | Path, lines: Sequence[int] | np.ndarray | None = None
) -> None:
    """Write a calibration file: the identified geometry in full and the identification report.

    ``compensate`` needs only this file: its ``[geometry]`` table is a complete
    DeltaGeometry (see :func:`load_geometry`).

    Args:
        result: The identification.
        path: The file to write (atomically).
        lines: The line of each measurement in the measurements file it came from: the
            outliers are then also saved by line (``outlier_lines``).
    """
    report = result.to_dict()
    if lines is not None:
        report["outlier_lines"] = [int(lines[k]) for k in result.outliers]
    data = {
        "format": CALIBRATION_FORMAT,
        "calibration": report,
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


def load_instrument(path: str | Path) -> dict[str, InstrumentFrame]:
    """The instrument frames of a calibration file (``[instrument]``), by station; empty if none.

    Returns:
        Station name -> :class:`~deltacal.identification.frames.InstrumentFrame`.
    """
    source = str(path)
    data = read_toml(path)
    if check_format(data, source) == GEOMETRY_FORMAT:
        return {}  # a geometry file: the robot alone, measured in its own base frame
    return {
        name: InstrumentFrame.from_vectors(np.radians(item["rotation_deg"]), item["translation_mm"])
        for name, item in instrument_tables(data, source).items()
    }


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
    """What the linear compensators need from a calibration file.

    The file's ``[nominal]`` table is the geometry identification started from, its
    ``[calibration]`` table names the model and the identified base parameters.
    """
    source = str(path)
    data = read_toml(path)
    if check_format(data, source) != CALIBRATION_FORMAT:
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
    tool_move = np.zeros(3)
    params = cal.raw("base_parameter") if cal.has("base_parameter") else []
    if not isinstance(params, list) or not all(isinstance(x, Mapping) for x in params):
        raise cal.error("base_parameter", "must be an array of tables [[calibration.base_parameter]]")
    for k, item in enumerate(params):
        t = _Table(item, source, f"calibration.base_parameter[{k + 1}].")
        name = t.string("name")
        if name.startswith("P[tcp]."):  # the tool identified as a free point
            tool_move["xyz".index(name[-1])] = t.number("value_mm")
            continue
        if name.startswith(("T[", "P[")):  # an instrument frame's or a free point's, not the model's
            continue
        if name not in model.names:
            raise t.error("name", f"{name!r} is not a parameter of model {model.name}")
        if t.has("value_deg"):
            value = math.radians(t.number("value_deg"))
        else:
            value = t.number("value_mm")
        deviation[model.names.index(name)] = value
    if not isinstance(data.get("geometry"), Mapping):
        raise InputError("missing required table", source, "key geometry")
    nominal = nominal.with_tool(nominal.tool + tool_move)
    geometry = geometry_from_dict(data["geometry"], source, "geometry.")
    predicted = model.apply(nominal, deviation)
    if data.get("instrument"):
        # identified with free instrument frames: [geometry] was moved to the axes gauge after the
        # fit, a rigid motion the base parameters do not hold; the sections agree modulo it
        predicted = predicted.moved_rigidly(*axes_motion(predicted, geometry))
    check_sections_agree(geometry, predicted, source)
    return LinearCalibration(nominal=nominal, model=model, deviation=deviation)


def check_calibration(path: str | Path) -> None:
    """Refuse a calibration file whose sections contradict each other (see :func:`check_sections_agree`).

    A geometry file (``format = 'deltacal-geometry-1'``) has one section only: nothing to check.

    Raises:
        InputError: naming both keys, or the first key of the file that is wrong.
    """
    if check_format(read_toml(path), str(path)) == CALIBRATION_FORMAT:
        load_linear_calibration(path)


#: How far ``[geometry]`` may be from ``[nominal]`` moved by the base parameters: lengths [mm],
#: angles and unit vectors [rad]. Identification composes its steps, the file sums them: the two
#: differ by second-order terms, measured up to 2e-5 mm and 6e-7 rad with Bai's tolerances; an
#: edit that changes a compensation by 1 µm is above these.
SECTIONS_TOLERANCE = {"mm": 1e-3, "rad": 1e-5}

_SECTION_KEYS = (
    # (DeltaGeometry field, TOML key in a limb or at the top, unit)
    ("tool", "tool_mm", "mm"),
    ("axis_point", "axis_point_mm", "mm"),
    ("axis_direction", "axis_direction", "rad"),
    ("encoder_offset", "encoder_offset_deg", "rad"),
    ("arm_ball", "arm_ball_mm", "mm"),
    ("plate_ball", "plate_ball_mm", "mm"),
    ("rod_length", "rod_length_mm", "mm"),
)


def check_sections_agree(geometry, predicted, source: str) -> None:
    """Refuse a calibration file whose ``[geometry]`` is not ``[nominal]`` moved by its base parameters.

    ``compensate --method exact`` reads ``[geometry]``; the linear methods read
    ``[nominal]`` and the base parameters. A file edited in one place only (the
    tool in ``[geometry]``, say) would make them command different robots: it is
    refused, naming both keys (see docs/errors.md).
    """
    for field, key, unit in _SECTION_KEYS:
        got = np.asarray(getattr(geometry, field), dtype=float)
        want = np.asarray(getattr(predicted, field), dtype=float)
        if field == "tool":
            got, want = got[None], want[None]
        off = np.abs(got - want).reshape(len(got), -1).max(axis=1)
        bad = np.flatnonzero(off > SECTIONS_TOLERANCE[unit])
        if bad.size:
            i = int(bad[0])
            where = key if field == "tool" else f"limb[{i + 1}].{key}"
            shown = np.degrees if key.endswith("_deg") else (lambda v: v)
            raise InputError(
                f"[geometry] and [nominal] disagree: key geometry.{where} = "
                f"{np.round(shown(got[i]), 6).tolist()}, but key nominal.{where} moved by the base "
                f"parameters gives {np.round(shown(want[i]), 6).tolist()} (a file edited in one place only? "
                "edit both, or identify again)",
                source,
            )
