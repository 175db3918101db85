"""A firmware's values that fit an identified linear Delta printer best, whatever the firmware.

A firmware's model (Klipper's, RepRapFirmware's) has vertical towers, one rod per tower and a point
effector; a real printer differs in every element. For each target t of a grid over the printable
volume (:func:`printable_grid`) the firmware commands steps ``n(t)`` (its closed-form inverse); the
real printer (its identified geometry, the true bed as z = 0) puts the nozzle at ``T(n d)`` (exact
forward kinematics, d the printer's nominal step distance: deltacal's readings); the residual is
``T − t``. :func:`gauss_newton` minimises the sum of squares over the firmware's values (a
:class:`ValueVector`: their names, how to read them off a model and put them back, the steps of
their central differences), with the Jacobian ``dT/dq · dq/dk``: ``dT/dq`` from the exact forward
Jacobian with the nozzle's lever, ``dq/dk`` by central differences of the firmware's closed form.
The first layer's height errors can be weighted in (:func:`first_layer`), and the volume's errors
judged in the printed part's frame: less the shift along the bed and the turn about its normal that
fit them best (:func:`~deltacal.printer.robot.less_bed_motion`), fitted with the values. The scaled
pivoted QR of the Jacobian says what the grid cannot tell apart; those values are held.
Each firmware's ``fit`` module names its values and writes the result in its own words.
Units: mm and rad.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic

import numpy as np

from ...exceptions import ConvergenceError
from ...geometry import DeltaGeometry, Workspace
from ...identifiability import base_parameters
from ...kinematics import exact
from ...rotations import skew
from ..robot import in_plane_motion, less_bed_motion
from .base import FirmwareModel, ModelT

#: Gauss-Newton stops when a step moves no nozzle by more than this [mm].
TOLERANCE = 1e-8
#: The height of the first layer, where flatness is judged [mm].
FIRST_LAYER = 0.2
#: The first layer's weight of every firmware's exported values (``export --controller NAME``) and of
#: the report's: it trades the volume's largest error for the first layer's flatness, which the
#: firmware's values must not leave worse than the firmware's own calibration (the figures:
#: docs/printers.md and docs/results.md).
EXPORT_FIRST_LAYER_WEIGHT = 30.0


@dataclass(frozen=True)
class ErrorStats:
    """Nozzle errors over the printable volume and over the first layer [mm].

    Attributes:
        max_3d: Largest 3-D error over the grid.
        rms_3d: Root mean square 3-D error over the grid.
        flatness: Largest |z error| at z = 0.2 mm over the disc (the first layer's height error).
        flatness_pv: Peak to valley of the z error at z = 0.2 mm over the disc.
    """

    max_3d: float
    rms_3d: float
    flatness: float
    flatness_pv: float

    def as_dict(self) -> dict[str, float]:
        """The figures by name [mm]."""
        return {"max_3d_mm": self.max_3d, "rms_3d_mm": self.rms_3d, "flatness_mm": self.flatness,
                "flatness_pv_mm": self.flatness_pv}


def printable_grid(workspace: Workspace, per_radius: int = 6, layers: int = 5, ring: int = 24,
                   z_min: float = FIRST_LAYER) -> np.ndarray:
    """Targets over the printable cylinder: a square grid and a ring on its rim, on each layer [mm].

    Args:
        workspace: The cylinder (radius; heights ``z_min .. top_z``).
        per_radius: Grid steps per radius.
        layers: Number of layers, evenly from ``z_min`` to the top.
        ring: Points on the rim per layer (the largest errors are there).
        z_min: The lowest layer [mm] (the first layer).

    Returns:
        Points [mm], (N, 3), layer by layer from the bottom.
    """
    steps = np.arange(-per_radius, per_radius + 1) / per_radius * workspace.radius
    x, y = np.meshgrid(steps, steps, indexing="ij")
    inside = x**2 + y**2 < workspace.radius**2 * (1.0 - 1e-9)
    phi = np.arange(ring) * 2.0 * np.pi / ring
    xy = np.concatenate([np.stack([x[inside], y[inside]], axis=1),
                         workspace.radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)])
    heights = np.linspace(z_min, workspace.top_z, layers)
    return np.concatenate([np.column_stack([xy, np.full(len(xy), z)]) for z in heights])


def first_layer(workspace: Workspace, per_radius: int = 12, ring: int = 48) -> np.ndarray:
    """Targets over the disc at the first layer's height (z = 0.2 mm) [mm], (N, 3)."""
    disc = Workspace(workspace.radius, 0.0, FIRST_LAYER)
    return printable_grid(disc, per_radius, 1, ring)


def nozzle_errors(geometry: DeltaGeometry, model: FirmwareModel, step_distance: np.ndarray | float,
                  targets: np.ndarray) -> np.ndarray:
    """Where the real nozzle lands minus the target, the firmware commanding each target [mm], (N, 3)."""
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    q = model.inverse(targets, step_distance)
    return exact.forward(geometry, q).point(geometry.tool) - targets


def error_stats(geometry: DeltaGeometry, model: FirmwareModel, step_distance: np.ndarray | float,
                workspace: Workspace, grid: np.ndarray | None = None, part_frame: bool = False) -> ErrorStats:
    """3-D errors over the printable volume and the first layer's flatness of a firmware's values [mm].

    With ``part_frame`` the 3-D errors are less the in-plane motion that fits them best
    (:func:`~deltacal.printer.robot.less_bed_motion`); the first layer's z errors are the same either way.
    """
    grid = printable_grid(workspace) if grid is None else grid
    errors = nozzle_errors(geometry, model, step_distance, grid)
    error = np.linalg.norm(less_bed_motion(grid, errors)[0] if part_frame else errors, axis=1)
    z = nozzle_errors(geometry, model, step_distance, first_layer(workspace))[:, 2]
    return ErrorStats(float(error.max()), float(np.sqrt(np.mean(error**2))), float(np.max(np.abs(z))),
                      float(z.max() - z.min()))


@dataclass(frozen=True)
class ValueVector(Generic[ModelT]):
    """A firmware's values as the fit's unknowns.

    Attributes:
        names: The values' names, in the fit's order.
        steps: The central-difference step of each value [mm, rad, fraction; relative from
            ``relative`` on].
        relative: The index of the first value whose step is relative to it (the step distances).
        values_of: A model's values in the order of ``names``.
        with_values: The model with given values.
    """

    names: tuple[str, ...]
    steps: tuple[float, ...]
    relative: int
    values_of: Callable[[ModelT], np.ndarray]
    with_values: Callable[[ModelT, np.ndarray], ModelT]


@dataclass(frozen=True)
class GaussNewton(Generic[ModelT]):
    """What :func:`gauss_newton` found.

    Attributes:
        model: The fitted values.
        columns: Indices (in the value vector) of the values fitted.
        unidentifiable: Names of the values the grid cannot tell apart from the others (held).
        singular_values: Singular values of the column-scaled Jacobian, largest first.
        iterations: Gauss-Newton iterations.
    """

    model: ModelT
    columns: list[int]
    unidentifiable: list[str]
    singular_values: np.ndarray
    iterations: int


def residuals(geometry: DeltaGeometry, model: ModelT, vector: ValueVector[ModelT],
              step_distance: np.ndarray | float, targets: np.ndarray,
              columns: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Nozzle errors (3N,) of the firmware's values and their Jacobian in the chosen values (3N, k) [mm]."""
    q = model.inverse(targets, step_distance)
    pose = exact.forward(geometry, q)
    residual = pose.point(geometry.tool) - targets
    J = exact.forward_jacobian(geometry, q, pose)  # (N, 6, 3)
    nozzle = J[:, :3] - skew(pose.rotation @ geometry.tool) @ J[:, 3:]
    start = vector.values_of(model)
    dq = np.empty((targets.shape[0], 3, len(columns)))
    for k, c in enumerate(columns):
        h = vector.steps[c] * start[c] if c >= vector.relative else vector.steps[c]
        up, down = start.copy(), start.copy()
        up[c] += h
        down[c] -= h
        dq[:, :, k] = (vector.with_values(model, up).inverse(targets, step_distance)
                       - vector.with_values(model, down).inverse(targets, step_distance)) / (2.0 * h)
    return residual.ravel(), (nozzle @ dq).reshape(-1, len(columns))


def gauss_newton(geometry: DeltaGeometry, start: ModelT, vector: ValueVector[ModelT],
                 step_distance: np.ndarray | float, workspace: Workspace, grid: np.ndarray,
                 wanted: list[int], max_iter: int = 30, first_layer_weight: float = 0.0,
                 part_frame: bool = True, title: str = "the firmware") -> GaussNewton[ModelT]:
    """The firmware's values that leave the least squared nozzle error over the grid (see the module).

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The values to start from.
        vector: The firmware's values as unknowns.
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (for the first layer's disc).
        grid: Targets [mm], (N, 3).
        wanted: Indices of the values to fit, those the grid cannot tell apart aside.
        max_iter: Gauss-Newton iterations at most.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        part_frame: Judge the volume's errors in the printed part's frame.
        title: The firmware's name, for the message of a fit that does not converge.

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a target out of the firmware's reach.
    """
    targets, weights = grid, np.ones(grid.size)
    if first_layer_weight > 0.0:
        disc = first_layer(workspace)
        targets = np.vstack([grid, disc])
        weights = np.concatenate([weights, np.tile([0.0, 0.0, first_layer_weight], len(disc))])
    motion = np.zeros((targets.size, 3 if part_frame else 0))  # d residual / d in-plane motion
    motion[:grid.size] = -in_plane_motion(grid).reshape(-1, 3)[:, :motion.shape[1]]

    def weighted(model: ModelT, columns: list[int], moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r, J = residuals(geometry, model, vector, step_distance, targets, columns)
        return weights * (r + motion @ moved), weights[:, None] * np.hstack([J, motion])

    moved = np.zeros(motion.shape[1])
    _, W = weighted(start, wanted, moved)
    W, B = W[:, :len(wanted)], W[:, len(wanted):]
    if part_frame:  # the values as they change the part, not where it stands
        W = W - B @ np.linalg.lstsq(B, W, rcond=None)[0]
    scale = np.linalg.norm(W, axis=0)
    singular = np.linalg.svd(W / np.where(scale > 0.0, scale, 1.0), compute_uv=False)
    names = [vector.names[c] for c in wanted]
    base = base_parameters(W, names, prefer=names)
    columns = [wanted[k] for k in sorted(base.base)]
    residual, W = weighted(start, columns, moved)
    model, iteration = start, 0
    while True:
        iteration += 1
        step = np.linalg.lstsq(W, -residual, rcond=None)[0]
        values = vector.values_of(model)
        values[columns] += step[:len(columns)]
        moved = moved + step[len(columns):]
        model = vector.with_values(model, values)
        change = float(np.max(np.abs(W @ step))) / max(1.0, first_layer_weight)  # [mm], unweighted
        residual, W = weighted(model, columns, moved)
        if change < TOLERANCE:
            break
        if iteration == max_iter:
            raise ConvergenceError(f"the {title} fit did not converge in {max_iter} iterations (last step "
                                   f"moved the nozzle by {change:.3g} mm)", change)
    return GaussNewton(model, columns, [names[k] for k in base.unidentifiable], singular, iteration)
