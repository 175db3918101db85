"""Geometry files: a DeltaGeometry in full, in mm and degrees, exact round trip."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..chains import JOINTS, REVOLUTE, chain_of
from ..exceptions import GeometryError, InputError
from ..geometry import DeltaGeometry, Masses
from ..towers import written_per_tower
from .atomic import atomic_write_text
from .names import check_names, check_robot_name, control_character
from .toml import TomlTable, exact_degrees, read_toml, shown_value, toml_dumps

GEOMETRY_FORMAT = "deltacal-geometry-1"


CALIBRATION_FORMAT = "deltacal-calibration-1"


def geometry_to_dict(geometry: DeltaGeometry) -> dict[str, Any]:
    """The TOML tables of a DeltaGeometry (mm, deg), as written by :func:`save_geometry`.

    A linear Delta (a prismatic chain) has ``joint = "prismatic"`` at the top and, per limb, its
    endstop's error ``endstop_offset_mm`` (the encoder offset of a carriage) and ``joint_scale``
    (true over nominal step distance) in place of ``encoder_offset_deg``, and ``step_distance_mm``
    at the top when known: the nominal step distance its readings count steps in (what the
    firmware's steps are converted with), a number when the three towers' are equal, else
    ``[a, b, c]``; a rotary robot's file is unchanged.
    """
    steps = geometry.chain.counts_steps
    limbs = []
    for i in range(3):
        limb: dict[str, Any] = {
            "azimuth_deg": exact_degrees(float(geometry.limb_azimuth[i])),
            "axis_point_mm": geometry.axis_point[i].tolist(),
            "axis_direction": geometry.axis_direction[i].tolist(),
        }
        if steps:
            limb["endstop_offset_mm"] = float(geometry.encoder_offset[i])
            limb["joint_scale"] = float(geometry.joint_scale[i])
        else:
            limb["encoder_offset_deg"] = exact_degrees(float(geometry.encoder_offset[i]))
            if geometry.joint_scale[i] != 1.0:  # a rotary printer's step angle; a robot's file unchanged
                limb["joint_scale"] = float(geometry.joint_scale[i])
        limb |= {
            "arm_ball_mm": geometry.arm_ball[i].tolist(),
            "plate_ball_mm": geometry.plate_ball[i].tolist(),
            "rod_length_mm": geometry.rod_length[i].tolist(),
        }
        limbs.append(limb)
    out: dict[str, Any] = {"format": GEOMETRY_FORMAT, "name": geometry.name}
    if geometry.chain != REVOLUTE:  # the default, not written: a rotary robot's file is unchanged
        out["joint"] = geometry.chain.name
        if geometry.step_distance is not None:
            out["step_distance_mm"] = written_per_tower(geometry.step_distance)
    out |= {"tool_mm": geometry.tool.tolist(), "limb": limbs}
    if geometry.points:
        out["points"] = {k: v.tolist() for k, v in geometry.points.items()}
    if not geometry.masses.is_zero:
        out["masses"] = masses_to_dict(geometry.masses)
    if np.any(geometry.compliance):
        out["compliance"] = {"actuator_rad_per_nm": geometry.compliance.tolist()}
    return out


def masses_to_dict(masses: Masses) -> dict[str, float]:
    """The ``[masses]`` table (conventions, "Gravity and payload") [kg]."""
    return {"arm_kg": masses.arm, "rod_kg": masses.rod, "plate_kg": masses.plate}


def masses_from_table(table: TomlTable) -> Masses:
    """Read a ``[masses]`` table: ``arm_kg``, ``rod_kg``, ``plate_kg``, each required, finite, >= 0.

    Raises:
        InputError: naming the file and the key.
    """
    table.check_unknown(["arm_kg", "rod_kg", "plate_kg"])
    values = {}
    for key in ("arm_kg", "rod_kg", "plate_kg"):
        value = table.number(key)
        if value < 0.0:
            raise table.error(key, f"a mass cannot be negative, got {value!r} kg")
        values[key[:-3]] = value
    return Masses(**values)


def _compliance_from_table(table: TomlTable) -> np.ndarray:
    """A geometry's ``[compliance]``: ``actuator_rad_per_nm = [c1, c2, c3]`` [rad/N m]."""
    table.check_unknown(["actuator_rad_per_nm"])
    return table.vector("actuator_rad_per_nm", (3,))


def geometry_from_dict(data: Mapping[str, Any], source: str, prefix: str = "") -> DeltaGeometry:
    """Build a DeltaGeometry from tables written by :func:`geometry_to_dict`."""
    top = TomlTable(data, source, prefix)
    top.check_unknown(["format", "name", "joint", "step_distance_mm", "tool_mm", "limb", "points", "masses",
                       "compliance"])
    fmt = top.string("format")
    if fmt != GEOMETRY_FORMAT:
        raise top.error("format", f"expected {GEOMETRY_FORMAT!r}, got {fmt!r}")
    name = top.string("name", default="")
    problem = control_character(name)
    if problem is not None:
        raise top.error("name", f"robot name {name!r} {problem}")
    joint = top.string("joint", default=REVOLUTE.name)
    if joint not in JOINTS:
        raise top.error("joint", f"must be one of {', '.join(JOINTS)}, got {joint!r}")
    chain = chain_of(joint)
    step_distance = None
    if "step_distance_mm" in data:
        if not chain.counts_steps:
            raise top.error("step_distance_mm", "a rotary robot's file (no joint = \"prismatic\") has no "
                            "step distance")
        step_distance = top.per_tower("step_distance_mm", positive=True)
    tool = top.vector("tool_mm", (3,))
    limbs = top.raw("limb")
    if not isinstance(limbs, list) or len(limbs) != 3 or not all(isinstance(x, Mapping) for x in limbs):
        raise top.error("limb", "must be an array of exactly 3 tables [[limb]]")
    fields: dict[str, list[Any]] = {k: [] for k in (
        "limb_azimuth", "axis_point", "axis_direction", "encoder_offset", "arm_ball", "plate_ball",
        "rod_length", "joint_scale")}
    joint_keys = ["endstop_offset_mm", "joint_scale"] if chain.counts_steps else ["encoder_offset_deg",
                                                                                   "joint_scale"]
    for i, limb_data in enumerate(limbs):
        t = TomlTable(limb_data, source, f"{prefix}limb[{i + 1}].")
        t.check_unknown(["azimuth_deg", "axis_point_mm", "axis_direction", *joint_keys, "arm_ball_mm",
                         "plate_ball_mm", "rod_length_mm"])
        fields["limb_azimuth"].append(t.angle("azimuth_deg"))
        fields["axis_point"].append(t.vector("axis_point_mm", (3,)))
        w = t.vector("axis_direction", (3,))
        if abs(float(np.linalg.norm(w)) - 1.0) > 1e-9:
            raise t.error("axis_direction", f"must be a unit vector, got {w.tolist()}")
        fields["axis_direction"].append(w)
        if chain.counts_steps:
            fields["encoder_offset"].append(t.number("endstop_offset_mm"))
            scale = t.number("joint_scale")
            if scale <= 0.0:
                raise t.error("joint_scale", f"must be positive, got {scale!r}")
            fields["joint_scale"].append(scale)
        else:
            fields["encoder_offset"].append(t.angle("encoder_offset_deg"))
            fields["joint_scale"].append(t.number("joint_scale", positive=True) if "joint_scale" in limb_data
                                         else 1.0)
        fields["arm_ball"].append(t.vector("arm_ball_mm", (2, 3)))
        fields["plate_ball"].append(t.vector("plate_ball_mm", (2, 3)))
        rods = t.vector("rod_length_mm", (2,))
        if np.any(rods <= 0):
            raise t.error("rod_length_mm", f"must be positive, got {rods.tolist()}")
        fields["rod_length"].append(rods)
    points = {}
    pts = top.table("points", required=False)
    if pts is not None:
        check_names(pts.data, "point", source, f"key {prefix}points")
        for k in pts.data:
            points[k] = pts.vector(k, (3,))
    table = top.table("masses", required=False)
    masses = Masses() if table is None else masses_from_table(table)
    table = top.table("compliance", required=False)
    compliance = np.zeros(3) if table is None else _compliance_from_table(table)
    try:
        arrays: dict[str, Any] = {k: np.array(v) for k, v in fields.items()}
        return DeltaGeometry(**arrays, tool=tool, points=points, name=name, masses=masses,
                             compliance=compliance, chain=chain, step_distance=step_distance)
    except GeometryError as exc:
        raise InputError(str(exc), source) from None


def save_geometry(geometry: DeltaGeometry, path: str | Path) -> None:
    """Write a DeltaGeometry to TOML (mm, deg), atomically; it reads back bit for bit.

    Raises:
        InputError: a point name no file can carry (:func:`~deltacal.io.names.name_problem`).
    """
    check_robot_name(geometry.name, str(path))
    check_names(geometry.points, "point", str(path))
    header = "# deltacal geometry: every element of a real Delta robot (mm, deg)\n"
    atomic_write_text(path, header + toml_dumps(geometry_to_dict(geometry)))


def check_format(data: Mapping[str, Any], source: str) -> str:
    """The ``format`` of a geometry or calibration file; a missing or unknown one is refused.

    Raises:
        InputError: naming the key, what is wrong and the formats deltacal reads.
    """
    _check_not_nominal(data, source)
    known = (f"the known formats are {GEOMETRY_FORMAT!r} (a geometry) and {CALIBRATION_FORMAT!r} "
             "(a calibration)")
    if "format" not in data:
        raise InputError(f"missing required key ({known})", source, "key format")
    fmt = data["format"]
    if fmt not in (GEOMETRY_FORMAT, CALIBRATION_FORMAT):
        raise InputError(f"unknown format {shown_value(fmt)}: {known}", source, "key format")
    return str(fmt)


def load_geometry(path: str | Path) -> DeltaGeometry:
    """Read a geometry TOML file, or the ``[geometry]`` part of a calibration file."""
    data = read_toml(path)
    check_format(data, str(path))
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
