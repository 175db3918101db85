"""3-D views of a Delta robot in meshcat: the true robot over its nominal ghost.

The scene shows every element of a :class:`~deltacal.geometry.DeltaGeometry`
at given joint readings: base, actuators, arms with their elbow bars, the
twelve ball centres, the six rods, the travelling plate and the tool (a stick
from the plate centre to the TCP and a small sphere). The nominal robot at the
same readings is drawn as a translucent ghost over it.

A real plate tilts by tenths of a degree, invisible at the scale of a robot a
metre tall. The plate's rotation, and everything that follows it (plate,
plate balls, rod ends, tool, plate axis), is therefore drawn with its rotation
vector multiplied by ``exaggerate`` (default :data:`DEFAULT_EXAGGERATION` =
100: a 0.1 deg tilt is drawn as 10 deg); the real angle is written in the
scene. Positions are never exaggerated. An inset beside the robot shows both
plates :data:`INSET_MAGNIFICATION` times larger, turned so that the tilt is
seen side-on.

TCP error arrows over a grid of the workspace show what the uncalibrated robot
does: at each commanded point x the readings are the nominal inverse
kinematics of x, and the arrow goes from x towards the true TCP reached with
those readings, drawn ``arrow_scale`` times longer than the error and
coloured by its size (legend in the scene).

Units: the library's mm and rad. The meshcat scene is in metres: everything
of the robot lives under the node ``/meshcat/deltacal``, whose transform scales
mm to m and moves the middle of the view to the viewer's origin (where the
camera looks and orbits).

Scene tree (under ``/meshcat/deltacal``): ``true/`` and ``nominal/`` (each with
``base``, ``limb{i}/actuator``, ``limb{i}/arm/{link,elbow,ball1,ball2}``,
``limb{i}/rod{j}``, ``plate/{body,ball{i}{j},axis,tool,tcp}``),
``inset/{true,nominal}/...`` (the plates again), ``workspace``, ``arrows``,
``frame`` and ``labels/...``.

Static HTML export needs no server: :class:`SceneRecorder` stands in for
meshcat's server, records the commands and writes the standalone page with
meshcat's own viewer script. :func:`meshcat_server` starts a live server and
always stops it.
"""

from __future__ import annotations

import base64
import contextlib
import io
import math
import os
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .exceptions import UnreachableError, ViewerError
from .geometry import DeltaGeometry, Workspace, rotation_from_vector, vector_from_rotation
from .kinematics import exact
from .kinematics.closed_form import VirtualDelta

#: Default factor on the plate's rotation vector: a 0.1 deg tilt is drawn as 10 deg.
DEFAULT_EXAGGERATION = 100.0
#: Window size of the rendered screenshots [px].
DEFAULT_WINDOW = (1200, 900)
#: Shaft radius of the error arrows, per workspace radius.
ARROW_RADIUS = 0.011
#: Size factor of the inset that shows both plates magnified.
INSET_MAGNIFICATION = 3.0
#: Vertical field of view of the scene's camera [deg].
CAMERA_FOV = 35.0
#: Camera direction: azimuth about z from x and elevation above the horizon [deg].
CAMERA_AZIMUTH = -55.0
CAMERA_ELEVATION = 18.0

_MM = 1e-3  # scene metres per mm

# Colours (0xRRGGBB).
_TRUE_COLOURS = {
    "base": 0x5A5F66,
    "actuator": 0x2C4A7A,
    "arm": 0xD9822B,
    "elbow": 0xB8651A,
    "ball": 0xC8CCD2,
    "rod": 0x6F7A86,
    "plate": 0x3C9E5A,
    "axis": 0x1F6B38,
    "tool": 0xC0392B,
}
_GHOST_COLOUR = 0x6FB7FF
_GHOST_OPACITY = 0.28

