"""Meshes and materials: transforms, prisms, arrows, text sprites, colours."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ._meshcat import import_meshcat

#: Shaft radius of the error arrows, per workspace radius.
ARROW_RADIUS = 0.011


MM = 1e-3  # scene metres per mm


# Colours (0xRRGGBB).
TRUE_COLOURS = {
    "base": 0x5A5F66,
    "actuator": 0x2C4A7A,
    "arm": 0xD9822B,
    "elbow": 0xB8651A,
    "ball": 0xC8CCD2,
    "rod": 0x6F7A86,
    "plate": 0x3C9E5A,
    "axis": 0x1F6B38,
    "tool": 0xC0392B,
    "bed": 0x8C8F94,
}


_GHOST_COLOUR = 0x6FB7FF


_GHOST_OPACITY = 0.28


# ============================================================================== scene primitives
def mesh_transform(
    rotation: np.ndarray, position: Any, scale: Sequence[float] = (1.0, 1.0, 1.0)
) -> np.ndarray:
    """Homogeneous transform: rotation times a scale along the local axes, then a translation."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(rotation) @ np.diag(scale)
    T[:3, 3] = position
    return T


def rotation_y_to(direction: np.ndarray) -> np.ndarray:
    """A rotation taking the y axis (three.js cylinders) to ``direction``; continuous near z."""
    u = direction / np.linalg.norm(direction)
    ref = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - np.dot(ref, u) * u
    x /= np.linalg.norm(x)
    return np.column_stack([x, u, np.cross(x, u)])


def cylinder_between(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation, midpoint and length of a unit cylinder stretched from a to b."""
    d = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
    return rotation_y_to(d), 0.5 * (np.asarray(a) + np.asarray(b)), float(np.linalg.norm(d))


def part_material(colour: int, ghost: bool, **kwargs: Any) -> Any:
    """The material of a drawn part: shiny in ``colour``, or the ghost's translucent grey."""
    g = import_meshcat().geometry
    if ghost:
        return g.MeshLambertMaterial(color=_GHOST_COLOUR, opacity=_GHOST_OPACITY, depthWrite=False, **kwargs)
    return g.MeshPhongMaterial(color=colour, shininess=40, **kwargs)


def prism_mesh(polygon: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
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


def arrow_mesh(
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
        R = rotation_y_to(v)
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


def text_objects() -> tuple[type, type]:
    """Meshcat geometry classes for a text texture and a plane (missing from meshcat 0.3.2)."""
    g = import_meshcat().geometry

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

    class PlaneGeometry(g.Geometry):  # type: ignore[misc,name-defined]
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

    return TextTexture, PlaneGeometry
