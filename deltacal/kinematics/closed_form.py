"""Closed-form kinematics of a Delta robot with perfect parallelograms.

With perfect parallelograms the plate stays parallel to the base and each
parallelogram can be replaced by a virtual rod from the elbow midpoint E_i to
the point ``x + a_i`` of the plate (conventions; Savoure 2006, Table 1: the
"simplified" models FPR_S, IPR_S, J_S, J_S^m). The virtual model here is
general: every limb has its own actuator axis (point and direction), encoder
offset, elbow point in the arm frame, plate attachment and rod length, which is
Vischer and Clavel's 24-parameter model (Bai 2015 model 24, Eq. 10).

Units: mm and rad. Batches: positions (N, 3), readings (N, 3).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..chains import REVOLUTE, Chain
from ..exceptions import AssemblyError, GeometryError, UnreachableError
from ..geometry import DeltaGeometry, NominalDelta
from . import batch3 as b3


@dataclass(frozen=True, eq=False)
class VirtualDelta:
    """Per-limb parameters of the virtual-rod (perfect parallelogram) Delta.

    Attributes:
        axis_point: Point of each actuator axis in {O} [mm], (3, 3).
        actuator_rotation: R0_i, actuator frame at zero true angle, (3, 3, 3); y is the axis.
        encoder_offset: True angle minus reading [rad], (3,).
        elbow: Elbow midpoint E_i in the arm frame [mm], (3, 3).
        plate_attachment: a_i, the virtual rod's end in the plate frame [mm], (3, 3).
        rod_length: Virtual rod lengths [mm], (3,).
        chain: The actuated chain (:mod:`deltacal.chains`; :attr:`joint` is its word): for a
            prismatic one the "elbow" is the carriage's ball-pair midpoint in its frame, the
            readings are travels [mm] and the offsets endstop errors [mm].
        joint_scale: True joint coordinate per unit reading, (3,).
    """

    axis_point: np.ndarray
    actuator_rotation: np.ndarray
    encoder_offset: np.ndarray
    elbow: np.ndarray
    plate_attachment: np.ndarray
    rod_length: np.ndarray
    chain: Chain = REVOLUTE
    joint_scale: np.ndarray = field(default_factory=lambda: np.ones(3))

    @classmethod
    def from_nominal(cls, nominal: NominalDelta) -> VirtualDelta:
        """The virtual model of a nominal robot."""
        return cls.from_geometry(nominal.geometry())

    @classmethod
    def from_geometry(cls, geometry: DeltaGeometry) -> VirtualDelta:
        """The classical view of any geometry: pair midpoints and mean rod lengths.

        Exact for a geometry with perfect parallelograms; an approximation otherwise.
        """
        return cls(
            axis_point=np.array(geometry.axis_point),
            actuator_rotation=geometry.actuator_rotation(),
            encoder_offset=np.array(geometry.encoder_offset),
            elbow=geometry.arm_ball.mean(axis=1),
            plate_attachment=geometry.plate_ball.mean(axis=1),
            rod_length=geometry.rod_length.mean(axis=1),
            chain=geometry.chain,
            joint_scale=np.array(geometry.joint_scale),
        )

    @property
    def joint(self) -> str:
        """The chain's word in files: ``"revolute"`` or ``"prismatic"``."""
        return self.chain.name

    # ------------------------------------------------------------- helpers
    @cached_property
    def elbow_path(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Elbow paths, ``E_i = C_i + f(θ_i) U_i + g(θ_i) V_i``: C, U, V, each (3, 3).

        θ is the true joint coordinate; :meth:`~deltacal.chains.Chain.carried_points` (rows are limbs).
        """
        path = self.chain.carried_points(self.axis_point, self.actuator_rotation, self.elbow[:, None])
        centre, along_f, along_g = (np.array(v[:, 0]) for v in path)
        for v in (centre, along_f, along_g):
            v.setflags(write=False)
        return centre, along_f, along_g

    @property
    def elbow_circle(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A revolute chain's elbow circles, ``E_i = C_i + cos θ_i U_i + sin θ_i V_i``: C, U, V.

        Raises:
            GeometryError: the chain is prismatic (:attr:`elbow_path`).
        """
        if self.chain.slides:
            raise GeometryError("a prismatic chain's elbows move on lines, not circles: use elbow_path")
        return self.elbow_path

    def _theta(self, q: np.ndarray) -> np.ndarray:
        """True joint coordinates at readings q, (N, 3, 1)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return self.chain.coordinate(q, self.joint_scale, self.encoder_offset)[..., None]

    def elbows(self, q: np.ndarray) -> np.ndarray:
        """Elbow midpoints E_i in {O} [mm], shape (N, 3, 3), at readings q (N, 3) [rad or mm]."""
        f, g = self.chain.path_terms(self._theta(q))
        base, along_f, along_g = self.elbow_path
        return base + f * along_f + g * along_g

    def elbow_velocity(self, q: np.ndarray) -> np.ndarray:
        """dE_i/dq_i [mm/rad or mm/mm], shape (N, 3, 3): each elbow's motion per unit of its reading."""
        f, g = self.chain.path_slopes(self._theta(q))
        _, along_f, along_g = self.elbow_path
        return self.joint_scale[:, None] * (f * along_f + g * along_g)

    # ------------------------------------------------------------ kinematics
    def forward(self, q: np.ndarray, check: bool = True) -> np.ndarray:
        """Forward position relation FPR_S: plate-frame origin at readings q.

        Intersection of the three spheres of centres ``E_i - a_i`` and radii ``l_i``,
        lower solution (plate below the base).

        Args:
            q: Readings [rad], shape (N, 3) or (3,).
            check: Raise AssemblyError where no assembly exists (else NaN rows).

        Returns:
            Plate positions [mm], shape (N, 3).
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        # sphere centres, component first: c[k, i] is coordinate k of limb i's centre, (3, 3, N)
        c = (self.elbows(q) - self.plate_attachment[None]).transpose(2, 1, 0)
        r2 = self.rod_length**2
        d1 = c[:, 1] - c[:, 0]
        d2 = c[:, 2] - c[:, 0]
        n = b3.cross(d1, d2)
        c0sq = b3.dot(c[:, 0], c[:, 0])
        M = np.stack([2.0 * d1, 2.0 * d2, n])
        rhs = np.stack([b3.dot(c[:, 1], c[:, 1]) - c0sq - r2[1] + r2[0],
                        b3.dot(c[:, 2], c[:, 2]) - c0sq - r2[2] + r2[0],
                        b3.dot(n, c[:, 0])])
        # no assembly (or no plane of centres) gives NaN rows, checked below or by the caller
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            x0, _ = b3.solve(M, rhs)  # the radical line's point in the plane of the centres
            v = x0 - c[:, 0]
            nn = b3.dot(n, n)
            b = b3.dot(n, v)
            disc = b * b - nn * (b3.dot(v, v) - r2[0])
            root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
            s1 = (-b + root) / nn
            s2 = (-b - root) / nn
            x1 = x0 + s1 * n
            x2 = x0 + s2 * n
            x = np.where(x1[2] < x2[2], x1, x2).T
        if check:
            bad = ~np.all(np.isfinite(x), axis=1)
            if np.any(bad):
                idx = np.flatnonzero(bad)
                raise AssemblyError(
                    f"no assembly at {idx.size} reading(s), first: q = "
                    f"{np.round(self.chain.reading_to_file(q[idx[0]]), 6).tolist()} "
                    f"{self.chain.words.reading_unit} (index {idx[0]})",
                    idx,
                    q[idx],
                )
        return x

    def inverse(self, x: np.ndarray, check: bool = True) -> np.ndarray:
        """Inverse position relation IPR_S, knee-out branch (larger cos of the true angle).

        Args:
            x: Plate-frame origins [mm], shape (N, 3) or (3,).
            check: Raise UnreachableError for unreachable points (else NaN rows).

        Returns:
            Readings [rad], shape (N, 3).
        """
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if self.chain.slides:
            return self._inverse_prismatic(x, check)
        # d in actuator frames: X - p_i, X = x + a_i
        # d = X - p_i in the actuator frames, coordinate by coordinate: (N, 3) arrays, limbs last
        offset = self.plate_attachment - self.axis_point
        d = [x[:, k : k + 1] + offset[:, k] for k in range(3)]
        R0 = self.actuator_rotation
        dx, dy, dz = (d[0] * R0[:, 0, k] + d[1] * R0[:, 1, k] + d[2] * R0[:, 2, k] for k in range(3))
        e = self.elbow
        A = dx * e[:, 0] + dz * e[:, 2]
        B = dx * e[:, 2] - dz * e[:, 0]
        K = 0.5 * (np.sum(e * e, axis=1) + (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - self.rod_length**2)
        K = K - dy * e[:, 1]
        rho = np.hypot(A, B)
        ratio = K / rho
        ok = np.abs(ratio) <= 1.0
        gamma = np.arccos(np.where(ok, ratio, np.nan))
        base = np.arctan2(B, A)
        t1 = base + gamma
        t2 = base - gamma
        theta = np.where(np.cos(t1) >= np.cos(t2), t1, t2)
        q = theta - self.encoder_offset
        q = ((q + np.pi) % (2.0 * np.pi) - np.pi) / self.joint_scale
        if check:
            bad = ~np.all(np.isfinite(q), axis=1)
            if np.any(bad):
                raise UnreachableError.from_mask(bad, x)
        return q

    def _inverse_prismatic(self, x: np.ndarray, check: bool) -> np.ndarray:
        """IPR_S of a prismatic chain: the travel that puts each carriage's elbow above the plate point.

        With ``D = x + a_i − C_i`` (C_i the elbow at zero travel) and the elbow at ``C_i − θ w_i``,
        ``|D + θ w_i| = l_i`` gives ``θ = −D·w − sqrt((D·w)² − |D|² + l²)``: the root with the
        carriage above the plate point along its tower.
        """
        centre, _, _ = self.elbow_path
        w = self.actuator_rotation[:, :, 1]
        D = x[:, None, :] + (self.plate_attachment - centre)[None]  # (N, 3, 3)
        along = np.sum(D * w, axis=2)
        with np.errstate(invalid="ignore"):
            theta = -along - np.sqrt(along * along - np.sum(D * D, axis=2) + self.rod_length**2)
        q = (theta - self.encoder_offset) / self.joint_scale
        if check:
            bad = ~np.all(np.isfinite(q), axis=1)
            if np.any(bad):
                raise UnreachableError.from_mask(bad, x)
        return q

    def velocity_matrices(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The two sides of the velocity constraint ``A xdot = B qdot``.

        Rows of A are the virtual rod vectors ``n_i = x + a_i - E_i``; B is diagonal
        with ``n_i . dE_i/dq_i``.

        Returns:
            A (N, 3, 3) [mm] and B (N, 3, 3) [mm^2/rad].
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        x = self.forward(q)
        n = x[:, None, :] + self.plate_attachment[None] - self.elbows(q)
        dE = self.elbow_velocity(q)
        B = np.zeros((q.shape[0], 3, 3))
        idx = np.arange(3)
        B[:, idx, idx] = np.sum(n * dE, axis=2)
        return n, B

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """Forward velocity relation J_S: ``xdot = J_S(q) qdot`` (Savoure Table 1).

        Returns:
            J_S [mm/rad], shape (N, 3, 3).
        """
        A, B = self.velocity_matrices(q)
        return np.linalg.solve(A, B)

    def inverse_jacobian(self, q: np.ndarray) -> np.ndarray:
        """Inverse velocity relation J_S^m: ``qdot = J_S^m(q) xdot`` (Savoure Table 1, Eq. 32).

        Returns:
            J_S^m [rad/mm], shape (N, 3, 3).
        """
        A, B = self.velocity_matrices(q)
        diag = np.diagonal(B, axis1=1, axis2=2)
        return A / diag[..., None]


def forward(nominal: NominalDelta, q: np.ndarray) -> np.ndarray:
    """Plate positions of the perfect robot at readings q [rad], (N, 3) [mm]."""
    return VirtualDelta.from_nominal(nominal).forward(q)


def inverse(nominal: NominalDelta, x: np.ndarray) -> np.ndarray:
    """Readings [rad] that put the perfect robot's plate origin at x [mm], (N, 3)."""
    return VirtualDelta.from_nominal(nominal).inverse(x)
