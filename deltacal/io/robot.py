"""The nominal robot file (conventions: [geometry], [points], [workspace]) of a rotary Delta.

A file with ``kind = "linear"`` is a printer's: the printer's wing reads it
(:mod:`deltacal.printer.files.robot_file`), and :func:`deltacal.robots.load_robot` reads a file of
either kind. The readers of the parts both kinds share (``kind``, ``name``, ``[points]``, the
plausible lengths) are here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..chains import PRISMATIC, REVOLUTE
from ..chains import ROBOT_KINDS as ROBOT_KINDS  # the kinds of robot file (kind absent: rotary)
from ..exceptions import GeometryError, InputError
from ..geometry import Masses, NominalDelta, Workspace
from ..kinematics.closed_form import VirtualDelta
from .geometry_file import CALIBRATION_FORMAT, GEOMETRY_FORMAT, masses_from_table
from .names import check_names, control_character
from .toml import TomlTable, read_toml

#: The lengths of a robot file's ``[geometry]`` a Delta robot can have [mm]. Below, the file is
#: most likely written in metres (every Delta has a plate radius under 1 m); above, in
#: micrometres or mistyped (the largest Delta printers stand about 12 m tall).
PLAUSIBLE_LENGTH_MM = (1.0, 20_000.0)


def _kind(top: TomlTable) -> str:
    """The file's ``kind`` (absent: ``"rotary"``), checked."""
    if not top.has("kind"):
        return REVOLUTE.robot_kind
    kind = top.string("kind")
    if kind not in ROBOT_KINDS:
        raise top.error("kind", f"unknown robot kind {kind!r}: one of {', '.join(map(repr, ROBOT_KINDS))}")
    return kind


def is_printer_file(top: TomlTable) -> bool:
    """Whether the file is a linear Delta printer's (``kind = "linear"``; checked): the wing reads it."""
    return _kind(top) == PRISMATIC.robot_kind


def robot_kind(data: dict, source: str) -> str:
    """The ``kind`` of a robot file's parsed TOML ``data`` (absent: ``"rotary"``), checked.

    Raises:
        InputError: naming the file ``source`` and the key, for a kind deltacal does not know.
    """
    return _kind(TomlTable(data, source))


def load_nominal(path: str | Path, data: dict | None = None) -> NominalDelta:
    """Read and validate a nominal robot file (format of the project's conventions).

    Args:
        path: The file.
        data: Its TOML, already parsed (:func:`~deltacal.io.toml.read_toml`): the file is read once.

    Raises:
        InputError: naming the file and the key of the first problem found.
    """
    source = str(path)
    top = TomlTable(read_toml(path) if data is None else data, source)
    if top.data.get("format") in (GEOMETRY_FORMAT, CALIBRATION_FORMAT):
        raise top.error("format", f"this is a deltacal {top.data['format']!r} file, not a nominal "
                                  "robot file (such as deltacal/models/bai2015.toml)")
    if is_printer_file(top):
        raise top.error("kind", "a linear Delta printer's file (kind = 'linear'): this command "
                                "serves rotary Delta robots only")
    top.check_unknown(["name", "description", "kind", "geometry", "points", "workspace", "masses"])
    name = read_robot_name(top)
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
    for key, value in zip(("base_radius_mm", "plate_radius_mm", "arm_length_mm", "rod_length_mm",
                           "rod_spacing_mm"), values.values(), strict=True):
        check_plausible_length(geo, key, value)
    azimuth_deg = _azimuths(geo)
    b, a, L, l_rod = (values[k] for k in ("base_radius", "plate_radius", "arm_length", "rod_length"))
    size = b + L + l_rod
    tool = geo.vector("tool_mm", (3,))
    _check_offset(geo, "tool_mm", tool, size)
    points = read_points(top, source, size)
    workspace = _workspace(top)
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
            masses=_masses(top, values),
            **values,
        )
    except GeometryError as exc:
        raise InputError(str(exc), source) from None
    if workspace is not None:
        _check_workspace_reachable(nominal, source)
    return nominal


def read_robot_name(top: TomlTable) -> str:
    """The robot's ``name``: any text without control characters (it names the MJCF model too)."""
    name = top.string("name")
    problem = control_character(name)
    if problem is not None:
        raise top.error("name", f"robot name {name!r} {problem}")
    return name


def read_points(top: TomlTable, source: str, size: float = math.inf) -> dict[str, np.ndarray]:
    """The ``[points]`` table: named plate points [mm], names checked (not ``tcp``, no control characters).

    A point farther from the plate than ``size`` [mm], the robot's own size, is refused.
    """
    points: dict[str, np.ndarray] = {}
    pts = top.table("points", required=False)
    if pts is not None:
        check_names(pts.data, "point", source, "key points")
        for k in pts.data:
            if k == "tcp":
                raise pts.error(k, "'tcp' is reserved for the tool centre point")
            points[k] = pts.vector(k, (3,))
            _check_offset(pts, k, points[k], size)
    return points


