"""The labels of the printed object's balls: their names and where each one's tile lies on the bed.

Each ball is named by a number, 1 to N in the order of the plan's features, and its name is printed
beside it (:mod:`.lettering`: a tile on the bed with the digits raised, reading from the printer's
front). The tile lies beside the ball's pad, not touching it nor any other pad or tile, within the
printable radius, nearer its own ball than any other; the features are unchanged, so the distances
are. Among the places that fit (around the pad every 15°), the tile goes where it is furthest
from the lines the caliper measures (projected on the bed, within :data:`LINE_CLEARANCE`), then as
near the direction of the bed's centre as possible. Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...exceptions import PlanningError
from .lettering import label_mesh, text_size
from .object import BALL_DIAMETER, footprint_radius

if TYPE_CHECKING:
    import trimesh

#: Gap kept between a label's tile and any pad or other tile [mm].
LABEL_GAP = 1.5
#: Distance from a measured line (projected on the bed) beyond which a tile is out of the caliper's way [mm].
LINE_CLEARANCE = 12.0
#: Directions tried around a pad.
DIRECTIONS = 24


@dataclass(frozen=True)
class BallLabel:
    """A ball's name and its tile on the bed.

    Attributes:
        name: The name printed (``"1"`` ...).
        ball: The ball's index in the plan's features.
        centre: The tile's centre (x, y) [mm], (2,).
        size: The tile's width (along x) and depth (along y) [mm], (2,).
    """

    name: str
    ball: int
    centre: np.ndarray
    size: np.ndarray

    @property
    def corners(self) -> np.ndarray:
        """The tile's lowest and highest (x, y) [mm], (2, 2)."""
        return np.array([self.centre - 0.5 * self.size, self.centre + 0.5 * self.size])

    def mesh(self) -> trimesh.Trimesh:
        """The tile with the name raised on it (:func:`~.lettering.label_mesh`)."""
        return label_mesh(self.name, self.centre)


def ball_names(count: int) -> list[str]:
    """The names of ``count`` balls: ``"1"`` to ``str(count)``."""
    return [str(k + 1) for k in range(count)]


def _rectangle_distance(points: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Distance from each point (x, y) to an axis-aligned rectangle (0 inside) [mm], (N,)."""
    outside = np.maximum(np.maximum(low - points, points - high), 0.0)
    return np.hypot(outside[:, 0], outside[:, 1])


def _segment_distance(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from a point to segments a-b on the bed [mm], (M,)."""
    d = b - a
    along = np.einsum("mk,mk->m", point - a, d) / np.maximum(np.einsum("mk,mk->m", d, d), 1e-12)
    t = np.clip(along, 0.0, 1.0)
    return np.linalg.norm(a + t[:, None] * d - point, axis=1)


class NoLabelRoom(PlanningError):
    """A ball's label finds no room on the bed (the pads and labels crowd a small one)."""


def place_labels(features: np.ndarray, pairs: np.ndarray, radius: float) -> tuple[BallLabel, ...]:
    """Where each ball's label lies (:class:`BallLabel`, in the order of ``features``).

    Args:
        features: The balls' centres [mm], (F, 3).
        pairs: The measured pairs, indices into ``features``, (M, 2).
        radius: The printable radius [mm].

    Raises:
        NoLabelRoom: a ball has no room for its label.
    """
    sites = np.asarray(features, dtype=float)[:, :2]
    pads = np.array([footprint_radius(float(z)) for z in features[:, 2]])
    # the measured lines on the bed, each extended beyond its balls by a ball (where the jaws close)
    a, b = sites[pairs[:, 0]], sites[pairs[:, 1]]
    u = (b - a) / np.maximum(np.linalg.norm(b - a, axis=1), 1e-12)[:, None]
    a, b = a - BALL_DIAMETER * u, b + BALL_DIAMETER * u
    angles = np.radians(np.arange(DIRECTIONS) * 360.0 / DIRECTIONS)
    placed: list[BallLabel] = []
    for f, (name, site) in enumerate(zip(ball_names(len(sites)), sites, strict=True)):
        size = text_size(name)
        toward_centre = np.arctan2(-site[1], -site[0]) if np.hypot(*site) > 1e-9 else -0.5 * np.pi
        best, best_score = None, (-np.inf, -np.inf)
        for angle in angles:
            direction = np.array([np.cos(angle), np.sin(angle)])
            # the tile's support along the direction, and a micrometre that its rounding cannot take back
            reach = pads[f] + LABEL_GAP + 0.5 * float(np.abs(direction) @ size) + 1e-3
            centre = np.round(site + reach * direction, 3)
            label = BallLabel(name, f, centre, size)
            if not _fits(label, sites, pads, placed, radius):
                continue
            score = (min(float(_segment_distance(centre, a, b).min(initial=np.inf)), LINE_CLEARANCE),
                     -abs(float(np.angle(np.exp(1j * (angle - toward_centre))))))
            if score > best_score:
                best, best_score = label, score
        if best is None:
            raise NoLabelRoom(f"no room on the bed for the label of ball {name} at "
                              f"({site[0]:g}, {site[1]:g}) mm")
        placed.append(best)
    return tuple(placed)


def _fits(label: BallLabel, sites: np.ndarray, pads: np.ndarray, placed: list[BallLabel],
          radius: float) -> bool:
    """The tile within the printable radius, clear of every pad and tile, nearest its own ball."""
    low, high = label.corners
    corners = np.array([[x, y] for x in (low[0], high[0]) for y in (low[1], high[1])])
    if np.max(np.hypot(corners[:, 0], corners[:, 1])) > radius:
        return False
    others = np.arange(len(sites)) != label.ball
    if np.any(_rectangle_distance(sites[others], low, high) < pads[others] + LABEL_GAP):
        return False
    for other in placed:
        o_low, o_high = other.corners
        if np.all(low < o_high + LABEL_GAP) and np.all(o_low < high + LABEL_GAP):
            return False
    distance = np.linalg.norm(sites - label.centre, axis=1)
    return bool(np.all(distance[others] > distance[label.ball]))


def labels_mesh(labels: tuple[BallLabel, ...] | list[BallLabel]) -> trimesh.Trimesh:
    """Every label's tile, side by side (none touching) [mm]."""
    import trimesh

    mesh = trimesh.util.concatenate([label.mesh() for label in labels])
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh
