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
A user sees the worst point, not the sum of squares: with ``minimax`` the least-squares values are
then moved to leave the least largest error over the grid, the first layer no less flat than they
leave it (:func:`least_largest`: a linear program on the linearised errors, stepped in a trust region).
Each firmware's ``fit`` module names its values and writes the result in its own words.
Units: mm and rad.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

import numpy as np

from ...exceptions import ConvergenceError, UnreachableError
from ...geometry import DeltaGeometry, Workspace
from ...identifiability import base_parameters
from ...kinematics import exact
from ...rotations import skew
from ..robot import in_plane_motion, less_bed_motion
from .base import Flatness

#: Gauss-Newton stops when a step moves no nozzle by more than this [mm].
TOLERANCE = 1e-8
#: The height of the first layer, where flatness is judged [mm].
FIRST_LAYER = 0.2
#: The first layer's weight of every firmware's exported values (``export --controller NAME``) and of
#: the report's: it trades the volume's largest error for the first layer's flatness, which the
#: firmware's values must not leave worse than the firmware's own calibration (the figures:
#: docs/printers.md and docs/results.md).
EXPORT_FIRST_LAYER_WEIGHT = 30.0
#: :func:`least_largest` stops when a step would lower the largest error by less than this [mm].
LARGEST_TOLERANCE = 1e-5
#: What a step of :func:`least_largest` may leave above the start's flatness: the second order of a
#: step the linear model keeps within it [mm].
FLATNESS_SLACK = 1e-6
#: :func:`largest_step`'s cutting planes: the cuts to begin with, the rounds at most, the cuts each
#: round adds at most, and how far above the bound a cut is wanted [mm] (HiGHS holds rows to 1e-7).
FIRST_CUTS, MAX_CUTS, CUTS_PER_ROUND, CUT_TOLERANCE = 30, 60, 10, 1e-6


class Commands(Protocol):
    """What the fit asks of a firmware's values: the readings it commands for nozzle targets.

    Every :class:`~.base.FirmwareModel` is one; so is a rotary printer's
    (:class:`~.klipper.rotary_fit.RotaryCommands`).
    """

    def inverse(self, targets: np.ndarray, step_distance: np.ndarray | float,
                check: bool = True) -> np.ndarray:
        """The printer's readings the firmware commands for nozzle targets, (N, 3)."""


CommandsT = TypeVar("CommandsT", bound=Commands)


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


def nozzle_errors(geometry: DeltaGeometry, model: Commands, step_distance: np.ndarray | float,
                  targets: np.ndarray) -> np.ndarray:
    """Where the real nozzle lands minus the target, the firmware commanding each target [mm], (N, 3)."""
    targets = np.atleast_2d(np.asarray(targets, dtype=float))
    q = model.inverse(targets, step_distance)
    return exact.forward(geometry, q).point(geometry.tool) - targets


def error_stats(geometry: DeltaGeometry, model: Commands, step_distance: np.ndarray | float,
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
class ValueVector(Generic[CommandsT]):
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
    values_of: Callable[[CommandsT], np.ndarray]
    with_values: Callable[[CommandsT, np.ndarray], CommandsT]


@dataclass(frozen=True)
class GaussNewton(Generic[CommandsT]):
    """What :func:`gauss_newton` found.

    Attributes:
        model: The fitted values.
        columns: Indices (in the value vector) of the values fitted.
        unidentifiable: Names of the values the grid cannot tell apart from the others (held).
        singular_values: Singular values of the column-scaled Jacobian, largest first.
        iterations: Gauss-Newton iterations.
    """

    model: CommandsT
    columns: list[int]
    unidentifiable: list[str]
    singular_values: np.ndarray
    iterations: int


def residuals(geometry: DeltaGeometry, model: CommandsT, vector: ValueVector[CommandsT],
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


def gauss_newton(geometry: DeltaGeometry, start: CommandsT, vector: ValueVector[CommandsT],
                 step_distance: np.ndarray | float, workspace: Workspace, grid: np.ndarray,
                 wanted: list[int], max_iter: int = 30, first_layer_weight: float = 0.0,
                 part_frame: bool = True, title: str = "the firmware",
                 minimax: bool = False, flatness: Flatness = None) -> GaussNewton[CommandsT]:
    """The firmware's values that leave the least squared nozzle error over the grid (see the module).

    With ``minimax``, those values moved to leave the least largest error (:func:`least_largest`).

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
        minimax: Then the least largest error over the grid, the first layer no less flat.
        flatness: With ``minimax``, the first layer's bounds instead (:data:`Flatness`).

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

    def weighted(model: CommandsT, columns: list[int], moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
    if minimax:
        model = least_largest(geometry, model, vector, step_distance, workspace, grid, columns, part_frame,
                              flatness=flatness)
    return GaussNewton(model, columns, [names[k] for k in base.unidentifiable], singular, iteration)


def part_errors(geometry: DeltaGeometry, model: CommandsT, vector: ValueVector[CommandsT],
                step_distance: np.ndarray | float, grid: np.ndarray, layer: np.ndarray,
                columns: Sequence[int],
                part_frame: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The volume's nozzle errors and the first layer's height errors, with their Jacobians [mm].

    Args:
        geometry: The printer (the true bed is z = 0).
        model: The firmware's values.
        vector: The firmware's values as unknowns.
        step_distance: The printer's nominal step distance [mm].
        grid: The volume's targets [mm], (N, 3).
        layer: The first layer's targets [mm], (K, 3).
        columns: Indices (in the value vector) of the values varied.
        part_frame: The volume's errors less the in-plane motion that fits them best
            (:func:`~deltacal.printer.robot.less_bed_motion`: a linear projection, so its Jacobian's too).

    Returns:
        The volume's errors (N, 3) and their Jacobian (N, 3, k); the first layer's z errors (K,) and
        their Jacobian (K, k).
    """
    r, J = residuals(geometry, model, vector, step_distance, np.vstack([grid, layer]), columns)
    n = grid.size
    volume, slope = r[:n], J[:n]
    if part_frame:
        A = in_plane_motion(grid).reshape(-1, 3)
        fit = np.linalg.solve(A.T @ A, A.T)  # (3, 3N): the motion that fits errors best
        volume = volume - A @ (fit @ volume)
        slope = slope - A @ (fit @ slope)
    return volume.reshape(-1, 3), slope.reshape(len(grid), 3, -1), r[n + 2::3], J[n + 2::3]


@dataclass(frozen=True)
class Cuts:
    """The rows of :func:`largest_step`'s linear program: cuts of the volume's errors, first layer's bounds.

    Attributes:
        rows: The grid points cut, (m,) (a point may be cut along several directions).
        units: The direction of each cut, unit vectors, (m, 3).
        level: The first layer's points bounded, (p,).
        signs: The side of each bound: +1 bounds z from above (by the flatness and the highest),
            -1 from below (by minus the flatness and the lowest), (p,).
    """

    rows: np.ndarray
    units: np.ndarray
    level: np.ndarray
    signs: np.ndarray

    @classmethod
    def largest(cls, a: np.ndarray, c: np.ndarray, count: int = FIRST_CUTS) -> Cuts:
        """Cuts along the ``count`` largest errors a, bounds on the ``count/2`` highest and lowest c."""
        rows = np.argsort(-np.linalg.norm(a, axis=1), kind="stable")[:count]
        order = np.argsort(c, kind="stable")
        level = np.concatenate([order[::-1][:count // 2], order[:count // 2]])
        signs = np.repeat([1.0, -1.0], [min(count // 2, len(c))] * 2)
        return cls(rows, a[rows] / np.linalg.norm(a[rows], axis=1, keepdims=True), level, signs)

    def more(self, rows: np.ndarray, units: np.ndarray, level: np.ndarray, signs: np.ndarray) -> Cuts:
        """These cuts and the given ones."""
        return Cuts(np.concatenate([self.rows, rows]), np.vstack([self.units, units]),
                    np.concatenate([self.level, level]), np.concatenate([self.signs, signs]))


def largest_step(a: np.ndarray, B: np.ndarray, c: np.ndarray, D: np.ndarray, flatness: float, spread: float,
                 reach: float, cuts: Cuts) -> tuple[np.ndarray, float, Cuts]:
    """The step d (``|d_l| <= reach``) leaving the least largest ``|a_i + B_i d|``, the first layer bounded.

    The first layer's height errors ``z = c + D d`` stay within ``flatness`` (``|z| <= flatness``) and
    their peak to valley within ``spread``. The Euclidean norm is the largest of its cuts ``u . v``
    over unit vectors u (equal along v): a linear program in (d, t, h, l), least t over the cuts
    ``u_i . (a_i + B_i d) <= t``, the first layer's rows ``l <= z_j <= h``, ``|z_j| <= flatness``
    and ``h - l <= spread``, begun with ``cuts``; then a cut along each of the errors the solution
    leaves most above t, and the rows of the first layer's points it leaves most outside its bounds,
    are added until none is outside by more than :data:`CUT_TOLERANCE` (Kelley's cutting planes:
    the solution is then the least largest error of the linear model).

    Args:
        a: The volume's errors [mm], (N, 3).
        B: Their Jacobian [mm per unit of d], (N, 3, k).
        c: The first layer's height errors [mm], (K,).
        D: Their Jacobian [mm per unit of d], (K, k).
        flatness: The first layer's largest |height error| allowed [mm].
        spread: The first layer's largest peak to valley allowed [mm].
        reach: The trust region: the largest |d_l|.
        cuts: The rows to begin with (:meth:`Cuts.largest`, or a previous step's).

    Returns:
        The step (k,), the largest error it leaves by the linear model [mm] and the cuts it used;
        a zero step if the linear program fails.
    """
    from scipy.optimize import linprog  # here: scipy.optimize takes a while to import

    k = B.shape[2]
    cost = np.zeros(k + 3)
    cost[k] = 1.0
    bounds = [(-reach, reach)] * k + [(0.0, None), (None, None), (None, None)]
    spread_row = np.zeros((1, k + 3))
    spread_row[0, k + 1:] = (1.0, -1.0)  # h - l <= spread
    for _ in range(MAX_CUTS):
        s = cuts.signs[:, None]
        side = np.where(s > 0.0, np.array([[0.0, -1.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]))  # z <= h, l <= z
        level = s * D[cuts.level]
        A_ub = np.vstack([
            np.column_stack([np.einsum("nj,njk->nk", cuts.units, B[cuts.rows]), -np.ones(len(cuts.rows)),
                             np.zeros((len(cuts.rows), 2))]),
            np.column_stack([level, np.zeros((len(level), 3))]), np.column_stack([level, side]), spread_row])
        z0 = cuts.signs * c[cuts.level]
        b_ub = np.concatenate([-np.einsum("nj,nj->n", cuts.units, a[cuts.rows]), flatness - z0, -z0,
                               [spread]])
        solved = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")
        if solved.status != 0:
            return np.zeros(k), float(np.max(np.linalg.norm(a, axis=1))), cuts
        d, (t, high, low) = solved.x[:k], solved.x[k:]
        v, z = a + B @ d, c + D @ d
        size = np.linalg.norm(v, axis=1)
        above = np.argsort(t - size, kind="stable")[:CUTS_PER_ROUND]
        above = above[size[above] > t + CUT_TOLERANCE]
        out = np.maximum(z - min(flatness, high), max(-flatness, low) - z)
        over = np.argsort(-out, kind="stable")[:CUTS_PER_ROUND]
        over = over[out[over] > CUT_TOLERANCE]
        if len(above) == 0 and len(over) == 0:
            break
        cuts = cuts.more(above, v[above] / size[above, None], over, np.where(z[over] > high, 1.0, -1.0))
    return d, float(np.max(np.linalg.norm(a + B @ d, axis=1))), cuts


def flatness_limits(flatness: float | tuple[float, float]) -> np.ndarray:
    """The first layer's largest |z error| and peak to valley allowed, of a :data:`Flatness` [mm], (2,)."""
    if isinstance(flatness, tuple):
        return np.array(flatness, dtype=float)
    return np.array([flatness, 2.0 * flatness])


def least_largest(geometry: DeltaGeometry, start: CommandsT, vector: ValueVector[CommandsT],
                  step_distance: np.ndarray | float, workspace: Workspace, grid: np.ndarray,
                  columns: Sequence[int], part_frame: bool = True, max_iter: int = 40,
                  flatness: Flatness = None) -> CommandsT:
    """The firmware's values that leave the least largest nozzle error over the grid, from ``start``.

    The first layer (:func:`first_layer`) stays no worse than the start leaves it: its largest
    |z error| and its peak to valley (within :data:`FLATNESS_SLACK`); constraints, not weights. Each
    step is :func:`largest_step` on the errors linearised at the current values (:func:`part_errors`),
    the values scaled by how far each moves the nozzle (RMS over the grid), within a trust region,
    begun with the last step's cuts. A step is kept if the largest error over the grid, recomputed,
    falls and the first layer stays within its bounds; one that lowers the error but leaves the
    first layer outside (the second order of the step) is tried again with the linear model's bounds
    lowered by the excess; else the region shrinks. Deterministic (HiGHS' simplex).

    Args:
        geometry: The printer (the true bed is z = 0).
        start: The values to start from (the least-squares fit's).
        vector: The firmware's values as unknowns.
        step_distance: The printer's nominal step distance [mm].
        workspace: The printable cylinder (for the first layer's disc).
        grid: The volume's targets [mm], (N, 3).
        columns: Indices (in the value vector) of the values varied; the others are held.
        part_frame: Judge the volume's errors in the printed part's frame.
        max_iter: Steps at most.
        flatness: The first layer's bounds instead of the start's (:data:`Flatness`); a start
            outside them is brought within them where a step can.

    Raises:
        UnreachableError: a target out of the firmware's reach at ``start``.
    """
    layer = first_layer(workspace)
    columns = list(columns)

    def errors(model: CommandsT) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return part_errors(geometry, model, vector, step_distance, grid, layer, columns, part_frame)

    def first(z: np.ndarray) -> np.ndarray:  # [mm]: largest |z|, peak to valley
        return np.array([np.max(np.abs(z)), np.ptp(z)])

    a, B, c, D = errors(start)
    largest = float(np.max(np.linalg.norm(a, axis=1)))
    limits = first(c) if flatness is None else flatness_limits(flatness)
    within = bool(np.all(first(c) <= limits + FLATNESS_SLACK))
    bounds, cuts = limits, Cuts.largest(a, c)
    scale = np.sqrt(np.mean(np.sum(B**2, axis=1), axis=0))  # [mm per unit]: RMS nozzle motion
    scale = np.where(scale > 0.0, scale, 1.0)
    model, reach = start, 1.0  # [mm]
    for _ in range(max_iter):
        step, predicted, cuts = largest_step(a, B / scale, c, D / scale, float(bounds[0]), float(bounds[1]),
                                             reach, cuts)
        if within and largest - predicted < LARGEST_TOLERANCE or not np.any(step):
            break
        values = vector.values_of(model)
        values[columns] += step / scale
        trial = vector.with_values(model, values)
        try:
            found = errors(trial)
        except UnreachableError:
            reach = float(np.max(np.abs(step))) / 4.0
            continue
        now, excess = float(np.max(np.linalg.norm(found[0], axis=1))), first(found[2]) - limits
        better = now < largest or not within
        if better and np.all(excess <= FLATNESS_SLACK):
            gain = (largest - now) / (largest - predicted) if within else 1.0
            model, (a, B, c, D), largest, bounds, within = trial, found, now, limits, True  # cuts stay cuts
            reach = 2.0 * reach if gain > 0.75 else reach
        elif better and np.all(bounds > 0.5 * limits):
            bounds = bounds - np.maximum(excess, 0.0)
        else:
            reach = float(np.max(np.abs(step))) / 4.0
    return model
