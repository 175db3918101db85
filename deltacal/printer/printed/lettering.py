"""Raised lettering for a printed part: a small block font of digits and its tiles as closed meshes.

A label is a tile lying on the bed whose top carries the characters raised above it. The font is
a grid of square cells, 3 across and 5 high per character (:data:`GLYPHS`): one cell is one stroke,
so a cell of :data:`CELL` gives characters :data:`CELL` × 5 high with strokes :data:`CELL` wide,
which a 0.4 mm nozzle prints as two or three lines. A 6 and a 9 are underlined, so that a tile read
upside down says which it is.

The mesh (:func:`terrace_mesh`) is the tile as a stack of cells, each cell a column whose height is
its level: tops, bottoms and walls of whole cells (split at every level), so that every edge is
shared by exactly two faces (closed and consistently wound) without a polygon library. A raster
whose cells touch only at a corner would share an edge four times: :func:`terrace_mesh` refuses
it, and no glyph has one. Units: mm.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import trimesh

#: Side of a cell of the font, and so the width of a stroke [mm].
CELL = 1.0
#: Thickness of a label's tile [mm] (three layers of 0.2 mm).
TILE_THICKNESS = 0.6
#: Height of the characters above the tile [mm] (four layers of 0.2 mm).
RELIEF = 0.8
#: Empty cells around the characters on a tile.
MARGIN = 1

#: The digits, rows from the top, ``#`` a raised cell: 3 cells across, 5 high.
GLYPHS: dict[str, tuple[str, ...]] = {
    "0": ("###", "#.#", "#.#", "#.#", "###"),
    "1": (".#.", "##.", ".#.", ".#.", "###"),
    "2": ("###", "..#", "###", "#..", "###"),
    "3": ("###", "..#", "###", "..#", "###"),
    "4": ("#.#", "#.#", "###", "..#", "..#"),
    "5": ("###", "#..", "###", "..#", "###"),
    "6": ("###", "#..", "###", "#.#", "###"),
    "7": ("###", "..#", "..#", "..#", "..#"),
    "8": ("###", "#.#", "###", "#.#", "###"),
    "9": ("###", "#.#", "###", "..#", "###"),
}
#: Characters underlined (they read as each other upside down).
UNDERLINED = frozenset("69")
#: Rows of a line of text: the glyph, a gap and the underline.
TEXT_ROWS = 7


def text_raster(text: str) -> np.ndarray:
    """The raised cells of ``text``, rows from the top, with :data:`MARGIN` empty cells around, bool.

    Characters are 3 cells wide with one empty column between them; every tile is
    :data:`TEXT_ROWS` rows high (plus the margins), underlined or not.

    Raises:
        ValueError: a character the font does not have.
    """
    missing = sorted({c for c in text if c not in GLYPHS})
    if missing or not text:
        raise ValueError(f"the label font has the digits only; cannot write {text!r}")
    columns = 4 * len(text) - 1
    raster = np.zeros((TEXT_ROWS + 2 * MARGIN, columns + 2 * MARGIN), dtype=bool)
    for k, char in enumerate(text):
        left = MARGIN + 4 * k
        glyph = np.array([[c == "#" for c in row] for row in GLYPHS[char]])
        raster[MARGIN:MARGIN + 5, left:left + 3] = glyph
        if char in UNDERLINED:
            raster[MARGIN + TEXT_ROWS - 1, left:left + 3] = True
    return raster


def text_size(text: str) -> np.ndarray:
    """Width and depth of the tile of ``text`` [mm], (2,)."""
    rows, columns = text_raster(text).shape
    return np.array([columns * CELL, rows * CELL])


def terrace_mesh(levels: np.ndarray, heights: np.ndarray, origin: np.ndarray,
                 cell: float = CELL) -> trimesh.Trimesh:
    """A closed mesh of square columns standing on z = 0: cell (row, column) rises to ``heights[level]``.

    Args:
        levels: The level of each cell, rows along +y from ``origin``, columns along +x, each at
            least 1 (every cell is solid), (ny, nx) int.
        heights: The height of each level [mm], increasing, ``heights[0] = 0`` (the bed).
        origin: The (x, y) of the corner of cell (0, 0) [mm].
        cell: The side of a cell [mm].

    Raises:
        ValueError: a cell below level 1, or two cells at or above a level touching only at a corner.
    """
    import trimesh

    L = np.asarray(levels, dtype=int)
    if L.min() < 1:
        raise ValueError("every cell of a terrace mesh must stand at level 1 or above")
    ny, nx = L.shape
    padded = np.zeros((ny + 2, nx + 2), dtype=int)
    padded[1:-1, 1:-1] = L
    for k in range(1, int(L.max()) + 1):
        b = padded >= k
        if np.any((b[:-1, :-1] == b[1:, 1:]) & (b[:-1, 1:] == b[1:, :-1]) & (b[:-1, :-1] != b[:-1, 1:])):
            raise ValueError(f"cells at level {k} touch only at a corner: the mesh would not be a manifold")
    keys: dict[tuple[int, int, int], int] = {}
    faces: list[tuple[int, int, int]] = []

    def quad(*corners: tuple[int, int, int]) -> None:
        a, b, c, d = (keys.setdefault(v, len(keys)) for v in corners)
        faces.extend([(a, b, c), (a, c, d)])

    for iy in range(ny):
        for ix in range(nx):
            k = int(L[iy, ix])
            quad((ix, iy, k), (ix + 1, iy, k), (ix + 1, iy + 1, k), (ix, iy + 1, k))  # top, facing +z
            quad((ix, iy, 0), (ix, iy + 1, 0), (ix + 1, iy + 1, 0), (ix + 1, iy, 0))  # bottom, facing -z
    for iy in range(ny + 1):
        for ix in range(nx + 1):
            if iy < ny:  # the wall at x = ix between columns ix - 1 and ix
                left, right = int(padded[iy + 1, ix]), int(padded[iy + 1, ix + 1])
                for k in range(min(left, right), max(left, right)):
                    c = [(ix, iy, k), (ix, iy + 1, k), (ix, iy + 1, k + 1), (ix, iy, k + 1)]
                    quad(*(c if left > right else c[::-1]))
            if ix < nx:  # the wall at y = iy between rows iy - 1 and iy
                below, above = int(padded[iy, ix + 1]), int(padded[iy + 1, ix + 1])
                for k in range(min(below, above), max(below, above)):
                    c = [(ix, iy, k), (ix, iy, k + 1), (ix + 1, iy, k + 1), (ix + 1, iy, k)]
                    quad(*(c if below > above else c[::-1]))
    grid = np.array(list(keys), dtype=float).reshape(-1, 3)
    z = np.asarray(heights, dtype=float)
    vertices = np.column_stack([origin[0] + cell * grid[:, 0], origin[1] + cell * grid[:, 1],
                                z[grid[:, 2].astype(int)]])
    return trimesh.Trimesh(vertices, np.array(faces, dtype=np.int64), process=False)


def label_mesh(text: str, centre: np.ndarray) -> trimesh.Trimesh:
    """The tile of ``text`` centred on ``centre`` (x, y) [mm], lying on the bed, its characters raised.

    The text reads from the printer's front (−y), its baseline along +x.
    """
    raster = text_raster(text)[::-1]  # rows along +y
    size = text_size(text)
    origin = np.asarray(centre, dtype=float)[:2] - 0.5 * size
    return terrace_mesh(1 + raster.astype(int), np.array([0.0, TILE_THICKNESS, TILE_THICKNESS + RELIEF]),
                        origin)
