"""Geometry of Savoure's planar parallelogram mechanism and its simplified model (Savoure 2006, Sec. III).

Conventions: see :mod:`deltacal.planar`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..exceptions import GeometryError, UnreachableError

#: Names of the complete model's parameters, order of Savoure Eq. 39/40/69.
PARAMETER_NAMES: tuple[str, ...] = ("q0", "a1x", "a2x", "a2y", "b1x", "b2x", "b2y", "l1", "l2")
#: Names of the simplified model's parameters (Eq. 38, 74).
SIMPLIFIED_NAMES: tuple[str, ...] = ("q0", "l")
#: Which parameters to keep when regrouping, so that the base is Savoure's Eq. 73:
#: ``[δq0, δa2x − δb2x, δa2y − δb2y, δb1x − δa1x, δl1, δl2]``.
PAPER_BASE_ORDER: tuple[str, ...] = ("q0", "a2x", "a2y", "b1x", "l1", "l2", "a1x", "b2x", "b2y")

#: Convergence threshold of the Pinocchio loop closure [mm].
LOOP_TOLERANCE = 1e-11


@dataclass(frozen=True)
class PlanarGeometry:
    """Geometry of the planar parallelogram mechanism (Savoure Fig. 3, Table 2).

    The defaults are Table 2's nominal values.

    Attributes:
        a1x: Base joint A1 at ``(-a1x, 0)`` [mm].
        a2x: x of base joint A2 [mm].
        a2y: y of base joint A2 [mm].
        b1x: Plate joint B1 at ``-b1x x_p`` from O_p [mm].
        b2x: Plate joint B2 along ``x_p`` from O_p [mm].
        b2y: Plate joint B2 along ``y_p`` from O_p [mm].
        l1: Length of rod A1B1 (the actuated one) [mm].
        l2: Length of rod A2B2 [mm].
        h: Tool length, C at ``-h y_p`` from O_p [mm].
        q0: Offset of the actuated joint: the rod angle is ``q + q0`` [rad].
    """

    a1x: float = 125.0
    a2x: float = 125.0
    a2y: float = 0.0
    b1x: float = 125.0
    b2x: float = 125.0
    b2y: float = 0.0
    l1: float = 950.0
    l2: float = 950.0
    h: float = 100.0
    q0: float = 0.0

    def __post_init__(self) -> None:
        for name in ("a1x", "a2x", "a2y", "b1x", "b2x", "b2y", "l1", "l2", "h", "q0"):
            value = getattr(self, name)
            if not np.isfinite(value):
                raise GeometryError(f"planar geometry: {name} = {value} is not finite")
        for name in ("l1", "l2"):
            if getattr(self, name) <= 0.0:
                raise GeometryError(f"planar geometry: rod length {name} = {getattr(self, name)} mm <= 0")
        if self.a1x + self.a2x <= 0.0 or self.b1x + self.b2x <= 0.0:
            raise GeometryError(
                "planar geometry: A1A2 and B1B2 must point along +x: "
                f"a1x + a2x = {self.a1x + self.a2x} mm, b1x + b2x = {self.b1x + self.b2x} mm"
            )

    def parameters(self) -> np.ndarray:
        """The parameter vector ``k_C`` in the order of Eq. 39 [rad, mm...], shape (9,)."""
        return np.array([getattr(self, name) for name in PARAMETER_NAMES])

    def perturbed(self, delta: Sequence[float] | np.ndarray) -> PlanarGeometry:
        """This geometry plus parameter errors ``δk_C`` (Eq. 40 order), h unchanged.

        Args:
            delta: Errors ``[δq0 [rad], δa1x, ..., δl2 [mm]]``, shape (9,).

        Returns:
            The perturbed geometry.
        """
        d = np.asarray(delta, dtype=float)
        if d.shape != (len(PARAMETER_NAMES),):
            raise ValueError(f"δk_C must have shape (9,), got {d.shape}")
        values = self.parameters() + d
        return replace(self, **{n: float(v) for n, v in zip(PARAMETER_NAMES, values, strict=True)})

    def with_tool(self, h: float) -> PlanarGeometry:
        """The same mechanism with another tool length h [mm]."""
        return replace(self, h=float(h))


def table2_errors() -> np.ndarray:
    """Parameter errors of Savoure Table 2, order of Eq. 40 [rad, mm...], shape (9,).

    ``δq0 = 0.01°, δa1x = 1, δa2x = 0, δa2y = 3, δb1x = 0, δb2x = -2, δb2y = 0,
    δl1 = 1, δl2 = -1 mm``.
    """
    return np.array([np.deg2rad(0.01), 1.0, 0.0, 3.0, 0.0, -2.0, 0.0, 1.0, -1.0])


def unit_vector(theta: np.ndarray) -> np.ndarray:
    """``u(theta) = (sin theta, -cos theta)`` (Eq. 61), shape ``theta.shape + (2,)``."""
    return np.stack([np.sin(theta), -np.cos(theta)], axis=-1)


def perpendicular(w: np.ndarray) -> np.ndarray:
    """``z × w`` for planar vectors ``w`` (shape ``S + (2,)``)."""
    return np.stack([-w[..., 1], w[..., 0]], axis=-1)


# --------------------------------------------------------------------------------------------
# Simplified (virtual bar) model, Eq. 34-38
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SimplifiedModel:
    """The simplified model: a bar of length l actuated at O_b (Savoure Fig. 3 right).

    The plate is assumed to translate only, so the tool C sits h below the bar's tip:
    ``C = (l sin(q + q0), -l cos(q + q0) - h)`` and ``alpha = 0``.

    Attributes:
        length: Bar length l [mm].
        q0: Offset of the actuated joint [rad].
        h: Tool length [mm].
    """

    length: float = 950.0
    q0: float = 0.0
    h: float = 100.0

    @classmethod
    def from_geometry(cls, geometry: PlanarGeometry) -> SimplifiedModel:
        """The simplified model of a (nominal) mechanism: ``l = l1`` (Eq. 59)."""
        return cls(length=geometry.l1, q0=geometry.q0, h=geometry.h)

    def forward(self, q: np.ndarray | float) -> np.ndarray:
        """FPR_S, Eq. 34: ``x = l sin(q + q0)`` [mm], shape of q."""
        return self.length * np.sin(np.asarray(q, dtype=float) + self.q0)

    def forward_pose(self, q: np.ndarray | float) -> np.ndarray:
        """Pose ``(x, y, alpha)`` of the tool by the simplified model [mm, mm, rad].

        Eq. 34 for x; the same bar gives y; alpha is 0. Shape ``q.shape + (3,)``.
        """
        theta = np.asarray(q, dtype=float) + self.q0
        return np.stack(
            [self.length * np.sin(theta), -self.length * np.cos(theta) - self.h, np.zeros_like(theta)],
            axis=-1,
        )

    def inverse(self, x: np.ndarray | float) -> np.ndarray:
        """IPR_S, Eq. 35: ``q = arcsin(x / l) - q0`` [rad], shape of x.

        Raises:
            UnreachableError: If ``|x| > l``.
        """
        x = np.asarray(x, dtype=float)
        ratio = x / self.length
        bad = np.flatnonzero(np.abs(ratio) > 1.0)
        if bad.size:
            raise UnreachableError(
                f"{bad.size} target(s) beyond the bar length l = {self.length} mm, first x = "
                f"{np.ravel(x)[bad[0]]} mm",
                indices=bad,
                targets=np.ravel(x)[bad],
            )
        return np.arcsin(ratio) - self.q0

    def jacobian(self, q: np.ndarray | float) -> np.ndarray:
        """J_S, Eq. 36: ``dx/dq = l cos(q + q0)`` [mm/rad], shape of q."""
        return self.length * np.cos(np.asarray(q, dtype=float) + self.q0)

    def inverse_jacobian(self, q: np.ndarray | float) -> np.ndarray:
        """J_S^m, Eq. 37: ``dq/dx = 1 / (l cos(q + q0))`` [rad/mm], shape of q."""
        return 1.0 / self.jacobian(q)

    def sensitivity(self, q: np.ndarray | float) -> np.ndarray:
        """S_S: pose errors per ``[δq0, δl]``, shape ``q.shape + (3, 2)``.

        Row x is Eq. 38 ``[l cos(q + q0), sin(q + q0)]``; row y is the same
        derivative of ``y = -l cos(q + q0) - h``; row alpha is zero.
        """
        theta = np.asarray(q, dtype=float) + self.q0
        out = np.zeros(theta.shape + (3, 2))
        out[..., 0, 0] = self.length * np.cos(theta)
        out[..., 0, 1] = np.sin(theta)
        out[..., 1, 0] = self.length * np.sin(theta)
        out[..., 1, 1] = -np.cos(theta)
        return out

    def corrected(self, delta: Sequence[float] | np.ndarray) -> SimplifiedModel:
        """The model with ``[δq0 [rad], δl [mm]]`` added."""
        d = np.asarray(delta, dtype=float)
        return replace(self, q0=self.q0 + float(d[0]), length=self.length + float(d[1]))


# --------------------------------------------------------------------------------------------
# Complete model: closed-form forward position relationship, Eq. 41-52
