"""A linear Delta printer's robot file (``kind = "linear"``; conventions, "Linear Delta printers").

The same file as a rotary Delta's (:mod:`deltacal.io.robot`: ``name``, ``description``,
``[points]``), with a printer's ``[geometry]`` (tower and effector radii, rods, endstop height,
tower azimuths [deg], nozzle, step distance [mm]) and its printable cylinder from the bed up as
``[workspace]``. Files are in millimetres and degrees; :class:`~.robot.NominalLinearDelta` holds
millimetres and radians.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ...exceptions import GeometryError, InputError
from ...geometry import Workspace
from ...io.robot import check_plausible_length, is_printer_file, read_points, read_robot_name
from ...io.toml import TomlTable, read_toml
from ...kinematics.closed_form import VirtualDelta
from ...towers import TOWERS
from ..robot import NominalLinearDelta

#: A step distance [mm] at or above this is not a printer's (steps per mm given instead?).
MAX_STEP_DISTANCE_MM = 1.0
#: The ``[geometry]`` lengths of a linear Delta printer's file (conventions, "Linear Delta printers").
LINEAR_LENGTH_KEYS = ("tower_radius_mm", "effector_radius_mm", "rod_length_mm", "rod_spacing_mm",
                      "endstop_height_mm")
#: The ``[geometry]`` values that are a number or ``[a, b, c]``, one per tower (conventions,
#: "Printers as they are found").
PER_TOWER_KEYS = ("rod_length_mm", "endstop_height_mm", "step_distance_mm")


def load_printer(path: str | Path, data: dict | None = None) -> NominalLinearDelta:
    """Read and validate a linear Delta printer's robot file (``kind = "linear"``).

    ``rod_length_mm``, ``endstop_height_mm`` and ``step_distance_mm`` are each a number or
    ``[a, b, c]`` (towers A, B, C); each tower's value is checked as a number is.

    Args:
        path: The file.
        data: Its TOML, already parsed (:func:`~deltacal.io.toml.read_toml`): the file is read once.

    Raises:
        InputError: naming the file and the key (and value, and tower) of the first problem found.
    """
    source = str(path)
    top = TomlTable(read_toml(path) if data is None else data, source)
    if not is_printer_file(top):
        raise top.error("kind", "not a linear Delta printer's file: kind = 'linear' is required")
    top.check_unknown(["name", "description", "kind", "geometry", "points", "workspace"])
    geo = top.table("geometry")
    assert geo is not None
    geo.check_unknown([*LINEAR_LENGTH_KEYS, "tower_azimuth_deg", "nozzle_mm", "step_distance_mm"])
    lengths = {key: geo.per_tower(key, positive=True) if key in PER_TOWER_KEYS else
               geo.number(key, positive=True) for key in LINEAR_LENGTH_KEYS}
    for key in lengths:
        for tower, value in _each_tower(geo, key):
            _check_on_tower(tower, check_plausible_length, geo, key, value)
    step = geo.per_tower("step_distance_mm", positive=True)
    for tower, value in _each_tower(geo, "step_distance_mm"):
        if value >= MAX_STEP_DISTANCE_MM:
            raise geo.error("step_distance_mm", f"{value!r} mm per step{tower} is not a printer's (steps per "
                                                "mm given? the step distance is mm per step, such as 0.0125)")
    azimuth_deg = geo.vector("tower_azimuth_deg", (3,))
    if len({round(float(a) % 360.0, 9) for a in azimuth_deg}) < 3:
        raise geo.error("tower_azimuth_deg", f"the three azimuths must differ, got {azimuth_deg.tolist()}")
    reach = float(lengths["tower_radius_mm"]) - float(lengths["effector_radius_mm"])
    for tower, rod in _each_tower(geo, "rod_length_mm"):
        if rod <= reach:
            raise geo.error("rod_length_mm", f"rods of {rod} mm{tower} cannot reach the effector from "
                                             f"towers {reach} mm away (tower_radius_mm - effector_radius_mm)")
    try:
        printer = NominalLinearDelta(
            name=read_robot_name(top),
            description=top.string("description", ""),
            tower_radius=float(lengths["tower_radius_mm"]),
            effector_radius=float(lengths["effector_radius_mm"]),
            rod_length=np.asarray(lengths["rod_length_mm"]),
            rod_spacing=float(lengths["rod_spacing_mm"]),
            tower_azimuth=np.radians(azimuth_deg),
            endstop_height=np.asarray(lengths["endstop_height_mm"]),
            step_distance=step,
            tool=geo.vector("nozzle_mm", (3,)),
            points=read_points(top, source),
            workspace=_printable(top),
        )
    except GeometryError as exc:
        raise InputError(str(exc), source) from None
    if printer.workspace is not None:
        _check_printable_reachable(printer, source)
    return printer


def _each_tower(geo: TomlTable, key: str) -> list[tuple[str, float]]:
    """A key's values with the words that name each one's tower: none when the file holds one number.

    The key was read and checked already (a number, or three).
    """
    value = geo.raw(key)
    if not isinstance(value, list):
        return [("", float(value))]
    return [(f" (tower {tower})", float(v)) for tower, v in zip(TOWERS, value, strict=True)]


def _check_on_tower(tower: str, check: Callable[[TomlTable, str, float], None], geo: TomlTable, key: str,
                    value: float) -> None:
    """Run a one-value check, its message naming the tower (``tower``: the words, or "")."""
    try:
        check(geo, key, value)
    except InputError as exc:
        raise InputError(f"{exc.detail}{tower}", exc.source, exc.location) from None


def _printable(top: TomlTable) -> Workspace | None:
    """A printer's ``[workspace]``: the printable cylinder from the bed (z = 0) up, or None."""
    ws = top.table("workspace", required=False)
    if ws is None:
        return None
    ws.check_unknown(["radius_mm", "height_mm"])
    height = ws.number("height_mm", positive=True)
    return Workspace(radius=ws.number("radius_mm", positive=True), height=height, top_z=height)


def _check_printable_reachable(printer: NominalLinearDelta, source: str) -> None:
    """The printable cylinder's rim must be reachable with every carriage below its endstop."""
    ws = printer.workspace
    assert ws is not None
    ang = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    rim = [np.stack([ws.radius * np.cos(ang), ws.radius * np.sin(ang), np.full_like(ang, z)], 1)
           for z in (ws.bottom_z, ws.top_z)]
    pts = np.concatenate(rim)
    travel = VirtualDelta.from_geometry(printer.geometry()).inverse(pts - printer.tool, check=False)
    with np.errstate(invalid="ignore"):
        bad = ~np.all(travel >= 0.0, axis=1)  # NaN: out of the rods' reach; negative: above an endstop
    if np.any(bad):
        p = pts[np.argmax(bad)]
        raise InputError(
            f"the workspace reaches {np.round(p, 3).tolist()} mm, out of reach of the printer "
            "(above an endstop, or beyond the rods)",
            source,
            "key workspace",
        )