# A perceptually ordered colour map (viridis, 5 stops) for the error sizes.
_COLOUR_STOPS = np.array(
    [
        [0.267, 0.005, 0.329],
        [0.229, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ]
)


# =============================================================================== meshcat helpers
def _meshcat() -> Any:
    """Import meshcat (optional extra ``viz``), with a clear error when it is missing."""
    try:
        import meshcat
        import meshcat.animation  # noqa: F401
        import meshcat.geometry  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ViewerError("deltacal.viz needs meshcat: pip install 'deltacal[viz]' (meshcat>=0.3.2)") from exc
    return meshcat


def _viewer_script() -> str:
    """Meshcat's bundled viewer (three.js and the scene tree), inlined into the HTML."""
    meshcat = _meshcat()
    return (Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js").read_text(encoding="utf-8")


class _Node(dict):
    """A node of the recorded scene tree (what meshcat's server keeps)."""

    def __init__(self) -> None:
        super().__init__()
        self.object: bytes | None = None
        self.transform: bytes | None = None
        self.properties: list[bytes] = []

    def find(self, path: Sequence[str]) -> _Node:
        node = self
        for name in path:
            node = node.setdefault(name, _Node())
        return node

    def walk(self) -> Iterator[_Node]:
        yield self
        for child in self.values():
            yield from child.walk()


class SceneRecorder:
    """Stands in for meshcat's server window: records commands, writes a standalone page.

    Use through :func:`recording_visualizer`. It keeps the scene tree the way
    meshcat's server does (the last object, transform and properties of each
    path, the last animation) and :meth:`get_scene` writes the same kind of
    page as ``Visualizer.static_html()``, without starting any process.
    """

    server_proc = None
    web_url = None

    def __init__(self, title: str = "deltacal") -> None:
        self.title = title
        self.tree = _Node()
        self.animation: bytes | None = None

    def send(self, command: Any) -> None:
        """Record one meshcat command (the interface of ``meshcat.visualizer.ViewerWindow``)."""
        import umsgpack

        data = command.lower()
        kind = data["type"]
        packed = umsgpack.packb(data)
        path = [p for p in str(data["path"]).split("/") if p]
        if kind == "set_animation":
            self.animation = packed
            return
        if kind == "delete":
            if not path:
                self.tree = _Node()
            else:
                self.tree.find(path[:-1]).pop(path[-1], None)
            return
        node = self.tree.find(path)
        if kind == "set_object":
            node.object = packed
            node.properties = []
        elif kind == "set_transform":
            node.transform = packed
        elif kind == "set_property":
            node.properties.append(packed)
        else:  # pragma: no cover - meshcat 0.3.2 has no other commands
            raise ViewerError(f"unsupported meshcat command {kind!r}")

    def commands(self) -> list[bytes]:
        """The recorded commands in replay order (parents first; the animation last)."""
        out: list[bytes] = []
        for node in self.tree.walk():
            if node.object is not None:
                out.append(node.object)
            out.extend(node.properties)
            if node.transform is not None:
                out.append(node.transform)
        if self.animation is not None:
            out.append(self.animation)
        return out

    def get_scene(self) -> str:
        """The standalone HTML page of the recorded scene."""
        replay = "".join(
            "fetch('data:application/octet-binary;base64,"
            + base64.b64encode(c).decode("ascii")
            + "').then(r => r.arrayBuffer())"
            ".then(b => viewer.handle_command_bytearray(new Uint8Array(b)));\n"
            for c in self.commands()
        )
        return (
            "<!DOCTYPE html>\n<html>\n<head><meta charset='utf-8'>"
            f"<title>{_html_escape(self.title)}</title>\n"
            "<style>body { margin: 0; } #meshcat-pane { width: 100vw; height: 100vh; overflow: hidden; }"
            "</style>\n</head>\n<body>\n<div id='meshcat-pane'></div>\n"
            f"<script>\n{_viewer_script()}\n</script>\n"
            "<script>\nvar viewer = new MeshCat.Viewer(document.getElementById('meshcat-pane'));\n"
            f"{replay}</script>\n</body>\n</html>\n"
        )


def _html_escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def recording_visualizer(title: str = "deltacal") -> Any:
    """A ``meshcat.Visualizer`` that records into a :class:`SceneRecorder` (no server).

    ``vis.static_html()`` then returns the standalone page.
    """
    meshcat = _meshcat()
    return meshcat.Visualizer(window=SceneRecorder(title))


@contextlib.contextmanager
def meshcat_server() -> Iterator[Any]:
    """Start a meshcat server and yield its ``Visualizer``; the server is always stopped.

    The server subprocess is killed and reaped on leaving the block, also on
    errors and Ctrl-C.
    """
    meshcat = _meshcat()
    with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL; the caller decides
        vis = meshcat.Visualizer()
    try:
        yield vis
    finally:
        stop_server(vis)


def stop_server(vis: Any) -> None:
    """Kill and reap the server subprocess of a ``meshcat.Visualizer`` (no-op for a recorder)."""
    window = vis.window
    proc = getattr(window, "server_proc", None)
    socket = getattr(window, "zmq_socket", None)
    if socket is not None:
        socket.close(linger=0)
    if proc is not None and proc.poll() is None:
        proc.kill()
    if proc is not None:
        proc.wait(timeout=30)


def write_html(vis: Any, path: str | Path) -> Path:
    """Write the standalone page of a visualizer's scene to ``path``, atomically."""
    path = Path(path)
    data = vis.static_html().encode("utf-8")
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _file_mode())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def _file_mode() -> int:
    """Permissions of a new file under the current umask (mkstemp's files are private)."""
    umask = 0o022
    with contextlib.suppress(OSError, ValueError):  # read it without os.umask's global side effect
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                umask = int(line.split()[1], 8)
    return 0o666 & ~umask


# ======================================================================== numbers of the scene
@dataclass(frozen=True)
class RobotState:
    """Everything needed to draw one robot at N readings (mm, rad).

    Attributes:
        q: Readings [rad], (N, 3).
        arm_rotation: Arm frames in {O}, (N, 3, 3, 3).
        arm_balls: Arm ball centres in {O} [mm], (N, 3, 2, 3).
        plate: True plate poses.
        shown_rotation: Plate rotation as drawn (tilt exaggerated), (N, 3, 3).
        plate_balls: Plate ball centres as drawn, in {O} [mm], (N, 3, 2, 3).
        tcp: True TCP in {O} [mm], (N, 3).
        axis_point: Actuator axis points in {O} [mm], (3, 3).
    """

    q: np.ndarray
    arm_rotation: np.ndarray
    arm_balls: np.ndarray
    plate: exact.PlatePose
    shown_rotation: np.ndarray
    plate_balls: np.ndarray
    tcp: np.ndarray
    axis_point: np.ndarray

    @classmethod
    def compute(cls, geometry: DeltaGeometry, q: np.ndarray, exaggerate: float = 1.0) -> RobotState:
        """Poses of every element of ``geometry`` at readings q, plate tilt times ``exaggerate``."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        plate = exact.forward(geometry, q)
        shown = rotation_from_vector(exaggerate * vector_from_rotation(plate.rotation))
        balls = plate.position[:, None, None, :] + np.einsum("nkl,ijl->nijk", shown, geometry.plate_ball)
        return cls(
            q=q,
            arm_rotation=geometry.arm_rotation(q),
            arm_balls=geometry.arm_balls_in_base(q),
            plate=plate,
            shown_rotation=shown,
            plate_balls=balls,
            tcp=plate.point(geometry.tool),
            axis_point=np.array(geometry.axis_point),
        )


@dataclass(frozen=True)
class ErrorField:
    """TCP errors of the uncalibrated robot over a set of commanded points.

    Attributes:
        commanded: Commanded TCP positions in {O} [mm], (N, 3).
        reached: True TCP positions at the nominal inverse-kinematics readings [mm], (N, 3).
    """

    commanded: np.ndarray
    reached: np.ndarray

    @property
    def error(self) -> np.ndarray:
        """True minus commanded TCP [mm], (N, 3)."""
        return self.reached - self.commanded

    @property
    def magnitude(self) -> np.ndarray:
        """Error sizes [mm], (N,)."""
        return np.linalg.norm(self.error, axis=1)

    @classmethod
    def compute(
        cls, nominal_geometry: DeltaGeometry, true_geometry: DeltaGeometry, targets: np.ndarray
    ) -> ErrorField:
        """Errors at the targets reachable by both robots (others are dropped).

        Args:
            nominal_geometry: The model the uncalibrated controller uses.
            true_geometry: The real robot.
            targets: Commanded TCP positions [mm], (N, 3).
        """
        targets = np.atleast_2d(np.asarray(targets, dtype=float))
        q = _reachable_readings(nominal_geometry, targets)
        keep = np.all(np.isfinite(q), axis=1)
        targets, q = targets[keep], q[keep]
        if targets.shape[0] == 0:
            return cls(np.zeros((0, 3)), np.zeros((0, 3)))
        reached = exact.forward(true_geometry, q).point(true_geometry.tool)
        return cls(targets, reached)


def _reachable_readings(geometry: DeltaGeometry, targets: np.ndarray) -> np.ndarray:
    """Readings putting the TCP at each target, NaN rows where it is out of reach."""
    first = VirtualDelta.from_geometry(geometry).inverse(targets - geometry.tool, check=False)
    out = np.full(targets.shape, np.nan)
    ok = np.flatnonzero(np.all(np.isfinite(first), axis=1))
    if ok.size:
        try:
            out[ok] = exact.inverse(geometry, targets[ok], start=first[ok])
        except UnreachableError as exc:
            good = np.setdiff1d(np.arange(ok.size), exc.indices)
            if good.size:
                out[ok[good]] = exact.inverse(geometry, targets[ok[good]], start=first[ok[good]])
    return out


def default_workspace(geometry: DeltaGeometry) -> Workspace:
    """A workspace cylinder sized from the robot, for geometries without a robot file.

    Centred on z under the plate at zero readings: radius 0.8 (b - a + L), height
    L / 2, middle 0.17 L below the zero-reading plate (close to Bai's Table 1
    cylinder for his robot).
    """
    b = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
    a = float(np.mean(np.linalg.norm(geometry.plate_ball.mean(axis=1)[:, :2], axis=1)))
    L = float(np.mean(np.linalg.norm(geometry.arm_ball.mean(axis=1), axis=1)))
    z0 = float(VirtualDelta.from_geometry(geometry).forward(np.zeros(3))[0, 2] + geometry.tool[2])
    height = 0.5 * L
    middle = z0 - 0.17 * L
    return Workspace(radius=0.8 * (b - a + L), height=height, top_z=middle + 0.5 * height)


def workspace_grid(workspace: Workspace, per_radius: int = 2) -> np.ndarray:
    """Points of a square grid inside the workspace cylinder, on its three layers.

    Args:
        workspace: The cylinder.
        per_radius: Grid steps per radius (2: spacing R/2, 13 points per layer).

    Returns:
        Points [mm], (N, 3), layer by layer from the top.
    """
    steps = np.arange(-per_radius, per_radius + 1) / per_radius * workspace.radius
    x, y = np.meshgrid(steps, steps, indexing="ij")
    inside = x**2 + y**2 <= workspace.radius**2 * (1.0 + 1e-9)
    xy = np.stack([x[inside], y[inside]], axis=1)
    layers = [workspace.top_z, workspace.middle_z, workspace.bottom_z]
    return np.concatenate([np.column_stack([xy, np.full(len(xy), z)]) for z in layers])


def demo_path(workspace: Workspace, frames: int = 100) -> np.ndarray:
    """A closed 3-D Lissajous path through the workspace centre (start and end there) [mm], (frames, 3)."""
    t = np.linspace(0.0, 2.0 * np.pi, frames)
    rho = 0.6 * workspace.radius
    return workspace.centre + np.column_stack(
        [rho * np.sin(t), 0.6 * rho * np.sin(2.0 * t), 0.35 * workspace.height * np.sin(3.0 * t)]
    )


def nice_number(x: float) -> float:
    """The largest of 1, 2, 5 times a power of ten not above x (x > 0)."""
    exponent = math.floor(math.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**exponent <= x * (1 + 1e-12):
            return m * 10.0**exponent
    return 10.0**exponent  # pragma: no cover


def error_colours(fraction: np.ndarray) -> np.ndarray:
    """RGB in [0, 1] of the error colour map at fractions of the largest error, (N, 3)."""
    f = np.clip(np.asarray(fraction, dtype=float), 0.0, 1.0) * (len(_COLOUR_STOPS) - 1)
    i = np.minimum(np.floor(f).astype(int), len(_COLOUR_STOPS) - 2)
    w = (f - i)[:, None]
    return (1.0 - w) * _COLOUR_STOPS[i] + w * _COLOUR_STOPS[i + 1]


# ============================================================================== scene primitives
def _transform(rotation: np.ndarray, position: Any, scale: Sequence[float] = (1.0, 1.0, 1.0)) -> np.ndarray:
    """Homogeneous transform: rotation times a scale along the local axes, then a translation."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(rotation) @ np.diag(scale)
    T[:3, 3] = position
    return T


def _rotation_y_to(direction: np.ndarray) -> np.ndarray:
    """A rotation taking the y axis (three.js cylinders) to ``direction``; continuous near z."""
    u = direction / np.linalg.norm(direction)
    ref = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - np.dot(ref, u) * u
    x /= np.linalg.norm(x)
    return np.column_stack([x, u, np.cross(x, u)])


def _segment(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation, midpoint and length of a unit cylinder stretched from a to b."""
    d = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
    return _rotation_y_to(d), 0.5 * (np.asarray(a) + np.asarray(b)), float(np.linalg.norm(d))


def _material(colour: int, ghost: bool, **kwargs: Any) -> Any:
    g = _meshcat().geometry
    if ghost:
        return g.MeshLambertMaterial(color=_GHOST_COLOUR, opacity=_GHOST_OPACITY, depthWrite=False, **kwargs)
    return g.MeshPhongMaterial(color=colour, shininess=40, **kwargs)


def _prism_mesh(polygon: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """A flat prism over a convex polygon (xy, counter-clockwise), flat-shaded: vertices, faces."""
    n = len(polygon)
    h = 0.5 * thickness
    top = np.column_stack([polygon, np.full(n, h)])
    bottom = np.column_stack([polygon, np.full(n, -h)])
    verts = [np.zeros((1, 3)) + [0, 0, h], top, np.zeros((1, 3)) + [0, 0, -h], bottom]
    faces = [[0, 1 + k, 1 + (k + 1) % n] for k in range(n)]
    off = n + 1
    faces += [[off, off + 1 + (k + 1) % n, off + 1 + k] for k in range(n)]
    base = 2 * n + 2
    side = []
    for k in range(n):
        k2 = (k + 1) % n
        quad = np.stack([bottom[k], bottom[k2], top[k2], top[k]])
        side.append(quad)
        j = base + 4 * k
        faces += [[j, j + 1, j + 2], [j, j + 2, j + 3]]
    vertices = np.concatenate(verts + side)
    return vertices, np.asarray(faces)


def _arrow_mesh(
    starts: np.ndarray, vectors: np.ndarray, colours: np.ndarray, radius: float, segments: int = 10
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One triangle mesh of many arrows (shaft and cone head), with vertex colours."""
    ang = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    ring = np.column_stack([np.cos(ang), np.zeros(segments), np.sin(ang)])  # around y
    verts: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    count = 0
    k = np.arange(segments)
    k2 = (k + 1) % segments
    for p, v, c in zip(starts, vectors, colours, strict=True):
        length = float(np.linalg.norm(v))
        if length < 1e-9:
            continue
        R = _rotation_y_to(v)
        head = min(0.4 * length, 4.0 * radius)
        head_r = min(2.2 * radius, 0.5 * head + radius)
        shaft_r = min(radius, 0.45 * head_r)
        local = np.concatenate(
            [
                shaft_r * ring,  # 0: shaft bottom ring
                shaft_r * ring + [0.0, length - head, 0.0],  # 1: shaft top ring
                head_r * ring + [0.0, length - head, 0.0],  # 2: head base ring
                [[0.0, length, 0.0]],  # tip
                [[0.0, length - head, 0.0]],  # head base centre
            ]
        )
        tip, centre = 3 * segments, 3 * segments + 1
        f = np.concatenate(
            [
                np.column_stack([k, k2, segments + k2]),
                np.column_stack([k, segments + k2, segments + k]),
                np.column_stack([2 * segments + k, 2 * segments + k2, np.full(segments, tip)]),
                np.column_stack([2 * segments + k2, 2 * segments + k, np.full(segments, centre)]),
            ]
        )
        verts.append(p + local @ R.T)
        cols.append(np.broadcast_to(c, local.shape))
        faces.append(f + count)
        count += len(local)
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3), dtype=int)
    return np.concatenate(verts), np.concatenate(cols), np.concatenate(faces)


