"""The options of a D-optimal selection: one frozen value, checked once.

:func:`~deltacal.planning.d_optimal` and its helpers share it; each option is checked here and
nowhere else. :class:`PlanOverrides` types the keyword arguments that
:func:`~deltacal.planning.d_optimal` takes for its fields (:func:`plan_options` applies them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Literal, TypedDict, get_args

import numpy as np

from ..kinematics.singularity import SingularityMargin
from ..observations import SIGMA_ANGLE, SIGMA_POSITION
from ..options import require_count, require_names, require_positive, with_overrides

#: Measurements whose regressor rows add up pose by pose (distance rows pair poses).
PoseMeasurement = Literal["pose", "position"]


@dataclass(frozen=True)
class PlanOptions:
    """How to select poses D-optimally (:func:`~deltacal.planning.d_optimal`).

    Attributes:
        pool_size: Candidates drawn when no pool is given.
        measurement: ``"pose"`` or ``"position"`` (distance rows are not additive per pose).
        points: Plate points measured (None: :func:`~deltacal.planning.default_points`).
        margin: Singularity margin of the drawn pool (None:
            :data:`~deltacal.kinematics.singularity.PLANNING_MARGIN`).
        tool: TCP of the targets [mm], (3,) (None: the robot file's; see :mod:`deltacal.planning`).
        sigma_position: σ of a position coordinate [mm].
        sigma_angle: σ of an orientation component [rad].
        max_passes: Exchange passes at most (0: the greedy selection alone).
        payloads: Plan for the actuators' compliances too [kg]: every pose measured at each
            payload (``simulate --payload``); the base parameters then hold c1..c3 where the
            gravity torques (the robot's masses, the payloads) separate them.

    Raises:
        ValueError: an option out of its range (the message names the field and value).
        TypeError: points that are not a sequence of names, a margin that is not a
            :class:`~deltacal.kinematics.singularity.SingularityMargin`.
    """

    pool_size: int = 1000
    measurement: PoseMeasurement = "pose"
    points: tuple[str, ...] | None = None
    margin: SingularityMargin | None = None
    tool: tuple[float, float, float] | None = None
    sigma_position: float = SIGMA_POSITION
    sigma_angle: float = SIGMA_ANGLE
    max_passes: int = 10
    payloads: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        require_count("pool_size", self.pool_size)
        if self.measurement not in get_args(PoseMeasurement):
            raise ValueError("measurement: per-pose blocks exist for pose or position measurements, "
                             f"not {self.measurement!r}")
        if self.points is not None:
            object.__setattr__(self, "points", require_names("points", self.points))
        if self.margin is not None and not isinstance(self.margin, SingularityMargin):
            raise TypeError(f"margin must be a SingularityMargin, got {self.margin!r}")
        if self.tool is not None:
            tool = np.asarray(self.tool, dtype=float)
            if tool.shape != (3,) or not np.all(np.isfinite(tool)):
                raise ValueError(f"tool must be 3 finite coordinates [mm], got {self.tool!r}")
            object.__setattr__(self, "tool", (float(tool[0]), float(tool[1]), float(tool[2])))
        for name in ("sigma_position", "sigma_angle"):
            require_positive(name, getattr(self, name))
        if isinstance(self.max_passes, bool) or not isinstance(self.max_passes, int) or self.max_passes < 0:
            raise ValueError(f"max_passes must be a non-negative integer, got {self.max_passes!r}")
        try:
            payloads = tuple(float(p) for p in self.payloads)
        except (TypeError, ValueError):
            payloads = (math.nan,)
        if not all(math.isfinite(p) for p in payloads):
            raise ValueError(f"payloads must be finite masses [kg], got {self.payloads!r}")
        object.__setattr__(self, "payloads", payloads)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The options' names (the keyword arguments :func:`~deltacal.planning.d_optimal` takes)."""
        return tuple(f.name for f in fields(cls))

    @property
    def tool_array(self) -> np.ndarray | None:
        """:attr:`tool` as an array [mm], (3,), or None."""
        return None if self.tool is None else np.array(self.tool)


class PlanOverrides(TypedDict, total=False):
    """The fields of :class:`PlanOptions` as keyword arguments (see there), each optional."""

    pool_size: int
    measurement: PoseMeasurement
    points: Sequence[str] | None
    margin: SingularityMargin | None
    tool: Sequence[float] | np.ndarray | None
    sigma_position: float
    sigma_angle: float
    max_passes: int
    payloads: Sequence[float]


def plan_options(options: PlanOptions | None, overrides: Mapping[str, object]) -> PlanOptions:
    """The options of a selection: ``options`` (default: :class:`PlanOptions`), ``overrides`` applied once.

    Raises:
        TypeError: ``options`` is not a :class:`PlanOptions`, or an override names none of its fields.
        ValueError: a value out of its range.
    """
    return with_overrides(PlanOptions, options, overrides)
