"""The printed calibration object of a linear Delta printer: its features, their mesh and the probe grid.

A printer measures itself (conventions, "Linear Delta printers"): its probe triggers on the bed
(the probe grid, :func:`probe_grid`: the points of a Klipper round-bed mesh), and an object it
printed is measured with calipers. Probe heights see only the nozzle's height on the bed plane;
distances between features printed at several heights and in several directions see what they
cannot: each tower's XY scale (its step distance), the towers' leans (a lean shears the volume:
x' = x + s z changes no height and no horizontal distance, only a slanted one), the radius, the rods
and the effector's tilt.

The object (:func:`feature_mesh`, :func:`object_mesh`): separate ball-topped posts standing on
the bed, one per site. A feature is a ball of :data:`BALL_DIAMETER` whose centre is the commanded
nozzle position the distances refer to; below it a 45° cone (no overhang steeper than 45°), then a
post that widens down to a thin pad on the bed. Every part is a solid of revolution
(``trimesh.creation.revolve``), watertight on its own; the parts do not touch, so their union is
their concatenation, and the STL is in the printer's coordinates (mm, origin at the bed's centre,
z up): slice and print it where it stands, unmoved.

How the user measures a distance (the features' centres, 3-D): close the caliper's outside jaws
across the two balls, rock the caliper about the line joining them and read the largest value;
subtract the balls' diameter (each ball's diameter measured across its equator, the mean of the
two). Measure with the object still on the bed, once the bed is at room temperature. A pair is
offered only if the line between the centres rises at most :data:`MAX_ELEVATION` (the jaws touch
the spherical part, above the cone), the reading fits the caliper (:data:`CALIPER_RANGE`) and no
other post comes within :data:`CLEARANCE` of that line. Units: mm and rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...exceptions import PlanningError
from ...geometry import Workspace

if TYPE_CHECKING:
    import trimesh

#: Diameter of a feature's ball [mm].
BALL_DIAMETER = 10.0
#: Radius of the post where it meets the ball's cone [mm].
NECK_RADIUS = 2.5
#: How much a post's radius grows per mm down from its neck (a stiff post for a tall feature).
TAPER = 0.06
#: Thickness of the pad a post stands on [mm] and how far it reaches beyond the post's foot [mm].
PAD_THICKNESS = 0.6
PAD_MARGIN = 2.0
#: Height of the lowest features' centres [mm].
LOWEST_LEVEL = 8.0
#: Levels of features' centres, evenly from :data:`LOWEST_LEVEL` up to the top level.
LEVEL_COUNT = 4
#: The top level's height above the lowest, per mm of the caliper's range: slanted pairs across the
#: whole span must still fit the caliper. The factor was chosen on simulated printers (the figures:
#: docs/results.md, "The printed object's levels and caliper").
LEVEL_SPAN_PER_CALIPER = 0.55
#: Room left between the top ball and the printable height [mm].
TOP_MARGIN = 2.0
#: Longest outside-jaw reading of the caliper [mm]: a common 200 mm (8 in) caliper, whose longer,
#: taller pairs leave less error than a 150 mm one's (docs/results.md); ``plan --caliper 150`` plans
#: for the shorter one.
CALIPER_RANGE = 200.0
#: Steepest line between two measured centres [rad]: the jaws must touch the balls above their cones.
MAX_ELEVATION = math.radians(45.0)
#: Free space kept around the line between two measured centres [mm] (the caliper's jaws and beam).
CLEARANCE = 8.0
#: Gap kept between two neighbouring pads [mm].
PAD_GAP = 3.0
#: Facets about the axis of each part (the ball's outline is within 5 µm of a circle).
SECTIONS = 72
#: Most distances the object offers to measure (at most 40 caliper distances).
MAX_DISTANCES = 40


class CaliperTooShort(PlanningError):
    """The caliper is too short for the object (a longer one, ``plan --caliper``, would do)."""


# --------------------------------------------------------------------------- the probe grid
def probe_grid(radius: float, count: int = 7) -> np.ndarray:
    """Klipper's round-bed mesh: the points of a count × count grid over the disc of ``radius``.

    As ``[bed_mesh] mesh_radius`` and ``round_probe_count`` place them: a square grid centred on
    the bed with ``count`` points (odd) across the diameter, those within the radius kept (29 of
    7 × 7), row by row from −y. The commanded probe points at the bed's nominal height z = 0.

    Args:
        radius: The probed radius [mm] (the printable radius).
        count: Points across the diameter, odd, at least 3.

    Returns:
        (N, 3) [mm].
    """
    if count < 3 or count % 2 == 0:
        raise PlanningError(f"the probe grid needs an odd number of points across the bed, at least 3; "
                            f"got {count}")
    u = np.linspace(-radius, radius, count)
    y, x = np.meshgrid(u, u, indexing="ij")
    xy = np.column_stack([x.reshape(-1), y.reshape(-1)])
    keep = np.hypot(xy[:, 0], xy[:, 1]) <= radius * (1.0 + 1e-9)
    return np.column_stack([np.round(xy[keep], 3), np.zeros(int(keep.sum()))])  # to the micrometre


# --------------------------------------------------------------------------- the features
def levels(workspace: Workspace, caliper: float = CALIPER_RANGE) -> np.ndarray:
    """Heights of the features' centres [mm], (:data:`LEVEL_COUNT`,): evenly from the lowest to the top.

    The top is :data:`LEVEL_SPAN_PER_CALIPER` times the caliper's range above the lowest level, or
    lower where the printable height ends (room for the ball and :data:`TOP_MARGIN`).

    Raises:
        CaliperTooShort: the caliper's levels are less than a ball's diameter apart.
        PlanningError: the printable height leaves less than a ball's diameter between the levels.
    """
    room = workspace.height - TOP_MARGIN - 0.5 * BALL_DIAMETER
    top = min(LOWEST_LEVEL + LEVEL_SPAN_PER_CALIPER * caliper, room)
    if room >= LOWEST_LEVEL + BALL_DIAMETER and top < LOWEST_LEVEL + BALL_DIAMETER:
        raise CaliperTooShort(f"a caliper of {caliper:g} mm is too short for two feature levels (balls of "
                              f"{BALL_DIAMETER:g} mm)")
    if top < LOWEST_LEVEL + BALL_DIAMETER:
        raise PlanningError(f"the printable height {workspace.height:g} mm holds no two feature levels "
                            f"(balls of {BALL_DIAMETER:g} mm, the lowest centred at {LOWEST_LEVEL:g} mm)")
    return np.round(np.linspace(LOWEST_LEVEL, top, LEVEL_COUNT), 1)  # commanded to 0.1 mm


def footprint_radius(height: float) -> float:
    """Radius of the pad under a feature centred at ``height`` [mm]."""
    return _foot_radius(height) + PAD_MARGIN


def _neck_height(height: float) -> float:
    """Height where the ball's 45° cone meets the post [mm]."""
    r = 0.5 * BALL_DIAMETER
    tangent = r / math.sqrt(2.0)  # the cone is tangent to the ball at latitude −45°
    return height - tangent - (tangent - NECK_RADIUS)


