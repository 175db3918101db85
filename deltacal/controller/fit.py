"""The controller values that best represent an identified robot over a workspace.

A controller that accepts only joint offsets, or per-limb values, cannot follow every element of a
real robot; :func:`fit_controller` finds the values that leave the least TCP error over a grid of
points. For a point x the controller commands the readings of its inverse at x; the identified
robot's exact forward kinematics puts its TCP at ``T(q)``; the residual is ``T(q) − x``. Gauss-Newton
on the sum of squares, to convergence, with the Jacobian ``dT/dq · dq/dk``: ``dT/dq`` from the exact
forward Jacobian (Savoure Eq. 17) with the tool's lever, ``dq/dk`` by central differences of the
controller's closed-form inverse. Parameters the grid cannot tell apart (b_i and a_i enter only as
``b_i − a_i``) are found by the scaled pivoted QR of :func:`deltacal.identifiability.base_parameters`
(ties to the earlier parameter: b_i is kept, a_i held) and held at the starting (nominal) value.
Units: mm and rad.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..calibration import Calibration
from ..exceptions import ConvergenceError
from ..geometry import AXES, DeltaGeometry
from ..identifiability import base_parameters
from ..kinematics import exact, statics
from ..rotations import skew
from .model import LIMB_VALUES, Controller

#: What a fit may change: the joint offsets alone (every controller accepts them), or every per-limb
#: value and the tool.
FIT_KINDS = ("offsets", "limbs")
#: Units of each value: angles [rad], the others [mm].
ANGLES = ("limb_azimuth", "joint_offset")
#: Central-difference steps of dq/dk [mm, rad]: the closed-form inverse is exact to about 1e-13, so
#: the derivative is good to about 1e-9 relative, plenty for Gauss-Newton's direction.
STEP = {"mm": 1e-4, "rad": 1e-7}
#: Gauss-Newton stops when a step moves no TCP by more than this [mm]. The exact forward solver
#: (rod residuals to 1e-11 mm) leaves a noise floor: steps of 3e-10 to 2e-9 mm, on and on, once
#: converged (limbs fit, bai2015).
TOLERANCE = 1e-8


@dataclass(frozen=True)
class ControllerFit:
    """What a fit of a controller's values found.

    Attributes:
        controller: The fitted controller.
        kind: ``"offsets"`` or ``"limbs"``.
        fitted: Names of the values fitted (``limb1.joint_offset``, ``tool.z``...).
        held: Names of the values the grid cannot identify, held at their starting value.
        max_error: Largest TCP error left over the points [mm].
        rms_error: RMS of the TCP error's length over the points [mm].
        max_error_before: The same with the starting controller [mm].
        rms_error_before: The same with the starting controller [mm].
        points: Number of points of the grid.
        iterations: Gauss-Newton iterations.
        errors: The TCP error left at each point [mm], (N, 3).
    """

    controller: Controller
    kind: str
    fitted: list[str]
    held: list[str]
    max_error: float
    rms_error: float
    max_error_before: float
    rms_error_before: float
    points: int
    iterations: int
    errors: np.ndarray = field(repr=False)


def parameter_names(kind: str) -> list[str]:
    """The names of the values a fit of this kind may change, in a fixed order."""
    if kind == "offsets":
        return [f"limb{i}.joint_offset" for i in (1, 2, 3)]
    if kind == "limbs":
        return [f"limb{i}.{key}" for i in (1, 2, 3) for key in LIMB_VALUES] + [f"tool.{a}" for a in AXES]
    raise ValueError(f"kind must be one of {', '.join(FIT_KINDS)}, got {kind!r}")


def _split(name: str) -> tuple[str, int]:
    """(Controller field, index) of a parameter name."""
    head, key = name.split(".")
    return ("tool", AXES.index(key)) if head == "tool" else (key, int(head[-1]) - 1)


def values_of(controller: Controller, names: list[str]) -> np.ndarray:
    """The controller's values of these parameters [mm, rad]."""
    return np.array([getattr(controller, f)[i] for f, i in map(_split, names)])


def with_values(controller: Controller, names: list[str], values: np.ndarray) -> Controller:
    """A copy of the controller with these parameters set [mm, rad]."""
    changed: dict[str, np.ndarray] = {}
    for name, value in zip(names, values, strict=True):
        key, i = _split(name)
        changed.setdefault(key, np.array(getattr(controller, key)))[i] = value
    return controller.replace(**changed)


def tcp_errors(geometry: DeltaGeometry, controller: Controller, points: np.ndarray) -> np.ndarray:
    """Where the real TCP lands minus x, the controller commanding each point x [mm], (N, 3).

    Raises:
        UnreachableError: a point out of the controller model's reach.
        AssemblyError: readings at which the real robot has no assembly.
    """
    q = statics.compliant_readings(geometry, controller.inverse(points))  # a compliant robot sags
    return exact.forward(geometry, q).point(geometry.tool) - points


def _jacobian(geometry: DeltaGeometry, controller: Controller, points: np.ndarray,
              names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (3N,) and their Jacobian in the parameters (3N, k)."""
    q = statics.compliant_readings(geometry, controller.inverse(points))
    pose = exact.forward(geometry, q)
    residual = pose.point(geometry.tool) - points
    J = exact.forward_jacobian(geometry, q, pose)  # (N, 6, 3)
    tcp = J[:, :3] - skew(pose.rotation @ geometry.tool) @ J[:, 3:]  # dT = dp + dφ × (R t)
    start = values_of(controller, names)
    dq = np.empty((points.shape[0], 3, len(names)))
    for k, name in enumerate(names):
        h = STEP["rad" if _split(name)[0] in ANGLES else "mm"]
        up, down = start.copy(), start.copy()
        up[k] += h
        down[k] -= h
        dq[:, :, k] = (with_values(controller, names, up).inverse(points)
                       - with_values(controller, names, down).inverse(points)) / (2.0 * h)
    return residual.ravel(), (tcp @ dq).reshape(-1, len(names))


def fit_controller(
    calibration: Calibration | DeltaGeometry,
    start: Controller,
    points: np.ndarray,
    kind: str = "offsets",
    max_iter: int = 30,
) -> ControllerFit:
    """The controller values that leave the least squared TCP error over ``points``.

    Args:
        calibration: The calibration (or the identified geometry itself).
        start: The controller to start from (its nominal values); values not fitted keep these.
        points: Grid of TCP targets over the workspace [mm], (N, 3).
        kind: ``"offsets"`` (the three joint offsets) or ``"limbs"`` (every per-limb value and
            the tool; the unidentifiable ones held).
        max_iter: Gauss-Newton iterations at most.

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a point out of the controller model's reach.
    """
    geometry = calibration.geometry if isinstance(calibration, Calibration) else calibration
    points = np.atleast_2d(np.asarray(points, dtype=float))
    names = parameter_names(kind)
    residual, W = _jacobian(geometry, start, points, names)
    before = np.linalg.norm(residual.reshape(-1, 3), axis=1)
    base = base_parameters(W, names)
    fitted = [names[k] for k in sorted(base.base)]
    held = [names[k] for k in base.unidentifiable]
    columns = sorted(base.base)
    W = W[:, columns]
    controller = start
    iteration = 0
    while True:
        iteration += 1
        step = np.linalg.lstsq(W, -residual, rcond=None)[0]
        controller = with_values(controller, fitted, values_of(controller, fitted) + step)
        moved = float(np.max(np.abs(W @ step)))
        residual, W = _jacobian(geometry, controller, points, fitted)
        if moved < TOLERANCE:
            break
        if iteration == max_iter:
            raise ConvergenceError(f"the {kind} fit did not converge in {max_iter} iterations (last step "
                                   f"moved the TCP by {moved:.3g} mm)", moved)
    errors = residual.reshape(-1, 3)
    after = np.linalg.norm(errors, axis=1)
    return ControllerFit(
        controller=controller, kind=kind, fitted=fitted, held=held,
        max_error=float(after.max()), rms_error=float(np.sqrt(np.mean(after**2))),
        max_error_before=float(before.max()), rms_error_before=float(np.sqrt(np.mean(before**2))),
        points=points.shape[0], iterations=iteration, errors=errors,
    )
