"""The options of an identification: one frozen value, checked once.

:func:`~deltacal.identification.identify`, :func:`~deltacal.identification.fit`, the command
line and the poor-fit review (:func:`~deltacal.identification.quality.readings`) share it; each
option is checked here and nowhere else. :class:`FitOverrides` types the keyword arguments
that :func:`~deltacal.identification.identify` and :func:`~deltacal.identification.fit` take for
its fields (:func:`fit_options` applies them).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Literal, TypedDict, get_args

from ..observations import SIGMA_ANGLE, SIGMA_POSITION
from ..options import require_bool, require_count, require_names, require_positive, with_overrides

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
        TypeError: a switch that is not a bool, or free points that are not a sequence of names.
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
        object.__setattr__(self, "free_points", require_names("free_points", self.free_points))
        for name in ("distances", "accept_poor_fit", "axes_gauge", "compliance"):
            object.__setattr__(self, name, require_bool(name, getattr(self, name)))
        for name, allowed in (("method", Method), ("frame", Frame), ("pairs", Pairs)):
            value = getattr(self, name)
            if value not in get_args(allowed):
                raise ValueError(f"{name} must be one of {get_args(allowed)}, got {value!r}")
        for name in ("sigma_position", "sigma_angle", "rtol"):
            require_positive(name, getattr(self, name))
        require_count("max_iter", self.max_iter)
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


class FitOverrides(TypedDict, total=False):
    """The fields of :class:`FitOptions` as keyword arguments (see there), each optional."""

    method: Method
    sigma_position: float
    sigma_angle: float
    distances: bool
    pairs: Pairs
    rtol: float
    max_iter: int
    frame: Frame
    free_points: Sequence[str]
    accept_poor_fit: bool
    axes_gauge: bool
    compliance: bool


def fit_options(options: FitOptions | None, overrides: Mapping[str, object]) -> FitOptions:
    """The options of a fit: ``options`` (default: :class:`FitOptions`) with ``overrides`` applied once.

    Raises:
        TypeError: ``options`` is not a :class:`FitOptions`, or an override names none of its fields.
        ValueError: a value out of its range, or options that do not go together.
    """
    return with_overrides(FitOptions, options, overrides)