def _foot_radius(height: float) -> float:
    return NECK_RADIUS + TAPER * max(_neck_height(height) - PAD_THICKNESS, 0.0)


@dataclass(frozen=True)
class ObjectLayout:
    """Where the object's features may stand: sites on the bed, levels above it.

    One feature per site is printed; a candidate feature is a (site, level). Sites: the centre,
    a ring of 6 halfway out (between the towers' directions and across them) and a rim of 12 every
    30° (the towers' directions, across them and between).

    Attributes:
        sites: Sites on the bed (x, y) [mm], (S, 2).
        levels: Heights of the features' centres [mm], (L,).
    """

    sites: np.ndarray
    levels: np.ndarray

    @property
    def centres(self) -> np.ndarray:
        """Every candidate feature's centre, site-major [mm], (S L, 3)."""
        s, lv = self.site_of, self.level_of
        return np.column_stack([self.sites[s], self.levels[lv]])

    @property
    def site_of(self) -> np.ndarray:
        """The site of each candidate feature, (S L,)."""
        return np.repeat(np.arange(len(self.sites)), len(self.levels))

    @property
    def level_of(self) -> np.ndarray:
        """The level of each candidate feature, (S L,)."""
        return np.tile(np.arange(len(self.levels)), len(self.sites))


def object_layout(workspace: Workspace, tower_azimuth: np.ndarray,
                  caliper: float = CALIPER_RANGE, top: float | None = None) -> ObjectLayout:
    """The sites and levels of the object for a printable cylinder.

    Args:
        workspace: The printable cylinder (radius, height from the bed up).
        tower_azimuth: The towers' azimuths [rad], (3,): the rims' sites start at tower A.
        caliper: The caliper's longest outside reading [mm] (:func:`levels`).
        top: The top level at most [mm] (None: as the caliper and the pads allow).
    """
    heights = levels(workspace, caliper)
    highest = float(heights[-1]) if top is None else min(float(heights[-1]), top)
    if not _pads_fit(workspace.radius, highest):
        highest = tallest_fitting(workspace.radius, highest)
    if highest < heights[-1]:
        heights = np.round(np.linspace(LOWEST_LEVEL, highest, LEVEL_COUNT), 1)
    pad = footprint_radius(float(heights[-1]))
    if not _pads_fit(workspace.radius, float(heights[-1])) or heights[-1] < LOWEST_LEVEL + BALL_DIAMETER:
        raise PlanningError(f"the printable radius {workspace.radius:g} mm is too small for the object "
                            f"(pads of {2.0 * pad:.3g} mm across)")
    rim = workspace.radius - max(pad, 0.5 * BALL_DIAMETER)
    middle = 0.5 * rim
    start = float(tower_azimuth[0])
    outer = start + np.radians(np.arange(0.0, 360.0, 30.0))
    inner = start + np.radians(np.arange(30.0, 360.0, 60.0))
    sites = np.vstack([np.zeros((1, 2)), middle * np.column_stack([np.cos(inner), np.sin(inner)]),
                       rim * np.column_stack([np.cos(outer), np.sin(outer)])])
    return ObjectLayout(sites=np.round(sites, 3), levels=heights)  # commanded to the micrometre


