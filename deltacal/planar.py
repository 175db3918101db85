"""Savoure's planar 1-dof parallelogram mechanism (Savoure et al. 2006, Sec. III).

A small mechanism that has the property of the Delta robot's parallelograms that
matters for calibration: when the four joint centres do not form a true
parallelogram the travelling plate rotates, and a tool at a distance ``h`` from
the plate turns that rotation into a position error that the classical
(virtual bar) model cannot represent.

Frames and conventions (Savoure Fig. 3, Sec. III-A-2), units mm and rad:

* Base frame R_b (O_b, x_b, y_b): ``A1 = (-a1x, 0)`` and ``A2 = (a2x, a2y)``.
* Plate frame R_p (O_p, x_p, y_p), at angle ``alpha`` from R_b:
  ``O_p B1 = -b1x x_p``, ``O_p B2 = b2x x_p + b2y y_p`` and the tool centre point
  ``O_p C = -h y_p``.
* Rod i joins A_i to B_i, of length l_i. The actuated joint at A1 sets the
  angle ``theta = q + q0`` from ``-y_b`` to ``A1B1``: ``A1B1 = l1 u(theta)`` with
  ``u(theta) = (sin theta, -cos theta)`` (Eq. 61). ``phi`` is the same angle for
  rod 2. The nominal mechanism hangs down: ``q > 0`` moves C towards ``+x_b``.
* Parameter order (Eq. 39, 40, 69): ``k_C = [q0 | a1x a2x a2y | b1x b2x b2y | l1 l2]``.
  The tool length h is not identified (Savoure: it is a metrology problem).

The simplified model is a single bar of length l actuated at O_b (Fig. 3, right).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin
import scipy.linalg

from .exceptions import (
    AssemblyError,
    ConvergenceError,
    GeometryError,
    IdentificationError,
    UnreachableError,
)
from .identifiability import BaseParameters, base_parameters

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


def _unit(theta: np.ndarray) -> np.ndarray:
    """``u(theta) = (sin theta, -cos theta)`` (Eq. 61), shape ``theta.shape + (2,)``."""
    return np.stack([np.sin(theta), -np.cos(theta)], axis=-1)


def _perp(w: np.ndarray) -> np.ndarray:
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
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PlanarConfiguration:
    """Assembled configurations of the mechanism, in the base frame.

    Attributes:
        theta: Angle of rod 1, ``q + q0`` [rad], shape S.
        phi: Angle of rod 2 from ``-y_b`` [rad], shape S.
        alpha: Plate angle [rad], shape S.
        a1: Base joint A1 [mm], shape S + (2,).
        a2: Base joint A2 [mm], shape S + (2,).
        b1: Plate joint B1 [mm], shape S + (2,).
        b2: Plate joint B2 [mm], shape S + (2,).
        c: Tool centre point C [mm], shape S + (2,).
    """

    theta: np.ndarray
    phi: np.ndarray
    alpha: np.ndarray
    a1: np.ndarray
    a2: np.ndarray
    b1: np.ndarray
    b2: np.ndarray
    c: np.ndarray

    def pose(self) -> np.ndarray:
        """Tool pose ``(x, y, alpha)`` [mm, mm, rad], shape S + (3,)."""
        return np.concatenate([self.c, self.alpha[..., None]], axis=-1)


def configuration(q: np.ndarray | float, geometry: PlanarGeometry) -> PlanarConfiguration:
    """Complete forward position relationship in closed form (Savoure Eq. 41-52).

    Subtracting the loop closures (42) and (43) gives (44)-(48)::

        sin(phi) = E + F cos(alpha) + G sin(alpha)
        cos(phi) = E' + G cos(alpha) - F sin(alpha)

    with ``E = (l1 sin(theta) - (a1x + a2x)) / l2``, ``E' = (l1 cos(theta) + a2y) / l2``,
    ``F = (b1x + b2x) / l2`` and ``G = -b2y / l2``. Eliminating phi gives (50)
    ``E' sin(alpha + gamma_p) - E cos(alpha + gamma_p) = I`` with (51)
    ``I = (l_b^2 + l_p^2 + l1^2 - l2^2 + 2 l_b l1 sin(gamma_b - theta)) / (2 l_p l2)``,
    solved by (52) on the branch of the (uncrossed) parallelogram, and (42) gives C.

    Args:
        q: Joint readings [rad], any shape S.
        geometry: The mechanism.

    Returns:
        The assembled configurations.

    Raises:
        AssemblyError: If the loop cannot close at some readings.
    """
    g = geometry
    q = np.asarray(q, dtype=float)
    theta = q + g.q0
    E = (g.l1 * np.sin(theta) - (g.a1x + g.a2x)) / g.l2  # Eq. 46
    Ep = (g.l1 * np.cos(theta) + g.a2y) / g.l2  # Eq. 47
    l_b = np.hypot(g.a1x + g.a2x, g.a2y)
    gamma_b = np.arctan2(g.a2y, g.a1x + g.a2x)
    l_p = np.hypot(g.b1x + g.b2x, g.b2y)
    gamma_p = np.arctan2(g.b2y, g.b1x + g.b2x)
    numerator = l_b**2 + l_p**2 + g.l1**2 - g.l2**2 + 2.0 * l_b * g.l1 * np.sin(gamma_b - theta)
    I = numerator / (2.0 * l_p * g.l2)  # noqa: E741 (the I of Eq. 51)
    disc = E**2 + Ep**2 - I**2
    bad = np.flatnonzero(np.ravel(disc) < 0.0)
    if bad.size:
        raise AssemblyError(
            f"the planar loop does not close at {bad.size} reading(s), first q = {np.ravel(q)[bad[0]]} rad",
            indices=bad,
            readings=np.ravel(q)[bad],
        )
    root = np.sqrt(disc)
    # Eq. 52: beta = alpha + gamma_p; the + root is the branch through alpha = 0 for the
    # nominal mechanism (the other one is the crossed parallelogram).
    alpha = np.arctan2(Ep * I + E * root, Ep * root - E * I) - gamma_p
    x_p = np.stack([np.cos(alpha), np.sin(alpha)], axis=-1)
    y_p = _perp(x_p)
    shape = theta.shape + (2,)
    a1 = np.broadcast_to(np.array([-g.a1x, 0.0]), shape).copy()
    a2 = np.broadcast_to(np.array([g.a2x, g.a2y]), shape).copy()
    b1 = a1 + g.l1 * _unit(theta)
    o_p = b1 + g.b1x * x_p  # Eq. 42
    c = o_p - g.h * y_p
    b2 = o_p + g.b2x * x_p + g.b2y * y_p
    rod2 = b2 - a2
    phi = np.arctan2(rod2[..., 0], -rod2[..., 1])
    return PlanarConfiguration(theta=theta, phi=phi, alpha=alpha, a1=a1, a2=a2, b1=b1, b2=b2, c=c)


def forward_position(q: np.ndarray | float, geometry: PlanarGeometry) -> np.ndarray:
    """Complete FPR_C (Eq. 41-52): tool pose ``(x, y, alpha)`` [mm, mm, rad].

    Args:
        q: Joint readings [rad], any shape S.
        geometry: The mechanism.

    Returns:
        Poses, shape S + (3,).
    """
    return configuration(q, geometry).pose()


# --------------------------------------------------------------------------------------------
# Complete sensitivity, Eq. 56-69
# --------------------------------------------------------------------------------------------


def calibration_jacobians(q: np.ndarray | float, geometry: PlanarGeometry) -> tuple[np.ndarray, np.ndarray]:
    """The matrices of ``J_X δX = J_kC δk_C`` (Savoure Eq. 56-65) at the true configuration.

    The three relations (56) are the differentials of ``|A1B1| = l1``,
    ``|A2B2| = l2`` and of the direction of rod 1, ``v1 · A1B1 = 0`` with
    ``v1 = du/dtheta``, whose differential is ``v1 · (δB1 - δA1) = l1 δq0`` (55).
    With ``n_i = A_iB_i / l_i`` and ``δB_i = δx + δalpha z × (B_i - C) + δb_i`` (57)::

        J_X  = [[n1,  n1 · z×(B1 - C)],            J_kC rows on [δq0 δa1x δa2x δa2y δb1x δb2x δb2y δl1 δl2]:
                [n2,  n2 · z×(B2 - C)],            [0,   -n1x, 0,   0,   n1·x_p, 0,       0,       1, 0]
                [v1,  v1 · z×(B1 - C)]]            [0,   0,    n2x, n2y, 0,      -n2·x_p, -n2·y_p, 0, 1]
                                                   [l1,  -v1x, 0,   0,   v1·x_p, 0,       0,       0, 0]

    For the nominal mechanism ``n1 = n2 = u``, ``v1 = (-v, u)`` and this is Eq. 64-65,
    except for the third row of J_kC: the paper prints ``[-l, 0, 0, 0, -v, ...]`` while
    the differential of (55) gives ``+l1`` for δq0 (consistent with Eq. 38) and ``v``
    for δa1x (the paper's (56) omits δA1 in the third relation). Without that term
    δa1x would be identifiable on its own, contradicting Eq. 72.

    Args:
        q: Joint readings [rad], any shape S.
        geometry: The mechanism at which to linearise.

    Returns:
        ``(J_X, J_kC)`` of shapes S + (3, 3) and S + (3, 9).
    """
    cfg = configuration(q, geometry)
    n1 = (cfg.b1 - cfg.a1) / geometry.l1
    n2 = (cfg.b2 - cfg.a2) / geometry.l2
    u1 = _unit(cfg.theta)
    v1 = _perp(u1)  # du/dtheta = (cos theta, sin theta)
    x_p = np.stack([np.cos(cfg.alpha), np.sin(cfg.alpha)], axis=-1)
    y_p = _perp(x_p)
    rot1 = _perp(cfg.b1 - cfg.c)  # dB1/dalpha with C fixed
    rot2 = _perp(cfg.b2 - cfg.c)

    def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.einsum("...k,...k->...", a, b)

    shape = cfg.theta.shape
    J_X = np.zeros(shape + (3, 3))
    J_X[..., 0, :2] = n1
    J_X[..., 0, 2] = dot(n1, rot1)
    J_X[..., 1, :2] = n2
    J_X[..., 1, 2] = dot(n2, rot2)
    J_X[..., 2, :2] = v1
    J_X[..., 2, 2] = dot(v1, rot1)

    J_k = np.zeros(shape + (3, 9))
    # Row 1: n1 · (δB1 - δA1) = δl1, with δA1 = (-δa1x, 0), δB1 ∋ -δb1x x_p.
    J_k[..., 0, 1] = -n1[..., 0]
    J_k[..., 0, 4] = dot(n1, x_p)
    J_k[..., 0, 7] = 1.0
    # Row 2: n2 · (δB2 - δA2) = δl2, with δA2 = (δa2x, δa2y), δB2 ∋ δb2x x_p + δb2y y_p.
    J_k[..., 1, 2] = n2[..., 0]
    J_k[..., 1, 3] = n2[..., 1]
    J_k[..., 1, 5] = -dot(n2, x_p)
    J_k[..., 1, 6] = -dot(n2, y_p)
    J_k[..., 1, 8] = 1.0
    # Row 3: v1 · (δB1 - δA1) = (u1 · A1B1) δq0, and u1 · A1B1 = l1 once assembled.
    J_k[..., 2, 0] = dot(u1, cfg.b1 - cfg.a1)
    J_k[..., 2, 1] = -v1[..., 0]
    J_k[..., 2, 4] = dot(v1, x_p)
    return J_X, J_k


def sensitivity(q: np.ndarray | float, geometry: PlanarGeometry) -> np.ndarray:
    """Complete sensitivity ``S_C = J_X^-1 J_kC`` (Savoure Eq. 66-69).

    ``δX = [δx, δy, δalpha] = S_C δk_C`` with δk_C in the order of Eq. 69.

    Args:
        q: Joint readings [rad], any shape S.
        geometry: The mechanism at which to linearise (Savoure uses the nominal one).

    Returns:
        S_C [mm/rad, 1, ...; rad/rad, rad/mm, ...], shape S + (3, 9).
    """
    J_X, J_k = calibration_jacobians(q, geometry)
    return np.linalg.solve(J_X, J_k)


# --------------------------------------------------------------------------------------------
# Ground truth: Pinocchio closed-loop model
# --------------------------------------------------------------------------------------------


def _se3(rotation_z: float, xy: Sequence[float]) -> pin.SE3:
    c, s = np.cos(rotation_z), np.sin(rotation_z)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return pin.SE3(R, np.array([xy[0], xy[1], 0.0]))


def _rod_inertia(length: float) -> pin.Inertia:
    # Any positive inertia: only kinematics are used.
    return pin.Inertia(1.0, np.array([0.0, -0.5 * length, 0.0]), np.diag([1.0, 1.0, 1.0]))


class PlanarMultibody:
    """The mechanism as a Pinocchio planar multibody with one loop closure (ground truth).

    Tree: rod 1 on a revolute joint (z) at A1, rotated by q0, actuated by q; the
    plate on a revolute joint at B1 on rod 1; rod 2 on a revolute joint at A2. A
    point-anchor (ball) constraint joins B2 on the plate to the end of rod 2. The
    loop is closed by a Newton iteration on the two passive joints with minimum-norm
    steps. Shares no code with :func:`configuration`.

    Attributes:
        geometry: The mechanism.
        model: The Pinocchio model (configuration ``[q, plate, rod 2]``).
        tcp_frame: Index of the frame at the tool centre point C (on the plate).
    """

    def __init__(self, geometry: PlanarGeometry) -> None:
        g = geometry
        self.geometry = g
        model = pin.Model()
        model.name = "savoure_planar"
        rod1 = model.addJoint(0, pin.JointModelRZ(), _se3(g.q0, (-g.a1x, 0.0)), "actuator")
        model.appendBodyToJoint(rod1, _rod_inertia(g.l1), pin.SE3.Identity())
        # Joint frame of the plate at B1; its angle is alpha - (q + q0).
        plate = model.addJoint(rod1, pin.JointModelRZ(), _se3(0.0, (0.0, -g.l1)), "plate")
        model.appendBodyToJoint(plate, pin.Inertia.Identity(), pin.SE3.Identity())
        rod2 = model.addJoint(0, pin.JointModelRZ(), _se3(0.0, (g.a2x, g.a2y)), "rod2")
        model.appendBodyToJoint(rod2, _rod_inertia(g.l2), pin.SE3.Identity())
        # In the plate joint frame (origin B1, axes x_p, y_p): O_p = (b1x, 0).
        self.tcp_frame = model.addFrame(
            pin.Frame("tcp", plate, _se3(0.0, (g.b1x, -g.h)), pin.FrameType.OP_FRAME), False
        )
        self.model = model
        self.data = model.createData()
        closure = pin.PointAnchorConstraintModel(
            model,
            plate,
            _se3(0.0, (g.b1x + g.b2x, g.b2y)),
            rod2,
            _se3(0.0, (0.0, -g.l2)),
        )
        self._constraints = pin.StdVec_ConstraintModel()
        self._constraints.append(closure)
        self._constraint_datas = pin.StdVec_ConstraintData()
        self._constraint_datas.append(closure.createData())
        self._passive = np.array([1, 2])

    def _closure_error(self) -> np.ndarray:
        """Loop-closure error at B2 [mm] in the plate joint frame, shape (3,) (z is 0).

        The constraint data held by the vector is the one updated, since
        ``getConstraintsJacobian`` reads the placements computed by ``calc``.
        """
        c, cd = self._constraints[0], self._constraint_datas[0]
        c.calc(self.model, self.data, cd)
        return np.array(cd.extract().constraint_position_error)

    def closure_residual(self, configuration: np.ndarray) -> np.ndarray:
        """Loop-closure error at B2 in the plate joint frame [mm], shape (2,)."""
        pin.forwardKinematics(self.model, self.data, configuration)
        return self._closure_error()[:2]

    def assemble(self, q: float, guess: np.ndarray | None = None, max_iterations: int = 50) -> np.ndarray:
        """Close the loop at actuated reading q by Newton's method.

        Args:
            q: Actuated joint reading [rad].
            guess: Starting configuration ``[q, plate, rod2]``; by default the nominal
                parallelogram (plate parallel to the base, rod 2 parallel to rod 1).
            max_iterations: Newton iterations allowed.

        Returns:
            The configuration ``[q, plate, rod2]`` [rad], shape (3,).

        Raises:
            ConvergenceError: If the residual does not fall below LOOP_TOLERANCE.
        """
        theta = q + self.geometry.q0
        config = np.array([q, -theta, theta]) if guess is None else np.array(guess, dtype=float)
        config[0] = q
        residual = np.inf
        for _ in range(max_iterations):
            pin.computeJointJacobians(self.model, self.data, config)
            error = self._closure_error()
            residual = float(np.linalg.norm(error))
            if residual < LOOP_TOLERANCE:
                return config
            J = pin.getConstraintsJacobian(self.model, self.data, self._constraints, self._constraint_datas)
            step = np.zeros(self.model.nv)
            # Minimum-norm step on the passive joints (the z row of the 3D error is empty).
            step[self._passive] = -np.linalg.lstsq(J[:, self._passive], error, rcond=None)[0]
            config = pin.integrate(self.model, config, step)
        raise ConvergenceError(
            f"planar loop closure did not converge at q = {q} rad: residual {residual:.3g} mm",
            residual=residual,
        )

    def tcp_pose(self, q: np.ndarray | float) -> np.ndarray:
        """Tool pose ``(x, y, alpha)`` [mm, mm, rad] of the assembled mechanism.

        Args:
            q: Actuated readings [rad], any shape S.

        Returns:
            Poses, shape S + (3,).
        """
        q = np.asarray(q, dtype=float)
        out = np.empty(q.shape + (3,))
        for index in np.ndindex(q.shape):
            config = self.assemble(float(q[index]))
            pin.forwardKinematics(self.model, self.data, config)
            placement = pin.updateFramePlacement(self.model, self.data, self.tcp_frame)
            R = placement.rotation
            out[index] = (
                placement.translation[0],
                placement.translation[1],
                np.arctan2(R[1, 0], R[0, 0]),
            )
        return out


# --------------------------------------------------------------------------------------------
# Identification
# --------------------------------------------------------------------------------------------


def _weights(noise_std: Sequence[float] | None) -> np.ndarray:
    if noise_std is None:
        return np.ones(3)
    s = np.asarray(noise_std, dtype=float)
    if s.shape != (3,) or np.any(s <= 0.0):
        raise ValueError(f"noise_std must be three positive values (x, y, alpha), got {noise_std}")
    return 1.0 / s


def _check_measurements(q: np.ndarray, measured: np.ndarray) -> None:
    if q.ndim != 1 or measured.shape != (q.size, 3):
        raise ValueError(
            f"measurements must be q of shape (m,) and poses of shape (m, 3); got {q.shape} "
            f"and {measured.shape}"
        )


def _standard_deviations(A: np.ndarray, residual: np.ndarray, known_weights: bool) -> np.ndarray:
    """Standard deviations of a least-squares estimate from the QR factor of A."""
    R = scipy.linalg.qr(A, mode="r")[0][: A.shape[1]]
    Rinv = scipy.linalg.solve_triangular(R, np.eye(A.shape[1]))
    dof = A.shape[0] - A.shape[1]
    factor = 1.0 if known_weights else float(residual @ residual) / max(dof, 1)
    return np.sqrt(factor * np.sum(Rinv**2, axis=1))


@dataclass(frozen=True)
class SimplifiedIdentification:
    """Result of the classical (simplified model) identification.

    Attributes:
        delta: Estimated ``[δq0 [rad], δl [mm]]`` (Eq. 74).
        std: Their standard deviations.
        model: The corrected simplified model.
        residual_rms: RMS of the (weighted) residuals at the solution.
    """

    delta: np.ndarray
    std: np.ndarray
    model: SimplifiedModel
    residual_rms: float
    names: tuple[str, ...] = SIMPLIFIED_NAMES


def identify_simplified(
    q: np.ndarray,
    measured: np.ndarray,
    nominal: SimplifiedModel,
    noise_std: Sequence[float] | None = None,
    coordinates: Sequence[str] = ("x",),
    max_iterations: int = 20,
) -> SimplifiedIdentification:
    """Classical calibration: identify ``[δq0, δl]`` from tool measurements (Eq. 38).

    Gauss-Newton on the stacked rows of every configuration. By default only the
    operational coordinate x is used, as in Eq. 38; ``("x", "y")`` also fits the
    vertical coordinate of the virtual bar (the alpha rows would carry no
    information: this model cannot rotate the plate).

    Args:
        q: Joint readings of the m measurement configurations [rad], shape (m,).
        measured: Measured tool poses ``(x, y, alpha)`` [mm, mm, rad], shape (m, 3).
        nominal: The simplified model before calibration.
        noise_std: Standard deviations of the measurements (x, y, alpha) used as
            weights [mm, mm, rad]; None for unweighted least squares (Eq. 26).
        coordinates: Which measured coordinates to fit, among "x" and "y".
        max_iterations: Gauss-Newton iterations allowed.

    Returns:
        The identification.

    Raises:
        IdentificationError: If fewer than 2 configurations are given.
        ConvergenceError: If Gauss-Newton does not converge.
    """
    q = np.asarray(q, dtype=float)
    measured = np.asarray(measured, dtype=float)
    _check_measurements(q, measured)
    rows = []
    for name in coordinates:
        if name not in ("x", "y"):
            raise ValueError(f"coordinates of the simplified model are 'x' and 'y', got {name!r}")
        rows.append("xy".index(name))
    if not rows:
        raise ValueError("coordinates is empty")
    if q.size < 2:
        raise IdentificationError(f"classical identification needs >= 2 configurations, got {q.size}")
    w = _weights(noise_std)[rows]

    def linearise(model: SimplifiedModel) -> tuple[np.ndarray, np.ndarray]:
        r = ((measured - model.forward_pose(q))[:, rows] * w).ravel()
        A = (model.sensitivity(q)[:, rows, :] * w[None, :, None]).reshape(-1, 2)
        return r, A

    delta = np.zeros(2)
    scale = float(np.linalg.norm(measured[:, rows] * w))
    for _ in range(max_iterations):
        r, A = linearise(nominal.corrected(delta))
        step = np.linalg.lstsq(A, r, rcond=None)[0]
        delta = delta + step
        if np.linalg.norm(A @ step) <= 1e-13 * scale:
            break
    else:
        raise ConvergenceError("classical identification did not converge")
    model = nominal.corrected(delta)
    r, A = linearise(model)
    return SimplifiedIdentification(
        delta=delta,
        std=_standard_deviations(A, r, noise_std is not None),
        model=model,
        residual_rms=float(np.sqrt(np.mean(r**2))),
    )


@dataclass(frozen=True)
class CompleteIdentification:
    """Result of the identification of the complete model's base parameters (Eq. 25-26, 73).

    Attributes:
        base: The base parameters (which are kept, the regroupings, rank...).
        estimate: Estimated base parameter values ``δk_C^b`` [rad, mm...], shape (rank,).
        std: Their standard deviations, shape (rank,).
        nominal: The geometry the errors are relative to.
        residual_rms: RMS of the (weighted) residuals at the solution.
        iterations: Gauss-Newton iterations done.
    """

    base: BaseParameters
    estimate: np.ndarray
    std: np.ndarray
    nominal: PlanarGeometry
    residual_rms: float
    iterations: int
    names: tuple[str, ...] = field(default=PARAMETER_NAMES)

    @property
    def delta(self) -> np.ndarray:
        """A full error vector ``δk_C`` with these base values (non-kept parameters 0)."""
        return self.base.expand(self.estimate)

    @property
    def geometry(self) -> PlanarGeometry:
        """The identified geometry (nominal plus :attr:`delta`)."""
        return self.nominal.perturbed(self.delta)

    def labels(self) -> list[str]:
        """Readable base parameters, e.g. ``δa2x − δb2x`` (Eq. 70-72)."""
        return self.base.labels()

    def regroupings(self) -> list[str]:
        """Labels of the base parameters that regroup more than one parameter."""
        rows = np.count_nonzero(self.base.regrouping, axis=1) > 1
        return [label for label, many in zip(self.labels(), rows, strict=True) if many]


def identify_complete(
    q: np.ndarray,
    measured: np.ndarray,
    nominal: PlanarGeometry,
    noise_std: Sequence[float] | None = None,
    prefer: Sequence[str] | None = PAPER_BASE_ORDER,
    rtol: float = 1e-8,
    max_iterations: int = 20,
) -> CompleteIdentification:
    """Improved calibration: identify the complete model's base parameters (Eq. 23-26).

    The base parameters come from the QR decomposition of the stacked sensitivity
    S_G at the nominal geometry (Eq. 23-25, :func:`deltacal.identifiability.base_parameters`);
    with ``prefer = PAPER_BASE_ORDER`` they are Savoure's Eq. 73. The estimate is then
    refined by Gauss-Newton on the closed-form model (the paper stops after the first,
    linear, step).

    Args:
        q: Joint readings of the m measurement configurations [rad], shape (m,).
        measured: Measured tool poses ``(x, y, alpha)`` [mm, mm, rad], shape (m, 3).
        nominal: The nominal mechanism, with the tool h used for the measurements.
        noise_std: Standard deviations (x, y, alpha) used as weights [mm, mm, rad];
            None for unweighted least squares (Eq. 26).
        prefer: Preference order of the parameters kept in the base; None lets the
            pivoted QR choose.
        rtol: Rank tolerance of the QR decomposition.
        max_iterations: Gauss-Newton iterations allowed.

    Returns:
        The identification.

    Raises:
        IdentificationError: If the measurements identify nothing or are too few.
        ConvergenceError: If Gauss-Newton does not converge.
    """
    q = np.asarray(q, dtype=float)
    measured = np.asarray(measured, dtype=float)
    _check_measurements(q, measured)
    w = _weights(noise_std)

    def regressor(geometry: PlanarGeometry) -> np.ndarray:
        return (sensitivity(q, geometry) * w[None, :, None]).reshape(-1, len(PARAMETER_NAMES))

    base = base_parameters(regressor(nominal), list(PARAMETER_NAMES), rtol=rtol, prefer=prefer)
    if base.rank == 0 or 3 * q.size <= base.rank:
        raise IdentificationError(
            f"{q.size} configuration(s) cannot identify the {base.rank} base parameter(s)"
        )
    estimate = np.zeros(base.rank)
    scale = float(np.linalg.norm(measured * w))
    iterations = 0
    while iterations < max_iterations:
        iterations += 1
        geometry = nominal.perturbed(base.expand(estimate))
        r = ((measured - forward_position(q, geometry)) * w).ravel()
        A = regressor(geometry)[:, base.base]
        step = np.linalg.lstsq(A, r, rcond=None)[0]
        estimate = estimate + step
        if np.linalg.norm(A @ step) <= 1e-13 * scale:
            break
    else:
        raise ConvergenceError("complete identification did not converge")
    geometry = nominal.perturbed(base.expand(estimate))
    r = ((measured - forward_position(q, geometry)) * w).ravel()
    A = regressor(geometry)[:, base.base]
    return CompleteIdentification(
        base=base,
        estimate=estimate,
        std=_standard_deviations(A, r, noise_std is not None),
        nominal=nominal,
        residual_rms=float(np.sqrt(np.mean(r**2))),
        iterations=iterations,
    )


# --------------------------------------------------------------------------------------------
# Compensation
# --------------------------------------------------------------------------------------------


def command_classical(x: np.ndarray | float, model: SimplifiedModel) -> np.ndarray:
    """Joint commands by the simplified IPR_S (Eq. 35) of a (corrected) model [rad].

    With the nominal model this is the uncalibrated command; with the model of
    :func:`identify_simplified` it is the classical calibration.
    """
    return model.inverse(x)


def command_improved(
    x: np.ndarray | float, nominal: PlanarGeometry, identification: CompleteIdentification
) -> np.ndarray:
    """Joint commands by Savoure's approximate complete inverse model (Eq. 29-33, Fig. 2).

    ``q = IPR_S(x, k_S)`` (29); ``δX = S_C^b(q, k_C) δk_C^b`` (30) at the nominal
    geometry; ``δx = δX[0]`` (31); ``δq = J_S^m(q, k_S) δx`` (32); ``q - δq`` (33).

    Args:
        x: Desired tool positions along ``x_b`` [mm].
        nominal: The nominal mechanism with the tool in use (its h).
        identification: The complete identification (its base parameters).

    Returns:
        Corrected joint commands [rad], shape of x.
    """
    simple = SimplifiedModel.from_geometry(nominal)
    q = simple.inverse(x)
    S = sensitivity(q, nominal)
    S_b = S[..., :, identification.base.base]
    dX = S_b @ identification.estimate
    dq = simple.inverse_jacobian(q) * dX[..., 0]
    return q - dq
