"""Where a printer's calibration holds: the predicted σ of its nozzle correction over the printable volume.

A printer's measurements (probe heights, distances of a printed object) determine its nozzle well
where they were made and less well away from them: seven probe heights and a flat object's
distances, all at the bed, say little of the nozzle 100 mm up. Identification gives the covariance
of the printer's parameters; propagated through the exact nozzle sensitivity at the readings that
command each point (in the controller's frame: the shift along the bed and the turn about its
normal that no measurement sees are taken out, :data:`BED_POINTS`), it is the covariance of where a
corrected command puts the nozzle. :class:`WhereItHolds` carries it on a cylindrical grid over the
printable volume (its σ along the bed, the larger principal σ of the horizontal part, and its σ in
height), so that ``compensate``, ``export``, the report and the live Klipper module read the same
answer, interpolated the same way (:meth:`WhereItHolds.sigma`: trilinear in radius, azimuth and
height, held at the grid's edges: continuous everywhere).

A correction is applied where it holds: its weight (:func:`correction_weight`) is 1 where its σ is
at most half the bound a printer's owner accepts (:data:`DEFAULT_BOUND`), 0 from the bound on (the
controller's own command), and a smooth step between, so consecutive commands never jump. The
horizontal and the vertical part of a correction have their own σ and weight: a first layer's
height is known from the probe heights long before its place along the bed is.

Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .geometry import DeltaGeometry, Workspace

#: The σ of a correction a printer's owner accepts by default [mm]: a correction whose σ is above it
#: is not applied (the controller's own command is sent there).
DEFAULT_BOUND = 0.05
#: Grid of a :class:`WhereItHolds`: radii (from the centre to the printable radius) and azimuths.
GRID_RADII, GRID_AZIMUTHS = 7, 12
#: Grid heights [mm] up to the printable top (the top itself added): dense near the bed, where the
#: σ grows fastest.
GRID_HEIGHTS = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 35.0, 50.0, 75.0, 100.0, 150.0, 200.0, 300.0, 400.0,
                500.0)
#: Where the frame along the bed is fixed: the first layer, a ring at each of these fractions of the
#: printable radius (and the centre). No measurement sees a printer shifted along its bed or turned
#: about its normal; the correction's mean shift and turn over these points are zero.
BED_POINTS = (0.25, 0.5, 0.75, 1.0)
#: Points on each ring of :data:`BED_POINTS`.
BED_RING = 12
#: The first layer's height [mm].
FIRST_LAYER = 0.2
#: A firmware's value is determined by the measurements when its σ after them is at most this share of
#: its σ from the build tolerances alone (:meth:`WhereItHolds.determined`).
DETERMINED = 1.0 / 3.0
#: From this many times its σ a correction along the bed is applied less 1.5 σ (:func:`significance_weight`).
SIGNIFICANT = 2.0
#: A measured layer thinner than this is "at one height" [mm]: its data cannot tell heights apart.
ONE_LAYER_MM = 25.0
#: The σ a node the printer cannot reach is given [mm]: no correction there, and the interpolation stays
#: finite (continuous) next to it.
UNREACHED = 1000.0


def in_plane_motion(points: np.ndarray) -> np.ndarray:
    """Nozzle displacement per unit shift along the bed (x, y) and turn about its normal (z) [rad], (N, 3, 3).

    No probe height and no printed distance sees a printer shifted along its bed or turned about
    its normal, and a part printed so is the same part: the gauge of a printer's errors.
    """
    points = np.atleast_2d(points)
    A = np.zeros((points.shape[0], 3, 3))
    A[:, 0, 0] = A[:, 1, 1] = 1.0
    A[:, 0, 2], A[:, 1, 2] = -points[:, 1], points[:, 0]
    return A


def bed_points(radius: float) -> np.ndarray:
    """The first layer's points that fix the frame along the bed (:data:`BED_POINTS`) [mm], (K, 3)."""
    phi = 2.0 * np.pi * np.arange(BED_RING) / BED_RING
    ring = np.column_stack([np.cos(phi), np.sin(phi)])
    rings = [np.zeros((1, 2))] + [f * radius * ring for f in BED_POINTS]
    xy = np.concatenate(rings)
    return np.column_stack([xy, np.full(len(xy), FIRST_LAYER)])


