"""Actuated chains: how an actuator moves the balls it carries.

A rotary Delta and a linear one (a 3D printer's towers) differ only here. Each limb's actuator
carries its arm-side balls rigidly, and the actuator's frame at zero motion is the same for both:
origin ``P_i`` (``axis_point``), rotation ``R0_i = [x0 w z0]`` with y along the joint's axis ``w_i``
(the rotation axis of a revolute joint, the line of travel of a prismatic one), x the radial
direction made orthogonal to it. A point ``a`` carried by the actuator is, at the joint coordinate
``θ_i = scale_i q_i + offset_i`` (reading q; the true angle [rad] or the true travel [mm]),

    A = C + f(θ) U + g(θ) V

* ``revolute``: f = cos, g = sin: a circle about the axis (:func:`arm_frame_circle`,
  ``C = P + a_y w``, ``U = a_x x0 + a_z z0``, ``V = a_z x0 − a_x z0``); q > 0 lowers the arm tip.
* ``prismatic``: f = θ, g = 0: a line down the tower, ``C = P + R0 a``, ``U = −w``, ``V = 0``; θ is
  the carriage's travel below its endstop (q: steps times the nominal step distance, scale: the
  true step distance over the nominal one).

Everything that moves an arm ball (the geometry, the exact solver, the virtual model) goes
through a :class:`Chain`'s :meth:`~Chain.carried_points`, :meth:`~Chain.path_terms` and
:meth:`~Chain.path_slopes`.

The rest of what differs between the two kinds is here too, on the chain object (one per kind,
:data:`REVOLUTE` and :data:`PRISMATIC`; :func:`chain_of` maps a file's word to it once): the
words users read, the solvers' limits, and flags that say what the viewer, the exporters, the
report and the commands do with such a robot. Code elsewhere asks the chain; it does not test
which chain it holds. Units: mm and rad.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .rotations import rotation_about_y

#: Readings a real arm can take [rad]: from straight up (-90 deg) to folded under (135 deg).
ARM_RANGE = (float(np.radians(-90.0)), float(np.radians(135.0)))
#: Readings a printer's carriage can take [mm]: travel below its endstop, which it cannot pass.
TRAVEL_RANGE = (0.0, float(np.inf))


@dataclass(frozen=True)
class ChainWords:
    """What users read about a robot of one chain: messages, the report, the viewer, exported models.

    Attributes:
        part: The actuated part: ``arm`` or ``carriage``.
        plate: The moving platform: ``plate`` or ``effector``.
        tcp: Its tool point as the viewer labels it: ``TCP`` or ``nozzle``.
        tool: The tool in running text: ``tool`` or ``nozzle``.
        robot: The machine: ``robot`` or ``printer``.
        a_robot: The machine in short, with its article: ``a rotary Delta`` or ``a printer``.
        a_kind: The machine in full, with its article: ``a rotary Delta`` or ``a linear Delta printer``.
        robots: The family: ``rotary Delta robots`` or ``linear Delta printers``.
        model: An exported model's description: ``Delta robot`` or ``linear Delta printer``.
        reading_rule: What readings given on the command line must be (:attr:`Chain.option_range`).
        reading_unit: The unit of a reading in files and messages: ``deg`` or ``mm``.
    """

    part: str
    plate: str
    tcp: str
    tool: str
    robot: str
    a_robot: str
    a_kind: str
    robots: str
    model: str
    reading_rule: str
    reading_unit: str


class Chain(ABC):
    """One kind of actuated chain: how its actuators move the balls they carry, and what differs with it.

    There is one instance per kind, :data:`REVOLUTE` and :data:`PRISMATIC` (they survive copies and
    pickling as themselves). Code asks a chain for its values, words, flags and paths instead of
    testing which one it is.
    """

    #: Its word in geometry files (``joint = ...``) and messages: ``revolute`` or ``prismatic``.
    name: ClassVar[str]
    #: Its word in robot files (``kind = ...``): ``rotary`` or ``linear``.
    robot_kind: ClassVar[str]
    #: What users read about such a robot.
    words: ClassVar[ChainWords]
    #: The largest joint step of one inverse-kinematics iteration [rad, mm]: small enough that a far
    #: start cannot jump to the other branch (knee in; effector above the carriage).
    max_step: ClassVar[float]
    #: A warm start is used when the readings moved by less than this in each joint [rad, mm].
    warm_radius: ClassVar[float]
    #: The readings the real actuator can take [rad, mm] (:data:`ARM_RANGE`, :data:`TRAVEL_RANGE`).
    reading_range: ClassVar[tuple[float, float]]
    #: Largest difference between the readings wanted and those a controller's inverse gives for
    #: the corrected target [rad, mm]: a round trip through its closed-form forward and inverse
    #: models (1e-15 rad measured; a printer's, 1e-13 mm); beyond, the readings are on the
    #: model's other branch (knee in; a carriage below the nozzle).
    round_trip_tolerance: ClassVar[float]
    #: Readings a user may give on the command line, in the file's unit [deg, mm].
    option_range: ClassVar[tuple[float, float]]
    #: The letter of the second axis tilt in error names: ``z`` (about z: a revolute axis lies
    #: along t_i) or ``t`` (about t_i: a tower stands along z).
    tilt_letter: ClassVar[str]
    #: Readings are steps counted in a nominal step distance: a geometry has a joint scale (true over
    #: nominal step distance) and may know its step distance; else its joint scale is 1.
    counts_steps: ClassVar[bool]
    #: The actuator slides along its axis (its balls move on lines); else it turns about it (circles).
    slides: ClassVar[bool]
    #: A turn of the actuator frame about its axis turns the carried balls (a carriage turned about
    #: its tower); else it is a change of the joint's offset (an arm's encoder offset).
    turns_balls: ClassVar[bool]
    #: The working assembly's plate hangs below the lowest carried ball (an effector below its
    #: carriages); else below the actuator axes.
    plate_below_balls: ClassVar[bool]
    #: The robot stands on a bed, the plane z = 0 of {O}, its actuators along towers up from it: what
    #: the viewer and the exported models draw, where its default workspace is, and a gauge of the
    #: report (a motion along the bed is no error of a printed part).
    on_bed: ClassVar[bool]
    #: Its controller is a printer's firmware (Klipper's values), not a controller file fitted here.
    firmware: ClassVar[bool]
    #: Its identification says where the calibration holds (the σ of its corrections over the volume, a
    #: calibration file's ``[holds]``), which the routes that correct only there read: a calibration of
    #: it without that is refused by them (:meth:`~deltacal.calibration.Calibration.where_held`).
    says_where_it_holds: ClassVar[bool]
    #: Gravity statics (compliance, payload) are modelled for it.
    gravity_statics: ClassVar[bool]
    #: Savoure's and Bai's linear compensations (their error models) serve it.
    linear_compensation: ClassVar[bool]
    #: The viewer's drawn size per unit of :meth:`limb_length` (its parts are drawn for a 375 mm
    #: arm, or for a printer's 600 mm rods).
    drawn_scale: ClassVar[float]
    #: The :class:`~deltacal.geometry.Tolerances` constructor of such a robot's typical build.
    typical_tolerances: ClassVar[str]

    def __repr__(self) -> str:
        return f"<{self.name} chain>"

    def __reduce__(self) -> tuple:
        return chain_of, (self.name,)

    @abstractmethod
    def carried_points(
        self, axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The paths of points carried by the actuators, ``A = C + f(θ) U + g(θ) V``: C, U, V.

        Args:
            axis_point: P_i [mm], shape (3, 3).
            actuator_rotation: R0_i, shape (3, 3, 3).
            local: Points in the arm (or carriage) frames [mm], shape (3, K, 3).

        Returns:
            C, U, V, each of shape (3, K, 3).
        """

    @abstractmethod
    def path_terms(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The coefficients ``f(θ), g(θ)`` of U and V in a carried point's position (any shape)."""

    @abstractmethod
    def path_slopes(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Their derivatives ``f'(θ), g'(θ)`` (any shape): ``dA/dθ = f' U + g' V``."""

    @abstractmethod
    def coordinate(self, q: np.ndarray, scale: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """True joint coordinates ``θ = scale q + offset`` [rad or mm] of readings q (broadcast)."""

    @abstractmethod
    def carrier_rotation(self, actuator_rotation: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Rotations of the arm (or carriage) frames in {O} at joint coordinates θ (N, 3), (N, 3, 3, 3)."""

    @abstractmethod
    def joint_value(self, q: np.ndarray, scale: np.ndarray, length_unit: float = 1.0) -> np.ndarray:
        """A multibody model's joint values at readings q: the angle [rad], or minus the true travel.

        A slide's value goes up the tower, in ``length_unit`` [mm per unit]; :meth:`reading_of`
        inverts it (length unit 1).
        """

    @abstractmethod
    def reading_of(self, value: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Readings of a multibody model's joint values (in mm): the inverse of :meth:`joint_value`."""

    @abstractmethod
    def wrap(self, difference: np.ndarray) -> np.ndarray:
        """A difference of readings as the least motion: an angle within ±π, a travel as it is."""

    @abstractmethod
    def reading_from_file(self, values: np.ndarray) -> np.ndarray:
        """Readings in the file's unit (degrees, mm) -> [rad, mm]."""

    @abstractmethod
    def reading_to_file(self, q: np.ndarray) -> np.ndarray:
        """Readings [rad, mm] -> in the file's unit (:attr:`ChainWords.reading_unit`)."""

    @abstractmethod
    def limb_length(self, arm_ball: np.ndarray, rod_length: np.ndarray) -> float:
        """A robot's size [mm]: its mean arm length (axis to elbow), or a printer's mean rod length.

        Args:
            arm_ball: Arm-side ball centres in the arm frames [mm], (3, 2, 3).
            rod_length: Rod lengths [mm], (3, 2).
        """

    @abstractmethod
    def second_tilt_axis(self, tangent: np.ndarray) -> np.ndarray:
        """The axes of the second axis tilts (:attr:`tilt_letter`), one row per limb, (3, 3).

        Args:
            tangent: The limbs' tangent vectors t_i, (3, 3).
        """


class RevoluteChain(Chain):
    """A rotary Delta's arms: each turns about its actuator axis; its balls move on circles."""

    name = "revolute"
    robot_kind = "rotary"
    words = ChainWords(
        part="arm", plate="plate", tcp="TCP", tool="tool", robot="robot", a_robot="a rotary Delta",
        a_kind="a rotary Delta", robots="rotary Delta robots", model="Delta robot",
        reading_rule="readings must lie within ±180 deg", reading_unit="deg",
    )
    max_step = 0.2
    warm_radius = float(np.radians(5.0))
    reading_range = ARM_RANGE
    round_trip_tolerance = 1e-9
    option_range = (-180.0, 180.0)
    tilt_letter = "z"
    counts_steps = False
    slides = False
    turns_balls = False
    plate_below_balls = False
    on_bed = False
    firmware = False
    says_where_it_holds = False
    gravity_statics = True
    linear_compensation = True
    drawn_scale = 1.0
    typical_tolerances = "bai2015"

    def carried_points(
        self, axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Circles about the actuator axes (:func:`arm_frame_circle`)."""
        return arm_frame_circle(axis_point, actuator_rotation, local)

    def path_terms(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``cos θ, sin θ``."""
        return np.cos(theta), np.sin(theta)

    def path_slopes(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``−sin θ, cos θ``."""
        return -np.sin(theta), np.cos(theta)

    def coordinate(self, q: np.ndarray, scale: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """``scale q + offset``: the scale is 1 for a robot (its reading taken as it is, bit for bit).

        A rotary printer's scale is its arm's true turn per unit counted in the nominal step angle.
        """
        return scale * q + offset

    def carrier_rotation(self, actuator_rotation: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """``R0_i R_y(θ_i)``."""
        return actuator_rotation[None] @ rotation_about_y(theta)

    def joint_value(self, q: np.ndarray, scale: np.ndarray, length_unit: float = 1.0) -> np.ndarray:
        """The arms' turns from their offsets, ``scale q`` [rad] (the readings themselves at scale 1)."""
        return scale * q

    def reading_of(self, value: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """The readings of the turns: ``value / scale`` [rad]."""
        return value / scale

    def wrap(self, difference: np.ndarray) -> np.ndarray:
        """Within ±π [rad]."""
        return (difference + np.pi) % (2.0 * np.pi) - np.pi

    def reading_from_file(self, values: np.ndarray) -> np.ndarray:
        """Degrees -> [rad]."""
        return np.radians(values)

    def reading_to_file(self, q: np.ndarray) -> np.ndarray:
        """[rad] -> degrees."""
        return np.degrees(q)

    def limb_length(self, arm_ball: np.ndarray, rod_length: np.ndarray) -> float:
        """The mean distance of the arms' ball-pair midpoints from their axes' origins [mm]."""
        return float(np.mean(np.linalg.norm(arm_ball.mean(axis=1), axis=1)))

    def second_tilt_axis(self, tangent: np.ndarray) -> np.ndarray:
        """z, for each limb."""
        return np.broadcast_to(np.array([0.0, 0.0, 1.0]), np.shape(tangent))


class PrismaticChain(Chain):
    """A linear Delta's carriages: each slides down its tower; its balls move on lines."""

    name = "prismatic"
    robot_kind = "linear"
    words = ChainWords(
        part="carriage", plate="effector", tcp="nozzle", tool="nozzle", robot="printer", a_robot="a printer",
        a_kind="a linear Delta printer", robots="linear Delta printers", model="linear Delta printer",
        reading_rule="a printer's readings are carriage travels below the endstops [mm], not negative",
        reading_unit="mm",
    )
    max_step = 50.0
    warm_radius = 20.0
    reading_range = TRAVEL_RANGE
    round_trip_tolerance = 1e-9
    option_range = TRAVEL_RANGE
    tilt_letter = "t"
    counts_steps = True
    slides = True
    turns_balls = True
    plate_below_balls = True
    on_bed = True
    firmware = True
    says_where_it_holds = True
    gravity_statics = False
    linear_compensation = False
    drawn_scale = 375.0 / 600.0
    typical_tolerances = "printer_kit"

    def carried_points(
        self, axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Lines down the towers: ``C = P + R0 a``, ``U = −w``, ``V = 0``."""
        centre = axis_point[:, None, :] + np.einsum("ikl,ijl->ijk", actuator_rotation, local)
        along = np.broadcast_to(-actuator_rotation[:, None, :, 1], centre.shape).copy()
        return centre, along, np.zeros_like(centre)

    def path_terms(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``θ, 0``."""
        return theta, np.zeros_like(theta)

    def path_slopes(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``1, 0``."""
        return np.ones_like(theta), np.zeros_like(theta)

    def coordinate(self, q: np.ndarray, scale: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """``scale q + offset`` [mm]."""
        return scale * q + offset

    def carrier_rotation(self, actuator_rotation: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """``R0_i``: a carriage slides without turning."""
        return np.broadcast_to(actuator_rotation, (theta.shape[0], 3, 3, 3)).copy()

    def joint_value(self, q: np.ndarray, scale: np.ndarray, length_unit: float = 1.0) -> np.ndarray:
        """``−scale q / length_unit``: the slide goes up the tower, the reading down."""
        return -scale * q / length_unit

    def reading_of(self, value: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """``−value / scale`` [mm]."""
        return -value / scale

    def wrap(self, difference: np.ndarray) -> np.ndarray:
        """The difference as it is [mm]."""
        return difference

    def reading_from_file(self, values: np.ndarray) -> np.ndarray:
        """Millimetres, as they are."""
        return values

    def reading_to_file(self, q: np.ndarray) -> np.ndarray:
        """Millimetres, as they are."""
        return np.asarray(q, dtype=float)

    def limb_length(self, arm_ball: np.ndarray, rod_length: np.ndarray) -> float:
        """The mean rod length [mm] (the carriage balls are on the towers)."""
        return float(np.mean(rod_length))

    def second_tilt_axis(self, tangent: np.ndarray) -> np.ndarray:
        """t_i, for each limb."""
        return tangent


#: A rotary Delta's chain.
REVOLUTE: Chain = RevoluteChain()
#: A linear Delta's (a 3-D printer's) chain.
PRISMATIC: Chain = PrismaticChain()
#: Every chain, the default (a rotary Delta's) first.
CHAINS: tuple[Chain, ...] = (REVOLUTE, PRISMATIC)
#: The chains' words in geometry files.
JOINTS = tuple(chain.name for chain in CHAINS)
#: The chains' words in robot files.
ROBOT_KINDS = tuple(chain.robot_kind for chain in CHAINS)


def chain_of(word: str | Chain) -> Chain:
    """The chain of a geometry file's ``joint`` word or a robot file's ``kind`` word (a chain: itself).

    Raises:
        ValueError: naming the words known.
    """
    if isinstance(word, Chain):
        return word
    for chain in CHAINS:
        if word in (chain.name, chain.robot_kind):
            return chain
    raise ValueError(f"joint must be one of {', '.join(JOINTS)}, got {word!r}")


def arm_frame_circle(
    axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points fixed in the arm frames, on their circles about the actuator axes.

    A point ``a`` of arm i is at ``P_i + R0_i R_y(θ_i) a = C + cos θ_i U + sin θ_i V`` in {O}
    (θ the true angle; conventions), with ``C = P_i + a_y w_i``, ``U = a_x x0_i + a_z z0_i``
    and ``V = a_z x0_i − a_x z0_i`` in the actuator frame's axes ``R0_i = [x0 w z0]``.

    Args:
        axis_point: P_i [mm], shape (3, 3).
        actuator_rotation: R0_i, shape (3, 3, 3).
        local: Points in the arm frames [mm], shape (3, K, 3) (K points of each arm).

    Returns:
        C, U, V, each of shape (3, K, 3).
    """
    x0, w, z0 = (actuator_rotation[:, None, :, k] for k in range(3))  # (3, 1, 3) each
    ax, ay, az = local[..., 0:1], local[..., 1:2], local[..., 2:3]
    return axis_point[:, None, :] + ay * w, ax * x0 + az * z0, az * x0 - ax * z0


def carried_points(
    joint: str | Chain, axis_point: np.ndarray, actuator_rotation: np.ndarray, local: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`Chain.carried_points` of a chain given by its word (or itself)."""
    return chain_of(joint).carried_points(axis_point, actuator_rotation, local)


def path_terms(joint: str | Chain, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Chain.path_terms` of a chain given by its word (or itself)."""
    return chain_of(joint).path_terms(theta)


def path_slopes(joint: str | Chain, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Chain.path_slopes` of a chain given by its word (or itself)."""
    return chain_of(joint).path_slopes(theta)
