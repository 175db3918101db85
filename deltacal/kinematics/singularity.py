"""Singularities: one set of measures, and one margin type whose policies say how far to stay.

A Delta (virtual, perfect-parallelogram model) has two kinds of singularity:

* serial (inverse-kinematics): an arm and its rod aligned; measured by the least
  **transmission angle** over the limbs, ``asin |n̂ · (w × û)|`` between the rod n̂ and
  the arm's direction of motion (w: actuator axis, û: arm), 90° when the rod pulls along
  the elbow's velocity, 0 at the singularity;
* parallel (forward-kinematics): the rods coplanar; measured by the **rod conditioning**,
  the inverse condition number of the matrix of unit rod directions (0 at the singularity),
  and, more strictly, by the **condition number κ of J_S** (``xdot = J_S qdot``, Savoure
  Table 1), which grows without bound near both kinds.

:class:`SingularityMargin` holds thresholds on the three; its :meth:`~SingularityMargin.margin`
is always the smallest ratio measure/threshold (κ as threshold/κ): below 1 a pose is refused.
Two policies: :data:`COMMAND_MARGIN` (what compensation refuses to command) and
:data:`PLANNING_MARGIN` (where measurement poses are drawn: far from both).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .closed_form import VirtualDelta


def inverse_condition_3x3(M: np.ndarray) -> np.ndarray:
    """Inverse condition number ``s_min / s_max`` of 3x3 matrices, in closed form, (N,).

    The singular values squared are the eigenvalues λ₁ ≥ λ₂ ≥ λ₃ of ``G = M Mᵀ``. The largest
    comes from the trigonometric solution of the symmetric 3x3 eigenproblem; the two others
    are the roots of ``λ² − (λ₂ + λ₃) λ + λ₂ λ₃``, whose coefficients come without
    cancellation from the invariants ``λ₂ λ₃ = det(M)² / λ₁`` and
    ``λ₂ + λ₃ = (Σ |mᵢ × mⱼ|² − λ₂ λ₃) / λ₁`` (rows mᵢ), the smaller root taken in its
    stable form. Near a singular matrix its accuracy is that of ``det(M)``, as for an SVD
    (absolute, about 1e-16 of ``s_max``); where singular values coincide (a Delta's
    symmetric poses) a double eigenvalue keeps half the digits (absolute error up to
    about 2e-8 on the ratio), far below what a threshold on it needs. A zero matrix
    gives 0; a matrix holding NaN gives NaN.

    Args:
        M: Matrices, shape (N, 3, 3).
    """
    rows = np.ascontiguousarray(np.moveaxis(np.asarray(M, dtype=float), 0, -1))  # (3, 3, N)
    return _inverse_condition(rows[0], rows[1], rows[2])


def _inverse_condition(r0: np.ndarray, r1: np.ndarray, r2: np.ndarray) -> np.ndarray:
    """:func:`inverse_condition_3x3` of the matrices of rows r0, r1, r2, each given as (3, N)."""
    g00 = r0[0] * r0[0] + r0[1] * r0[1] + r0[2] * r0[2]
    g11 = r1[0] * r1[0] + r1[1] * r1[1] + r1[2] * r1[2]
    g22 = r2[0] * r2[0] + r2[1] * r2[1] + r2[2] * r2[2]
    g01 = r0[0] * r1[0] + r0[1] * r1[1] + r0[2] * r1[2]
    g02 = r0[0] * r2[0] + r0[1] * r2[1] + r0[2] * r2[2]
    g12 = r1[0] * r2[0] + r1[1] * r2[1] + r1[2] * r2[2]
    # |r_i × r_j|² = g_ii g_jj − g_ij² loses digits near parallel rows: from the cross products
    minors = np.zeros_like(g00)
    det = np.zeros_like(g00)
    for a, b in ((r0, r1), (r0, r2), (r1, r2)):
        cx = a[1] * b[2] - a[2] * b[1]
        cy = a[2] * b[0] - a[0] * b[2]
        cz = a[0] * b[1] - a[1] * b[0]
        minors += cx * cx + cy * cy + cz * cz  # λ₁λ₂ + λ₁λ₃ + λ₂λ₃
        if a is r1:
            det = r0[0] * cx + r0[1] * cy + r0[2] * cz
    mean = (g00 + g11 + g22) / 3.0
    b00, b11, b22 = g00 - mean, g11 - mean, g22 - mean  # B = G − mean I
    spread = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (g01 * g01 + g02 * g02 + g12 * g12)) / 6.0)
    det_b = b00 * (b11 * b22 - g12 * g12) - g01 * (g01 * b22 - g12 * g02) + g02 * (g01 * g12 - b11 * g02)
    with np.errstate(invalid="ignore", divide="ignore"):
        half_cos = np.clip(det_b / (2.0 * spread**3), -1.0, 1.0)
        top = mean + 2.0 * spread * np.cos(np.arccos(np.where(spread > 0.0, half_cos, 1.0)) / 3.0)  # λ₁
        product = det * det / top  # λ₂ λ₃
        total = (minors - product) / top  # λ₂ + λ₃
        denominator = total + np.sqrt(np.maximum(total * total - 4.0 * product, 0.0))
        least = np.where(denominator > 0.0, 2.0 * product / denominator, 0.0)  # λ₃
        ratio = np.sqrt(np.clip(least / top, 0.0, 1.0))
    ratio = np.where(top == 0.0, 0.0, ratio)
    return np.where(np.isnan(top), np.nan, ratio)


def singularity_measures(
    virtual: VirtualDelta, q: np.ndarray, x: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Least transmission angle over the limbs [rad] and rod conditioning at readings q, each (N,).

    Computed coordinate by coordinate on (N, 3) arrays (limbs along the last axis), with each
    elbow of a revolute chain on its circle (:attr:`VirtualDelta.elbow_circle`) and the arm's
    direction of motion ``w × û = (cos θ w × U + sin θ w × V) / |e|``; a prismatic chain's
    carriage moves along its tower (:func:`_prismatic_measures`).

    Args:
        virtual: The virtual model.
        q: Readings [rad], shape (N, 3).
        x: The virtual model's plate position at q [mm], (N, 3), where it is known exactly
            (readings from :meth:`VirtualDelta.inverse` at x); else its forward kinematics.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if x is None:
        x = virtual.forward(q, check=False)
    if virtual.chain.slides:
        return _prismatic_measures(virtual, q, x)
    w = virtual.actuator_rotation[:, :, 1]  # (limb, coordinate)
    e = virtual.elbow
    centre, u, v = virtual.elbow_circle
    reach = np.linalg.norm(e, axis=1)
    wu = np.cross(w, u) / reach[:, None]
    wv = np.cross(w, v) / reach[:, None]
    theta = virtual.chain.coordinate(q, virtual.joint_scale, virtual.encoder_offset)
    cos, sin = np.cos(theta), np.sin(theta)
    rod = [x[:, k : k + 1] + (virtual.plate_attachment[:, k] - centre[:, k]) - cos * u[:, k] - sin * v[:, k]
           for k in range(3)]  # x + a_i − E_i, (N, 3) per coordinate
    length = np.sqrt(rod[0] * rod[0] + rod[1] * rod[1] + rod[2] * rod[2])
    along = sum(rod[k] * (cos * wu[:, k] + sin * wv[:, k]) for k in range(3))
    sin_t = (np.abs(along) / length).min(axis=1)
    angle = np.arcsin(np.clip(sin_t, 0.0, 1.0))
    unit = np.stack([(r / length).T for r in rod], axis=1)  # (limb, coordinate, N)
    return angle, _inverse_condition(unit[0], unit[1], unit[2])


def _prismatic_measures(virtual: VirtualDelta, q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`singularity_measures` of a prismatic chain: each carriage moves along its tower.

    The transmission angle is ``asin |n̂ · ŵ|`` between the rod n̂ and the carriage's line of
    travel ŵ (0 when the rod lies square to its tower: a rod horizontal on a printer).
    """
    rod = x[:, None, :] + virtual.plate_attachment[None] - virtual.elbows(q)  # (N, limb, coordinate)
    unit = rod / np.linalg.norm(rod, axis=2, keepdims=True)
    w = virtual.actuator_rotation[:, :, 1]  # the tower's direction, (limb, coordinate)
    sin_t = np.abs(np.sum(unit * w[None], axis=2)).min(axis=1)
    angle = np.arcsin(np.clip(sin_t, 0.0, 1.0))
    rows = np.ascontiguousarray(unit.transpose(1, 2, 0))  # (limb, coordinate, N)
    return angle, _inverse_condition(rows[0], rows[1], rows[2])