def _text_objects() -> tuple[type, type]:
    """Meshcat geometry classes for a text texture and a plane (missing from meshcat 0.3.2)."""
    g = _meshcat().geometry

    class TextTexture(g.Texture):  # type: ignore[misc,name-defined]
        """Text drawn by the viewer on a 256 px canvas (meshcat's ``_text`` texture)."""

        def __init__(self, text: str, font_size: int = 30, font_face: str = "sans-serif") -> None:
            super().__init__()
            self.text, self.font_size, self.font_face = text, font_size, font_face

        def lower(self, object_data: Any) -> dict[str, Any]:
            return {
                "uuid": self.uuid,
                "type": "_text",
                "text": self.text,
                "font_size": self.font_size,
                "font_face": self.font_face,
            }

    class Plane(g.Geometry):  # type: ignore[misc,name-defined]
        """A rectangle in the local xy plane, facing +z."""

        def __init__(self, width: float, height: float) -> None:
            super().__init__()
            self.width, self.height = width, height

        def lower(self, object_data: Any) -> dict[str, Any]:
            return {
                "uuid": self.uuid,
                "type": "PlaneGeometry",
                "width": self.width,
                "height": self.height,
                "widthSegments": 1,
                "heightSegments": 1,
            }

    return TextTexture, Plane


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


