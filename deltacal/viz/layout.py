"""Layout of a scene: camera framing, callouts, the legend, text blocks."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import (
    DeltaGeometry,
    rotation_from_vector,
)
from ._meshcat import import_meshcat
from .meshes import MM, arrow_mesh, mesh_transform, text_objects
from .state import RobotState, error_colours, nice_number
from .writer import SceneWriter, drawn_sizes, plate_polygon

#: Window size of the rendered screenshots [px].
DEFAULT_WINDOW = (1200, 900)


#: Size factor of the inset that shows both plates magnified.
INSET_MAGNIFICATION = 3.0


#: Vertical field of view of the scene's camera [deg].
CAMERA_FOV = 35.0


#: Camera direction: azimuth about z from x and elevation above the horizon [deg].
CAMERA_AZIMUTH = -55.0


CAMERA_ELEVATION = 18.0


def words(geometry: DeltaGeometry) -> tuple[str, str]:
    """What the scene calls the plate and the TCP: a rotary Delta's, or a printer's effector and nozzle."""
    return geometry.chain.words.plate, geometry.chain.words.tcp


# ==================================================================================== the scene
@dataclass(frozen=True)
class CameraView:
    """The scene's initial camera, in the robot's base frame {O}.

    Attributes:
        target: Point looked at [mm] (placed at the viewer's origin).
        direction: Unit vector from the target towards the camera.
        distance: Camera distance from the target [mm].
        fov: Vertical field of view [deg].
    """

    target: np.ndarray
    direction: np.ndarray
    distance: float
    fov: float = CAMERA_FOV

    @property
    def right(self) -> np.ndarray:
        """Unit vector of the screen's right in {O}."""
        r = np.cross(-self.direction, [0.0, 0.0, 1.0])
        return r / np.linalg.norm(r)

    @property
    def up(self) -> np.ndarray:
        """Unit vector of the screen's up in {O}."""
        return np.cross(self.right, -self.direction)

    @property
    def rotation(self) -> np.ndarray:
        """Rotation whose x, y, z axes are the screen's right, up and towards the viewer."""
        return np.column_stack([self.right, self.up, self.direction])

    @classmethod
    def framing(
        cls,
        points: np.ndarray,
        azimuth: float = CAMERA_AZIMUTH,
        elevation: float = CAMERA_ELEVATION,
        fov: float = CAMERA_FOV,
        aspect: float = DEFAULT_WINDOW[0] / DEFAULT_WINDOW[1],
        margin: float = 1.06,
    ) -> CameraView:
        """The camera looking from (azimuth, elevation) [deg] that just holds every point in view."""
        az, el = math.radians(azimuth), math.radians(elevation)
        d = np.array([math.cos(az) * math.cos(el), math.sin(az) * math.cos(el), math.sin(el)])
        probe = cls(np.zeros(3), d, 1.0, fov)
        right, up = probe.right, probe.up
        # centre the points on screen, in the plane across the view
        lo = np.array([np.min(points @ right), np.min(points @ up)])
        hi = np.array([np.max(points @ right), np.max(points @ up)])
        depth = points @ d
        target = 0.5 * (lo[0] + hi[0]) * right + 0.5 * (lo[1] + hi[1]) * up
        target = target + 0.5 * (depth.min() + depth.max()) * d
        rel = points - target
        tan_v = math.tan(math.radians(fov) / 2.0)
        tan_h = tan_v * aspect
        need = np.maximum(np.abs(rel @ right) / tan_h, np.abs(rel @ up) / tan_v) + rel @ d
        return cls(target, d, float(margin * need.max()), fov)


def text_block(
    writer: SceneWriter,
    name: str,
    lines: Sequence[str],
    anchor: np.ndarray,
    camera: CameraView,
    line_height: float,
) -> np.ndarray:
    """Lines of text facing the camera, centred on ``anchor`` horizontally, top line at anchor.

    Returns:
        Corners of the text's bounding rectangle in {O} [mm], (4 * len(lines), 3).
    """
    TextTexture, PlaneGeometry = text_objects()
    g = writer.g
    size = line_height * 256.0 / 30.0  # the 256 px canvas holds a 30 px line
    corners = []
    for k, text in enumerate(lines):
        centre = anchor - k * 1.25 * line_height * camera.up
        # the viewer draws the baseline at the canvas centre: lift the plane by half a line
        plane_centre = centre - 0.3 * line_height * camera.up
        material = g.MeshBasicMaterial(
            map=TextTexture(text, font_size=30), transparent=True, depthWrite=False, color=0x000000
        )
        writer.object(
            f"labels/{name}{k}", PlaneGeometry(size, size), material,
            mesh_transform(camera.rotation, plane_centre),
        )
        half_w = min(0.5 * size, 0.27 * line_height * len(text))
        for sx in (-1.0, 1.0):
            for sy in (-0.5, 0.5):
                corners.append(centre + sx * half_w * camera.right + sy * line_height * camera.up)
    return np.asarray(corners)


@dataclass(frozen=True)
class LabelLayout:
    """Where the labels go: beside the robot as a provisional camera sees it (mm, in {O})."""

    camera: CameraView
    line: float  # line height of the text
    left: float  # extent of the robot along camera.right
    right: float
    top: float  # top of the robot along camera.up
    depth: np.ndarray  # the robot's middle depth, a vector along camera.direction

    @classmethod
    def around(cls, points: np.ndarray) -> LabelLayout:
        """The layout beside ``points`` [mm], (N, 3), as the camera framing them sees them."""
        camera = CameraView.framing(points)
        up = points @ camera.up
        return cls(
            camera=camera,
            line=0.028 * float(up.max() - up.min()),
            left=float(np.min(points @ camera.right)),
            right=float(np.max(points @ camera.right)),
            top=float(up.max()),
            depth=camera.direction * float(np.mean(points @ camera.direction)),
        )


@dataclass(frozen=True)
class _Callout:
    points: np.ndarray  # corners of what was drawn, for the framing [mm]
    below: np.ndarray  # anchor of a further line under the tilt text [mm]


def draw_plate_callout(
    writer: SceneWriter,
    layout: LabelLayout,
    true_geometry: DeltaGeometry,
    nominal_geometry: DeltaGeometry,
    true_state: RobotState,
    ghost_state: RobotState,
    exaggerate: float,
) -> _Callout:
    """Right of the robot: a magnified inset of both plates and, below it, the real tilt.

    The inset holds the ghost plate at its origin and the true plate at its
    offset from it, :data:`INSET_MAGNIFICATION` times larger, turned about z so
    that the tilt is seen side-on (in the screen plane). A leader line joins
    the tilt text to the plate.
    """
    g = writer.g
    camera, line = layout.camera, layout.line
    polygon = plate_polygon(nominal_geometry)
    plate, tcp = words(nominal_geometry)
    plate_pos = true_state.plate.position[0]
    plate_r = float(np.max(np.linalg.norm(polygon, axis=1)))
    tcp_error = true_state.tcp[0] - ghost_state.tcp[0]
    tilt_lines = [
        f"{plate} tilt {math.degrees(float(true_state.plate.tilt()[0])):.3f}\u00b0",
        f"(drawn \u00d7{exaggerate:g})",
        f"{tcp} error {np.linalg.norm(tcp_error):.2f} mm",
    ]
    half_w = 0.27 * line * max(len(t) for t in tilt_lines)
    m = INSET_MAGNIFICATION
    normal = true_state.plate.rotation[0, :, 2]
    turn = 0.0
    if np.hypot(normal[0], normal[1]) > 1e-12:
        turn = math.atan2(camera.right[1], camera.right[0]) - math.atan2(normal[1], normal[0])
    Rz = rotation_from_vector(np.array([0.0, 0.0, turn]))
    content = np.concatenate(
        [
            true_state.plate_balls[0].reshape(-1, 3) - ghost_state.plate.position[0],
            ghost_state.plate_balls[0].reshape(-1, 3) - ghost_state.plate.position[0],
            [[0.0, 0.0, -2.5 * plate_r]],
        ]
    )
    content = content @ Rz.T
    ball_r = 15.0 * drawn_sizes(nominal_geometry, True)[0]
    col_half = max(half_w, m * (float(np.max(np.abs(content @ camera.right))) + ball_r))
    col_x = (layout.right + 2.0 * line + col_half) * camera.right
    tilt_anchor = col_x + (plate_pos @ camera.up + 1.25 * line) * camera.up + layout.depth
    out = [text_block(writer, "tilt", tilt_lines, tilt_anchor, camera, line)]
    writer.plate("inset/true", true_geometry, False, polygon)
    writer.plate("inset/nominal", nominal_geometry, True, polygon)
    writer.inset_pose(true_state, ghost_state, 0)
    content_top = m * float(np.max(content @ camera.up))
    inset_origin = col_x + (layout.top - 2.0 * line - content_top) * camera.up + layout.depth
    writer.transform("inset", mesh_transform(Rz, inset_origin, (m, m, m)))
    for sign in (-1.0, 1.0):
        out.append(inset_origin + m * (content + sign * ball_r * camera.right))
    title_at = inset_origin + (content_top + 1.5 * line) * camera.up
    out.append(text_block(writer, "inset", [f"{plate}s \u00d7{m:g}, tilt side-on"], title_at, camera, line))
    leader = np.stack(
        [
            plate_pos + 1.3 * plate_r * camera.right,
            tilt_anchor - (half_w + line) * camera.right - 1.25 * line * camera.up,
        ]
    )
    material = g.LineBasicMaterial(color=0x333333)
    writer.object(
        "labels/tilt_leader", g.LineSegments(g.PointsGeometry(leader.T.astype(np.float32)), material)
    )
    below = tilt_anchor - len(tilt_lines) * 1.25 * line * camera.up
    return _Callout(np.concatenate(out), below)


def draw_legend(
    writer: SceneWriter,
    layout: LabelLayout,
    geometry: DeltaGeometry,
    name: str,
    arrow_scale: float,
    max_error: float,
    radius: float,
) -> np.ndarray:
    """Left of the robot: its name, the ghost, the arrows' scale and colour bar; returns corners [mm]."""
    g = writer.g
    camera, line = layout.camera, layout.line
    legend = [name, "blue ghost: nominal"]
    tcp = words(geometry)[1]
    half = 0.27 * line * max(len(t) for t in legend)
    if arrow_scale > 0.0:
        legend += [f"{tcp} error arrows", f"(true - commanded) \u00d7{arrow_scale:g}"]
        half = max(0.27 * line * max(len(t) for t in legend), 4.5 * line + 0.27 * line * 8)
    anchor = (layout.left - 2.0 * line - half) * camera.right + layout.top * camera.up + layout.depth
    out = [text_block(writer, "legend", legend, anchor, camera, line)]
    if arrow_scale <= 0.0:
        return np.concatenate(out)
    # a reference arrow of a round error size
    ref = nice_number(max_error)
    y0 = anchor - (len(legend) + 0.6) * 1.25 * line * camera.up
    vector = ref * arrow_scale * camera.right
    colour = error_colours(np.array([ref / max_error]))
    verts, cols, faces = arrow_mesh((y0 - 0.5 * vector)[None], vector[None], colour, radius)
    material = g.MeshPhongMaterial(vertexColors=True)
    writer.object("labels/ref_arrow", g.TriangularMeshGeometry(verts, faces, color=cols), material)
    below = y0 - 1.3 * line * camera.up
    out.append(text_block(writer, "ref", [f"{ref:g} mm"], below, camera, line))
    # colour bar from 0 to the largest error
    bar_y = below - 2.6 * line * camera.up
    width, n = 9.0 * line, 12
    for k in range(n):
        centre = bar_y + ((k + 0.5) / n - 0.5) * width * camera.right
        rgb = (255 * error_colours(np.array([(k + 0.5) / n]))[0]).astype(int)
        writer.object(
            f"labels/bar{k:02d}",
            g.Box([width / n, 0.8 * line, 0.2 * line]),
            g.MeshBasicMaterial(color=int(rgb[0]) << 16 | int(rgb[1]) << 8 | int(rgb[2])),
            mesh_transform(camera.rotation, centre),
        )
    ends = [bar_y - 0.5 * width * camera.right, bar_y + 0.5 * width * camera.right]
    out.append(text_block(writer, "bar_lo", ["0"], ends[0] - 1.3 * line * camera.up, camera, line))
    out.append(
        text_block(writer, "bar_hi", [f"{max_error:.1f} mm"], ends[1] - 1.3 * line * camera.up, camera, line)
    )
    out.append(np.stack(ends))
    return np.concatenate(out)


def set_camera(vis: Any, camera: CameraView) -> None:
    """Put the camera's target at the viewer's origin (the orbit centre) and the camera in place."""
    g = import_meshcat().geometry
    root = np.eye(4)
    root[:3, :3] *= MM
    root[:3, 3] = -MM * camera.target
    vis["deltacal"].set_transform(root)
    position = MM * camera.distance * camera.direction  # metres, z up
    far = max(100.0, 4.0 * MM * camera.distance)
    vis["/Cameras/default/rotated"].set_object(
        g.PerspectiveCamera(fov=camera.fov, aspect=DEFAULT_WINDOW[0] / DEFAULT_WINDOW[1], near=0.01, far=far)
    )
    # the camera's parent frame is three.js's y-up frame: (x, y, z) -> (x, z, -y)
    vis["/Cameras/default/rotated/<object>"].set_property(
        "position", [float(position[0]), float(position[2]), float(-position[1])]
    )
    vis["/Grid"].set_property("visible", False)
    vis["/Axes"].set_property("visible", False)
    vis["/Background"].set_property("top_color", [0.98, 0.98, 1.0])
    vis["/Background"].set_property("bottom_color", [0.78, 0.81, 0.86])
