"""A printer as its ``M503`` capture finds it: the robot file of Marlin's model of those settings.

``deltacal import M503.txt -o DIR`` writes ``DIR/printer.toml`` (:func:`~...imported.imported_robot_text`):

* per tower: ``rod_length_mm`` = ``M665 L`` + ``A``/``B``/``C``; ``tower_azimuth_deg`` = 210, 330,
  90 + ``M665 X Y Z``; ``endstop_height_mm`` = ``M665 H − M851 Z + sqrt(rod² − R²)`` (+ the
  ``M666`` move G28 makes, when Marlin makes it) + nozzle drop: each carriage's height at its
  endstop (:attr:`~.model.MarlinDelta.carriage_top`); ``step_distance_mm`` = 1 / ``M92``;
* ``tower_radius_mm`` = ``M665 R`` + the effector radius; ``nozzle_mm`` = ``[0, 0, −drop]``;
* ``[workspace] radius_mm`` = the soft endstops' radius (``M211``'s ``Min``/``Max``, else Marlin's
  default); ``height_mm`` = the height up to which the full radius is reachable.

Units: mm and deg in the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...imported import ImportedValues, imported_robot_text
from .model import BASE_ANGLES_DEG, MarlinDelta
from .settings import load_marlin


def import_marlin(path: str | Path, effector_radius: float, rod_spacing: float,
                  nozzle_drop: float, defaults: tuple[str, ...] = ()) -> tuple[str, MarlinDelta]:
    """The robot file's text of an ``M503`` capture, and Marlin's model of it.

    Args:
        path: The capture.
        effector_radius: Effector centre to each ball pair's midpoint [mm].
        rod_spacing: Between a pair's two balls [mm].
        nozzle_drop: The nozzle below the effector's ball plane [mm].
        defaults: Which of them were taken by default, as said.

    Raises:
        InputError: the capture's first problem, or no printable volume.
    """
    marlin = load_marlin(path)
    limits = marlin.soft_endstops
    values = ImportedValues(
        "Marlin", str(path), (marlin.radius, "M665 R"), (marlin.rods, "M665 L + A/B/C"),
        (np.array(BASE_ANGLES_DEG) + marlin.angle_trim, "210, 330, 90 + M665 X/Y/Z"),
        (np.array(marlin.carriage_top), "M665 H - M851 Z + sqrt(rod^2 - R^2) (+ G28's M666 move)"),
        (marlin.step_distance, "1 / M92"),
        (limits.radius, "the soft endstops' radius (M211 Min/Max)"))
    return imported_robot_text(values, effector_radius, rod_spacing, nozzle_drop, defaults, "M665 H"), marlin