class _SceneWriter:
    """Sends the robot's objects to a visualizer under the ``deltacal`` node and notes their paths."""

    def __init__(self, vis: Any) -> None:
        self.vis = vis
        self.root = vis["deltacal"]
        self.paths: list[str] = []
        self.g = _meshcat().geometry

    def object(
        self, path: str, geometry: Any, material: Any = None, transform: np.ndarray | None = None
    ) -> None:
        node = self.root[path]
        node.set_object(geometry, material)
        if transform is not None:
            node.set_transform(transform)
        self.paths.append(path)

    def transform(self, path: str, transform: np.ndarray) -> None:
        self.root[path].set_transform(transform)

    def robot(
        self, name: str, geometry: DeltaGeometry, state: RobotState, ghost: bool, plate_shape: np.ndarray
    ) -> None:
        """Draw one robot at the first pose of ``state``."""
        g = self.g
        C = _TRUE_COLOURS
        b = float(np.mean(np.linalg.norm(geometry.axis_point[:, :2], axis=1)))
        s, fat = _sizes(geometry, ghost)
        ball_r, rod_r, arm_r = 11.0 * s * fat, 4.5 * s * fat, 13.0 * s * fat
        mat = {k: _material(v, ghost) for k, v in C.items()}
        # base disc above the actuators
        housing_r = 32.0 * s * fat
        base_T = _transform(_rotation_y_to(np.array([0.0, 0.0, 1.0])), [0.0, 0.0, 44.0 * s])
        self.object(f"{name}/base", g.Cylinder(16.0 * s, b + 55.0 * s), mat["base"], base_T)
        R0 = geometry.actuator_rotation()
        for i in range(3):
            limb = f"{name}/limb{i + 1}"
            self.object(
                f"{limb}/actuator",
                g.Cylinder(120.0 * s, housing_r),
                mat["actuator"],
                _transform(R0[i], geometry.axis_point[i]),
            )
            elbow = geometry.arm_ball[i].mean(axis=0)
            R, mid, length = _segment(np.zeros(3), elbow)
            self.object(
                f"{limb}/arm/link", g.Cylinder(1.0, arm_r), mat["arm"], _transform(R, mid, (1, length, 1))
            )
            R, mid, length = _segment(geometry.arm_ball[i, 0], geometry.arm_ball[i, 1])
            self.object(
                f"{limb}/arm/elbow",
                g.Cylinder(1.0, 0.55 * arm_r),
                mat["elbow"],
                _transform(R, mid, (1, length, 1)),
            )
            for j in range(2):
                self.object(
                    f"{limb}/arm/ball{j + 1}",
                    g.Sphere(ball_r),
                    mat["ball"],
                    _transform(np.eye(3), geometry.arm_ball[i, j]),
                )
                self.object(f"{limb}/rod{j + 1}", g.Cylinder(1.0, rod_r), mat["rod"])
        self.plate(f"{name}/plate", geometry, ghost, plate_shape)
        self.pose(name, state, 0)

    def plate(self, prefix: str, geometry: DeltaGeometry, ghost: bool, plate_shape: np.ndarray) -> None:
        """Draw the plate and what it carries, in the plate frame, under ``prefix``."""
        g = self.g
        s, fat = _sizes(geometry, ghost)
        mat = {k: _material(v, ghost) for k, v in _TRUE_COLOURS.items()}
        vertices, faces = _prism_mesh(plate_shape, 12.0 * s)
        self.object(f"{prefix}/body", g.TriangularMeshGeometry(vertices, faces), mat["plate"])
        for i in range(3):
            for j in range(2):
                self.object(
                    f"{prefix}/ball{i + 1}{j + 1}",
                    g.Sphere(11.0 * s * fat),
                    mat["ball"],
                    _transform(np.eye(3), geometry.plate_ball[i, j]),
                )
        axis_len = 2.5 * float(np.max(np.linalg.norm(plate_shape, axis=1)))
        R, mid, length = _segment(np.zeros(3), np.array([0.0, 0.0, -axis_len]))
        self.object(
            f"{prefix}/axis", g.Cylinder(1.0, 4.0 * s * fat), mat["axis"], _transform(R, mid, (1, length, 1))
        )
        if np.linalg.norm(geometry.tool) > 1e-6:
            R, mid, length = _segment(np.zeros(3), geometry.tool)
            self.object(
                f"{prefix}/tool",
                g.Cylinder(1.0, 6.0 * s * fat),
                mat["tool"],
                _transform(R, mid, (1, length, 1)),
            )
        self.object(
            f"{prefix}/tcp", g.Sphere(9.0 * s * fat), mat["tool"], _transform(np.eye(3), geometry.tool)
        )

    def pose(self, name: str, state: RobotState, k: int, frame: Any = None) -> None:
        """Set the moving parts of a robot to pose k (into an animation frame when given)."""
        target = self.root if frame is None else frame["deltacal"]
        for i in range(3):
            limb = f"{name}/limb{i + 1}"
            arm_T = _transform(state.arm_rotation[k, i], state.axis_point[i])
            target[f"{limb}/arm"].set_transform(arm_T)
            for j in range(2):
                R, mid, length = _segment(state.arm_balls[k, i, j], state.plate_balls[k, i, j])
                if frame is None:
                    target[f"{limb}/rod{j + 1}"].set_transform(_transform(R, mid, (1, length, 1)))
                else:
                    target[f"{limb}/rod{j + 1}"].set_transform(_transform(R, mid))
                    target[f"{limb}/rod{j + 1}"].set_property("scale", "vector3", [1.0, length, 1.0])
        target[f"{name}/plate"].set_transform(_transform(state.shown_rotation[k], state.plate.position[k]))

    def inset_pose(self, true_state: RobotState, ghost_state: RobotState, k: int, frame: Any = None) -> None:
        """Set the inset's true plate relative to the ghost plate (at the inset's origin)."""
        target = self.root if frame is None else frame["deltacal"]
        offset = true_state.plate.position[k] - ghost_state.plate.position[k]
        target["inset/true"].set_transform(_transform(true_state.shown_rotation[k], offset))


def _sizes(geometry: DeltaGeometry, ghost: bool) -> tuple[float, float]:
    """Size unit of the drawn parts (1 for a 375 mm arm) and the ghost's fattening."""
    L = float(np.mean(np.linalg.norm(geometry.arm_ball.mean(axis=1), axis=1)))
    return L / 375.0, (1.35 if ghost else 1.0)  # the ghost's round parts sheathe the true ones


def _plate_polygon(geometry: DeltaGeometry) -> np.ndarray:
    """The plate's outline in its frame: the six plate ball centres in xy, by angle [mm], (6, 2)."""
    xy = geometry.plate_ball.reshape(6, 3)[:, :2]
    order = np.argsort(np.arctan2(xy[:, 1], xy[:, 0]))
    return xy[order]


def _text_block(
    writer: _SceneWriter,
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
    TextTexture, Plane = _text_objects()
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
            f"labels/{name}{k}", Plane(size, size), material, _transform(camera.rotation, plane_centre)
        )
        half_w = min(0.5 * size, 0.27 * line_height * len(text))
        for sx in (-1.0, 1.0):
            for sy in (-0.5, 0.5):
                corners.append(centre + sx * half_w * camera.right + sy * line_height * camera.up)
    return np.asarray(corners)


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
    """
    meshcat = _meshcat()
    if not (math.isfinite(exaggerate) and exaggerate > 0.0):
        raise ValueError(f"exaggerate must be a positive finite factor, got {exaggerate!r}")
    ws = workspace if workspace is not None else default_workspace(nominal_geometry)
    if q is None:
        q = _reachable_readings(nominal_geometry, ws.centre[None])[0]
        if not np.all(np.isfinite(q)):
            raise UnreachableError(
                f"workspace centre {ws.centre.tolist()} mm is out of reach of the nominal robot",
                [0],
                ws.centre[None],
            )
    q = np.asarray(q, dtype=float).reshape(3)
    true_state = RobotState.compute(true_geometry, q, exaggerate)
    ghost_state = RobotState.compute(nominal_geometry, q, 1.0)
    commanded = ghost_state.tcp[0]

    vis["deltacal"].delete()
    writer = _SceneWriter(vis)
    polygon = _plate_polygon(nominal_geometry)
    writer.robot("true", true_geometry, true_state, ghost=False, plate_shape=polygon)
    writer.robot("nominal", nominal_geometry, ghost_state, ghost=True, plate_shape=polygon)
    L = float(np.mean(np.linalg.norm(nominal_geometry.arm_ball.mean(axis=1), axis=1)))
    writer.object("frame", writer.g.triad(0.4 * L))
    b = float(np.mean(np.linalg.norm(nominal_geometry.axis_point[:, :2], axis=1)))
    ang = np.linspace(0.0, 2.0 * np.pi, 37)
    points = [
        true_state.arm_balls[0].reshape(-1, 3),
        true_state.plate_balls[0].reshape(-1, 3),
        ghost_state.plate_balls[0].reshape(-1, 3),
        true_state.tcp,
        np.column_stack([(b + 60.0) * np.cos(ang), (b + 60.0) * np.sin(ang), np.full_like(ang, 60.0)]),
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
    layout = _Layout.around(robot_points)
    callout = _draw_plate_callout(
        writer, layout, true_geometry, nominal_geometry, true_state, ghost_state, exaggerate
    )
    name = title if title is not None else (true_geometry.name or nominal_geometry.name or "Delta robot")
    legend = _draw_legend(writer, layout, name, arrow_scale, max_error, ARROW_RADIUS * ws.radius)
    label_points = [callout.points, legend]

    frames_done, max_path_tilt = 0, 0.0
    if animate:
        qs = _reachable_readings(nominal_geometry, demo_path(ws, frames))
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
            label_points.append(_text_block(writer, "path", text, callout.below, layout.camera, layout.line))

    if camera_view is None:
        camera_view = CameraView.framing(np.concatenate([robot_points, *label_points]))
    _set_camera(vis, camera_view)
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


def _draw_workspace(writer: _SceneWriter, ws: Workspace) -> np.ndarray:
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
    writer: _SceneWriter, errors: ErrorField, workspace_radius: float
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
    verts, cols, faces = _arrow_mesh(errors.commanded, vectors, error_colours(magnitude / max_error), radius)
    writer.object(
        "arrows",
        g.TriangularMeshGeometry(verts, faces, color=cols),
        g.MeshPhongMaterial(vertexColors=True, shininess=20),
    )
    return scale, max_error, errors.commanded + vectors


@dataclass(frozen=True)
class _Layout:
    """Where the labels go: beside the robot as a provisional camera sees it (mm, in {O})."""

    camera: CameraView
    line: float  # line height of the text
    left: float  # extent of the robot along camera.right
    right: float
    top: float  # top of the robot along camera.up
    depth: np.ndarray  # the robot's middle depth, a vector along camera.direction

    @classmethod
    def around(cls, points: np.ndarray) -> _Layout:
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


def _draw_plate_callout(
    writer: _SceneWriter,
    layout: _Layout,
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
    polygon = _plate_polygon(nominal_geometry)
    plate_pos = true_state.plate.position[0]
    plate_r = float(np.max(np.linalg.norm(polygon, axis=1)))
    tcp_error = true_state.tcp[0] - ghost_state.tcp[0]
    tilt_lines = [
        f"plate tilt {math.degrees(float(true_state.plate.tilt()[0])):.3f}\u00b0",
        f"(drawn \u00d7{exaggerate:g})",
        f"TCP error {np.linalg.norm(tcp_error):.2f} mm",
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
    ball_r = 15.0 * _sizes(nominal_geometry, True)[0]
    col_half = max(half_w, m * (float(np.max(np.abs(content @ camera.right))) + ball_r))
    col_x = (layout.right + 2.0 * line + col_half) * camera.right
    tilt_anchor = col_x + (plate_pos @ camera.up + 1.25 * line) * camera.up + layout.depth
    out = [_text_block(writer, "tilt", tilt_lines, tilt_anchor, camera, line)]
    writer.plate("inset/true", true_geometry, False, polygon)
    writer.plate("inset/nominal", nominal_geometry, True, polygon)
    writer.inset_pose(true_state, ghost_state, 0)
    content_top = m * float(np.max(content @ camera.up))
    inset_origin = col_x + (layout.top - 2.0 * line - content_top) * camera.up + layout.depth
    writer.transform("inset", _transform(Rz, inset_origin, (m, m, m)))
    for sign in (-1.0, 1.0):
        out.append(inset_origin + m * (content + sign * ball_r * camera.right))
    title_at = inset_origin + (content_top + 1.5 * line) * camera.up
    out.append(_text_block(writer, "inset", [f"plates \u00d7{m:g}, tilt side-on"], title_at, camera, line))
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


def _draw_legend(
    writer: _SceneWriter, layout: _Layout, name: str, arrow_scale: float, max_error: float, radius: float
) -> np.ndarray:
    """Left of the robot: its name, the ghost, the arrows' scale and colour bar; returns corners [mm]."""
    g = writer.g
    camera, line = layout.camera, layout.line
    legend = [name, "blue ghost: nominal"]
    half = 0.27 * line * max(len(t) for t in legend)
    if arrow_scale > 0.0:
        legend += ["TCP error arrows", f"(true - commanded) \u00d7{arrow_scale:g}"]
        half = max(0.27 * line * max(len(t) for t in legend), 4.5 * line + 0.27 * line * 8)
    anchor = (layout.left - 2.0 * line - half) * camera.right + layout.top * camera.up + layout.depth
    out = [_text_block(writer, "legend", legend, anchor, camera, line)]
    if arrow_scale <= 0.0:
        return np.concatenate(out)
    # a reference arrow of a round error size
    ref = nice_number(max_error)
    y0 = anchor - (len(legend) + 0.6) * 1.25 * line * camera.up
    vector = ref * arrow_scale * camera.right
    colour = error_colours(np.array([ref / max_error]))
    verts, cols, faces = _arrow_mesh((y0 - 0.5 * vector)[None], vector[None], colour, radius)
    material = g.MeshPhongMaterial(vertexColors=True)
    writer.object("labels/ref_arrow", g.TriangularMeshGeometry(verts, faces, color=cols), material)
    below = y0 - 1.3 * line * camera.up
    out.append(_text_block(writer, "ref", [f"{ref:g} mm"], below, camera, line))
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
            _transform(camera.rotation, centre),
        )
    ends = [bar_y - 0.5 * width * camera.right, bar_y + 0.5 * width * camera.right]
    out.append(_text_block(writer, "bar_lo", ["0"], ends[0] - 1.3 * line * camera.up, camera, line))
    out.append(
        _text_block(writer, "bar_hi", [f"{max_error:.1f} mm"], ends[1] - 1.3 * line * camera.up, camera, line)
    )
    out.append(np.stack(ends))
    return np.concatenate(out)