def jacobian_condition(virtual: VirtualDelta, q: np.ndarray) -> np.ndarray:
    """Condition number κ of the virtual J_S at readings q, (N,)."""
    return np.linalg.cond(virtual.jacobian(np.atleast_2d(np.asarray(q, dtype=float))))


@dataclass(frozen=True)
class SingularityMargin:
    """How far from singularities a pose must be (see the module docstring).

    Attributes:
        min_arm_rod_angle: Least transmission angle [rad].
        min_rod_conditioning: Least inverse condition number of the unit rod directions.
        max_condition: Largest condition number of J_S (inf: not checked).
    """

    min_arm_rod_angle: float = math.radians(3.0)
    min_rod_conditioning: float = 0.0
    max_condition: float = math.inf

    def margin(self, virtual: VirtualDelta, q: np.ndarray, x: np.ndarray | None = None) -> np.ndarray:
        """Smallest ratio of a measure to its threshold at readings q, (N,): below 1, refused.

        x: the virtual model's plate position at q where known exactly (see :func:`singularity_measures`).
        """
        angle, conditioning = singularity_measures(virtual, q, x)
        no_limit = np.full_like(angle, np.inf)
        ratios = [angle / self.min_arm_rod_angle if self.min_arm_rod_angle > 0 else no_limit]
        if self.min_rod_conditioning > 0:
            ratios.append(conditioning / self.min_rod_conditioning)
        if math.isfinite(self.max_condition):
            ratios.append(self.max_condition / jacobian_condition(virtual, q))
        return np.minimum.reduce(ratios)

    def admits(self, virtual: VirtualDelta, q: np.ndarray) -> np.ndarray:
        """Readings at least this far from every singularity, (N,) bool."""
        return self.margin(virtual, q) >= 1.0


#: What compensation refuses to command: arm and rod within 3° of alignment, or rods nearly
#: coplanar (inverse condition of their directions below 0.02).
COMMAND_MARGIN = SingularityMargin(min_arm_rod_angle=math.radians(3.0), min_rod_conditioning=0.02)
#: Where measurement poses are drawn: transmission angle of 20° at least and κ(J_S) at most 10.
PLANNING_MARGIN = SingularityMargin(min_arm_rod_angle=math.radians(20.0), max_condition=10.0)
