"""Klipper's values that fit an identified linear Delta printer best.

Klipper's delta model (:class:`~.model.KlipperDelta`) has vertical towers, one rod
per tower and a point effector; a real printer differs in every element. For each target t of a
grid over the printable volume, Klipper commands steps ``n(t)`` (its closed-form inverse); the real
printer (its identified geometry, the true bed as z = 0) puts the nozzle at ``T(n d)`` (exact
forward kinematics, d the printer's nominal step distance: deltacal's readings); the residual is
``T − t``. :func:`fit_klipper` minimises the sum of squares by Gauss-Newton on Klipper's
``delta_radius``, three ``angle``, three ``arm_length``, three ``position_endstop`` and (unless held)
three step distances (its ``rotation_distance``), with the Jacobian ``dT/dq · dq/dk``: ``dT/dq`` from
the exact forward Jacobian with the nozzle's lever, ``dq/dk`` by central differences of Klipper's
closed form. The printer's frame is fixed by its bed, so no value is a gauge (the towers' common
rotation is not: it turns the printed part on the bed); the scaled pivoted QR and the singular
values of the Jacobian say what the grid cannot tell apart, and those values are held.

What the values leave per error source, for any firmware: :func:`~..budget.error_budget`.

Units: mm and rad (the dataclass's angles), degrees only in reports.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ....exceptions import ConvergenceError
from ....geometry import DeltaGeometry, Workspace
from ....identifiability import base_parameters
from ....kinematics import exact
from ....rotations import skew
from ...robot import in_plane_motion, less_bed_motion
from ..base import FirmwareModel
from .model import KlipperDelta

#: Klipper's values in the order of the fit's unknowns (step distances last).
KLIPPER_NAMES = (
    "delta_radius", "angle_a", "angle_b", "angle_c", "arm_length_a", "arm_length_b", "arm_length_c",
    "position_endstop_a", "position_endstop_b", "position_endstop_c",
    "step_distance_a", "step_distance_b", "step_distance_c",
)
#: Central-difference steps of Klipper's closed form per value [mm, rad, relative for step distances].
_STEP = {"delta_radius": 1e-4, "angle": 1e-7, "arm_length": 1e-4, "position_endstop": 1e-4,
         "step_distance": 1e-7}
#: The index of ``angle_c`` in :data:`KLIPPER_NAMES`.
_ANGLE_C = 3
#: Gauss-Newton stops when a step moves no nozzle by more than this [mm].
TOLERANCE = 1e-8
#: The first layer's weight of ``export --controller klipper`` and the report (:func:`fit_klipper`):
#: it trades the volume's largest error for the first layer's flatness, which the firmware's values
#: must not leave worse than the firmware's own calibration (the figures: docs/printers.md and
#: docs/results.md).
EXPORT_FIRST_LAYER_WEIGHT = 30.0
#: The height of the first layer, where flatness is judged [mm].
FIRST_LAYER = 0.2


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


@dataclass(frozen=True)
class KlipperFit:
    """Klipper's values fitted to a printer, and what they leave.

    Attributes:
        klipper: The fitted configuration.
        fitted: Names (:data:`KLIPPER_NAMES`) of the values fitted.
        held: Names held at the start's values (asked, or not identifiable over the grid).
        unidentifiable: The held values the grid cannot tell apart from the others.
        singular_values: Singular values of the column-scaled Jacobian, largest first.
        before: Errors with the start's values.
        after: Errors with the fitted values.
        iterations: Gauss-Newton iterations.
        points: Number of grid points.
    """

    klipper: KlipperDelta
    fitted: list[str]
    held: list[str]
    unidentifiable: list[str]
    singular_values: np.ndarray
    before: ErrorStats
    after: ErrorStats
    iterations: int
    points: int

    @property
    def values(self) -> KlipperDelta:
        """The fitted configuration (:attr:`klipper`), by the firmware interface's name."""
        return self.klipper


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


