"""The options of an identification: one frozen value, checked once.

:func:`~deltacal.identification.identify`, the command line and the poor-fit review
(:func:`~deltacal.identification.quality.readings`) share it; each option is checked here
and nowhere else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal, get_args

from ..observations import SIGMA_ANGLE, SIGMA_POSITION

Method = Literal["linear", "iterated"]
Frame = Literal["base", "free"]
Pairs = Literal["all", "reference"]


@dataclass(frozen=True)
class FitOptions:
    """How to fit a geometry to measurements.

    Attributes:
        method: ``"iterated"`` (Gauss-Newton with the exact kinematics, step halving) or
            ``"linear"`` (one shot around the start, as in the papers).
        sigma_position: σ of each measured coordinate [mm].
        sigma_angle: σ of each measured orientation component [rad].
        distances: Identify from distances between positions of a same point (Bai Eq. 12).
        pairs: ``"all"`` pairs or pairs with the ``"reference"`` (first) pose (with distances).
        rtol: Rank tolerance relative to the largest scaled pivot.
        max_iter: Iterations at most for ``"iterated"``.
        frame: ``"base"``: the measurements are in the robot base frame {O}; ``"free"``: each
            station's instrument frame is identified with the geometry.
        free_points: Measured plate points whose position on the plate is identified too.
        accept_poor_fit: Return a poor fit instead of raising :class:`~deltacal.PoorFitError`.
        axes_gauge: With free frames, move the identified robot (and the frames) to the gauge
            where its actuator axes have no net rigid motion; False keeps the model's own gauge.
        compliance: Identify the actuators' compliances c1..c3 too (three more columns: the
            measured point's sensitivity to θ_i times the gravity torque tau_i; the start's
            masses and the measurements' payloads give the torques).

    Raises:
        ValueError: an option out of its range, or two that do not go together (the message
            names the fields and values).
    """

    method: Method = "iterated"
    sigma_position: float = SIGMA_POSITION
    sigma_angle: float = SIGMA_ANGLE
    distances: bool = False
    pairs: Pairs = "all"
    rtol: float = 1e-8
    max_iter: int = 30
    frame: Frame = "base"
    free_points: tuple[str, ...] = ()
    accept_poor_fit: bool = False
    axes_gauge: bool = True
    compliance: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "free_points", tuple(dict.fromkeys(self.free_points)))
        for name, allowed in (("method", Method), ("frame", Frame), ("pairs", Pairs)):
            value = getattr(self, name)
            if value not in get_args(allowed):
                raise ValueError(f"{name} must be one of {get_args(allowed)}, got {value!r}")
        for name in ("sigma_position", "sigma_angle", "rtol"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, int) or self.max_iter < 1:
            raise ValueError(f"max_iter must be a positive integer, got {self.max_iter!r}")
        if self.distances and self.free_points:
            raise ValueError(
                f"free_points={self.free_points!r} applies to positions and poses, not to distances=True"
            )
        if self.distances and self.compliance:
            raise ValueError("compliance=True applies to positions and poses, not to distances=True")
        if self.distances and self.frame == "free":
            raise ValueError(
                "frame='free' applies to positions and poses: distances=True do not depend on the frame"
            )

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The options' names (the keyword arguments :func:`identify` takes for them)."""
        return tuple(f.name for f in fields(cls))
