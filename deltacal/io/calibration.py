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
from ..identification.frames import InstrumentFrame
from .atomic import atomic_write_text
from .geometry_file import (
    CALIBRATION_FORMAT,
    GEOMETRY_FORMAT,
    _check_not_nominal,
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


def load_linear_calibration(path: str | Path) -> LinearCalibration:
    """What the linear compensators need from a calibration file.

    The file's ``[nominal]`` table is the geometry identification started from, its
    ``[calibration]`` table names the model and the identified base parameters.
    """
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
        if name.startswith(("T[", "P[")):  # an instrument frame's or a free point's, not the model's
            continue
        if name not in model.names:
            raise t.error("name", f"{name!r} is not a parameter of model {model.name}")
        if t.has("value_deg"):
            value = math.radians(t.number("value_deg"))
        else:
            value = t.number("value_mm")
        deviation[model.names.index(name)] = value
    return LinearCalibration(nominal=nominal, model=model, deviation=deviation)