def nozzle_errors(geometry: DeltaGeometry, klipper: FirmwareModel, step_distance: np.ndarray | float,
                  targets: np.ndarray) -> np.ndarray:
    """Where the real nozzle lands minus the target, the firmware commanding each target [mm], (N, 3)."""
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    q = klipper.inverse(targets, step_distance)
    return exact.forward(geometry, q).point(geometry.tool) - targets


def error_stats(geometry: DeltaGeometry, klipper: KlipperDelta, step_distance: np.ndarray | float,
                workspace: Workspace, grid: np.ndarray | None = None, part_frame: bool = False) -> ErrorStats:
    """3-D errors over the printable volume and the first layer's flatness of Klipper's values [mm].

    With ``part_frame`` the 3-D errors are less the in-plane motion that fits them best
    (:func:`~deltacal.printer.robot.less_bed_motion`); the first layer's z errors are the same either way.
    """
    grid = printable_grid(workspace) if grid is None else grid
    errors = nozzle_errors(geometry, klipper, step_distance, grid)
    error = np.linalg.norm(less_bed_motion(grid, errors)[0] if part_frame else errors, axis=1)
    z = nozzle_errors(geometry, klipper, step_distance, first_layer(workspace))[:, 2]
    return ErrorStats(float(error.max()), float(np.sqrt(np.mean(error**2))), float(np.max(np.abs(z))),
                      float(z.max() - z.min()))


def values_of(klipper: KlipperDelta) -> np.ndarray:
    """Klipper's values in the order of :data:`KLIPPER_NAMES` (angles in rad) [mm, rad], (13,)."""
    return np.concatenate([[klipper.delta_radius], klipper.angle, klipper.arm_length,
                           klipper.position_endstop, klipper.step_distance])


def with_values(klipper: KlipperDelta, values: np.ndarray) -> KlipperDelta:
    """The configuration with the 13 values of :data:`KLIPPER_NAMES` [mm, rad]."""
    v = np.asarray(values, dtype=float)
    return replace(klipper, delta_radius=float(v[0]), angle=v[1:4], arm_length=v[4:7],
                   position_endstop=v[7:10], step_distance=v[10:13])


def _steps(name: str, value: float) -> float:
    h = _STEP[name.rsplit("_", 1)[0] if name != "delta_radius" else name]
    return h * value if name.startswith("step_distance") else h


def _residuals(geometry: DeltaGeometry, klipper: KlipperDelta, step_distance: np.ndarray | float,
               targets: np.ndarray, columns: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (3N,) and their Jacobian in the chosen values (3N, k)."""
    q = klipper.inverse(targets, step_distance)
    pose = exact.forward(geometry, q)
    residual = pose.point(geometry.tool) - targets
    J = exact.forward_jacobian(geometry, q, pose)  # (N, 6, 3)
    nozzle = J[:, :3] - skew(pose.rotation @ geometry.tool) @ J[:, 3:]
    start = values_of(klipper)
    dq = np.empty((targets.shape[0], 3, len(columns)))
    for k, c in enumerate(columns):
        h = _steps(KLIPPER_NAMES[c], start[c])
        up, down = start.copy(), start.copy()
        up[c] += h
        down[c] -= h
        dq[:, :, k] = (with_values(klipper, up).inverse(targets, step_distance)
                       - with_values(klipper, down).inverse(targets, step_distance)) / (2.0 * h)
    return residual.ravel(), (nozzle @ dq).reshape(-1, len(columns))


def fit_klipper(
    geometry: DeltaGeometry,
    start: KlipperDelta,
    step_distance: np.ndarray | float,
    workspace: Workspace,
    hold_step_distance: bool = False,
    grid: np.ndarray | None = None,
    max_iter: int = 30,
    first_layer_weight: float = 0.0,
    part_frame: bool = True,
) -> KlipperFit:
    """Klipper's values that leave the least squared nozzle error over the printable volume.

    With ``first_layer_weight`` w > 0 the sum also has the z errors over the first layer's disc
    (:func:`first_layer`) times w: the first layer's flatness bought with some of the volume's
    error. With ``part_frame`` the volume's errors are those of the printed part: less the shift
    along the bed and the turn about its normal that fit them best (:func:`~..robot.less_bed_motion`:
    no measurement sees them and a part printed so is the same part), fitted with the values;
    the towers' common turn is then (to first order) the part's turn, so ``angle_c`` is held, as
    Klipper's own calibration holds it.

    Args:
        geometry: The printer (a prismatic chain; the true bed is z = 0).
        start: The configuration to start from (its step distances are kept when held).
        step_distance: The printer's nominal step distance, what deltacal's readings count [mm].
        workspace: The printable cylinder (radius; heights 0.2 mm to its top).
        hold_step_distance: Keep the configuration's step distances (``rotation_distance``).
        grid: Targets [mm], (N, 3) (default :func:`printable_grid`).
        max_iter: Gauss-Newton iterations at most.
        first_layer_weight: Weight of the first layer's z errors (0: the volume alone).
        part_frame: Judge the volume's errors in the printed part's frame (see above).

    Raises:
        ConvergenceError: Gauss-Newton did not converge in ``max_iter`` iterations.
        UnreachableError: a target out of Klipper's reach.
    """
    grid = printable_grid(workspace) if grid is None else np.atleast_2d(np.asarray(grid, dtype=float))
    targets, weights = grid, np.ones(grid.size)
    if first_layer_weight > 0.0:
        disc = first_layer(workspace)
        targets = np.vstack([grid, disc])
        weights = np.concatenate([weights, np.tile([0.0, 0.0, first_layer_weight], len(disc))])
    motion = np.zeros((targets.size, 3 if part_frame else 0))  # d residual / d in-plane motion
    motion[:grid.size] = -in_plane_motion(grid).reshape(-1, 3)[:, :motion.shape[1]]

    def residuals(klipper: KlipperDelta, columns: list[int],
                  moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r, J = _residuals(geometry, klipper, step_distance, targets, columns)
        return weights * (r + motion @ moved), weights[:, None] * np.hstack([J, motion])

    wanted = [c for c in range(10 if hold_step_distance else 13) if not (part_frame and c == _ANGLE_C)]
    moved = np.zeros(motion.shape[1])
    residual, W = residuals(start, wanted, moved)
    W, B = W[:, :len(wanted)], W[:, len(wanted):]
    if part_frame:  # the values as they change the part, not where it stands
        W = W - B @ np.linalg.lstsq(B, W, rcond=None)[0]
    scale = np.linalg.norm(W, axis=0)
    singular = np.linalg.svd(W / np.where(scale > 0.0, scale, 1.0), compute_uv=False)
    names = [KLIPPER_NAMES[c] for c in wanted]
    base = base_parameters(W, names, prefer=names)
    columns = [wanted[k] for k in sorted(base.base)]
    unidentifiable = [KLIPPER_NAMES[wanted[k]] for k in base.unidentifiable]
    residual, W = residuals(start, columns, moved)
    klipper, iteration = start, 0
    while True:
        iteration += 1
        step = np.linalg.lstsq(W, -residual, rcond=None)[0]
        values = values_of(klipper)
        values[columns] += step[:len(columns)]
        moved = moved + step[len(columns):]
        klipper = with_values(klipper, values)
        change = float(np.max(np.abs(W @ step))) / max(1.0, first_layer_weight)  # [mm], unweighted
        residual, W = residuals(klipper, columns, moved)
        if change < TOLERANCE:
            break
        if iteration == max_iter:
            raise ConvergenceError(f"the Klipper fit did not converge in {max_iter} iterations (last step "
                                   f"moved the nozzle by {change:.3g} mm)", change)
    return KlipperFit(
        klipper=klipper,
        fitted=[KLIPPER_NAMES[c] for c in columns],
        held=[n for n in KLIPPER_NAMES if n not in {KLIPPER_NAMES[c] for c in columns}],
        unidentifiable=unidentifiable,
        singular_values=singular,
        before=error_stats(geometry, start, step_distance, workspace, grid, part_frame),
        after=error_stats(geometry, klipper, step_distance, workspace, grid, part_frame),
        iterations=iteration,
        points=grid.shape[0],
    )

