"""The planar mechanism as a Pinocchio closed-loop multibody: the ground truth of the planar study."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..exceptions import ConvergenceError
from .geometry import LOOP_TOLERANCE, PlanarGeometry


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