def _pads_fit(radius: float, top: float) -> bool:
    """Whether the pads of features up to ``top`` [mm] stand in a ring halfway between the centre and rim."""
    pad = footprint_radius(top)
    return 0.5 * (radius - max(pad, 0.5 * BALL_DIAMETER)) >= 2.0 * pad + PAD_GAP


def tallest_fitting(radius: float, top: float) -> float:
    """The highest top level up to ``top`` whose pads fit a printable radius [mm], to 0.1 mm below.

    A pad widens with its feature's height (:func:`footprint_radius`): on a small bed (a rotary
    printer's ``[delta_calibrate] radius`` of 50 mm) the object stands lower than the caliper allows
    (:func:`levels`), and the calibration holds lower. Below the two lowest levels' room: that room.
    """
    low, high = LOWEST_LEVEL + BALL_DIAMETER, top
    if _pads_fit(radius, high) or not _pads_fit(radius, low):
        return high if _pads_fit(radius, high) else low
    for _ in range(60):  # bisection: the pads widen with the top
        middle = 0.5 * (low + high)
        low, high = (middle, high) if _pads_fit(radius, middle) else (low, middle)
    return math.floor(low * 10.0) / 10.0


def candidate_pairs(layout: ObjectLayout, caliper: float = CALIPER_RANGE) -> np.ndarray:
    """Pairs of candidate features a caliper can measure, (P, 2) indices into ``layout.centres``.

    Two features on different sites, whose reading (centre distance plus a ball) fits the caliper
    and whose line rises at most :data:`MAX_ELEVATION`.
    """
    c = layout.centres
    i, j = np.triu_indices(len(c), k=1)
    d = c[j] - c[i]
    length = np.linalg.norm(d, axis=1)
    horizontal = np.hypot(d[:, 0], d[:, 1])
    keep = ((layout.site_of[i] != layout.site_of[j]) & (length + BALL_DIAMETER <= caliper)
            & (np.abs(d[:, 2]) <= np.tan(MAX_ELEVATION) * horizontal + 1e-9))
    return np.column_stack([i[keep], j[keep]])