def _set_camera(vis: Any, camera: CameraView) -> None:
    """Put the camera's target at the viewer's origin (the orbit centre) and the camera in place."""
    g = _meshcat().geometry
    root = np.eye(4)
    root[:3, :3] *= _MM
    root[:3, 3] = -_MM * camera.target
    vis["deltacal"].set_transform(root)
    position = _MM * camera.distance * camera.direction  # metres, z up
    far = max(100.0, 4.0 * _MM * camera.distance)
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


def export_html(
    nominal_geometry: DeltaGeometry,
    true_geometry: DeltaGeometry,
    path: str | Path,
    **options: Any,
) -> SceneSummary:
    """Write the standalone HTML page of :func:`build_scene`'s scene, atomically, without a server.

    Args:
        nominal_geometry: The nominal robot.
        true_geometry: The real robot.
        path: Output HTML file.
        **options: Passed to :func:`build_scene` (``q``, ``exaggerate``, ``arrows``,
            ``animate``, ``workspace``, ``frames``, ``fps``, ``title``).

    Returns:
        What was drawn.
    """
    vis = recording_visualizer(f"deltacal: {true_geometry.name or nominal_geometry.name}")
    summary = build_scene(vis, nominal_geometry, true_geometry, **options)
    write_html(vis, path)
    return summary


