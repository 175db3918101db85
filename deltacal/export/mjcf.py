"""MJCF model of a DeltaGeometry: the identified robot for MuJoCo and Pinocchio.

The model is written as plain XML text (no MuJoCo import). Units are SI (metres,
kilograms, radians); every number is written with full double precision
(``repr(float)``), so the geometry reaches the other program unrounded.

Frame: the robot base frame {O} (z up, the origin at the centre of the circle of
actuator axes). When the calibration was identified with a free instrument
frame (``identify --frame free``), the model is still in {O}: the stations'
frames are not part of it (a comment in the XML says so).

Structure, mirroring :mod:`deltacal.kinematics.multibody`:

* one root body ``base`` in ``<worldbody>`` (Pinocchio's MJCF parser keeps the
  first top-level body only), holding everything else;
* three bodies ``arm1_link`` .. ``arm3_link`` placed at ``axis_point[i]`` with the
  rotation ``R0_i @ Ry(encoder_offset_i)``, each on a hinge joint ``arm1`` ..
  ``arm3`` about its local y axis: the joint value is the encoder reading q_i
  [rad]; offsets and axis misalignments live in the body placements;
* six bodies ``rod11_link`` .. ``rod32_link`` at the arm balls (arm frame), each on
  a ball joint ``rod11`` .. ``rod32``; the rod hangs along its local -z axis and
  its far ball centre is the site ``rodIJ_end`` at ``(0, 0, -rod_length)``;
* the plate body ``plate`` (frame {C}) on a chain of three slide joints
  ``plate_x``, ``plate_y``, ``plate_z`` along the base axes then a ball joint
  ``plate_rotation``: MuJoCo accepts a free joint only in a top-level body, and
  Pinocchio reads a single top-level body, so the plate's six degrees of
  freedom are this chain (Pinocchio makes it one composite joint). The slide
  values are the position of {C} in {O} [m], the ball its orientation;
* six ``<connect site1="rodIJ_end" site2="plate_ballIJ"/>`` closures. They name
  the two points by sites, so both anchors are explicit: the body/anchor form
  would take the second anchor from the default configuration, which is not an
  assembly;
* sites ``tcp`` and one per named point of the geometry, on the plate;
* position actuators on the three arms and a keyframe ``home``: an assembly
  from deltacal's exact forward kinematics at the home readings (zero by
  default), every joint included (MuJoCo ball quaternions are ``w x y z``).

A linear Delta printer (a prismatic chain, :mod:`deltacal.chains`) has the same tree and
closures with carriages instead of arms: bodies ``carriage1_link`` .. ``carriage3_link`` placed
at ``axis_point[i] - encoder_offset[i] w_i`` with the rotation ``R0_i`` (as
:mod:`deltacal.kinematics.multibody` places them), each on a slide joint ``carriage1`` ..
``carriage3`` along its local y axis (up the tower): the joint value is
``-joint_scale_i q_i`` [m] (q_i the reading, the travel below the endstop in nominal steps [mm]).
The position actuators ``carriage1`` .. ``carriage3`` have the gear ``-1000 / joint_scale_i``, so
their control, like the arms', is the reading (here in mm). The base holds the bed (its top the
plane z = 0) and the towers along the axis lines; the plate is the effector and ``tcp`` the nozzle.

Masses and inertias are the geometry's (:class:`~deltacal.geometry.Masses`, conventions "Gravity
and payload"; a carriage's at its ball-pair midpoint) when it has any, else plausible ones, not
identified: aluminium tubes for the arms (a printer: aluminium carriages), carbon tubes for the
rods, an aluminium disc for the plate. Geoms are visual only (no contacts).
The position servos of the arms are proportional only (and the closures, like
every MuJoCo constraint, soft): under gravity a simulated bai2015 settles a few
tenths of a millimetre from its target. For exact poses, set the arm joints and
solve the closures kinematically, as the tests do.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from .._version import __version__
from ..chains import REVOLUTE, Chain
from ..exceptions import GeometryError
from ..geometry import DeltaGeometry
from ..io import atomic_write_text
from ..kinematics import exact
from ..rotations import rotation_about_y

#: Name of the keyframe holding the assembled home configuration.
HOME_KEY = "home"

_MM = 1000.0  # millimetres per metre
_ALUMINIUM = 2700.0  # kg/m^3
_CARBON = 1550.0  # kg/m^3
#: Arm tube (outer, inner radius) [m].
_ARM_TUBE = (0.020, 0.017)
#: Rod tube (outer, inner radius) [m].
_ROD_TUBE = (0.006, 0.005)
#: Plate disc thickness [m] and margin beyond the balls [m].
_PLATE_THICKNESS = 0.010
_PLATE_MARGIN = 0.015
#: Base plate thickness [m] and margin beyond the actuator axes [m].
_BASE_THICKNESS = 0.020
_BASE_MARGIN = 0.080
#: Position servo gain [N m/rad] and joint damping [N m s/rad] of the arms.
_ARM_KP = 3000.0
_ARM_DAMPING = 50.0
#: A printer's rod tube (outer, inner radius) [m], effector disc thickness and margin beyond the
#: balls [m].
_PRINTER_ROD_TUBE = (0.003, 0.0025)
_EFFECTOR_THICKNESS = 0.006
_EFFECTOR_MARGIN = 0.008
#: A carriage: a box about its balls' midpoint, half-sizes radial and along the tower [m] (across the
#: tower it reaches its balls), and its mass [kg].
_CARRIAGE_HALF = (0.010, 0.030)
_CARRIAGE_KG = 0.12
#: The bed's thickness [m] and margin beyond the towers [m]; the towers' radius [m] and how far they
#: rise above the endstops [m].
_BED_THICKNESS = 0.006
_BED_MARGIN = 0.040
_TOWER_RADIUS = 0.010
_TOWER_ABOVE = 0.060
#: A carriage's position servo: gain [N per mm of reading, before the gear] (with the gear of about
#: -1000: 1e5 N/m on the slide) and the slide's damping [N s/m].
_CARRIAGE_KP = 0.1
_CARRIAGE_DAMPING = 200.0
#: A body the geometry's masses give 0 kg weighs this [kg]: MuJoCo needs a mass on every moving body.
_LEAST_MASS = 1e-6
#: Time constant and damping ratio of the closures' constraint (MuJoCo's soft constraints: stiffer
#: than the default 0.02 s, so the balls part by a few hundredths of a millimetre under gravity).
_CLOSURE_SOLREF = "0.004 1"


# ------------------------------------------------------------------- numbers
def _num(x: float) -> str:
    return repr(float(x))


def _vec(values: Iterable[float]) -> str:
    return " ".join(_num(v) for v in values)


def _quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation matrix, w >= 0 (Shepperd's method)."""
    R = np.asarray(R, dtype=float)
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    k = int(np.argmax([trace, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    out = np.array(q)
    out /= np.linalg.norm(out)
    return -out if out[0] < 0.0 else out


def _quaternion_from_z(u: np.ndarray) -> np.ndarray:
    """The smallest rotation taking the z axis to the unit vector u, as ``(w, x, y, z)``."""
    u = np.asarray(u, dtype=float) / np.linalg.norm(u)
    # half-way quaternion: (1 + z.u, z x u), normalised; z x u = (-u_y, u_x, 0)
    q = np.array([1.0 + u[2], -u[1], u[0], 0.0])
    norm = np.linalg.norm(q)
    if norm < 1e-12:  # u = -z: half a turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    return q / norm


# ------------------------------------------------------------------- inertia
def _tube(p0: np.ndarray, p1: np.ndarray, radii: tuple[float, float], density: float):
    """Mass [kg], centre [m] and inertia about the centre [kg m^2] of a tube from p0 to p1 [m]."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    ro, ri = radii
    length = float(np.linalg.norm(p1 - p0))
    mass = density * np.pi * (ro**2 - ri**2) * length
    e = (p1 - p0) / length
    axial = 0.5 * mass * (ro**2 + ri**2)
    perpendicular = mass * (3.0 * (ro**2 + ri**2) + length**2) / 12.0
    inertia = perpendicular * (np.eye(3) - np.outer(e, e)) + axial * np.outer(e, e)
    return mass, 0.5 * (p0 + p1), inertia


def _disc(centre: np.ndarray, radius: float, thickness: float, density: float):
    """Mass, centre and inertia about the centre of a disc of axis z [SI]."""
    mass = density * np.pi * radius**2 * thickness
    side = mass * (3.0 * radius**2 + thickness**2) / 12.0
    return mass, np.asarray(centre, dtype=float), np.diag([side, side, 0.5 * mass * radius**2])


def _combine(parts: Sequence[tuple[float, np.ndarray, np.ndarray]]):
    """Mass, centre and inertia about the centre of rigidly joined parts."""
    mass = sum(m for m, _, _ in parts)
    centre = sum(m * c for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, own in parts:
        r = c - centre
        inertia += own + m * (np.dot(r, r) * np.eye(3) - np.outer(r, r))
    return mass, centre, inertia


def _inertial(parent: ET.Element, part: tuple[float, np.ndarray, np.ndarray]) -> None:
    mass, centre, tensor = part
    ET.SubElement(parent, "inertial", {
        "pos": _vec(centre),
        "mass": _num(mass),
        # fullinertia: Ixx Iyy Izz Ixy Ixz Iyz about the centre of mass
        "fullinertia": _vec(tensor[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]),
    })


def _visual(parent: ET.Element, attributes: dict[str, str]) -> None:
    """A geom drawn only: no contacts, no mass (the body's inertial is given)."""
    ET.SubElement(parent, "geom", {**attributes, "contype": "0", "conaffinity": "0", "mass": "0"})


def _box(centre: np.ndarray, half: np.ndarray, mass: float):
    """Mass, centre and inertia about the centre of a solid box of half-sizes along the axes [SI]."""
    hx, hy, hz = (float(v) for v in half)
    inertia = mass / 3.0 * np.diag([hy**2 + hz**2, hx**2 + hz**2, hx**2 + hy**2])
    return mass, np.asarray(centre, dtype=float), inertia


def _weighing(part: tuple[float, np.ndarray, np.ndarray], mass: float):
    """A part made to weigh ``mass`` [kg] (at least :data:`_LEAST_MASS`), its shape and centre kept."""
    own, centre, inertia = part
    mass = max(float(mass), _LEAST_MASS)
    return mass, centre, inertia * (mass / own)


# ------------------------------------------------------------------- names
def _actuator_names(chain: Chain) -> tuple[str, str]:
    """The actuated joint's and its body's name stem: ``arm``, ``arm_link`` or ``carriage``, ..."""
    return chain.words.part, "_link"


def _reserved_names(chain: Chain = REVOLUTE) -> set[str]:
    stem, link = _actuator_names(chain)
    names = {"base", "plate", "plate_x", "plate_y", "plate_z", "plate_rotation", "tcp"}
    for i in range(1, 4):
        names |= {f"{stem}{i}", f"{stem}{i}{link}"}
        for j in (1, 2):
            names |= {f"rod{i}{j}", f"rod{i}{j}_link", f"rod{i}{j}_end", f"plate_ball{i}{j}", f"ball{i}{j}"}
    return names


def _check_point_names(geometry: DeltaGeometry) -> None:
    taken = _reserved_names(geometry.chain)
    for name in geometry.points:
        if name in taken:
            raise GeometryError(f"point {name!r}: the name is taken by an element of the MJCF model; "
                                "rename the point")


# ------------------------------------------------------------------- home
def home_configuration(geometry: DeltaGeometry, readings: np.ndarray | None = None) -> np.ndarray:
    """The model's qpos of an assembly at given readings (default zero), from deltacal's exact FK.

    Order: for each arm (or carriage), its joint then its two rods' quaternions ``(w, x, y, z)``;
    then the plate's three slides [m] and its quaternion. Length 34. An arm's joint value is its
    reading [rad]; a carriage's is ``-joint_scale q`` [m] (its reading q in mm).

    Raises:
        AssemblyError: the robot does not assemble at these readings.
    """
    q = np.zeros(3) if readings is None else np.asarray(readings, dtype=float).reshape(3)
    pose = exact.forward(geometry, q[None])
    p, R = pose.position[0], pose.rotation[0]
    arms = geometry.arm_rotation(q[None])[0]
    values = geometry.chain.joint_value(q, geometry.joint_scale, _MM)
    if geometry.chain.slides:
        carried = geometry.arm_balls_in_base(q[None])[0]
    else:
        carried = np.array([[geometry.axis_point[i] + arms[i] @ geometry.arm_ball[i, j] for j in range(2)]
                            for i in range(3)])
    qpos: list[float] = []
    for i in range(3):
        qpos.append(float(values[i]))
        for j in range(2):
            B = p + R @ geometry.plate_ball[i, j]
            # the rod's -z axis runs from the arm ball to the plate ball
            qpos.extend(_quaternion_from_z(-(arms[i].T @ (B - carried[i, j]))).tolist())
    qpos.extend((p / _MM).tolist())
    qpos.extend(_quaternion(R).tolist())
    return np.array(qpos)


# ------------------------------------------------------------------- model
def _rod_bodies(parent: ET.Element, geometry: DeltaGeometry, i: int, tube: tuple[float, float]) -> None:
    """The two rods of limb i on ball joints at the arm (carriage) balls, each with its end site."""
    g = geometry
    balls = g.arm_ball[i] / _MM
    for j in range(2):
        name = f"rod{i + 1}{j + 1}"
        length = float(g.rod_length[i, j]) / _MM
        end = np.array([0.0, 0.0, -length])
        rod = ET.SubElement(parent, "body", {"name": f"{name}_link", "pos": _vec(balls[j])})
        ET.SubElement(rod, "joint", {"name": name, "type": "ball"})
        part = _tube(np.zeros(3), end, tube, _CARBON)
        _inertial(rod, part if g.masses.is_zero else _weighing(part, g.masses.rod))
        _visual(rod, {"type": "capsule", "size": _num(tube[0]), "fromto": _vec([0.0, 0.0, 0.0, *end]),
                      "rgba": "0.15 0.15 0.15 1"})
        ET.SubElement(rod, "site", {"name": f"{name}_end", "pos": _vec(end), "size": "0.008"})


def _arm_body(base: ET.Element, geometry: DeltaGeometry, i: int, placement: np.ndarray) -> None:
    g = geometry
    arm = ET.SubElement(base, "body", {
        "name": f"arm{i + 1}_link",
        "pos": _vec(g.axis_point[i] / _MM),
        "quat": _vec(_quaternion(placement)),
    })
    ET.SubElement(arm, "joint", {
        "name": f"arm{i + 1}", "type": "hinge", "axis": "0 1 0",
        "damping": _num(_ARM_DAMPING),
    })
    balls = g.arm_ball[i] / _MM
    elbow = balls.mean(axis=0)
    if g.masses.is_zero:
        _inertial(arm, _combine([
            _tube(np.zeros(3), elbow, _ARM_TUBE, _ALUMINIUM),
            _tube(balls[0], balls[1], _ARM_TUBE, _ALUMINIUM),
        ]))
    else:  # conventions: the arm's centre of mass half-way from its axis to its elbow
        _inertial(arm, _weighing(_tube(np.zeros(3), elbow, _ARM_TUBE, _ALUMINIUM), g.masses.arm))
    _visual(arm, {"type": "capsule", "size": _num(_ARM_TUBE[0]), "fromto": _vec([0.0, 0.0, 0.0, *elbow]),
                  "rgba": "0.75 0.75 0.8 1"})
    _visual(arm, {"type": "capsule", "size": _num(_ARM_TUBE[0]), "fromto": _vec([*balls[0], *balls[1]]),
                  "rgba": "0.75 0.75 0.8 1"})
    _rod_bodies(arm, g, i, _ROD_TUBE)


def _carriage_body(base: ET.Element, geometry: DeltaGeometry, i: int) -> None:
    """Carriage i on its slide up the tower, placed as :mod:`deltacal.kinematics.multibody` places it."""
    g = geometry
    R0 = g.actuator_rotation()[i]
    carriage = ET.SubElement(base, "body", {
        "name": f"carriage{i + 1}_link",
        "pos": _vec((g.axis_point[i] - g.encoder_offset[i] * R0[:, 1]) / _MM),
        "quat": _vec(_quaternion(R0)),
    })
    ET.SubElement(carriage, "joint", {
        "name": f"carriage{i + 1}", "type": "slide", "axis": "0 1 0",
        "damping": _num(_CARRIAGE_DAMPING),
    })
    balls = g.arm_ball[i] / _MM
    centre = balls.mean(axis=0)
    half = np.array([*_CARRIAGE_HALF, float(np.max(np.abs(balls[:, 2] - centre[2])))])
    part = _box(centre, half, _CARRIAGE_KG)
    _inertial(carriage, part if g.masses.is_zero else _weighing(part, g.masses.arm))
    _visual(carriage, {"type": "box", "pos": _vec(centre), "size": _vec(half), "rgba": "0.2 0.3 0.5 1"})
    _rod_bodies(carriage, g, i, _PRINTER_ROD_TUBE)


def _plate_body(base: ET.Element, geometry: DeltaGeometry) -> None:
    g = geometry
    plate = ET.SubElement(base, "body", {"name": "plate"})
    for axis, direction in zip("xyz", ("1 0 0", "0 1 0", "0 0 1"), strict=True):
        ET.SubElement(plate, "joint", {"name": f"plate_{axis}", "type": "slide", "axis": direction})
    ET.SubElement(plate, "joint", {"name": "plate_rotation", "type": "ball"})
    balls = g.plate_ball.reshape(6, 3) / _MM
    thickness, margin = ((_EFFECTOR_THICKNESS, _EFFECTOR_MARGIN) if g.chain.on_bed
                         else (_PLATE_THICKNESS, _PLATE_MARGIN))
    radius = float(np.max(np.linalg.norm(balls[:, :2], axis=1))) + margin
    part = _disc(np.zeros(3), radius, thickness, _ALUMINIUM)
    _inertial(plate, part if g.masses.is_zero else _weighing(part, g.masses.plate))
    _visual(plate, {"type": "cylinder", "size": _vec([radius, 0.5 * thickness]),
                    "rgba": "0.6 0.65 0.75 1"})
    for k, ball in enumerate(balls):
        i, j = divmod(k, 2)
        ET.SubElement(plate, "site", {"name": f"plate_ball{i + 1}{j + 1}", "pos": _vec(ball),
                                      "size": "0.008"})
    for name in g.point_names:
        ET.SubElement(plate, "site", {"name": name, "pos": _vec(g.point(name) / _MM), "size": "0.005",
                                      "rgba": "1 0.3 0.1 1"})


def _rotary_base(base: ET.Element, geometry: DeltaGeometry, top: float) -> None:
    """The base plate above the actuators, and the three arms."""
    g = geometry
    base_radius = float(np.max(np.linalg.norm(g.axis_point[:, :2], axis=1))) / _MM + _BASE_MARGIN
    base_centre = np.array([0.0, 0.0, top + 0.5 * _BASE_THICKNESS + _ARM_TUBE[0]])
    _inertial(base, _disc(base_centre, base_radius, _BASE_THICKNESS, _ALUMINIUM))
    _visual(base, {"type": "cylinder", "pos": _vec(base_centre),
                   "size": _vec([base_radius, 0.5 * _BASE_THICKNESS]), "rgba": "0.4 0.4 0.45 1"})
    placements = g.actuator_rotation() @ rotation_about_y(g.encoder_offset)
    for i in range(3):
        _arm_body(base, g, i, placements[i])


def _printer_base(base: ET.Element, geometry: DeltaGeometry) -> None:
    """The bed (its top the plane z = 0), the towers along the axis lines, and the three carriages."""
    g = geometry
    bed_radius = float(np.max(np.linalg.norm(g.axis_point[:, :2], axis=1))) / _MM + _BED_MARGIN
    bed_centre = np.array([0.0, 0.0, -0.5 * _BED_THICKNESS])
    _inertial(base, _disc(bed_centre, bed_radius, _BED_THICKNESS, _ALUMINIUM))
    _visual(base, {"type": "cylinder", "pos": _vec(bed_centre),
                   "size": _vec([bed_radius, 0.5 * _BED_THICKNESS]), "rgba": "0.25 0.25 0.28 1"})
    for i in range(3):
        point, up = g.axis_point[i] / _MM, g.axis_direction[i]
        foot = point - point[2] / up[2] * up  # where the axis line meets the bed plane
        _visual(base, {"type": "capsule", "size": _num(_TOWER_RADIUS),
                       "fromto": _vec([*foot, *(point + _TOWER_ABOVE * up)]), "rgba": "0.5 0.5 0.55 1"})
    for i in range(3):
        _carriage_body(base, g, i)


def _actuators(actuator: ET.Element, geometry: DeltaGeometry) -> None:
    """Position servos whose control is the reading: on the arms [rad], or geared on the carriages [mm]."""
    for i in range(1, 4):
        if not geometry.chain.slides:
            ET.SubElement(actuator, "position", {"name": f"arm{i}", "joint": f"arm{i}", "kp": _num(_ARM_KP)})
        else:
            gear = -_MM / float(geometry.joint_scale[i - 1])  # actuator length = gear x slide = reading [mm]
            ET.SubElement(actuator, "position", {"name": f"carriage{i}", "joint": f"carriage{i}",
                                                 "kp": _num(_CARRIAGE_KP), "gear": _num(gear)})


def _comments(g: DeltaGeometry, model_name: str, readings: np.ndarray, stations: Sequence[str],
              source: str) -> list[str]:
    """The lines of the model's leading comments: what it is, its units, frames and joints."""
    printer = g.chain.on_bed
    lines = [
        f" {model_name}: {g.chain.words.model} written by deltacal "
        f"{__version__} export" + (f" from {source}" if source else "") + ". ",
    ]
    if printer:
        lines += [
            " Units: SI (m, kg, rad). Frame: the printer's {O} (z up, origin on the bed at its centre, "
            "the bed's top the plane z = 0). ",
            " Joints carriage1..carriage3: slides up the towers, value = minus the true travel below the "
            "endstop [m] (endstop errors and tower leans are in the carriage bodies' placements); "
            "actuators carriage1..carriage3: control = reading [mm] (steps times the nominal step "
            "distance), through a gear of -1000 / (true over nominal step distance). ",
            " Rods rod11..rod32: ball joints at the carriage balls, the rod along local -z; the effector "
            "{E} (body plate): slides plate_x/y/z (its position in {O}) then the ball plate_rotation; "
            "site tcp: the nozzle. ",
            " Ball quaternions are w x y z (MuJoCo order); keyframe 'home' is an assembly "
            "(readings " + _vec(readings) + " mm). ",
        ]
    else:
        lines += [
            " Units: SI (m, kg, rad). Frame: the robot base frame {O} (z up, origin at the centre "
            "of the circle of actuator axes). ",
            " Joints arm1..arm3: value = encoder reading [rad] (encoder offsets and axis "
            "misalignments are in the arm bodies' placements). ",
            " Rods rod11..rod32: ball joints at the arm balls, the rod along local -z; the plate "
            "{C}: slides plate_x/y/z (its position in {O}) then the ball plate_rotation. ",
            " Ball quaternions are w x y z (MuJoCo order); keyframe 'home' is an assembly "
            "(readings " + _vec(readings) + " rad). ",
        ]
    if not g.masses.is_zero:
        m = g.masses
        lines.append(f" Masses: the geometry's ({g.chain.words.part} {_num(m.arm)} kg, rod "
                     f"{_num(m.rod)} kg, plate {_num(m.plate)} kg; a body given 0 kg weighs {_LEAST_MASS:g} "
                     "kg); inertias those of their plausible shapes. ")
    elif printer:
        lines.append(" Masses and inertias are plausible values (aluminium carriages and effector, carbon "
                     "rods), not identified ones. ")
    else:
        lines.append(" Masses and inertias are plausible values (aluminium arms and plate, carbon rods), not "
                     "identified ones. ")
    if stations:
        lines.append(
            " The calibration was identified with a free instrument frame (stations "
            + ", ".join(stations) + "): this model is in the robot base frame {O}, not in a "
            "station's frame. "
        )
    return lines


def mjcf_model(
    geometry: DeltaGeometry,
    name: str | None = None,
    home: np.ndarray | None = None,
    stations: Sequence[str] = (),
    source: str = "",
) -> str:
    """The MJCF text of a robot (see the module docstring for the model's structure).

    Args:
        geometry: The robot (identified or nominal; a rotary Delta or a printer), in {O}, mm and rad.
        name: Model name (default: the geometry's name, else ``delta``).
        home: Readings of the ``home`` keyframe [rad; a printer's in mm], shape (3,) (default zero).
        stations: Instrument stations of the calibration, named in a comment: the model
            stays in the robot base frame {O}.
        source: The file the geometry came from, named in a comment.

    Returns:
        The XML document.

    Raises:
        GeometryError: a point's name is taken by an element of the model.
        AssemblyError: the robot does not assemble at the home readings.
    """
    g = geometry
    _check_point_names(g)
    model_name = name or g.name or "delta"
    readings = np.zeros(3) if home is None else np.asarray(home, dtype=float).reshape(3)
    qpos = home_configuration(g, readings)

    root = ET.Element("mujoco", {"model": model_name})
    for line in _comments(g, model_name, readings, stations, source):
        root.append(ET.Comment(re.sub("-(?=-)", "- ", line)))  # "--" may not appear in an XML comment
    ET.SubElement(root, "compiler", {"angle": "radian", "autolimits": "true"})
    ET.SubElement(root, "option", {"timestep": "0.001", "integrator": "implicitfast"})
    world = ET.SubElement(root, "worldbody")
    top = float(np.max(g.axis_point[:, 2])) / _MM
    ET.SubElement(world, "light", {"name": "top", "pos": _vec([0.0, 0.0, top + 2.0]), "dir": "0 0 -1",
                                   "directional": "true"})
    base = ET.SubElement(world, "body", {"name": "base"})
    if g.chain.on_bed:
        _printer_base(base, g)
    else:
        _rotary_base(base, g, top)
    _plate_body(base, g)

    equality = ET.SubElement(root, "equality")
    for i in range(1, 4):
        for j in (1, 2):
            ET.SubElement(equality, "connect", {"name": f"ball{i}{j}", "site1": f"rod{i}{j}_end",
                                                "site2": f"plate_ball{i}{j}",
                                                "solref": _CLOSURE_SOLREF})
    _actuators(ET.SubElement(root, "actuator"), g)
    keyframe = ET.SubElement(root, "keyframe")
    ET.SubElement(keyframe, "key", {"name": HOME_KEY, "qpos": _vec(qpos), "ctrl": _vec(readings)})
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_mjcf(
    path: str | Path,
    geometry: DeltaGeometry,
    name: str | None = None,
    home: np.ndarray | None = None,
    stations: Sequence[str] = (),
    source: str = "",
) -> Path:
    """Write :func:`mjcf_model` to ``path`` atomically; returns the path."""
    text = mjcf_model(geometry, name=name, home=home, stations=stations, source=source)
    return atomic_write_text(path, text)