def _workspace(top: TomlTable) -> Workspace | None:
    """The ``[workspace]`` table, or None."""
    ws = top.table("workspace", required=False)
    if ws is None:
        return None
    ws.check_unknown(["radius_mm", "height_mm", "top_z_mm"])
    workspace = Workspace(
        radius=ws.number("radius_mm", positive=True),
        height=ws.number("height_mm", positive=True),
        top_z=ws.number("top_z_mm"),
    )
    if workspace.top_z >= 0.0:
        raise ws.error("top_z_mm", f"the plate works below the base: must be < 0, got {workspace.top_z}")
    return workspace


def _azimuths(geo: TomlTable) -> np.ndarray:
    """``limb_azimuth_deg`` [deg]: three different azimuths, not radians."""
    azimuth_deg = geo.vector("limb_azimuth_deg", (3,))
    if len({round(float(a) % 360.0, 9) for a in azimuth_deg}) < 3:
        raise geo.error("limb_azimuth_deg", f"the three azimuths must differ, got {azimuth_deg.tolist()}")
    if np.max(np.abs(azimuth_deg)) <= 2.0 * math.pi:  # the limbs within 13 deg of each other: no Delta
        given = ", ".join(f"{a:g}" for a in azimuth_deg)
        meant = ", ".join(f"{np.degrees(a):.4g}" for a in azimuth_deg)
        spread = f"{np.ptp(azimuth_deg):.3g}"
        raise geo.error("limb_azimuth_deg", f"azimuths [{given}] put the limbs within {spread} deg of each "
                                            f"other: radians ([{meant}] deg)? deltacal reads degrees")
    return azimuth_deg


def _check_offset(table: TomlTable, key: str, offset: np.ndarray, size: float) -> None:
    """Refuse a tool or point offset from the plate beyond the robot's size ``size`` [mm] (units, typing)."""
    distance = float(np.linalg.norm(offset))
    if distance > size:
        raise table.error(key, f"{offset.tolist()} mm is {distance:g} mm from the plate, implausible for "
                               f"this robot (base radius + arm + rod = {size:g} mm): micrometres, a typo?")


#: Steel [kg/m^3]: a body heavier than a solid steel one of its size is not a Delta's.
STEEL_KG_PER_M3 = 7850.0


def _masses(top: TomlTable, values: dict[str, float]) -> Masses:
    """The optional ``[masses]`` (conventions, "Gravity and payload"); none: a massless robot.

    A mass beyond a solid steel body of the robot's dimensions (an arm a fifth as thick as long, a
    rod a twentieth, a plate as thick as its radius with the rods' spacing) is refused: grams.
    """
    table = top.table("masses", required=False)
    if table is None:
        return Masses()
    masses = masses_from_table(table)
    arm, rod = 1e-3 * values["arm_length"], 1e-3 * values["rod_length"]
    plate = 1e-3 * (values["plate_radius"] + 0.5 * values["rod_spacing"])
    for key, mass, body, bound in (
        ("arm_kg", masses.arm, f"an arm of {values['arm_length']:g} mm", math.pi * arm**3 / 100.0),
        ("rod_kg", masses.rod, f"a rod of {values['rod_length']:g} mm", math.pi * rod**3 / 1600.0),
        ("plate_kg", masses.plate, f"a plate of {values['plate_radius']:g} mm radius", math.pi * plate**3),
    ):
        heaviest = STEEL_KG_PER_M3 * bound
        if mass > heaviest:
            raise table.error(key, f"{mass:g} kg is implausible for {body} (heavier than {heaviest:.3g} kg "
                                   "of solid steel): grams? deltacal reads kilograms")
    return masses


def check_plausible_length(geo: TomlTable, key: str, value: float) -> None:
    """Refuse a length no Delta robot has (a file in metres, a typing error), naming the unit."""
    low, high = PLAUSIBLE_LENGTH_MM
    if low <= value <= high:
        return
    guess = "metres?" if value < low else "micrometres?" if value < 1000.0 * high else "a typing error?"
    raise geo.error(key, f"{value!r} mm is implausible for a Delta robot ({guess} deltacal reads "
                         f"millimetres and accepts lengths from {low:g} mm to {high:,.0f} mm)")


def _check_workspace_reachable(nominal, source: str) -> None:
    """The workspace cylinder's rim must be reachable by the nominal robot."""
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