# =================================================================================== rendering
def find_chromium() -> str | None:
    """Path of a Chromium executable, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def render_png(
    html_path: str | Path,
    png_path: str | Path,
    window: tuple[int, int] = DEFAULT_WINDOW,
    timeout: float = 180.0,
    chromium: str | None = None,
) -> Path:
    """Screenshot an HTML page with headless Chromium (software WebGL), atomically.

    Args:
        html_path: The page.
        png_path: Output PNG.
        window: Window size [px].
        timeout: Seconds before the browser is killed.
        chromium: Browser executable (default :func:`find_chromium`).

    Returns:
        The PNG path.

    Raises:
        ViewerError: No browser, it failed, timed out or wrote no image.
    """
    exe = chromium or find_chromium()
    if exe is None:
        raise ViewerError("no Chromium found to render the scene (apt-get install chromium)")
    html_path = Path(html_path).resolve()
    png_path = Path(png_path)
    folder = png_path.parent if str(png_path.parent) else Path(".")
    with tempfile.TemporaryDirectory(prefix="deltacal-chromium-") as profile:
        fd, tmp = tempfile.mkstemp(prefix=f".{png_path.name}.", suffix=".png", dir=folder)
        os.close(fd)
        args = [
            exe,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--hide-scrollbars",
            f"--user-data-dir={profile}",
            f"--screenshot={tmp}",
            f"--window-size={window[0]},{window[1]}",
            "--virtual-time-budget=8000",
            html_path.as_uri(),
        ]
        try:
            proc = subprocess.Popen(
                args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
            )
            try:
                _, err = proc.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                _kill_group(proc)
                raise ViewerError(f"chromium did not render {html_path} within {timeout:g} s") from None
            except BaseException:
                _kill_group(proc)
                raise
            _kill_group(proc)  # helpers it may have left in its session
            if proc.returncode != 0 or os.path.getsize(tmp) == 0:
                tail = err.decode("utf-8", "replace").strip().splitlines()[-3:]
                raise ViewerError(
                    f"chromium failed to render {html_path} (exit {proc.returncode}): {' | '.join(tail)}"
                )
            os.chmod(tmp, _file_mode())
            os.replace(tmp, png_path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    return png_path


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    """Kill the browser's own session (it was started in a new one) and reap it."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=30)


def export_views(
    nominal_geometry: DeltaGeometry,
    true_geometry: DeltaGeometry,
    html: str | Path,
    png: str | Path | None = None,
    workspace: Workspace | None = None,
    exaggerate: float = DEFAULT_EXAGGERATION,
) -> dict[str, Path]:
    """Write the animated page (error arrows) and, with Chromium, a still screenshot of it.

    The PNG shows the same scene without the animation (the robot at the
    workspace centre, tilt exaggerated, error arrows).

    Returns:
        ``{"html": path}``, and ``"png": path`` when ``png`` was asked for and Chromium is there.
    """
    options: dict[str, Any] = {"workspace": workspace, "exaggerate": exaggerate, "arrows": True}
    out = {"html": Path(html)}
    export_html(nominal_geometry, true_geometry, out["html"], animate=True, **options)
    if png is not None and find_chromium() is not None:
        with tempfile.TemporaryDirectory(prefix="deltacal-view-") as tmp:
            still = Path(tmp) / "still.html"
            export_html(nominal_geometry, true_geometry, still, animate=False, **options)
            out["png"] = render_png(still, png)
    return out
