"""Klipper's rotary Delta (``kinematics: rotary_delta``) as the controller of a rotary Delta's readings.

Klipper takes the nozzle's coordinates in its frame (the bed's: what G-code holds) and commands each
arm the angle θ_i of its inverse kinematics (:meth:`~.rotary_model.KlipperRotaryDelta.shoulder_angles`,
``kin_rotary_delta.c``); deltacal's reading of that arm is ``q = −θ`` (:mod:`.rotary_model`).
:class:`KlipperRotaryController` pairs the two so that Klipper serves
:func:`~deltacal.controller.corrected_targets` and the G-code route as a rotary
:class:`~deltacal.controller.Controller` does: forward and inverse in deltacal's readings [rad], its
virtual model the revolute chain of Klipper's values (a point effector: no tool), its home where
homing leaves the nozzle, its limits Klipper's move checks.

Its frame is Klipper's, not a rotary robot's base frame {O} (the shoulders' centre): a rotary
robot's geometry is put in it by :meth:`KlipperRotaryController.in_bed_frame`, moved up by
``shoulder_height`` + the robot's nozzle drop (the bed at ``z = −(H + h)`` in {O}, as ``deltacal
import`` writes the robot file). Units: mm and rad.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ....geometry import DeltaGeometry, NominalDelta
from ....kinematics.closed_form import VirtualDelta
from ...files.same_printer import LENGTH_RTOL, STEP_DISTANCE_RTOL, check_same_values
from ..controller import NozzleCommands, RotaryFirmwareController
from .rotary_model import KlipperRotaryDelta


@dataclass(frozen=True, eq=False)
class KlipperRotaryController(NozzleCommands):
    """Klipper's rotary_delta model as a :class:`~deltacal.controller.targets.CommandModel`.

    Attributes:
        firmware: Klipper's model, from its configuration.
    """

    firmware: KlipperRotaryDelta

    @property
    def virtual(self) -> VirtualDelta:
        """Klipper's model as a revolute :class:`VirtualDelta` in its frame, readings ``q = −θ``."""
        return self.firmware.virtual

    @property
    def reach_radius(self) -> float:
        """Klipper's ``max_xy`` [mm] (:attr:`~.rotary_model.KlipperRotaryDelta.max_radius`)."""
        return self.firmware.max_radius

    def values_read(self) -> dict[str, float]:
        """Klipper's rotary values by ``section.key`` (angles in deg, step distances in rad per step)."""
        k = self.firmware
        values = {"printer.shoulder_radius": float(k.shoulder_radius),
                  "printer.shoulder_height": float(k.shoulder_height)}
        for i, arm in enumerate("abc"):
            values |= {f"stepper_{arm}.angle": float(np.degrees(k.angle[i])),
                       f"stepper_{arm}.upper_arm_length": float(k.upper_arm[i]),
                       f"stepper_{arm}.lower_arm_length": float(k.lower_arm[i]),
                       f"stepper_{arm}.position_endstop": float(k.position_endstop[i]),
                       f"stepper_{arm}.step_distance": float(k.step_distance[i])}
        return values

    def with_values(self, values: Mapping[str, float]) -> KlipperRotaryController:
        """Klipper's rotary model with the values given by ``section.key`` (:meth:`values_read`'s), else ours.

        Its limits (``minimum_z_position``) and name are this configuration's.
        """
        k = self.firmware

        def arms(key: str, now: np.ndarray, unit: float = 1.0) -> np.ndarray:
            return np.array([values.get(f"stepper_{arm}.{key}", now[i] / unit) * unit
                             for i, arm in enumerate("abc")])

        return KlipperRotaryController(replace(
            k, shoulder_radius=float(values.get("printer.shoulder_radius", k.shoulder_radius)),
            shoulder_height=float(values.get("printer.shoulder_height", k.shoulder_height)),
            angle=arms("angle", k.angle, math.pi / 180.0), upper_arm=arms("upper_arm_length", k.upper_arm),
            lower_arm=arms("lower_arm_length", k.lower_arm),
            position_endstop=arms("position_endstop", k.position_endstop),
            step_distance=arms("step_distance", k.step_distance)))

    def recounted(self, readings: np.ndarray, counted_by: RotaryFirmwareController) -> np.ndarray:
        """The readings these values count where ``counted_by``'s count ``readings``: the same steps [rad].

        An arm's steps from its endstop are what it did (``(θ_end − θ) / d``, ``θ = −q``); each set of
        values counts them from its own endstop angle in its own step angle: ``q' = n d' − θ'_end``.
        """
        other = counted_by.firmware
        assert isinstance(other, KlipperRotaryDelta)  # the recorded values are Klipper's (its record's)
        steps = (other.endstop_angles + np.asarray(readings, dtype=float)) / other.step_distance
        return steps * self.firmware.step_distance - self.firmware.endstop_angles

    def check_same_values(self, other: RotaryFirmwareController, other_source: str, source: str) -> None:
        """Refuse ``other``'s values (``other_source``'s) of another printer than these (``source``'s).

        Each length within :data:`~...files.same_printer.LENGTH_RTOL` of these (as
        :meth:`check_same_printer`), each arm's step angle within
        :data:`~...files.same_printer.STEP_DISTANCE_RTOL` (a gear ratio).

        Raises:
            InputError: one line naming the value (Klipper's key), both sources and both values.
        """
        k = other.firmware
        assert isinstance(k, KlipperRotaryDelta)
        self._check_lengths(k.shoulder_radius, k.upper_arm, k.lower_arm, other_source, source)
        check_same_values("step_distance", k.step_distance, self.firmware.step_distance,
                          STEP_DISTANCE_RTOL * k.step_distance, other_source, source, unit="rad", part="arm")

    def _check_lengths(self, radius: float, upper: np.ndarray, lower: np.ndarray, our_source: str,
                       their_source: str) -> None:
        """Refuse a shoulder radius or arms (``our_source``'s) beyond a build's from these values'."""
        k = self.firmware
        check_same_values("shoulder_radius", np.array(radius), np.array(k.shoulder_radius),
                          LENGTH_RTOL * radius, our_source, their_source)
        for key, ours, theirs in (("upper_arm_length", upper, k.upper_arm),
                                  ("lower_arm_length", lower, k.lower_arm)):
            check_same_values(key, np.broadcast_to(ours, (3,)), theirs, LENGTH_RTOL * np.asarray(ours),
                              our_source, their_source, part="arm")

    def check_same_printer(self, robot: NominalDelta, our_source: str, their_source: str) -> None:
        """Refuse a rotary robot file of another printer than these values, naming the first value apart.

        The robot file ``deltacal import`` writes of a configuration holds its shoulder radius (its
        ``base_radius_mm`` less its ``plate_radius_mm``) and its arms (``arm_length_mm``, ``rod_length_mm``):
        each within :data:`~...files.same_printer.LENGTH_RTOL` of the configuration's, as a linear
        printer's radius and arms are checked.

        Raises:
            InputError: one line naming the value (Klipper's key), both files and both values.
        """
        self._check_lengths(robot.base_radius - robot.plate_radius, np.full(3, robot.arm_length),
                            np.full(3, robot.rod_length), our_source, their_source)

    def inverse(self, targets: np.ndarray, check: bool = True) -> np.ndarray:
        """The readings ``q = −θ`` Klipper commands for nozzle targets [mm], (N, 3) -> (N, 3) [rad]."""
        return self.firmware.inverse(targets, check)

    def forward(self, readings: np.ndarray, check: bool = True) -> np.ndarray:
        """The nozzle position Klipper's model puts at readings [rad], (N, 3) -> (N, 3) [mm]."""
        return self.firmware.forward(readings, check)

    def bed_height(self, geometry: DeltaGeometry) -> float:
        """How far Klipper's bed is below a rotary robot's {O}: ``shoulder_height`` + its nozzle drop [mm]."""
        return self.firmware.base_height(-float(geometry.tool[2]))

    def in_bed_frame(self, geometry: DeltaGeometry,
                     nozzle_drop_of: DeltaGeometry | None = None) -> DeltaGeometry:
        """A rotary robot's geometry moved from its {O} into Klipper's frame (up by :meth:`bed_height`).

        Args:
            geometry: The robot in {O}.
            nozzle_drop_of: The robot whose nozzle drop places the bed (a calibration's nominal robot,
                the one it was identified from); by default ``geometry`` itself.
        """
        lift = self.bed_height(geometry if nozzle_drop_of is None else nozzle_drop_of)
        return geometry.moved_rigidly(np.eye(3), np.array([0.0, 0.0, lift]))