def blocking(layout: ObjectLayout, pairs: np.ndarray, samples: int = 40) -> np.ndarray:
    """Which candidate features would stand in the way of each pair's measurement, (P, F) bool.

    A feature blocks a pair if its ball, cone or post comes within :data:`CLEARANCE` of the line
    between the pair's centres (extended by a ball's radius at both ends, where the jaws close).
    Features on the pair's own sites never block it (their posts stand below the jaws' contacts).
    """
    c = layout.centres
    r = 0.5 * BALL_DIAMETER
    a, b = c[pairs[:, 0]], c[pairs[:, 1]]
    u = (b - a) / np.linalg.norm(b - a, axis=1)[:, None]
    t = np.linspace(0.0, 1.0, samples)
    line = (a - r * u)[:, None, :] + t[None, :, None] * ((b + r * u) - (a - r * u))[:, None, :]  # (P, T, 3)
    height = c[:, 2]
    foot = np.array([_foot_radius(float(h)) for h in height])
    neck = np.array([_neck_height(float(h)) for h in height])
    out = np.zeros((len(pairs), len(c)), dtype=bool)
    for f in range(len(c)):  # per feature (at most a few hundred), vectorised over pairs and samples
        dxy = np.hypot(line[..., 0] - c[f, 0], line[..., 1] - c[f, 1])
        z = line[..., 2]
        ball = np.hypot(dxy, z - height[f]) - r
        along = np.clip(z / max(neck[f], 1e-9), 0.0, 1.0)  # the post narrows linearly to its neck
        post_radius = np.where(z <= neck[f], foot[f] + (NECK_RADIUS - foot[f]) * along, r)
        post = np.where(z <= height[f], dxy - post_radius, np.inf)
        out[:, f] = np.min(np.minimum(ball, post), axis=1) < CLEARANCE
    own = (layout.site_of[None, :] == layout.site_of[pairs[:, 0]][:, None]) | (
        layout.site_of[None, :] == layout.site_of[pairs[:, 1]][:, None])
    return out & ~own


# --------------------------------------------------------------------------- the mesh
def feature_profile(height: float) -> np.ndarray:
    """The outline (radius, z) of a feature centred at ``height``, from the axis on the bed to the ball's top.

    Pad, tapered post, 45° cone, then the ball's arc from latitude −45° over the top [mm], (K, 2).
    """
    r = 0.5 * BALL_DIAMETER
    foot = _foot_radius(height)
    neck = _neck_height(height)
    tangent = r / math.sqrt(2.0)
    arc = np.linspace(-0.25 * math.pi, 0.5 * math.pi, 28)
    points = [(0.0, 0.0), (foot + PAD_MARGIN, 0.0), (foot + PAD_MARGIN, PAD_THICKNESS), (foot, PAD_THICKNESS)]
    if neck > PAD_THICKNESS:
        points.append((NECK_RADIUS, neck))
    points.append((tangent, height - tangent))
    points += [(r * math.cos(a), height + r * math.sin(a)) for a in arc[1:-1]]
    points.append((0.0, height + r))
    return np.array(points)


def feature_mesh(centre: np.ndarray, sections: int = SECTIONS) -> trimesh.Trimesh:
    """One feature as a watertight solid of revolution standing on the bed under ``centre`` [mm]."""
    from trimesh.creation import revolve

    centre = np.asarray(centre, dtype=float)
    transform = np.eye(4)
    transform[:2, 3] = centre[:2]
    return revolve(feature_profile(float(centre[2])), sections=sections, transform=transform)


def object_mesh(centres: np.ndarray, sections: int = SECTIONS) -> trimesh.Trimesh:
    """The object: a feature at each centre, the parts side by side (their union, none touching) [mm]."""
    import trimesh

    parts = [feature_mesh(c, sections) for c in np.atleast_2d(centres)]
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh
