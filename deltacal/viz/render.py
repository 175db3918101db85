"""Pages and pictures: standalone HTML of a scene, Chromium screenshots."""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from ..exceptions import ViewerError
from ..geometry import (
    DeltaGeometry,
    Workspace,
)
from ..io import atomic_output
from .layout import DEFAULT_WINDOW
from .recorder import recording_visualizer, write_html
from .scene import SceneSummary, build_scene
from .state import DEFAULT_EXAGGERATION


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
    with tempfile.TemporaryDirectory(prefix="deltacal-chromium-") as profile, \
            atomic_output(png_path, suffix=".png") as tmp:
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