def grid_heights(top: float) -> np.ndarray:
    """The grid's heights up to ``top`` [mm] (:data:`GRID_HEIGHTS` below it, then the top)."""
    below = [z for z in GRID_HEIGHTS if z < top]
    return np.array(below + [float(top)])


def correction_weight(sigma: np.ndarray, bound: float) -> np.ndarray:
    """How much of a correction of σ ``sigma`` is applied: 1 up to half the bound, 0 from it, smooth between.

    A smooth step (``1 − 3t² + 2t³``, t from 0 at ``bound / 2`` to 1 at ``bound``): continuous, with
    a continuous slope. An infinite or NaN σ has weight 0.
    """
    sigma = np.asarray(sigma, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):  # an infinite σ: weight 0
        t = np.clip((np.nan_to_num(sigma, nan=np.inf) - 0.5 * bound) / (0.5 * bound), 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def significance_weight(size: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """How much of a correction of this size and σ is applied: 0 up to its σ, then what stands out of it.

    A correction no larger than its own σ is not determined by the measurements (zero is as
    probable), and applying it trades the controller's error for the correction's. Beyond its σ the
    part applied is what stands out of it, eased in: the applied size is ``σ f(size / σ)``, ``f(u)``
    0 up to 1, ``(u − 1)² / (2 (S − 1))`` up to S = :data:`SIGNIFICANT`, then ``u − (1 + S) / 2``:
    continuous with its slope, and never growing faster than the correction itself (slope at most
    1), so that a correction that grows across the bed is not switched on within a few mm (a step
    in the printed layer). The weight is ``f(u) / u``.
    """
    sigma = np.maximum(np.asarray(sigma, dtype=float), 1e-12)
    u = np.asarray(size, dtype=float) / sigma
    width = SIGNIFICANT - 1.0
    eased = np.where(u < SIGNIFICANT, np.clip(u - 1.0, 0.0, None) ** 2 / (2.0 * width), u - 1.0 - 0.5 * width)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(u > 1.0, eased / np.where(u > 1.0, u, 1.0), 0.0)


@dataclass(frozen=True)
class WhereItHolds:
    """The σ of a printer's nozzle correction on a cylindrical grid over its printable volume.

    Attributes:
        radius: The grid's radii, from 0 to the printable radius [mm], (R,).
        azimuth: Its azimuths, evenly over a turn from 0 [rad], (A,).
        height: Its heights, increasing from the bed [mm], (Z,).
        horizontal: σ of the correction along the bed (the larger principal σ of its x, y) [mm],
            (R, A, Z); :data:`UNREACHED` where the printer cannot reach.
        vertical: σ of the correction's height [mm], (R, A, Z).
        measured_top: The highest point a measurement was made at [mm] (where the data stop).
        values: The firmware's classical values (``delta_radius``, ``angle_a``, ``arm_length_a``,
            ``endstop_a``, ``scale_a``...: the ``klipper`` error model's names, which every
            firmware's values are), each with the ratio of its σ after the measurements to its σ
            from the build tolerances alone (:meth:`determined`).
        along_bed: The printer a correction along the bed follows, or None (the identified one):
            when the start was the firmware's values fitted to the same measurements (a saved
            ``DELTA_CALIBRATE``), the start moved only along the parameters' combinations the
            measurements determine (their σ after them at most :data:`DETERMINED` of the prior's:
            :func:`~deltacal.printer.identification.fit.determined_values`); the height follows the
            identified printer.
    """

    radius: np.ndarray
    azimuth: np.ndarray
    height: np.ndarray
    horizontal: np.ndarray
    vertical: np.ndarray
    measured_top: float = 0.0
    values: dict[str, float] = field(default_factory=dict)
    along_bed: DeltaGeometry | None = None

    def determined(self, ratio: float = DETERMINED) -> tuple[str, ...]:
        """The firmware's values the measurements determine: their σ at most ``ratio`` of the tolerances'."""
        return tuple(name for name, r in self.values.items() if r <= ratio)

    def undetermined(self, ratio: float = DETERMINED) -> tuple[str, ...]:
        """The firmware's values only the build tolerances bound (:meth:`determined`'s others)."""
        return tuple(name for name, r in self.values.items() if not r <= ratio)

    def __post_init__(self) -> None:
        for name in ("radius", "azimuth", "height"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        for name in ("horizontal", "vertical"):  # a node out of reach: UNREACHED, finite
            value = np.asarray(getattr(self, name), dtype=float)
            held = np.where(np.isfinite(value), np.minimum(value, UNREACHED), UNREACHED)
            object.__setattr__(self, name, held)
        shape = (self.radius.size, self.azimuth.size, self.height.size)
        if self.horizontal.shape != shape or self.vertical.shape != shape:
            raise ValueError(f"σ grids of shapes {self.horizontal.shape} and {self.vertical.shape} for a "
                             f"grid of {shape}")
        if (self.radius.size < 2 or self.height.size < 2 or self.azimuth.size < 1
                or np.any(np.diff(self.radius) <= 0.0) or np.any(np.diff(self.height) <= 0.0)):
            raise ValueError("a grid needs increasing radii and heights, two of each at least")

    @classmethod
    def grid(cls, radius: float, top: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The grid's radii, azimuths and heights for a printable cylinder [mm, rad]."""
        return (np.linspace(0.0, radius, GRID_RADII), 2.0 * np.pi * np.arange(GRID_AZIMUTHS) / GRID_AZIMUTHS,
                grid_heights(top))

    @property
    def printable_radius(self) -> float:
        """The printable radius [mm]: the grid's first :data:`GRID_RADII` radii span it (:meth:`grid`).

        The rings beyond, if any, go out to where the controller still moves the nozzle (a rotary
        printer's: :func:`~deltacal.printer.identification.where.where_it_holds`'s ``reach``).
        """
        return float(self.radius[min(GRID_RADII, self.radius.size) - 1])

    @staticmethod
    def nodes(radius: np.ndarray, azimuth: np.ndarray, height: np.ndarray) -> np.ndarray:
        """The grid's points, in the order of the σ arrays (radius, azimuth, height) [mm], (R·A·Z, 3)."""
        r, a, z = np.meshgrid(radius, azimuth, height, indexing="ij")
        return np.column_stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel(), z.ravel()])

    def sigma(self, points: np.ndarray) -> np.ndarray:
        """σ of the correction at points, along the bed and in height [mm], (N, 2).

        Trilinear in radius, azimuth (periodic) and height; a point beyond the grid takes its
        edge's value (continuous everywhere).
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        r = np.hypot(points[:, 0], points[:, 1])
        phi = np.mod(np.arctan2(points[:, 1], points[:, 0]), 2.0 * np.pi)
        ir, fr = _cell(self.radius, r)
        iz, fz = _cell(self.height, points[:, 2])
        step = 2.0 * np.pi / self.azimuth.size
        ia = np.floor((phi - self.azimuth[0]) / step).astype(int) % self.azimuth.size
        fa = np.clip((phi - self.azimuth[ia]) / step % 1.0, 0.0, 1.0)
        out = np.zeros((points.shape[0], 2))
        for k, grid in enumerate((self.horizontal, self.vertical)):
            total = np.zeros(points.shape[0])
            for dr, wr in ((0, 1.0 - fr), (1, fr)):
                for da, wa in ((0, 1.0 - fa), (1, fa)):
                    for dz, wz in ((0, 1.0 - fz), (1, fz)):
                        total += wr * wa * wz * grid[ir + dr, (ia + da) % self.azimuth.size, iz + dz]
            out[:, k] = total
        return out

    def weights(self, points: np.ndarray, bound: float = DEFAULT_BOUND,
                corrections: np.ndarray | None = None) -> np.ndarray:
        """The weights of the correction's horizontal and vertical parts, (N, 2).

        :func:`correction_weight` of each part's σ against ``bound``; with the corrections of a
        calibration measured at one height (:attr:`bed_level`), the horizontal part's times
        :func:`significance_weight` of its size against its σ: the probe measures heights, and a
        correction along the bed from bed-level data comes through the model's coupling of the
        towers' leans and positions with the heights, applied only where it stands out of its own σ.
        Measured over the volume (a printed object's levels), the correction along the bed is measured
        at each height and applied whole where it holds: on 24 simulated Kossels with deltacal's
        planned object and effects its model lacks (a probe bias, a bed bowl, an object printed
        small), the significance weighting left the largest 3-D error larger on 19 and the change of
        the error between points 10 mm apart larger on all 24 (0.010-0.043 mm against 0.004-0.014).

        Args:
            points: Targets [mm], (N, 3).
            bound: The σ of a correction accepted [mm].
            corrections: The whole corrections there (command − target) [mm], (N, 3), or None.
        """
        sigma = self.sigma(points)
        weights = correction_weight(sigma, bound)
        if corrections is not None and self.bed_level:
            corrections = np.atleast_2d(np.asarray(corrections, dtype=float))
            along = np.hypot(corrections[:, 0], corrections[:, 1])
            weights[:, 0] = weights[:, 0] * significance_weight(along, sigma[:, 0])
        return weights

    @property
    def bed_level(self) -> bool:
        """Whether its measurements are all at one height (the highest below :data:`ONE_LAYER_MM`)."""
        return self.measured_top < ONE_LAYER_MM

    def level_sigma(self, radius: float = math.inf) -> np.ndarray:
        """The largest 3-D σ (``√(σ_h² + σ_v²)``) at each height of the grid within ``radius`` [mm], (Z,)."""
        inside = self.radius <= radius * (1.0 + 1e-9)
        return np.max(np.hypot(self.horizontal, self.vertical)[inside], axis=(0, 1))

    def held_up_to(self, bound: float = DEFAULT_BOUND, radius: float = math.inf) -> float:
        """The height up to which the 3-D σ stays within ``bound`` over ``radius`` [mm] (-inf: nowhere).

        Linear between the grid's heights; its top when it holds everywhere.
        """
        level = self.level_sigma(radius)
        over = np.flatnonzero(~(level <= bound))
        if not over.size:
            return float(self.height[-1])
        k = int(over[0])
        if k == 0:
            return -math.inf
        lo, hi = level[k - 1], level[k]
        t = (bound - lo) / (hi - lo) if hi > lo else 0.0
        return float(self.height[k - 1] + t * (self.height[k] - self.height[k - 1]))

    def held_volume(self, within: Workspace, bound: float = DEFAULT_BOUND) -> Workspace | None:
        """The part of a printable cylinder where the nozzle's σ stays within ``bound`` (None: none of it).

        Its radius is :meth:`held_radius`'s, its top :meth:`held_up_to`'s over that radius (at least
        the first layer's height), each within ``within``'s.
        """
        radius = min(self.held_radius(bound), within.radius)
        if not radius > 0.0:
            return None
        top = min(max(self.held_up_to(bound, radius), FIRST_LAYER), within.top_z)
        return Workspace(radius=radius, height=top, top_z=top)

    def held_radius(self, bound: float = DEFAULT_BOUND) -> float:
        """The largest grid radius where the first layer's 3-D σ stays within ``bound`` [mm] (-inf: none)."""
        held = [r for r in self.radius if self.held_up_to(bound, float(r)) >= FIRST_LAYER]
        return float(max(held)) if held else -math.inf


def _cell(nodes: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid cell of each value (its lower node's index) and the fraction across it, held at the edges."""
    held = np.clip(values, nodes[0], nodes[-1])
    index = np.clip(np.searchsorted(nodes, held, side="right") - 1, 0, nodes.size - 2)
    fraction = (held - nodes[index]) / (nodes[index + 1] - nodes[index])
    return index, np.clip(fraction, 0.0, 1.0)
