"""Build tolerances: the σ of each kind of geometric error of a Delta before any measurement.

What a fit's prior is made of (each error model's ``prior_sigma``) and what simulated robots are
perturbed by (:meth:`~deltacal.geometry.DeltaGeometry.perturbed`). Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    """Standard deviations of the manufacturing errors of each class.

    Every error of a class is drawn independently from a normal law of this
    standard deviation (per coordinate for points).

    Attributes:
        ball_centre: Ball centres in their body (arm or plate), per coordinate [mm].
        rod_length: Rod lengths [mm].
        axis_position: Actuator axis point, per coordinate [mm].
        axis_direction: Actuator axis direction, each of its two tilts [rad].
        encoder_offset: Encoder zero [rad] (a prismatic chain's endstop [mm]).
        tool: TCP in the plate frame, per coordinate [mm] (0: the tool is known).
        joint_scale: Relative error of a printer's step distance or step angle (the scale's
            deviation from 1); a rotary robot's readings have none.
    """

    ball_centre: float = 0.05
    rod_length: float = 0.05
    axis_position: float = 0.2
    axis_direction: float = math.radians(0.05)
    encoder_offset: float = math.radians(0.3)
    tool: float = 0.0
    joint_scale: float = 0.0

    @classmethod
    def printer_kit(cls) -> Tolerances:
        """Errors of a typical linear Delta printer kit.

        Towers placed to 0.3 mm and leaning 0.15 deg, endstops to 0.5 mm, step distances to
        0.3 %, balls to 0.05 mm and rods to 0.1 mm (the two rods of a pair differ).
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.3,
            axis_direction=math.radians(0.15),
            encoder_offset=0.5,
            joint_scale=0.003,
        )

    @classmethod
    def rotary_printer_kit(cls) -> Tolerances:
        """Errors of a typical rotary Delta printer kit (the prior of its fit).

        Shoulder axes placed to 0.2 mm and turned 0.1 deg, endstops to 0.3 deg, the arms' gear
        ratios (their step angles) to 0.2 %, balls to 0.05 mm and rods to 0.1 mm.
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.2,
            axis_direction=math.radians(0.1),
            encoder_offset=math.radians(0.3),
            joint_scale=0.002,
        )

    @classmethod
    def bai2015(cls) -> Tolerances:
        """Errors of the size Bai et al. identified on their prototype (Tables 2-4).

        Encoder offsets about 1 deg (Table 2), actuator positions and lengths about
        0.1-0.3 mm, axis tilts about ``0.8 mm / L`` (Table 3), ball-pair
        discrepancies about 0.05 mm and pair misalignments about 0.2 mm / c (Table 4).
        """
        return cls(
            ball_centre=0.05,
            rod_length=0.1,
            axis_position=0.15,
            axis_direction=math.radians(0.1),
            encoder_offset=math.radians(1.0),
        )
