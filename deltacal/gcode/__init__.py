"""G-code programs rewritten for a controller: every move's points corrected, the rest kept byte for byte.

* :mod:`.rewriter`: the reader: the program read line by line into plans, streamed out in chunks
  (:func:`filter_gcode`, :func:`filter_lines`, :func:`read_lines`, :func:`is_gcode_path`).
* :mod:`.state`: the program's modal state, and its modes as enums (motion, plane, extrusion).
* :mod:`.moves`: the plan of a line (kept, a move sent whole, or split) and a split move's text.
* :mod:`.path`: a move's intended path (lines and XY arcs) cut into the points sent.
* :mod:`.batch`: a chunk of output, its points corrected once per chunk.
* :mod:`.source`: a program's text as read (its name, its lines with their endings, a byte-order mark).
* :mod:`.marker`: the first line of a corrected program, which says it is one.
* :mod:`.dialect`: a controller's reading of G-code where controllers differ (its lines, macros, rules).
* :mod:`.syntax`: a line's text as controllers read it (comment, ending, what they read differently).
* :mod:`.notes`: what is said of a program without refusing it (warnings, by kind).
* :mod:`.macros`, :mod:`.homing`: a controller's macro applied to the state; the first move after a homing.
"""

from .marker import MARKER, marker_line
from .rewriter import (
    ARC_RADIUS_TOLERANCE_MM,
    ARC_TOLERANCE_RATIO,
    CHUNK_LINES,
    CHUNK_POINTS,
    DEFAULT_SEGMENT_MM,
    E_DECIMALS,
    MAX_COORDINATE_MM,
    MIN_SEGMENT_MM,
    SUFFIXES,
    XYZ_DECIMALS,
    filter_gcode,
    filter_lines,
    is_gcode_path,
    read_lines,
)

__all__ = [
    "ARC_RADIUS_TOLERANCE_MM",
    "ARC_TOLERANCE_RATIO",
    "CHUNK_LINES",
    "CHUNK_POINTS",
    "DEFAULT_SEGMENT_MM",
    "E_DECIMALS",
    "MARKER",
    "MAX_COORDINATE_MM",
    "MIN_SEGMENT_MM",
    "SUFFIXES",
    "XYZ_DECIMALS",
    "filter_gcode",
    "filter_lines",
    "is_gcode_path",
    "marker_line",
    "read_lines",
]
