"""meshcat views of a robot, as a scene served live, a standalone page or a screenshot.

The true robot over its nominal ghost, the plate tilt exaggerated, TCP errors over the
workspace, an animation; standalone HTML pages and Chromium screenshots. A printer (a prismatic
chain) is drawn as its towers, carriages, rods, effector and nozzle over the bed.

meshcat is imported by :mod:`._meshcat` only, and only when a scene is drawn or served.
"""

from ..exceptions import ViewerError
from .layout import (
    CAMERA_AZIMUTH,
    CAMERA_ELEVATION,
    CAMERA_FOV,
    DEFAULT_WINDOW,
    INSET_MAGNIFICATION,
    CameraView,
    words,
)
from .meshes import ARROW_RADIUS
from .recorder import (
    SceneRecorder,
    meshcat_server,
    recording_visualizer,
    stop_server,
    write_html,
)
from .render import export_html, export_views, find_chromium, render_png
from .scene import SceneSummary, build_scene
from .state import (
    DEFAULT_EXAGGERATION,
    ErrorField,
    RobotState,
    default_workspace,
    demo_path,
    error_colours,
    nice_number,
    workspace_grid,
)

__all__ = [
    "ViewerError",
    "ARROW_RADIUS",
    "CAMERA_AZIMUTH",
    "CAMERA_ELEVATION",
    "CAMERA_FOV",
    "CameraView",
    "DEFAULT_EXAGGERATION",
    "DEFAULT_WINDOW",
    "ErrorField",
    "INSET_MAGNIFICATION",
    "RobotState",
    "SceneRecorder",
    "SceneSummary",
    "build_scene",
    "default_workspace",
    "demo_path",
    "error_colours",
    "export_html",
    "export_views",
    "find_chromium",
    "meshcat_server",
    "nice_number",
    "recording_visualizer",
    "render_png",
    "stop_server",
    "words",
    "workspace_grid",
    "write_html",
]
