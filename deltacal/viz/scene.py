"""The scene: the true robot over its nominal ghost, workspace and error arrows."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..exceptions import GeometryError, UnreachableError
from ..geometry import (
    DeltaGeometry,
    Workspace,
)
from ._meshcat import import_meshcat
from .layout import (
    CameraView,
    LabelLayout,
    draw_legend,
    draw_plate_callout,
    set_camera,
    text_block,
)
from .meshes import ARROW_RADIUS, arrow_mesh
from .state import (
    DEFAULT_EXAGGERATION,
    ErrorField,
    RobotState,
    default_workspace,
    demo_path,
    error_colours,
    nice_number,
    reachable_readings,
    workspace_grid,
)
from .writer import SceneWriter, plate_polygon, robot_size, tower_ends


@dataclass(frozen=True)
class SceneSummary:
    """What :func:`build_scene` drew.

    Attributes:
        tilt: Real plate tilt of the true robot at the drawn readings [rad].
        tcp_error: True minus commanded TCP at the drawn readings [mm], (3,).
        exaggerate: Factor on the plate's rotation as drawn.
        arrow_scale: Drawn arrow length per mm of TCP error (0 without arrows).
        max_error: Largest TCP error over the arrow grid [mm] (0 without arrows).
        arrows: Number of error arrows.
        animation_frames: Frames of the path animation (0 without animation).
        max_path_tilt: Largest real plate tilt along the animated path [rad] (0 without).
        camera: The initial camera.
        paths: Scene paths of the robot's objects, relative to the ``deltacal`` node.
    """

    tilt: float
    tcp_error: np.ndarray
    exaggerate: float
    arrow_scale: float
    max_error: float
    arrows: int
    animation_frames: int
    max_path_tilt: float
    camera: CameraView
    paths: list[str] = field(default_factory=list)


def _check_scene(nominal_geometry: DeltaGeometry, true_geometry: DeltaGeometry, exaggerate: float) -> None:
    """Two robots of one kind, and a positive finite exaggeration (ValueError, GeometryError)."""
    if not (math.isfinite(exaggerate) and exaggerate > 0.0):
        raise ValueError(f"exaggerate must be a positive finite factor, got {exaggerate!r}")
    if true_geometry.chain != nominal_geometry.chain:
        raise GeometryError(f"the true robot is a {true_geometry.chain.name} chain and the nominal one a "
                            f"{nominal_geometry.chain.name} chain: draw two robots of the same kind")


def _scene_readings(nominal_geometry: DeltaGeometry, ws: Workspace, q: np.ndarray | None) -> np.ndarray:
    """The readings to draw [rad], (3,): those given, or the nominal ones at the workspace centre."""
    if q is None:
        q = reachable_readings(nominal_geometry, ws.centre[None])[0]
        if not np.all(np.isfinite(q)):
            raise UnreachableError(
                f"workspace centre {ws.centre.tolist()} mm is out of reach of the nominal robot",
                [0],
                ws.centre[None],
            )
    return np.asarray(q, dtype=float).reshape(3)


def build_scene(
    vis: Any,
    nominal_geometry: DeltaGeometry,
    true_geometry: DeltaGeometry,
    q: np.ndarray | None = None,
    exaggerate: float = DEFAULT_EXAGGERATION,
    arrows: bool = True,
    animate: bool = False,
    workspace: Workspace | None = None,
    frames: int = 100,
    fps: float = 25.0,
    title: str | None = None,
    camera_view: CameraView | None = None,
) -> SceneSummary:
    """Draw the true robot over its nominal ghost into a meshcat visualizer.

    A rotary Delta is drawn as its base, actuators, arms, rods and plate; a printer (a chain on a
    bed, :attr:`~deltacal.chains.Chain.on_bed`) as its towers from the bed up past the endstops, the
    carriages where their travel puts them, the rods, the effector and nozzle, and the bed.

    Args:
        vis: A ``meshcat.Visualizer`` (live, or from :func:`recording_visualizer`).
        nominal_geometry: The nominal robot (the ghost, and the model of the
            uncalibrated controller for the error arrows).
        true_geometry: The real robot.
        q: Joint readings to draw [rad], (3,); default: the nominal inverse
            kinematics of the workspace centre.
        exaggerate: Factor on the true plate's rotation vector as drawn (1: true scale).
        arrows: Draw the TCP error arrows over the workspace grid.
        animate: Add an animation of both robots along :func:`demo_path` (plays in a loop).
        workspace: Cylinder for the grid and the path; default :func:`default_workspace`.
        frames: Frames of the animation.
        fps: Frame rate of the animation [1/s].
        title: First line of the legend; default the robot's name.
        camera_view: Initial camera; default: looking from :data:`CAMERA_AZIMUTH`,
            :data:`CAMERA_ELEVATION` and just holding the whole scene (pass a
            summary's ``camera`` to view another scene the same way).

    Returns:
        What was drawn (tilt, error scale, camera...).

    Raises:
        UnreachableError: The workspace centre (default readings) is out of reach.
        AssemblyError: The true robot cannot be assembled at the readings.
        GeometryError: The two robots are not of the same kind (rotary Delta, printer).
    """
    meshcat = import_meshcat()
    _check_scene(nominal_geometry, true_geometry, exaggerate)
    ws = workspace if workspace is not None else default_workspace(nominal_geometry)
    q = _scene_readings(nominal_geometry, ws, q)
    true_state = RobotState.compute(true_geometry, q, exaggerate)
    ghost_state = RobotState.compute(nominal_geometry, q, 1.0)
    commanded = ghost_state.tcp[0]

    vis["deltacal"].delete()
    writer = SceneWriter(vis)
    polygon = plate_polygon(nominal_geometry)
    writer.robot("true", true_geometry, true_state, ghost=False, plate_shape=polygon)
    writer.robot("nominal", nominal_geometry, ghost_state, ghost=True, plate_shape=polygon)
    writer.object("frame", writer.g.triad(0.4 * robot_size(nominal_geometry)))
    points = [
        true_state.arm_balls[0].reshape(-1, 3),
        true_state.plate_balls[0].reshape(-1, 3),
        ghost_state.plate_balls[0].reshape(-1, 3),
        true_state.tcp,
        _fixed_parts(writer, nominal_geometry, true_geometry),
        _draw_workspace(writer, ws),
    ]
    arrow_scale, max_error, n_arrows = 0.0, 0.0, 0
    if arrows:
        grid = workspace_grid(ws)
        # the arrow at the drawn pose would run through the plate: its error is written instead
        grid = grid[np.linalg.norm(grid - commanded, axis=1) > 0.2 * ws.radius]
        errors = ErrorField.compute(nominal_geometry, true_geometry, grid)
        n_arrows = len(errors.commanded)
        arrow_scale, max_error, tips = _draw_arrows(writer, errors, ws.radius)
        points.append(tips)

    robot_points = np.concatenate(points)
    layout = LabelLayout.around(robot_points)
    callout = draw_plate_callout(
        writer, layout, true_geometry, nominal_geometry, true_state, ghost_state, exaggerate
    )
    name = title if title is not None else (true_geometry.name or nominal_geometry.name or "Delta robot")
    legend = draw_legend(
        writer, layout, nominal_geometry, name, arrow_scale, max_error, ARROW_RADIUS * ws.radius
    )
    label_points = [callout.points, legend]

    frames_done, max_path_tilt = 0, 0.0
    if animate:
        qs = reachable_readings(nominal_geometry, demo_path(ws, frames))
        qs = qs[np.all(np.isfinite(qs), axis=1)]
        if len(qs) >= 2:
            true_path = RobotState.compute(true_geometry, qs, exaggerate)
            ghost_path = RobotState.compute(nominal_geometry, qs, 1.0)
            animation = meshcat.animation.Animation(default_framerate=fps)
            for k in range(len(qs)):
                with animation.at_frame(vis, k) as frame:
                    writer.pose("true", true_path, k, frame)
                    writer.pose("nominal", ghost_path, k, frame)
                    writer.inset_pose(true_path, ghost_path, k, frame)
            vis.set_animation(animation, play=True, repetitions=100000)
            frames_done = len(qs)
            max_path_tilt = float(true_path.plate.tilt().max())
            text = [f"path: tilt up to {math.degrees(max_path_tilt):.3f}\u00b0"]
            label_points.append(text_block(writer, "path", text, callout.below, layout.camera, layout.line))

    if camera_view is None:
        camera_view = CameraView.framing(np.concatenate([robot_points, *label_points]))
    set_camera(vis, camera_view)
    return SceneSummary(
        tilt=float(true_state.plate.tilt()[0]),
        tcp_error=true_state.tcp[0] - commanded,
        exaggerate=float(exaggerate),
        arrow_scale=arrow_scale,
        max_error=max_error,
        arrows=n_arrows,
        animation_frames=frames_done,
        max_path_tilt=max_path_tilt,
        camera=camera_view,
        paths=list(writer.paths),
    )


def _fixed_parts(
    writer: SceneWriter, nominal_geometry: DeltaGeometry, true_geometry: DeltaGeometry
) -> np.ndarray:
    """Points of what stands still, for the framing [mm].

    Round a rotary Delta's base; a printer's bed (drawn here: it is the plane z = 0 of both
    printers) and both printers' towers and frame tops.
    """
    if nominal_geometry.chain.on_bed:
        ends = [np.concatenate(tower_ends(g)) for g in (nominal_geometry, true_geometry)]
        top = np.max(np.concatenate(ends)[:, 2]) + 16.0 * robot_size(nominal_geometry) / 375.0
        return np.concatenate([writer.bed(nominal_geometry), *ends, [[0.0, 0.0, top]]])
    b = float(np.mean(np.linalg.norm(nominal_geometry.axis_point[:, :2], axis=1)))
    ang = np.linspace(0.0, 2.0 * np.pi, 37)
    return np.column_stack([(b + 60.0) * np.cos(ang), (b + 60.0) * np.sin(ang), np.full_like(ang, 60.0)])


def _draw_workspace(writer: SceneWriter, ws: Workspace) -> np.ndarray:
    """The workspace outline (top and bottom circles, four generatrices); returns its segment ends."""
    g = writer.g
    ang = np.linspace(0.0, 2.0 * np.pi, 73)
    circle = np.column_stack([ws.radius * np.cos(ang), ws.radius * np.sin(ang), np.zeros_like(ang)])
    outline = []
    for z in (ws.top_z, ws.bottom_z):
        c = circle + [0.0, 0.0, z]
        outline.append(np.stack([c[:-1], c[1:]], axis=1).reshape(-1, 3))
    for a in np.arange(4) * np.pi / 2.0:
        p = [ws.radius * math.cos(a), ws.radius * math.sin(a)]
        outline.append(np.array([[*p, ws.top_z], [*p, ws.bottom_z]]))
    segments = np.concatenate(outline)
    material = g.LineBasicMaterial(color=0x7A8A9A)
    writer.object("workspace", g.LineSegments(g.PointsGeometry(segments.T.astype(np.float32)), material))
    return segments


def _draw_arrows(
    writer: SceneWriter, errors: ErrorField, workspace_radius: float
) -> tuple[float, float, np.ndarray]:
    """The error arrows, the longest about 0.4 workspace radius (a round scale).

    Returns:
        Arrow scale (drawn mm per mm of error, 0 if no error), largest error [mm], arrow tips [mm].
    """
    g = writer.g
    magnitude = errors.magnitude
    max_error = float(magnitude.max()) if len(magnitude) else 0.0
    if max_error <= 0.0:
        return 0.0, max_error, np.zeros((0, 3))
    scale = nice_number(0.4 * workspace_radius / max_error)
    radius = ARROW_RADIUS * workspace_radius
    vectors = scale * errors.error
    verts, cols, faces = arrow_mesh(errors.commanded, vectors, error_colours(magnitude / max_error), radius)
    writer.object(
        "arrows",
        g.TriangularMeshGeometry(verts, faces, color=cols),
        g.MeshPhongMaterial(vertexColors=True, shininess=20),
    )
    return scale, max_error, errors.commanded + vectors
