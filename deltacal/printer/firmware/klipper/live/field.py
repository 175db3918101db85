"""The correction of Klipper's commands sampled on a grid: what a move needs, for the live module.

The exact correction of a program point x is its corrected target through Klipper's model,
``command(x)`` (:func:`~deltacal.controller.corrected_targets`: exact compensation on the
identified printer, then Klipper's forward model of those carriage travels). Klipper's host
cannot run it (no numpy, a Raspberry Pi's time per move), so the live module
(:mod:`.deltacal_geometry`) is given the correction ``c(x) = command(x) − x`` at the nodes of a
regular grid and interpolates it: Catmull-Rom tricubic (along each axis the cubic convolution
through the 4 nearest nodes: exact for quadratics, continuous with its first derivatives). At
:data:`DEFAULT_STEP_MM` its error is a few µm where trilinear interpolation is off by 0.01 mm:
the correction bends fast near the rim of Klipper's volume, where Klipper's model nears a flat rod.

The grid covers Klipper's printable volume (:class:`LiveVolume`) and :data:`TRUST_NODES` nodes
beyond it, where the node's value is the exact correction wherever the library gives it. Where it
refuses a point (out of the identified printer's reach, near a singularity, not commandable
through Klipper's model) and farther out, the correction blends to 0, Klipper's own command: the
same function is continued across those nodes (the library's kinematics without its checks, else
linear extrapolation), so that points near the border are interpolated from a smooth field, then
weighted down by a smoothstep over :data:`BLEND_NODES` nodes.

A calibration that knows where it holds (:class:`~deltacal.holds.WhereItHolds`) is corrected only
there (:func:`~deltacal.controller.weighted_targets`): its weights change from 1 to 0 within a few
mm where the σ crosses the bound, faster than any grid of the correction could follow. So the grid
holds the whole correction, smooth (the offline route's with ``bound = inf``: the identified
printer in Klipper's frame), and the weights are applied at each point after the interpolation,
from the calibration's σ grid, as the library computes them (:meth:`CorrectionField.applied`: the
module does the same arithmetic). :func:`curvature_bounds` bounds the applied correction's curvature (per
ring and layer, and per cell of the grid), what the module needs to cut long moves. Units: mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.ndimage import distance_transform_edt, maximum_filter

from .....calibration import Calibration, holds_of
from .....controller import CommandModel, corrected_targets
from .....controller.targets import printers_in_frame
from .....exceptions import AssemblyError, GeometryError, UnreachableError
from .....holds import DEFAULT_BOUND, WhereItHolds
from .....kinematics import exact
from ..model import SLOW_RATIO, KlipperDelta
from ..rotary_model import KlipperRotaryDelta

#: The grid's default spacing [mm] (its sampling error is measured and said at every export).
DEFAULT_STEP_MM = 10.0
#: Nodes beyond the volume (and beyond the last node the library corrects) whose values are the
#: correction itself: the interpolation at a point reads nodes up to 2 spacings away, and Klipper's
#: limits may be moved one spacing beyond the volume (:data:`COVERAGE_NODES`).
TRUST_NODES = 3
#: How far beyond the volume Klipper's limits may reach with the correction still exact, in nodes.
COVERAGE_NODES = 1
#: Nodes over which the correction is weighted down to 0 beyond those.
BLEND_NODES = 2
#: Calls of the library at most (each may name more refused points at a later check).
_TRIES = 8
#: The curvature of the applied correction is bounded from its values on a grid this many times finer
#: than the correction's (:func:`curvature_bounds`).
CURVATURE_REFINE = 4
#: The bound is this many times the largest second difference (:func:`curvature_bounds`): a second
#: difference at spacing f is the curvature averaged over ±f (a hat), and where the curvature jumps
#: (the smooth steps' ends, the interpolation's nodes) or gathers in a bend (the σ's trilinear
#: interpolation, its edges) the nearest fine node sees half of it or more.
CURVATURE_MARGIN = 2.0


@dataclass(frozen=True)
class LiveVolume:
    """The volume a program's moves reach: Klipper's limits on a move's end (its ``check_move``).

    Attributes:
        radius: The build radius [mm] (``min(print_radius, the arms' reach)``).
        min_z: The lowest Z (``minimum_z_position``) [mm].
        max_z: The highest Z (the lowest ``position_endstop``) [mm].
        limit_z: The Z above which the radius tapers [mm].
        delta_radius: ``delta_radius`` [mm] (the taper's).
        arm: The shortest ``arm_length`` [mm] (the taper's).
        slow_radius: Where Klipper halves a move's speed (a tower 3 times faster than XY) [mm].
        inner: What ``slow_radius`` is, in words; rim: what the correction does beyond it.
    """

    inner: ClassVar[str] = "where Klipper moves at full speed"
    rim: ClassVar[str] = "Klipper's model nears a flat rod there"

    radius: float
    min_z: float
    max_z: float
    limit_z: float
    delta_radius: float
    arm: float
    slow_radius: float

    @classmethod
    def of(cls, klipper: KlipperDelta) -> LiveVolume:
        """The volume of Klipper's values."""
        return cls(klipper.max_radius, klipper.minimum_z_position, klipper.max_z, klipper.limit_z,
                   klipper.delta_radius, float(np.min(klipper.arm_length)), klipper.ratio_radius(SLOW_RATIO))

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance of points from the volume's cylinder (0 inside), (N, 3) -> (N,) [mm]."""
        radial = np.maximum(np.hypot(points[:, 0], points[:, 1]) - self.radius, 0.0)
        vertical = np.maximum(np.maximum(self.min_z - points[:, 2], points[:, 2] - self.max_z), 0.0)
        return np.hypot(radial, vertical)

    def admits(self, points: np.ndarray) -> np.ndarray:
        """Which points Klipper admits as a move's end, (N, 3) -> (N,) bool (its taper included)."""
        radius = np.hypot(points[:, 0], points[:, 1])
        z = points[:, 2]
        allowed = np.where(z > self.limit_z, np.minimum(self.radius, self.taper(z)), self.radius)
        return (z >= self.min_z) & (z <= self.max_z) & (radius <= allowed)

    def taper(self, z: np.ndarray) -> np.ndarray:
        """The radius Klipper allows at heights z above ``limit_z`` (``delta.py``'s taper) [mm]."""
        above = np.maximum(z - self.limit_z, 0.0)
        return self.delta_radius - np.sqrt(np.maximum(self.arm**2 - (self.arm - above) ** 2, 0.0))

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """``count`` points spread uniformly over what Klipper admits, (count, 3) [mm]."""
        found: list[np.ndarray] = []
        while sum(len(p) for p in found) < count:
            r = self.radius * np.sqrt(rng.random(2 * count))
            a = 2.0 * np.pi * rng.random(2 * count)
            z = self.min_z + (self.max_z - self.min_z) * rng.random(2 * count)
            points = np.column_stack([r * np.cos(a), r * np.sin(a), z])
            found.append(points[self.admits(points)])
        return np.concatenate(found)[:count]


@dataclass(frozen=True)
class RotaryLiveVolume(LiveVolume):
    """The volume of Klipper's rotary delta (``rotary_delta.py``'s ``check_move``).

    Above ``limit_z`` the radius at most ``max_z − Z``; ``delta_radius`` and ``arm`` unused (0);
    ``slow_radius`` the printable radius (Klipper's rotary delta has no slower rim).
    """

    inner: ClassVar[str] = "the printable radius"
    rim: ClassVar[str] = "the arms near their reach there"

    @classmethod
    def of_rotary(cls, klipper: KlipperRotaryDelta, printable: float) -> RotaryLiveVolume:
        """The volume of Klipper's rotary values (its ``max_xy``, ``minimum_z_position`` to its top)."""
        return cls(klipper.max_radius, klipper.minimum_z_position, klipper.max_z, klipper.limit_z, 0.0, 0.0,
                   min(printable, klipper.max_radius))

    def taper(self, z: np.ndarray) -> np.ndarray:
        """The radius Klipper allows at heights z above ``limit_z``: ``max_z − Z`` [mm]."""
        return self.max_z - z


@dataclass(frozen=True, eq=False)
class CorrectionField:
    """The correction sampled at the nodes of a regular grid, and its interpolation.

    Attributes:
        origin: The first node [mm], (3,).
        step: The spacing of the nodes [mm].
        values: The correction at each node [mm], (nx, ny, nz, 3).
        volume: The volume it was built for.
        refused: Nodes within the trusted margin whose correction the library refused.
        computed: Nodes whose correction the library was asked for.
        holds: Where the calibration holds (its σ grid), or None: the correction applied wholly.
        bound: The σ of a correction accepted [mm] (``math.inf``: the whole correction everywhere).
    """

    origin: np.ndarray
    step: float
    values: np.ndarray
    volume: LiveVolume
    refused: int = 0
    computed: int = 0
    holds: WhereItHolds | None = None
    bound: float = DEFAULT_BOUND

    @property
    def shape(self) -> tuple[int, int, int]:
        """Nodes along x, y and z."""
        nx, ny, nz = self.values.shape[:3]
        return nx, ny, nz

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """The interpolated correction at points, (N, 3) -> (N, 3) [mm]; 0 beyond the grid.

        Catmull-Rom along each axis through the nodes ``i − 1 .. i + 2`` around a point: the live
        module's arithmetic (:meth:`.deltacal_geometry.CorrectionGrid.at`), vectorised.
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        u = (points - self.origin) / self.step
        cell = np.floor(u).astype(int)
        inside = np.all((u >= 1.0) & (u < np.array(self.shape) - 2.0), axis=1)
        out = np.zeros(points.shape)
        cell, t = cell[inside], u[inside] - cell[inside]
        w = [_catmull_rom_weights(t[:, k]) for k in range(3)]
        total = np.zeros((len(cell), 3))
        for a in range(4):
            for b in range(4):
                for c in range(4):
                    node = self.values[cell[:, 0] - 1 + a, cell[:, 1] - 1 + b, cell[:, 2] - 1 + c]
                    total += (w[0][:, a] * w[1][:, b] * w[2][:, c])[:, None] * node
        out[inside] = total
        return out

    def weights(self, points: np.ndarray, corrections: np.ndarray) -> np.ndarray:
        """The weights of the corrections' horizontal and vertical parts at points, (N, 2).

        :meth:`WhereItHolds.weights <deltacal.holds.WhereItHolds.weights>` with the field's bound
        (the offline route's, :func:`~deltacal.controller.weighted_targets`); ones without a σ
        grid or with an infinite bound (every correction applied).
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        if self.holds is None or not math.isfinite(self.bound):
            return np.ones((points.shape[0], 2))
        return self.holds.weights(points, self.bound, corrections)

    def applied(self, points: np.ndarray, corrections: np.ndarray | None = None) -> np.ndarray:
        """The correction the module applies at points: interpolated, then weighted, (N, 3) [mm].

        The horizontal part times its weight, the vertical part times its own (:meth:`weights` of
        the interpolated correction, ``corrections`` if given): the live module's
        :meth:`.deltacal_geometry.CorrectionGrid.correction`.
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        corrections = self(points) if corrections is None else corrections
        return self.weights(points, corrections)[:, [0, 0, 1]] * corrections


def _catmull_rom_weights(t: np.ndarray) -> np.ndarray:
    """The 4 weights of Catmull-Rom's cubic convolution at fractions t in [0, 1), (N,) -> (N, 4)."""
    t2, t3 = t * t, t * t * t
    return np.stack([0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2) + 1.0,
                     0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)], axis=-1)


def exact_correction(calibration: Calibration, controller: CommandModel, points: np.ndarray,
                     bound: float = math.inf) -> np.ndarray:
    """The library's correction ``command(x) − x`` at points, NaN rows where it refuses them, (N, 3).

    :func:`~deltacal.controller.corrected_targets` (the offline route's) with ``bound`` (by default
    the whole correction everywhere: what the grid holds), asked again without the points it
    refuses until it refuses none.
    """
    points = np.atleast_2d(np.asarray(points, dtype=float))
    out = np.full(points.shape, np.nan)
    todo = np.arange(len(points))
    for _ in range(_TRIES):
        if not todo.size:
            break
        try:
            out[todo] = corrected_targets(calibration, controller, points[todo], bound=bound).commands \
                - points[todo]
            return out
        except (UnreachableError, AssemblyError) as exc:
            if not exc.indices:
                raise
            todo = np.delete(todo, np.asarray(exc.indices, dtype=int))
    out[todo] = np.nan
    return out


def _continuation(calibration: Calibration, controller: CommandModel, points: np.ndarray) -> np.ndarray:
    """The same function where the library refuses points, unchecked, (N, 3); NaN where it has no value.

    The identified printer's exact inverse without its checks (a carriage a little above its
    endstop, a pose near a singularity) and the controller's forward model of those travels: used
    only to continue the field across the border of what the library corrects. The printer is the
    one the library corrects for: with a σ grid, in the controller's frame, along the bed the grid's
    ``along_bed`` printer when it has one (:func:`~deltacal.controller.targets.printers_in_frame`).
    """
    geometry = calibration.geometry if isinstance(calibration, Calibration) else calibration
    holds = holds_of(calibration)
    printers = [geometry] if holds is None else printers_in_frame(geometry, holds, controller)
    with np.errstate(invalid="ignore"):
        out = [controller.forward(exact.inverse(g, points, check=False), check=False) - points
               for g in printers]
    out[0][:, :2] = out[-1][:, :2]  # along the bed: WhereItHolds.along_bed's, when it has one
    return out[0]


def correction_field(calibration: Calibration, controller: CommandModel, volume: LiveVolume,
                     step: float = DEFAULT_STEP_MM, bound: float = DEFAULT_BOUND) -> CorrectionField:
    """The correction of Klipper's commands sampled on a grid over ``volume`` (see the module).

    Args:
        calibration: The calibration.
        controller: Klipper's model as a controller
            (:class:`~deltacal.printer.firmware.klipper.model.KlipperController`).
        volume: The volume the program's moves reach.
        step: The grid's spacing [mm].
        bound: The σ of a correction accepted [mm], where the calibration knows where it holds (the
            offline route's ``bound``; ``math.inf``: the whole correction everywhere).

    Raises:
        GeometryError: a spacing that is not a positive length, or a bound that is not positive.
        InputError: a printer's calibration that does not say where it holds (no ``[holds]``).
    """
    holds = holds_of(calibration)  # before anything is computed
    if not (np.isfinite(step) and step > 0.0):
        raise GeometryError(f"the grid's spacing must be a positive length, got {step!r}")
    if not bound > 0.0:
        raise GeometryError(f"the σ of a correction accepted must be positive, got {bound!r}")
    margin = (TRUST_NODES + BLEND_NODES + 2) * step  # trusted, blended, then the zeros the stencil reads
    reach = int(np.ceil((volume.radius + margin) / step))
    xy = np.arange(-reach, reach + 1) * step
    z = volume.min_z - margin + step * np.arange(int(np.ceil((volume.max_z - volume.min_z) / step + 2 * margin
                                                             / step)) + 1)
    flat = np.stack(np.meshgrid(xy, xy, z, indexing="ij"), axis=-1).reshape(-1, 3)
    shape = (len(xy), len(xy), len(z))
    beyond = volume.distance(flat) / step  # in nodes
    asked = beyond <= TRUST_NODES + BLEND_NODES
    values = np.full(flat.shape, np.nan)
    values[asked] = exact_correction(calibration, controller, flat[asked])
    known = np.all(np.isfinite(values), axis=1)
    values[asked & ~known] = _continuation(calibration, controller, flat[asked & ~known])
    continued = _continued(values.reshape(*shape, 3), np.all(np.isfinite(values), axis=1).reshape(shape))
    if np.any(known):  # extrapolated from a steep rim (a rotary Delta's reach) no larger than what is known
        largest = np.max(np.abs(values[known]), axis=0)
        clipped = np.clip(continued, -largest, largest)
        continued = np.where(known.reshape(shape)[..., None], continued, clipped)
    apart = distance_transform_edt(~known.reshape(shape)) if np.any(known) else np.full(shape, np.inf)
    held = _ramp(beyond.reshape(shape)) * _ramp(apart)
    refused = int(np.sum(asked & ~known & (beyond <= TRUST_NODES)))
    return CorrectionField(np.array([xy[0], xy[0], z[0]]), float(step), continued * held[..., None], volume,
                           refused, int(np.sum(asked)), holds, float(bound))


def _ramp(nodes_away: np.ndarray) -> np.ndarray:
    """1 up to :data:`TRUST_NODES` nodes away, a smoothstep down to 0 over :data:`BLEND_NODES` more."""
    s = np.clip(1.0 - (nodes_away - TRUST_NODES) / BLEND_NODES, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _continued(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """The known nodes' values continued over the others, (nx, ny, nz, 3).

    Layer by layer (as far as the blend reaches): a node next to known ones takes the mean of the
    linear extrapolations ``2 v1 − v2`` along the axes where two known nodes line up beside it,
    else of its known neighbours' values; the nodes beyond take their nearest continued node's.
    """
    values = np.where(known[..., None], values, 0.0)
    known = known.copy()
    for _ in range(TRUST_NODES + BLEND_NODES):
        line_sum, line_count = np.zeros(values.shape), np.zeros(known.shape)
        near_sum, near_count = np.zeros(values.shape), np.zeros(known.shape)
        for axis in range(3):
            for side in (1, -1):
                k1, v1 = _shifted(known, axis, side), _shifted(values, axis, side)
                k2, v2 = _shifted(known, axis, 2 * side), _shifted(values, axis, 2 * side)
                line = k1 & k2
                line_sum += np.where(line[..., None], 2.0 * v1 - v2, 0.0)
                line_count += line
                near_sum += np.where(k1[..., None], v1, 0.0)
                near_count += k1
        new = ~known & (near_count > 0)
        if not np.any(new):
            break
        mean = np.where((line_count > 0)[..., None], line_sum / np.maximum(line_count, 1)[..., None],
                        near_sum / np.maximum(near_count, 1)[..., None])
        values = np.where(new[..., None], mean, values)
        known = known | new
    if np.any(known) and not np.all(known):
        index = distance_transform_edt(~known, return_distances=False, return_indices=True)
        values = values[tuple(index)]
    return values


def _shifted(a: np.ndarray, axis: int, offset: int) -> np.ndarray:
    """``a`` moved so that each node sees its neighbour ``offset`` nodes along ``axis`` (False/0 beyond)."""
    out = np.zeros_like(a)
    n = a.shape[axis]
    if abs(offset) >= n:
        return out
    src, dst = [slice(None)] * a.ndim, [slice(None)] * a.ndim
    src[axis], dst[axis] = (slice(offset, n), slice(0, n - offset)) if offset > 0 else \
        (slice(0, n + offset), slice(-offset, n))
    out[tuple(dst)] = a[tuple(src)]
    return out


def curvature_bounds(field: CorrectionField, refine: int = CURVATURE_REFINE) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the applied correction's second derivative along any direction: per ring and layer, per cell.

    The applied correction (:meth:`CorrectionField.applied`: interpolated, then weighted where the
    calibration holds) is evaluated on a grid ``refine`` times finer than the field's over what
    Klipper admits: its weights turn from 1 to 0 within a few mm, and the σ's trilinear
    interpolation bends it at the σ grid's nodes, which the field's own nodes would not see. At each
    fine node, ``sqrt(Σ ‖H‖²)``, H each component's Hessian by finite differences at the fine
    spacing (its norm bounds the second derivative along any unit direction; across a bend, the
    slope's change over one fine spacing), times :data:`CURVATURE_MARGIN`.

    Per ring: ring k (radius k × step) and layer j (the field's z nodes) take the largest of the
    nodes at radius from k × step and heights from z_j up to z_{j+1}, then of their neighbours;
    non-decreasing outwards, so that a move's larger radius (one of its ends) and the layers of its
    heights give its bound. Shape (rings, nz).

    Per cell: the cell (i, j, k) of the field's grid (from node (i, j, k) to (i+1, j+1, k+1)) takes
    the largest of the fine nodes in it, then of its 26 neighbours' (a fine node's second difference
    sees ±1 fine spacing, into the next cell): the cells a move's box crosses give its bound, where
    the correction bends in one place only the moves near it are cut finely. Shape (nx-1, ny-1, nz-1).

    The chord of a segment of length s is then off the applied correction by at most s² K / 8: the
    module's cut of long moves (checked on random moves: tests/test_klipper_live.py).
    """
    h, volume = field.step, field.volume
    fine = h / refine
    low = np.array([-volume.radius, -volume.radius, volume.min_z]) - fine
    high = np.array([volume.radius, volume.radius, volume.max_z]) + fine
    first = np.floor((low - field.origin) / fine).astype(int)
    index = [np.arange(first[k], int(np.ceil((high[k] - field.origin[k]) / fine)) + 1) for k in range(3)]
    values = field.values
    for axis in range(3):  # Catmull-Rom is a tensor product: the field at the fine nodes, axis by axis
        values = _upsampled(values, axis, index[axis], refine)
    axes = [field.origin[k] + fine * index[k] for k in range(3)]
    nz = field.shape[2]
    rings = int(np.ceil(volume.radius / h)) + 2
    bound = np.zeros((rings, nz))
    cells = np.zeros(tuple(n - 1 for n in field.shape))
    width = 16  # x nodes per slab (and one on each side)
    for start in range(1, axes[0].size - 1, width):
        stop = min(start + width, axes[0].size - 1)
        nodes = np.stack(np.meshgrid(axes[0][start - 1:stop + 1], axes[1], axes[2], indexing="ij"), axis=-1)
        flat = nodes.reshape(-1, 3)
        applied = field.applied(flat, values[start - 1:stop + 1].reshape(-1, 3)).reshape(nodes.shape)
        norm = _hessian_norm(applied, fine)[1:-1, 1:-1, 1:-1].reshape(-1)
        inner = nodes[1:-1, 1:-1, 1:-1].reshape(-1, 3)
        admitted = volume.admits(inner)
        ring = np.minimum((np.hypot(inner[:, 0], inner[:, 1]) / h).astype(int), rings - 1)
        layer = np.clip(np.floor((inner[:, 2] - field.origin[2]) / h).astype(int), 0, nz - 1)
        np.maximum.at(bound, (ring[admitted], layer[admitted]), norm[admitted])
        cell = np.floor((inner[admitted] - field.origin) / h).astype(int)
        cell = np.clip(cell, 0, np.array(cells.shape) - 1)
        np.maximum.at(cells, tuple(cell.T), norm[admitted])
    return (CURVATURE_MARGIN * np.maximum.accumulate(maximum_filter(bound, size=3, mode="nearest"), axis=0),
            CURVATURE_MARGIN * maximum_filter(cells, size=3, mode="nearest"))


def _upsampled(values: np.ndarray, axis: int, index: np.ndarray, refine: int) -> np.ndarray:
    """Catmull-Rom along one axis at the fine nodes ``index`` (in fine spacings from the first node).

    The fine node m lies in the cell of node ``m // refine``, at the fraction ``(m % refine) / refine``
    across it; its value is the 4 nodes' around it, weighted (:func:`_catmull_rom_weights`).
    """
    cell, t = index // refine, (index % refine) / refine
    weights = _catmull_rom_weights(t)
    moved = np.moveaxis(values, axis, 0)
    out = np.zeros((index.size, *moved.shape[1:]))
    for k in range(4):
        out += weights[:, k].reshape(-1, *([1] * (moved.ndim - 1))) * moved[cell - 1 + k]
    return np.moveaxis(out, 0, axis)


def _hessian_norm(values: np.ndarray, spacing: float) -> np.ndarray:
    """``sqrt(Σ ‖H‖²)`` over the components by finite differences at the nodes of a grid, (nx, ny, nz).

    ``values`` (nx, ny, nz, 3) at the grid's spacing; at its outer nodes the differences read zeros.
    """
    v = values
    total = np.zeros(v.shape[:3])
    for a in range(3):
        for b in range(a, 3):
            if a == b:
                d = _shifted(v, a, 1) - 2.0 * v + _shifted(v, a, -1)
            else:
                d = 0.25 * (_shifted(_shifted(v, a, 1), b, 1) - _shifted(_shifted(v, a, 1), b, -1)
                            - _shifted(_shifted(v, a, -1), b, 1) + _shifted(_shifted(v, a, -1), b, -1))
            total += (1.0 if a == b else 2.0) * np.sum(d**2, axis=-1)
    return np.sqrt(total) / spacing**2


@dataclass(frozen=True)
class SamplingError:
    """How far the applied correction is from the offline route's exact one, at points off the grid [mm].

    Attributes:
        max: The largest distance, over the volume.
        rms: Its root mean square.
        max_full_speed: The largest within Klipper's slow radius (where it moves at full speed).
        points: Points compared (those the library corrects).
        refused: Points of the sample the library refuses (the field blends to 0 there).
    """

    max: float
    rms: float
    max_full_speed: float
    points: int
    refused: int


def sampling_error(field: CorrectionField, calibration: Calibration, controller: CommandModel,
                   count: int = 4000, seed: int = 41) -> SamplingError:
    """The applied correction against the offline route's at ``count`` points spread over its volume.

    The offline route's: :func:`~deltacal.controller.corrected_targets` with the field's bound (the
    correction weighted where the calibration holds, exactly); the field's: :meth:`CorrectionField.applied`.
    """
    points = field.volume.sample(count, np.random.default_rng(seed))
    exact_values = exact_correction(calibration, controller, points, field.bound)
    corrected = np.all(np.isfinite(exact_values), axis=1)
    points = points[corrected]
    error = np.linalg.norm(field.applied(points) - exact_values[corrected], axis=1)
    if not error.size:
        return SamplingError(float("nan"), float("nan"), float("nan"), 0, count)
    full = np.hypot(points[:, 0], points[:, 1]) <= field.volume.slow_radius
    return SamplingError(float(np.max(error)), float(np.sqrt(np.mean(error**2))),
                         float(np.max(error[full])) if np.any(full) else float("nan"), int(error.size),
                         int(count - error.size))
