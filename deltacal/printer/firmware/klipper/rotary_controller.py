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

from dataclasses import dataclass

import numpy as np

from ....geometry import DeltaGeometry, NominalDelta
from ....kinematics.closed_form import VirtualDelta
from ...files.same_printer import LENGTH_RTOL, check_same_values
from ..controller import NozzleCommands
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

    def check_same_printer(self, robot: NominalDelta, our_source: str, their_source: str) -> None:
        """Refuse a rotary robot file of another printer than these values, naming the first value apart.

        The robot file ``deltacal import`` writes of a configuration holds its shoulder radius (its
        ``base_radius_mm`` less its ``plate_radius_mm``) and its arms (``arm_length_mm``, ``rod_length_mm``):
        each within :data:`~...files.same_printer.LENGTH_RTOL` of the configuration's, as a linear
        printer's radius and arms are checked.

        Raises:
            InputError: one line naming the value (Klipper's key), both files and both values.
        """
        k = self.firmware
        radius = robot.base_radius - robot.plate_radius
        check_same_values("shoulder_radius", np.array(radius), np.array(k.shoulder_radius),
                          LENGTH_RTOL * radius, our_source, their_source)
        for key, ours, theirs in (("upper_arm_length", robot.arm_length, k.upper_arm),
                                  ("lower_arm_length", robot.rod_length, k.lower_arm)):
            check_same_values(key, np.full(3, ours), theirs, LENGTH_RTOL * ours, our_source, their_source,
                              part="arm")

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
