"""Marlin 2.x's model of a linear Delta printer (``#define DELTA``): its values, limits and controller.

Marlin's meaning of its values, from its source (``Marlin/src``), in its frame (the bed's, the
nozzle's coordinates; towers A, B, C are Marlin's X, Y, Z steppers):

* ``M665 R`` ``delta_radius`` ρ: horizontal distance from each carriage point to the effector point
  when the effector is centred (``module/delta.cpp``, ``recalc_delta_settings``: tower i at
  ``(ρ + DELTA_RADIUS_TRIM_TOWER_i)(cos α_i, sin α_i)``; the radius trims are compile-time,
  ``{0, 0, 0}`` by default, and not in ``M503``: deltacal takes them as 0);
* ``M665 X Y Z`` ``delta_tower_angle_trim`` [deg]: α_i = 210 + X, 330 + Y, 90 + Z; a positive
  trim turns that tower anticlockwise seen from above (``delta.cpp``); ``G33`` keeps their sum
  at 0 ("normalise angles to least squares", ``gcode/calibrate/G33.cpp``);
* ``M665 L`` ``delta_diagonal_rod`` and ``A B C`` ``delta_diagonal_rod_trim``: tower i's rod is
  ``L + trim_i`` (``delta.cpp``: ``delta_diagonal_rod_2_tower = sq(L + trim)``);
* ``M665 H`` ``delta_height``: the nozzle's height after homing, the effector centred, less the
  probe's ``M851 Z`` offset: ``G28`` sets the position to ``(0, 0, H − M851 Z)`` once the three
  carriages are home (``module/motion.cpp``, ``set_axis_is_at_home``;
  ``DIFF_TERN(HAS_BED_PROBE, delta_height, probe.offset.z)``);
* ``M666 X Y Z`` ``delta_endstop_adj`` [mm], each <= 0 (``gcode/calibrate/M666.cpp`` refuses a
  positive one): after its endstop, ``G28`` moves carriage i by that much, down, away from the
  endstop (``motion.cpp``, ``homeaxis``), unless it is no more than ``MIN_STEPS_PER_SEGMENT`` steps
  (6 by default): then it is not moved. ``M666 X-0.5`` homes tower A's carriage 0.5 mm lower, so
  every later position drives it 0.5 mm lower than with 0;
* ``M92 X Y Z`` steps per mm of each tower's carriage: the step distance is ``1 / M92``;
* ``M851 X Y Z`` the probe's offset from the nozzle (``gcode/probe/M851.cpp``): only its Z enters
  the kinematics, through the homed height above.

Inverse kinematics (``module/delta.h``, ``DELTA_Z``): carriage height ``h_i = z + sqrt(l_i² − (X_i −
x)² − (Y_i − y)²)``; at home carriage i stands at ``h_i(0, 0, H − M851 Z)``, ``adj_i`` below its
endstop, so its height at the endstop is ``E_i = H − M851 Z + sqrt(l_i² − ρ²) − adj_i`` and the
steps below the endstop are ``(E_i − h_i) · M92_i``. Forward kinematics: ``delta.cpp``'s
trilateration (the solution below the carriages). deltacal's readings of a printer are travels
below the endstops counted in its nominal step distance: reading = steps × that step distance.

Limits (``motion.cpp``, ``update_software_endstops`` and ``apply_motion_limits``): the soft
endstops of ``M211`` (``Min: X Y Z  Max: X Y Z``; Marlin's delta defaults ``X/Y_MIN_POS =
−DELTA_PRINTABLE_RADIUS``, ``X/Y_MAX_POS = DELTA_PRINTABLE_RADIUS``, ``Z_MIN_POS = 0``), the highest
z being the homed height ``H − M851 Z``; a target further from the centre than the smallest of
``|max(min X, min Y)|``, ``max X``, ``max Y`` (``delta_max_radius``) is pulled in to it, a z outside
``min Z .. max Z`` clamped. Units: mm; the dataclass's angle trims in degrees, as Marlin's.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ....exceptions import AssemblyError, GeometryError
from ....kinematics.closed_form import VirtualDelta
from ....towers import per_tower
from ..classical import carriage_tops, checked_steps, point_effector, tower_positions
from ..controller import FirmwareController

#: Marlin's tower angles before the trims (``delta.cpp``) [deg], towers A, B, C.
BASE_ANGLES_DEG = (210.0, 330.0, 90.0)
#: ``MIN_STEPS_PER_SEGMENT`` (``Configuration_adv.h``): an ``M666`` adjustment of no more steps is not moved.
MIN_STEPS_PER_SEGMENT = 6
#: ``DELTA_PRINTABLE_RADIUS`` of Marlin's generic delta configuration, the soft endstops' default [mm].
DEFAULT_PRINTABLE_RADIUS = 140.0
#: ``M665 S``, ``DELTA_SEGMENTS_PER_SECOND`` of Marlin's delta configurations.
DEFAULT_SEGMENTS_PER_SECOND = 200.0

#: The soft endstop a command breaks (:meth:`MarlinDelta.outside`): its Z below Min Z, above the top,
#: its radius beyond ``delta_max_radius``.
BELOW_MIN_Z, ABOVE_MAX_Z, BEYOND_RADIUS = 1, 2, 3

@dataclass(frozen=True)
class SoftEndstops:
    """Marlin's soft endstops (``M211``) [mm].

    Attributes:
        minimum: ``Min: X Y Z``, (3,).
        maximum: ``Max: X Y``; its z is None when the report gave none (then the homed height).
        enabled: ``M211 S1``.
    """

    minimum: tuple[float, float, float]
    maximum_xy: tuple[float, float]
    maximum_z: float | None = None
    enabled: bool = True

    @classmethod
    def default(cls, radius: float = DEFAULT_PRINTABLE_RADIUS) -> SoftEndstops:
        """Marlin's delta defaults: ±``DELTA_PRINTABLE_RADIUS`` in x and y, z from 0."""
        return cls((-radius, -radius, 0.0), (radius, radius))

    @property
    def radius(self) -> float:
        """``delta_max_radius``: the smallest of ``|max(min X, min Y)|``, ``max X``, ``max Y`` [mm]."""
        return float(min(abs(max(self.minimum[0], self.minimum[1])), *self.maximum_xy))


