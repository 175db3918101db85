"""Controller files (``deltacal-controller-1``, conventions "Controllers"): one reader, one writer.

A robot file given where a controller is expected is read as the controller of its nominal values
(all limbs alike, offsets zero). A printer's firmware configuration (Klipper's ``printer.cfg``) is
read by the printer's wing; :func:`deltacal.robots.load_controller` reads either. ``[fit]`` is
informative: written by ``deltacal export --controller``, read by no command. Files are in mm and
degrees.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..controller import Controller, ControllerFit
from ..exceptions import GeometryError, InputError
from .atomic import atomic_write_text
from .geometry_file import CALIBRATION_FORMAT, GEOMETRY_FORMAT
from .robot import PLAUSIBLE_LENGTH_MM, load_nominal
from .toml import TomlTable, radians_from_text, read_toml, short_degrees, shown_value, toml_dumps

CONTROLLER_FORMAT = "deltacal-controller-1"

#: ``[controller]`` keys -> (Controller field, unit), in the file's order.
CONTROLLER_KEYS = {
    "limb_azimuth_deg": ("limb_azimuth", "deg"),
    "base_radius_mm": ("base_radius", "mm"),
    "plate_radius_mm": ("plate_radius", "mm"),
    "arm_length_mm": ("arm_length", "mm"),
    "rod_length_mm": ("rod_length", "mm"),
    "joint_offset_deg": ("joint_offset", "deg"),
    "tool_mm": ("tool", "mm"),
}


def load_controller_file(path: str | Path) -> Controller:
    """Read a controller file, or a robot file as its nominal controller.

    Raises:
        InputError: naming the file and the key (and value) of the first problem found.
    """
    source = str(path)
    data = read_toml(path)
    fmt = data.get("format")
    geometry = data.get("geometry")
    if fmt is None and isinstance(geometry, Mapping) and "base_radius_mm" in geometry:
        return Controller.from_geometry(load_nominal(path))  # a robot file: its nominal controller
    top = TomlTable(data, source)
    if fmt in (GEOMETRY_FORMAT, CALIBRATION_FORMAT):
        raise top.error("format", f"this is a deltacal {fmt!r} file, not a controller file: give a "
                                  "controller file (from 'deltacal export CAL --controller offsets|limbs') "
                                  "or a robot file")
    if fmt != CONTROLLER_FORMAT:
        what = "missing required key" if fmt is None else f"unknown format {shown_value(fmt)}"
        raise InputError(f"{what}: a controller file has format = {CONTROLLER_FORMAT!r} (or give a robot "
                         "file)", source, "key format")
    top.raw("format")
    top.check_unknown(["format", "name", "controller", "fit"])
    name = top.string("name", "")
    table = top.table("controller")
    assert table is not None
    table.check_unknown(CONTROLLER_KEYS)
    values = {field: _values(table, key, unit) for key, (field, unit) in CONTROLLER_KEYS.items()}
    top.table("fit", required=False)  # informative: a table of any content, read by no command
    try:
        return Controller(**values, name=name)
    except GeometryError as exc:
        raise InputError(str(exc), source, "table controller") from None


def _values(table: TomlTable, key: str, unit: str) -> np.ndarray:
    """Three values of a ``[controller]`` key, checked, in mm or rad (angles exactly as written)."""
    array = table.vector(key, (3,))
    if unit == "deg":
        if np.any(np.abs(array) > 360.0):
            raise table.error(key, f"angles must lie within ±360 deg, got {array.tolist()}")
        if key == "limb_azimuth_deg" and len({round(float(a) % 360.0, 9) for a in array}) < 3:
            raise table.error(key, f"the three azimuths must differ, got {array.tolist()}")
        return np.array([radians_from_text(v) for v in table.raw(key)])
    if key == "tool_mm":
        return array
    low, high = (0.0 if key == "plate_radius_mm" else PLAUSIBLE_LENGTH_MM[0]), PLAUSIBLE_LENGTH_MM[1]
    bad = np.flatnonzero((array < low) | (array > high))
    if bad.size:
        i = int(bad[0])
        raise table.error(key, f"value {i + 1}, {float(array[i])!r} mm, is not a length of a Delta robot's "
                               f"(from {low:g} to {high:,.0f} mm; a file in metres?)")
    return array


def controller_to_dict(controller: Controller, fit: ControllerFit | None = None,
                       notes: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The controller file's content (angles in the fewest degrees' digits that read back exactly)."""
    table: dict[str, Any] = {}
    for key, (field, unit) in CONTROLLER_KEYS.items():
        value = getattr(controller, field)
        table[key] = [short_degrees(float(v)) if unit == "deg" else float(v) for v in value]
    out: dict[str, Any] = {"format": CONTROLLER_FORMAT, "name": controller.name, "controller": table}
    if fit is not None:
        out["fit"] = {
            "kind": fit.kind,
            "max_error_mm": fit.max_error,
            "rms_error_mm": fit.rms_error,
            "max_error_before_mm": fit.max_error_before,
            "rms_error_before_mm": fit.rms_error_before,
            "points": fit.points,
            "fitted": list(fit.fitted),
            "held_at_nominal": list(fit.held),
            **(dict(notes) if notes else {}),
        }
    return out


def save_controller(path: str | Path, controller: Controller, fit: ControllerFit | None = None,
                    notes: Mapping[str, Any] | None = None) -> None:
    """Write a controller file atomically, with the fit's ``[fit]`` table when given (and notes in it)."""
    header = "# deltacal controller: a controller's classical Delta model, per limb (mm, deg)\n"
    atomic_write_text(path, header + toml_dumps(controller_to_dict(controller, fit, notes)))
