"""Pinocchio closed-loop model of any DeltaGeometry: the ground truth.

The robot is built as a kinematic tree closed by ball joints:

* three revolute arms hanging from the universe. Joint placement of arm i:
  ``SE3(R0_i @ Ry(encoder_offset_i), axis_point_i)``, revolute about the local
  y axis, so the joint value *is* the reading q_i; the encoder offset and the
  axis misalignment live in the placement (geometry module, arm frame);
  or, for a linear Delta (a prismatic chain, :mod:`deltacal.chains`), three carriages on
  prismatic joints along the local y axis (up the tower) placed at
  ``SE3(R0_i, axis_point_i − encoder_offset_i w_i)``: the joint value is ``−joint_scale_i q_i``
  (a reading is a travel down the tower);
* six rods on spherical joints placed at the arm balls ``arm_ball[i, j]`` (arm
  frame); the rod hangs along its body's local -z axis and its far ball
  centre is the point ``(0, 0, -rod_length[i, j])`` of the rod body;
* the plate on a free-flyer joint (its frame is {C});
* six ``pin.PointAnchorConstraintModel`` closures: rod end point of rod (i, j)
  on the plate ball ``plate_ball[i, j]``. Their residual is the plate ball
  minus the rod end, expressed in the rod-end frame [mm].

The TCP (frame ``tcp``) and the named points of the geometry are frames of the
plate. Inertias: the geometry's masses (:class:`~deltacal.geometry.Masses`: each arm a
slender bar whose centre of mass is half-way from the axis to its elbow balls' midpoint,
each rod a uniform cylinder, the plate a sphere at its origin) and a payload as a point
mass at the TCP; gravity is ``-9810 mm/s²`` along z of {O}. A robot without masses and
payload gets placeholder inertias that only make the model valid for Pinocchio's
dynamics algorithms (its gravity torques are then zero).

Statics (:meth:`DeltaMultibody.gravity_torque`): at an assembled configuration,
``pin.computeGeneralizedGravity`` gives ``G = dU/dv`` of the open tree. In static
equilibrium the actuators' holding torques τ_a and the closures' forces λ balance it,
``G = Sᵀ τ_a + J_cᵀ λ`` (S selects the arm velocities, J_c the 18 x nv closure Jacobian).
These 27 equations in 21 unknowns are consistent (the idle rod spins carry no gravity
torque and no constraint force) and their solution is unique away from singularities;
it is solved by least squares and the gravity torque of the conventions is
``tau = -τ_a`` (the torque gravity applies about each actuator).

Forward kinematics holds the arms at the readings and runs Newton's method on
the 18 stacked closure residuals over the 24 non-actuated velocities (rods and
plate), stepping with ``pin.integrate``. Each rod has an idle spin about its
own axis: at an assembly its Jacobian column vanishes (the rod end lies on the
spin axis; away from it the spin only turns the frame in which the residual is
expressed), so the Jacobian has a six-dimensional null space there. The step is
the minimum-norm one, ``dv = -J^T (J J^T)^-1 e``, which leaves the spins alone.
When Newton does not converge, a Levenberg-Marquardt descent takes over.

Floating point: positions are ~1e3 mm, so one rounding is ~1e-13 mm and the
residual, composed through a handful of placements, stalls at a few 1e-13 mm.
The target is ``TOLERANCE = 1e-12`` mm; a solve that stalls on the
floating-point floor is accepted if it is below ``ACCEPT = 1e-10`` mm, and the
residual actually reached is reported in :class:`ClosureSolution`. Measured
over the workspace of perturbed bai2015 robots: median 2e-13 mm, largest
4.5e-13 mm, after 3 Newton iterations from the closed-form start.

Inverse kinematics appends a seventh anchor (universe point at the target to
the plate frame of the TCP or a named point) and solves over all velocities,
arms included (21 equations, 27 velocities, minimum-norm steps).

This module shares no solver code with :mod:`deltacal.kinematics.exact`; it only
uses the virtual (closed-form) model for its starting pose. Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..exceptions import AssemblyError, UnreachableError
from ..geometry import DeltaGeometry, Masses
from ..rotations import rotation_about_y
from .closed_form import VirtualDelta
from .exact import PlatePose

#: Target of the closure residual [mm] (max over the stacked coordinates).
TOLERANCE = 1e-12
#: A solve stalled on the floating-point floor is accepted below this residual [mm].
ACCEPT = 1e-10
#: Gravity along -z of {O} in the model's units [mm/s²] (conventions: 9.81 m/s²).
GRAVITY_MM = 9810.0
#: Generalised forces of the model (kg mm²/s² per rad) in N m.
_TO_NEWTON_METRE = 1e-6


@dataclass(frozen=True, eq=False)
class ClosureSolution:
    """An assembled configuration of the closed-loop model.

    Attributes:
        readings: Joint readings q [rad], shape (3,).
        configuration: Full Pinocchio configuration (arms, rod quaternions, plate), shape (nq,).
        position: Plate-frame origin in {O} [mm], shape (3,).
        rotation: Plate orientation in {O}, shape (3, 3).
        residual: Largest closure residual reached [mm].
        iterations: Newton (and Levenberg-Marquardt) iterations used.
        method: ``"newton"`` or ``"levenberg-marquardt"``.
    """

    readings: np.ndarray
    configuration: np.ndarray
    position: np.ndarray
    rotation: np.ndarray
    residual: float
    iterations: int
    method: str


@dataclass
class _System:
    """One set of closure constraints and the velocities it is solved over."""

    models: pin.StdVec_ConstraintModel
    datas: pin.StdVec_ConstraintData
    errors: list  # the concrete constraint datas, whose residuals are read
    columns: np.ndarray  # velocity indices solved over
    arm_columns: np.ndarray  # positions of the arm velocities within ``columns``


class _NotConverged(Exception):
    """Internal: a solver stopped without reaching the accepted residual."""

    def __init__(self, configuration: np.ndarray, residual: float, iterations: int):
        self.configuration = configuration
        self.residual = residual
        self.iterations = iterations


def _degrees(q: np.ndarray) -> list[float]:
    return np.round(np.degrees(q), 6).tolist()


class DeltaMultibody:
    """Pinocchio closed-loop model of a Delta robot built from a DeltaGeometry.

    Wraps a ``pin.Model`` and its ``pin.Data``; keeps the last assembled
    configuration to warm-start the next forward solve.

    Args:
        geometry: The robot, every element on its own.
        tol: Target closure residual [mm].
        max_iter: Newton iterations at most (Levenberg-Marquardt then gets ten times more).
        warm_radius: The last assembly warm-starts a solve when the readings moved by
            less than this in each joint [rad or mm; default: the chain's
            :attr:`~deltacal.chains.Chain.warm_radius`]; otherwise the closed-form pose is used.
        payload: A point mass at the TCP [kg] (statics only).
    """

    def __init__(
        self,
        geometry: DeltaGeometry,
        tol: float = TOLERANCE,
        max_iter: int = 20,
        warm_radius: float | None = None,
        payload: float = 0.0,
    ) -> None:
        if not (math.isfinite(payload) and payload >= 0.0):
            raise ValueError(f"payload must be a finite non-negative mass [kg], got {payload!r}")
        self.geometry = geometry
        self.payload = float(payload)
        self._massive = not geometry.masses.is_zero or self.payload > 0.0
        self.tol = float(tol)
        self.max_iter = int(max_iter)
        self.warm_radius = float(geometry.chain.warm_radius if warm_radius is None else warm_radius)
        self._max_arm_step = geometry.chain.max_step
        self._virtual = VirtualDelta.from_geometry(geometry)
        self._z_base = float(geometry.axis_point[:, 2].min())
        model = pin.Model()
        model.name = geometry.name or "delta"
        model.gravity = pin.Motion(np.array([0.0, 0.0, -GRAVITY_MM]), np.zeros(3))
        self._build(model)
        self._model = model
        self._data = model.createData()
        self._forward_system = self._system(self._rod_constraints(), with_arms=False)
        anchor = pin.PointAnchorConstraintModel(
            model, 0, pin.SE3.Identity(), self._plate_joint, pin.SE3.Identity()
        )
        constraints = self._rod_constraints()
        constraints.append(pin.ConstraintModel(anchor))
        self._inverse_system = self._system(constraints, with_arms=True)
        self._anchor = self._inverse_system.models[6].extract()
        self._last: np.ndarray | None = None

    # ------------------------------------------------------------ building
    def _add_actuator(self, model: pin.Model, i: int) -> int:
        """Joint of actuator i (revolute arm or prismatic carriage) with its body.

        A revolute arm is a slender bar [kg, mm]: with masses, the arm's mass half-way from the axis
        to its elbow (conventions); without, a placeholder 1 kg at the elbow. A carriage is a
        placeholder 0.2 kg box (linear Deltas have no statics yet).
        """
        g = self.geometry
        R0 = g.actuator_rotation()
        com = g.arm_ball[i].mean(axis=0)
        if g.chain.slides:
            place = pin.SE3(R0[i], g.axis_point[i] - g.encoder_offset[i] * R0[i][:, 1])
            jid = model.addJoint(0, pin.JointModelPY(), place, f"carriage{i + 1}")
            # placeholder inertia: a 0.2 kg carriage [kg, mm]
            model.appendBodyToJoint(jid, pin.Inertia.FromBox(0.2, 60.0, 20.0, 60.0), pin.SE3(np.eye(3), com))
            return jid
        placement_rot = R0 @ rotation_about_y(g.encoder_offset)
        jid = model.addJoint(0, pin.JointModelRY(), pin.SE3(placement_rot[i], g.axis_point[i]), f"arm{i + 1}")
        arm_length = float(np.linalg.norm(com))
        mass, centre = (g.masses.arm, 0.5 * com) if self._massive else (1.0, com)
        bar = mass * np.diag([1.0, arm_length**2, arm_length**2]) / 12.0
        model.appendBodyToJoint(jid, pin.Inertia(mass, centre, bar), pin.SE3.Identity())
        return jid

    def _joint_values(self, q: np.ndarray) -> np.ndarray:
        """Actuator joint values of readings q (revolute: the readings; prismatic: ``−scale q``)."""
        return self.geometry.chain.joint_value(q, self.geometry.joint_scale)

    def _build(self, model: pin.Model) -> None:
        g = self.geometry
        masses: Masses = g.masses
        self._arm_joints: list[int] = []
        self._rod_joints: list[int] = []
        # depth first (each arm then its rods): Pinocchio wants every subtree's
        # velocities contiguous (model.check, CRBA)
        for i in range(3):
            jid = self._add_actuator(model, i)
            self._arm_joints.append(jid)
            for j in range(2):
                rid = model.addJoint(
                    jid, pin.JointModelSpherical(), pin.SE3(np.eye(3), g.arm_ball[i, j]), f"rod{i + 1}{j + 1}"
                )
                length = float(g.rod_length[i, j])
                inertia = pin.Inertia.FromCylinder(masses.rod if self._massive else 0.1, 5.0, length)
                model.appendBodyToJoint(rid, inertia, pin.SE3(np.eye(3), np.array([0.0, 0.0, -length / 2])))
                self._rod_joints.append(rid)
        self._plate_joint = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "plate")
        plate = pin.Inertia.FromSphere(masses.plate if self._massive else 0.5, 50.0)
        model.appendBodyToJoint(self._plate_joint, plate, pin.SE3.Identity())
        if self.payload > 0.0:
            payload = pin.Inertia(self.payload, np.array(g.tool), np.zeros((3, 3)))
            model.appendBodyToJoint(self._plate_joint, payload, pin.SE3.Identity())
        self._frames: dict[str, int] = {}
        for name in ["plate", *g.point_names]:
            where = np.zeros(3) if name == "plate" else g.point(name)
            frame = pin.Frame(name, self._plate_joint, pin.SE3(np.eye(3), where), pin.FrameType.OP_FRAME)
            self._frames[name] = model.addFrame(frame, False)
        self._arm_q = np.array([model.joints[j].idx_q for j in self._arm_joints])
        self._arm_v = np.array([model.joints[j].idx_v for j in self._arm_joints])
        self._rod_q_all = np.array([model.joints[j].idx_q + k for j in self._rod_joints for k in range(4)])
        self._plate_balls = g.plate_ball.reshape(6, 3)
        self._plate_q = model.joints[self._plate_joint].idx_q
        rod_v = [model.joints[j].idx_v for j in self._rod_joints]
        plate_v = model.joints[self._plate_joint].idx_v
        self._passive_v = np.array(
            [v + k for v in rod_v for k in range(3)] + list(range(plate_v, plate_v + 6))
        )

    def _rod_constraints(self) -> pin.StdVec_ConstraintModel:
        g = self.geometry
        out = pin.StdVec_ConstraintModel()
        for k, rid in enumerate(self._rod_joints):
            i, j = divmod(k, 2)
            rod_end = pin.SE3(np.eye(3), np.array([0.0, 0.0, -g.rod_length[i, j]]))
            ball = pin.SE3(np.eye(3), g.plate_ball[i, j])
            c = pin.PointAnchorConstraintModel(self._model, rid, rod_end, self._plate_joint, ball)
            c.name = f"ball{i + 1}{j + 1}"
            out.append(pin.ConstraintModel(c))
        return out

    def _system(self, models: pin.StdVec_ConstraintModel, with_arms: bool) -> _System:
        datas = pin.StdVec_ConstraintData()
        for c in models:
            datas.append(c.createData())
        columns = np.concatenate([self._arm_v, self._passive_v]) if with_arms else self._passive_v
        arm_columns = np.arange(3) if with_arms else np.arange(0)
        return _System(models, datas, [d.extract() for d in datas], columns, arm_columns)

    # ---------------------------------------------------------- accessors
    @property
    def model(self) -> pin.Model:
        """The Pinocchio model (tree: arms, rods, plate)."""
        return self._model

    @property
    def data(self) -> pin.Data:
        """The Pinocchio data used by the solvers."""
        return self._data

    @property
    def point_names(self) -> list[str]:
        """Names of the plate frames: ``plate``, ``tcp`` and the geometry's named points."""
        return list(self._frames)

    def readings_of(self, configuration: np.ndarray) -> np.ndarray:
        """Readings q [rad, or mm for a prismatic chain] of a full configuration, shape (3,)."""
        values = np.array(configuration)[self._arm_q]
        return self.geometry.chain.reading_of(values, self.geometry.joint_scale)

    def plate_placement(self, configuration: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Plate position [mm] (3,) and rotation (3, 3) in {O} of a full configuration."""
        M = pin.XYZQUATToSE3(np.array(configuration[self._plate_q : self._plate_q + 7]))
        return np.array(M.translation), np.array(M.rotation)

    def closure_residual(self, configuration: np.ndarray) -> np.ndarray:
        """The six ball-joint residuals (plate ball minus rod end, rod-end frame) [mm], (6, 3)."""
        e, _ = self._evaluate(np.asarray(configuration, dtype=float), self._forward_system)
        return e.reshape(6, 3)

    def closure_jacobian(self, configuration: np.ndarray) -> np.ndarray:
        """Jacobian of :meth:`closure_residual` (flattened) over all velocities, shape (18, nv).

        Columns follow ``model.nv``, depth first: arm 1, its rods 1 and 2 (three local
        angular velocities each, the third the idle spin about the rod axis), arm 2, ...,
        then the plate's six (local linear, local angular).
        """
        x = np.asarray(configuration, dtype=float)
        self._evaluate(x, self._forward_system)
        system = self._forward_system
        return np.array(pin.getConstraintsJacobian(self._model, self._data, system.models, system.datas))

    def gravity_torque(self, configuration: np.ndarray) -> np.ndarray:
        """Gravity torque about each actuator of the closed loop, ``tau_i = -dU/dθ_i`` [N m], (3,).

        Pinocchio's generalised gravity of the tree carried to the actuators through the
        closures (module docstring: ``G = Sᵀ τ_a + J_cᵀ λ``, ``tau = -τ_a``), at an assembled
        configuration (:meth:`solve_forward`). Positive when gravity lowers the arm tip.
        """
        if not self._massive:
            return np.zeros(3)
        x = np.asarray(configuration, dtype=float)
        model, data, system = self._model, self._data, self._forward_system
        G = np.array(pin.computeGeneralizedGravity(model, data, x))
        pin.computeJointJacobians(model, data, x)
        for c, d in zip(system.models, system.datas, strict=True):
            c.calc(model, data, d)
        Jc = np.array(pin.getConstraintsJacobian(model, data, system.models, system.datas))
        S = np.zeros((3, model.nv))
        S[np.arange(3), self._arm_v] = 1.0
        balance = np.concatenate([S, Jc]).T  # (nv, 21): [Sᵀ J_cᵀ]
        holding = np.linalg.lstsq(balance, G, rcond=None)[0][:3]
        return -holding * _TO_NEWTON_METRE

    def frame_positions(self, configuration: np.ndarray, names: list[str] | None = None) -> np.ndarray:
        """Positions in {O} of plate frames (default: tcp and the named points) [mm], (k, 3)."""
        names = self.point_names[1:] if names is None else list(names)
        unknown = [n for n in names if n not in self._frames]
        if unknown:
            raise KeyError(f"unknown point(s) {unknown}; known: {self.point_names}")
        pin.forwardKinematics(self._model, self._data, np.asarray(configuration, dtype=float))
        return np.array(
            [pin.updateFramePlacement(self._model, self._data, self._frames[n]).translation for n in names]
        )

    # ---------------------------------------------------------- internals
    def _evaluate(self, x: np.ndarray, system: _System) -> tuple[np.ndarray, np.ndarray]:
        """Stacked residual and its Jacobian over the system's velocities at configuration x."""
        model, data = self._model, self._data
        pin.computeJointJacobians(model, data, x)
        for c, d in zip(system.models, system.datas, strict=True):
            c.calc(model, data, d)
        e = np.concatenate([d.constraint_position_error for d in system.errors])
        J = pin.getConstraintsJacobian(model, data, system.models, system.datas)[:, system.columns]
        return e, J

    def _step(self, x: np.ndarray, dv: np.ndarray, system: _System) -> np.ndarray:
        v = np.zeros(self._model.nv)
        v[system.columns] = dv
        return pin.integrate(self._model, x, v)

    def _newton(self, x: np.ndarray, system: _System) -> tuple[np.ndarray, float, int]:
        """Newton's method; raises _NotConverged with the best configuration reached."""
        e, J = self._evaluate(x, system)
        res = float(np.max(np.abs(e)))
        best = (x, res)
        for it in range(1, self.max_iter + 1):
            if res <= self.tol:
                return x, res, it - 1
            try:
                # minimum-norm step: dv = -J^T (J J^T)^-1 e
                dv = -J.T @ np.linalg.solve(J @ J.T, e)
            except np.linalg.LinAlgError:
                break
            if system.arm_columns.size:
                big = np.max(np.abs(dv[system.arm_columns]))
                if big > self._max_arm_step:
                    dv *= self._max_arm_step / big
            x_new = self._step(x, dv, system)
            e, J = self._evaluate(x_new, system)
            res_new = float(np.max(np.abs(e)))
            if not math.isfinite(res_new):
                break
            if res_new < best[1]:
                best = (x_new, res_new)
            # stalled on the floating-point floor: no more progress to make
            if res_new > 0.5 * res and best[1] <= ACCEPT:
                return best[0], best[1], it
            x, res = x_new, res_new
        if best[1] <= self.tol or (best[1] <= ACCEPT and res <= ACCEPT):
            return best[0], best[1], self.max_iter
        raise _NotConverged(best[0], best[1], self.max_iter)

    def _levenberg_marquardt(self, x: np.ndarray, system: _System) -> tuple[np.ndarray, float, int]:
        """Damped Gauss-Newton descent on the squared residual, from x."""
        e, J = self._evaluate(x, system)
        cost = float(e @ e)
        res = float(np.max(np.abs(e)))
        n = J.shape[1]
        H = J.T @ J
        lam = 1e-3 * float(np.max(np.diag(H)))
        stalls = 0
        it = 0
        for it in range(1, 10 * self.max_iter + 1):
            if res <= self.tol:
                return x, res, it - 1
            g = J.T @ e
            dv = -np.linalg.solve(H + lam * np.eye(n), g)
            x_new = self._step(x, dv, system)
            e_new, J_new = self._evaluate(x_new, system)
            cost_new = float(e_new @ e_new)
            if math.isfinite(cost_new) and cost_new < cost:
                stalls = 0 if cost_new < 0.9 * cost else stalls + 1
                x, e, J, cost = x_new, e_new, J_new, cost_new
                res = float(np.max(np.abs(e)))
                H = J.T @ J
                lam = max(lam / 3.0, 1e-12 * float(np.max(np.diag(H))))
            else:
                stalls += 1
                lam *= 4.0
            if stalls >= 8:
                break
        if res <= ACCEPT:
            return x, res, it
        raise _NotConverged(x, res, it)

    def initial_configuration(self, readings: np.ndarray, position: np.ndarray | None = None) -> np.ndarray:
        """Starting configuration of the solvers, rods aimed at their plate balls.

        Arms at the readings, plate parallel to the base at the closed-form
        (virtual model) pose or at ``position``.

        Args:
            readings: Joint readings [rad], shape (3,).
            position: Plate origin [mm], shape (3,) (default: the virtual model's).

        Returns:
            Configuration, shape (nq,).
        """
        q = np.asarray(readings, dtype=float)
        if position is None:
            x = self._virtual.forward(q[None], check=False)[0]
            if not np.all(np.isfinite(x)):
                # no virtual assembly: start under the elbows and let the solver tell
                elbows = self._virtual.elbows(q[None])[0] - self._virtual.plate_attachment
                x = elbows.mean(axis=0) - np.array([0.0, 0.0, 0.5 * self._virtual.rod_length.mean()])
        else:
            x = np.asarray(position, dtype=float)
        config = pin.neutral(self._model)
        config[self._arm_q] = self._joint_values(q)
        config[self._plate_q : self._plate_q + 3] = x
        pin.forwardKinematics(self._model, self._data, config)
        oMi = self._data.oMi
        rods = [oMi[rid] for rid in self._rod_joints]
        # rod directions in their arm frames (rod joint frames at zero rotation)
        v = np.array(
            [M.rotation.T @ (b - M.translation) for M, b in zip(rods, x + self._plate_balls, strict=True)]
        )
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        # shortest rotation taking the rod axis -z onto v: quaternion [x, y, z, w]
        quat = np.column_stack([v[:, 1], -v[:, 0], np.zeros(6), 1.0 - v[:, 2]])
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        config[self._rod_q_all] = quat.ravel()
        return config

    def _accept_branch(self, x: np.ndarray) -> bool:
        """Working assembly mode: plate below the actuator axes and not turned over.

        A linear Delta's effector hangs below its carriages' balls.
        """
        p = x[self._plate_q : self._plate_q + 3]
        R = pin.XYZQUATToSE3(np.array(x[self._plate_q : self._plate_q + 7])).rotation
        ceiling = self._z_base
        if self.geometry.chain.plate_below_balls:
            pin.forwardKinematics(self._model, self._data, x)
            ceiling = min(float(self._data.oMi[rid].translation[2]) for rid in self._rod_joints)
        return bool(p[2] < ceiling and R[2, 2] > 0.0)

    def _solution(self, x: np.ndarray, residual: float, iterations: int, method: str) -> ClosureSolution:
        position, rotation = self.plate_placement(x)
        self._last = np.array(x)
        return ClosureSolution(
            self.readings_of(x), np.array(x), position, rotation, residual, iterations, method
        )

    # --------------------------------------------------------- kinematics
    def solve_forward(
        self, readings: np.ndarray, start: np.ndarray | None = None, warm: bool = True
    ) -> ClosureSolution:
        """Assemble the robot at joint readings: the plate pose of the real robot.

        Args:
            readings: Joint readings q [rad], shape (3,).
            start: Full configuration to start from (its arm values are replaced by the readings).
            warm: Start from the last assembly when the readings are within ``warm_radius`` of it.

        Returns:
            The assembled configuration and the plate pose.

        Raises:
            AssemblyError: No assembly at these readings (Newton and Levenberg-Marquardt failed),
                or the assembly found is not the working mode (plate below the actuator
                axes, not turned over).
        """
        return self._assemble(np.asarray(readings, dtype=float).reshape(3), start, warm, None)

    def _assemble(
        self, q: np.ndarray, start: np.ndarray | None, warm: bool, cold_position: np.ndarray | None
    ) -> ClosureSolution:
        if not np.all(np.isfinite(q)):
            raise AssemblyError(f"readings must be finite, got q = {_degrees(q)} deg", [0], q[None])
        system = self._forward_system
        starts = []
        if start is not None:
            starts.append(np.array(start, dtype=float))
        elif warm and self._last is not None:
            if np.max(np.abs(self.readings_of(self._last) - q)) <= self.warm_radius:
                starts.append(np.array(self._last))
        used = 0
        for x0 in starts:
            x0[self._arm_q] = self._joint_values(q)
            try:
                x, res, it = self._newton(x0, system)
            except _NotConverged as fail:
                used += fail.iterations
                continue
            if self._accept_branch(x):
                return self._solution(x, res, used + it, "newton")
            used += it
        cold = self.initial_configuration(q, cold_position)
        try:
            x, res, it = self._newton(cold, system)
            method = "newton"
        except _NotConverged as fail:
            used += fail.iterations
            try:
                x, res, it = self._levenberg_marquardt(cold, system)
                method = "levenberg-marquardt"
            except _NotConverged as fail_lm:
                raise AssemblyError(
                    f"no assembly at q = {_degrees(q)} deg: closure residual {fail_lm.residual:.3g} mm "
                    f"after Newton and Levenberg-Marquardt",
                    [0],
                    q[None],
                    fail_lm.residual,
                ) from None
        if not self._accept_branch(x):
            p, R = self.plate_placement(x)
            raise AssemblyError(
                f"assembly at q = {_degrees(q)} deg is not the working mode: plate at "
                f"{np.round(p, 3).tolist()} mm, tilt {math.degrees(math.acos(np.clip(R[2, 2], -1, 1))):.3g}"
                f" deg (residual {res:.3g} mm)",
                [0],
                q[None],
                res,
            )
        return self._solution(x, res, used + it, method)

    def forward(self, q: np.ndarray, warm: bool = True) -> PlatePose:
        """Plate poses at a batch of readings (one solve per pose).

        Args:
            q: Joint readings [rad], shape (N, 3) or (3,).
            warm: Warm-start each pose from the previous assembly when close enough.

        Returns:
            The plate poses.

        Raises:
            AssemblyError: naming every reading (in degrees) where no assembly was found.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        position = np.full((q.shape[0], 3), np.nan)
        rotation = np.full((q.shape[0], 3, 3), np.nan)
        failed: list[int] = []
        residual = 0.0
        # closed-form starting poses of the whole batch at once
        virtual = self._virtual.forward(q, check=False)
        for n, qn in enumerate(q):
            try:
                cold = virtual[n] if np.all(np.isfinite(virtual[n])) else None
                sol = self._assemble(qn, None, warm, cold)
            except AssemblyError as err:
                failed.append(n)
                residual = max(residual, err.residual) if math.isfinite(err.residual) else residual
                continue
            position[n], rotation[n] = sol.position, sol.rotation
        if failed:
            raise AssemblyError(
                f"no assembly at {len(failed)} reading(s), first: q = {_degrees(q[failed[0]])} deg "
                f"(index {failed[0]}); largest closure residual {residual:.3g} mm",
                failed,
                q[failed],
                residual,
            )
        return PlatePose(position, rotation)

    def point_positions(self, q: np.ndarray, names: list[str] | None = None) -> np.ndarray:
        """Positions in {O} of plate points at a batch of readings [mm], shape (N, k, 3).

        Args:
            q: Joint readings [rad], shape (N, 3) or (3,).
            names: Frame names (default: ``tcp`` then the named points).
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        out = []
        for qn in q:
            out.append(self.frame_positions(self.solve_forward(qn).configuration, names))
        return np.array(out).reshape(q.shape[0], -1, 3)

    def solve_inverse(
        self, target: np.ndarray, point: str = "tcp", start: np.ndarray | None = None
    ) -> ClosureSolution:
        """Readings that put a plate point of the real robot at a target.

        A seventh anchor constraint ties the point to the target; Newton (then
        Levenberg-Marquardt) runs over all velocities, arms included, from the
        virtual model's knee-out solution (or ``start``).

        Args:
            target: Desired position of the point in {O} [mm], shape (3,).
            point: ``tcp`` or a named point of the geometry.
            start: Full configuration to start from.

        Returns:
            The assembled configuration; ``readings`` are the readings to command.

        Raises:
            UnreachableError: The target is out of reach (or the solvers failed there).
        """
        target = np.asarray(target, dtype=float).reshape(3)
        in_plate = self.geometry.point(point)
        self._anchor.joint1_placement = pin.SE3(np.eye(3), target)
        self._anchor.joint2_placement = pin.SE3(np.eye(3), np.array(in_plate))
        system = self._inverse_system

        def unreachable(detail: str) -> UnreachableError:
            return UnreachableError(
                f"target {np.round(target, 6).tolist()} mm of point {point!r} is out of reach: {detail}",
                [0],
                target[None],
            )

        if start is None:
            position = target - in_plate
            q0 = self._virtual.inverse(position[None], check=False)[0]
            if not np.all(np.isfinite(q0)):
                raise unreachable("no reading of the closed-form model reaches it")
            x0 = self.initial_configuration(q0, position)
        else:
            x0 = np.array(start, dtype=float)
        try:
            x, res, it = self._newton(x0, system)
            method = "newton"
        except _NotConverged:
            try:
                x, res, it = self._levenberg_marquardt(x0, system)
                method = "levenberg-marquardt"
            except _NotConverged as fail:
                raise unreachable(f"residual {fail.residual:.3g} mm after Newton and LM") from None
        if not self._accept_branch(x):
            raise unreachable("the assembly found is not the working mode")
        return self._solution(x, res, it, method)

    def inverse(self, target: np.ndarray, point: str = "tcp") -> np.ndarray:
        """Readings [rad], shape (N, 3), that put a plate point at targets [mm], shape (N, 3) or (3,).

        Raises:
            UnreachableError: naming every target out of reach.
        """
        target = np.atleast_2d(np.asarray(target, dtype=float))
        q = np.full((target.shape[0], 3), np.nan)
        failed: list[int] = []
        for n, tn in enumerate(target):
            try:
                q[n] = self.solve_inverse(tn, point).readings
            except UnreachableError:
                failed.append(n)
        if failed:
            raise UnreachableError(
                f"{len(failed)} target(s) out of reach of the robot, first: "
                f"{np.round(target[failed[0]], 6).tolist()} mm (index {failed[0]})",
                failed,
                target[failed],
            )
        return q