@dataclass(frozen=True, eq=False)
class MarlinDelta:
    """Marlin's delta kinematics with the values ``M503`` reports.

    Attributes:
        radius: ``M665 R`` ρ [mm].
        rod: ``M665 L`` [mm].
        height: ``M665 H`` [mm].
        angle_trim: ``M665 X Y Z`` [deg], (3,).
        rod_trim: ``M665 A B C`` [mm], (3,).
        endstop_adj: ``M666 X Y Z`` [mm], (3,), each <= 0.
        steps_per_mm: ``M92 X Y Z``, (3,).
        probe_offset: ``M851 X Y Z`` [mm], (3,).
        soft_endstops: ``M211``.
        segments_per_second: ``M665 S`` (kept to be written back).
        extruder_steps_per_mm: ``M92 E`` (kept to be written back), or None.
        name: A name (the settings file's).
        compiled_height: The report is a Marlin 1.1.0's (or older): its ``M665`` takes ``L R S A B
            C`` only, its homed height and tower angles are compiled in. Its homed height, given as
            a line ``M665 H`` added to the capture, is where its ``G28`` puts the nozzle whatever
            ``M851 Z`` (``MANUAL_Z_HOME_POS`` + ``M206 Z``: it homes up, no probe offset taken
            off); ``height`` holds it as Marlin 2's ``M665 H`` (that height + ``M851 Z``), so the
            model is the same. Its values cannot be written back (:func:`~.fit.fit_marlin` refuses).
    """

    radius: float
    rod: float
    height: float
    angle_trim: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rod_trim: np.ndarray = field(default_factory=lambda: np.zeros(3))
    endstop_adj: np.ndarray = field(default_factory=lambda: np.zeros(3))
    steps_per_mm: np.ndarray = field(default_factory=lambda: np.full(3, 80.0))
    probe_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    soft_endstops: SoftEndstops = field(default_factory=SoftEndstops.default)
    segments_per_second: float = DEFAULT_SEGMENTS_PER_SECOND
    extruder_steps_per_mm: float | None = None
    name: str = ""
    compiled_height: bool = False

    def __post_init__(self) -> None:
        for key in ("angle_trim", "rod_trim", "endstop_adj", "steps_per_mm", "probe_offset"):
            value = np.array(getattr(self, key), dtype=float).reshape(-1)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise GeometryError(f"{key} must be 3 finite values, got {getattr(self, key)!r}")
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        if not np.isfinite(self.radius) or self.radius <= 0.0:
            raise GeometryError(f"M665 R (delta_radius) must be a positive length, got {self.radius!r}")
        if not np.isfinite(self.height):
            raise GeometryError(f"M665 H (delta_height) must be finite, got {self.height!r}")
        if np.any(self.rods <= self.radius):
            raise GeometryError(f"M665 L + A/B/C (each tower's rod) must exceed R {self.radius:g}, got "
                                f"{self.rods.tolist()}")
        if np.any(self.endstop_adj > 0.0):
            raise GeometryError(f"M666 offsets must be <= 0 (Marlin refuses others), got "
                                f"{self.endstop_adj.tolist()}")
        if np.any(self.steps_per_mm <= 0.0):
            raise GeometryError(f"M92 steps per mm must be positive, got {self.steps_per_mm.tolist()}")

    @property
    def step_distance(self) -> np.ndarray:
        """Each carriage's travel per step, ``1 / M92`` [mm], (3,)."""
        return per_tower("step_distance", 1.0 / self.steps_per_mm)

    @property
    def rods(self) -> np.ndarray:
        """Each tower's rod ``L + trim_i`` [mm], (3,)."""
        return self.rod + self.rod_trim

    @property
    def angle(self) -> np.ndarray:
        """Tower azimuths ``210, 330, 90 + trims`` [rad], (3,)."""
        return np.radians(np.array(BASE_ANGLES_DEG) + self.angle_trim)

    @property
    def home_height(self) -> float:
        """Where ``G28`` puts the centred nozzle: ``H − M851 Z`` [mm]."""
        return float(self.height - self.probe_offset[2])

    @property
    def homing_moves(self) -> np.ndarray:
        """How far ``G28`` moves each carriage down from its endstop [mm], (3,).

        ``−adj``, or 0 where that is no more than ``MIN_STEPS_PER_SEGMENT`` steps.
        """
        moved = np.abs(self.endstop_adj) > MIN_STEPS_PER_SEGMENT * self.step_distance
        return np.where(moved, -self.endstop_adj, 0.0)

    @cached_property
    def towers(self) -> np.ndarray:
        """Tower positions ``(X_i, Y_i)`` [mm], (3, 2)."""
        return tower_positions(self.radius, self.angle)

    @cached_property
    def carriage_top(self) -> np.ndarray:
        """Each carriage point's height at its endstop in Marlin's frame, ``E_i`` [mm], (3,)."""
        return carriage_tops(self.home_height, self.rods, self.radius, self.homing_moves)

    def carriage_heights(self, targets: np.ndarray) -> np.ndarray:
        """``DELTA_Z``: carriage heights for nozzle targets [mm], (N, 3) -> (N, 3); NaN out of reach."""
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        dx = self.towers[None, :, 0] - targets[:, None, 0]
        dy = self.towers[None, :, 1] - targets[:, None, 1]
        with np.errstate(invalid="ignore"):
            return targets[:, 2:3] + np.sqrt(self.rods**2 - (dx * dx + dy * dy))

    def steps(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """Steps below the endstops Marlin commands for nozzle targets [mm], (N, 3) -> (N, 3).

        Raises:
            UnreachableError: a target no rod reaches (``check``; else NaN rows).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        return checked_steps((self.carriage_top - self.carriage_heights(targets)) * self.steps_per_mm,
                             targets, check)

    def positions(self, steps: np.ndarray, check: bool = True) -> np.ndarray:
        """``forward_kinematics``: the nozzle at steps below the endstops, (N, 3) -> (N, 3) [mm].

        ``delta.cpp``'s trilateration: a frame at tower A's carriage point with x towards B's, the
        solution below the carriages.

        Raises:
            AssemblyError: steps where the three spheres do not meet (``check``; else NaN rows).
        """
        steps = np.atleast_2d(np.asarray(steps, dtype=float))
        z = self.carriage_top - steps / self.steps_per_mm
        rod2 = self.rods**2
        tower = self.towers
        p12 = np.column_stack([np.broadcast_to(tower[1] - tower[0], (len(z), 2)), z[:, 1] - z[:, 0]])
        p13 = np.column_stack([np.broadcast_to(tower[2] - tower[0], (len(z), 2)), z[:, 2] - z[:, 0]])
        d2 = np.einsum("ij,ij->i", p12, p12)
        ex = p12 / np.sqrt(d2)[:, None]
        i = np.einsum("ij,ij->i", ex, p13)
        ey = p13 - i[:, None] * ex
        j2 = np.einsum("ij,ij->i", ey, ey)
        ey = ey / np.sqrt(j2)[:, None]
        ez = np.cross(ex, ey)
        x_new = (rod2[0] - rod2[1] + d2) / np.sqrt(d2) * 0.5
        y_new = ((rod2[0] - rod2[2] + i * i + j2) * 0.5 - i * x_new) / np.sqrt(j2)
        with np.errstate(invalid="ignore"):
            z_new = np.sqrt(rod2[0] - (x_new**2 + y_new**2))
        origin = np.column_stack([np.broadcast_to(tower[0], (len(z), 2)), z[:, 0]])
        nozzle = origin + ex * x_new[:, None] + ey * y_new[:, None] - ez * z_new[:, None]
        bad = ~np.all(np.isfinite(nozzle), axis=1)
        if check and np.any(bad):
            k = bad.nonzero()[0]
            raise AssemblyError(f"{k.size} step triple(s) where Marlin's rods do not meet, first: "
                                f"{steps[k[0]].tolist()} (index {k[0]})", k, steps[k], float("nan"))
        return nozzle

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Deltacal's readings (steps × the printer's nominal ``step_distance``) for targets, (N, 3) [mm]."""
        return self.steps(targets, check) * step_distance

    def forward(self, readings: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """Nozzle positions at deltacal's readings (travels in the towers' ``step_distance``), (N, 3) [mm]."""
        return self.positions(np.atleast_2d(np.asarray(readings, dtype=float)) / step_distance, check)

    @cached_property
    def virtual(self) -> VirtualDelta:
        """Marlin's model as a prismatic :class:`VirtualDelta` whose readings are steps.

        Carriage point ``(X_i, Y_i, E_i)`` at the endstop, sliding down z by ``1 / M92_i`` per step,
        a point effector, rods ``L + trim_i``.
        """
        return point_effector(self.angle, self.towers, self.carriage_top, self.rods, self.step_distance)

    @property
    def home_position(self) -> np.ndarray:
        """Where ``G28`` leaves the nozzle: ``(0, 0, H − M851 Z)`` [mm], (3,)."""
        return np.array([0.0, 0.0, self.home_height])

    def outside(self, targets: np.ndarray) -> np.ndarray:
        """Which soft endstop each target breaks (Marlin would clamp it), (N,) integers: 0 none, else a code.

        :data:`BELOW_MIN_Z`, :data:`ABOVE_MAX_Z`, :data:`BEYOND_RADIUS` (the first that applies);
        all 0 with the soft endstops off (``M211 S0``).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        limits = self.soft_endstops
        if not limits.enabled:
            return np.zeros(len(targets), dtype=int)
        top = self.home_height if limits.maximum_z is None else limits.maximum_z
        radius = np.hypot(targets[:, 0], targets[:, 1])
        return np.select([targets[:, 2] < limits.minimum[2], targets[:, 2] > top, radius > limits.radius],
                         [BELOW_MIN_Z, ABOVE_MAX_Z, BEYOND_RADIUS], 0)

    def refusal(self, commands: np.ndarray) -> str:
        """What Marlin's soft endstops would clamp of commands, and what admits them (one line).

        Marlin does not refuse such a move: it clamps it to the soft endstops, silently (a first
        layer below Z 0 printed at Z 0); the message names the first command and the limit.
        """
        commands = np.atleast_2d(np.asarray(commands, dtype=float))
        codes = self.outside(commands)
        of = f" of {self.name}" if self.name else ""
        x, y, z = commands[0]
        limits = self.soft_endstops
        if codes[0] == BELOW_MIN_Z:
            lowest = float(np.min(commands[:, 2]))
            return (f"corrected Z {z:.4f} mm is below the soft endstop Min Z {limits.minimum[2]:g}{of} "
                    f"(lowest {lowest:.4f} mm): Marlin would clamp it; send M211 S0 (soft endstops off) "
                    "before the program (its first line M211 S0 does), or a firmware built with a lower "
                    "Z_MIN_POS")
        if codes[0] == ABOVE_MAX_Z:
            return (f"corrected Z {z:.4f} mm is above Marlin's top {self.home_height:g}{of}: lower the "
                    "program's moves")
        return (f"corrected point at radius {np.hypot(x, y):.4f} mm is beyond the soft endstops' radius "
                f"{limits.radius:g}{of}: Marlin would clamp it; bring the program nearer the centre")

    def with_soft_endstops(self, enabled: bool) -> MarlinDelta:
        """The same values with the soft endstops on (``M211 S1``) or off (``M211 S0``)."""
        return replace(self, soft_endstops=replace(self.soft_endstops, enabled=bool(enabled)))

    def with_minimum_z(self, minimum_z: float) -> MarlinDelta:
        """The same values with the soft endstops' Min Z = ``minimum_z`` [mm]."""
        limits = self.soft_endstops
        lowered = replace(limits, minimum=(limits.minimum[0], limits.minimum[1], float(minimum_z)))
        return replace(self, soft_endstops=lowered)


class MarlinController(FirmwareController[MarlinDelta]):
    """Marlin as a controller of a printer whose readings count steps in ``step_distance``.

    Marlin cuts a delta move into ``M665 S`` segments a second whose ends lie on the straight line
    (``motion.cpp``, ``line_to_destination_kinematic``); its home is ``(0, 0, H − M851 Z)``.

    Attributes:
        firmware: Marlin's model, from its settings.
        step_distance: The step distance each tower's readings count in [mm], (3,) (a number
            broadcasts): the printer's nominal ones.
    """
