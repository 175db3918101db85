"""Closed-form complete kinematics of the planar mechanism and its sensitivities (Savoure Eq. 41-69)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exceptions import AssemblyError
from .geometry import PlanarGeometry, perpendicular, unit_vector


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
    y_p = perpendicular(x_p)
    shape = theta.shape + (2,)
    a1 = np.broadcast_to(np.array([-g.a1x, 0.0]), shape).copy()
    a2 = np.broadcast_to(np.array([g.a2x, g.a2y]), shape).copy()
    b1 = a1 + g.l1 * unit_vector(theta)
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
    u1 = unit_vector(cfg.theta)
    v1 = perpendicular(u1)  # du/dtheta = (cos theta, sin theta)
    x_p = np.stack([np.cos(cfg.alpha), np.sin(cfg.alpha)], axis=-1)
    y_p = perpendicular(x_p)
    rot1 = perpendicular(cfg.b1 - cfg.c)  # dB1/dalpha with C fixed
    rot2 = perpendicular(cfg.b2 - cfg.c)

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
