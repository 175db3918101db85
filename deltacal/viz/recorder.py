"""Scene recording without a server, standalone HTML pages, and the meshcat server's life."""

from __future__ import annotations

import base64
import contextlib
import io
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from ..exceptions import ViewerError
from ..io import atomic_write_bytes
from ._meshcat import import_meshcat, viewer_script


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
            f"<script>\n{viewer_script()}\n</script>\n"
            "<script>\nvar viewer = new MeshCat.Viewer(document.getElementById('meshcat-pane'));\n"
            f"{replay}</script>\n</body>\n</html>\n"
        )


def _html_escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def recording_visualizer(title: str = "deltacal") -> Any:
    """A ``meshcat.Visualizer`` that records into a :class:`SceneRecorder` (no server).

    ``vis.static_html()`` then returns the standalone page.
    """
    meshcat = import_meshcat()
    return meshcat.Visualizer(window=SceneRecorder(title))


@contextlib.contextmanager
def meshcat_server() -> Iterator[Any]:
    """Start a meshcat server and yield its ``Visualizer``; the server is always stopped.

    The server subprocess is killed and reaped on leaving the block, also on
    errors and Ctrl-C.
    """
    meshcat = import_meshcat()
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
    return atomic_write_bytes(path, vis.static_html().encode("utf-8"))
