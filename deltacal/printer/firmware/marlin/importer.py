"""A printer as its ``M503`` capture finds it: the robot file of Marlin's model of those settings.

``deltacal import M503.txt -o DIR`` writes ``DIR/printer.toml`` (by the one writer,
:func:`~...importer.write_printer_file`):

* per tower: ``rod_length_mm`` = ``M665 L`` + ``A``/``B``/``C``; ``tower_azimuth_deg`` = 210, 330,
  90 + ``M665 X Y Z``; ``endstop_height_mm`` = ``M665 H − M851 Z + sqrt(rod² − R²)`` (+ the
  ``M666`` move G28 makes, when Marlin makes it) + nozzle drop: each carriage's height at its
  endstop (:attr:`~.model.MarlinDelta.carriage_top`); a Marlin 1.1.0's report, its homed height
  added as a line ``M665 H`` (``MANUAL_Z_HOME_POS + M206 Z``), takes that height whole, ``M851 Z``
  apart (its ``G28`` homes up: no probe offset); ``step_distance_mm`` = 1 / ``M92``;
* ``tower_radius_mm`` = ``M665 R`` + the effector radius; ``nozzle_mm`` = ``[0, 0, −drop]``;
* ``[workspace] radius_mm`` = the soft endstops' radius (``M211``'s ``Min``/``Max``, else Marlin's
  default 140), never beyond what the rods reach at the bed with a margin, as the other firmwares'
  imports (:func:`~...files.importer.reach_radius`); ``height_mm`` = the height up to which the full
  radius is reachable.

An ``M503`` capture holds no measurements: no probe.csv, no distances.csv (the probe's results are
read from the console, :mod:`.log`). Units: mm and deg in the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...files.importer import ImportedValues, PrinterImport, reach_radius, within_reach, write_imported
from .model import BASE_ANGLES_DEG, MarlinDelta
from .settings import marlin_from_settings, read_marlin_settings


def marlin_imported_values(path: str | Path) -> tuple[MarlinDelta, ImportedValues]:
    """Marlin's model of an ``M503`` capture and its values in deltacal's words (the module's documentation).

    Raises:
        InputError: the capture's first problem.
    """
    settings = read_marlin_settings(path)
    marlin = marlin_from_settings(settings)
    words = "the soft endstops' radius (M211 Min/Max)" if settings.limits is not None else \
        "Marlin's default soft endstops' radius (no M211 Min/Max in the capture)"
    printable = within_reach(marlin.soft_endstops.radius, words, reach_radius(marlin.rods, marlin.radius),
                             "the rods' reach (a carriage at most 12 times faster than the nozzle)")
    home = "M665 H (the homed height given: Marlin 1.1.0's G28 keeps M851 Z apart)" \
        if marlin.compiled_height else "M665 H - M851 Z"
    values = ImportedValues(
        "Marlin", str(path), (marlin.radius, "M665 R"), (marlin.rods, "M665 L + A/B/C"),
        (np.array(BASE_ANGLES_DEG) + marlin.angle_trim, "210, 330, 90 + M665 X/Y/Z"),
        (np.array(marlin.carriage_top), f"{home} + sqrt(rod^2 - R^2) (+ G28's M666 move)"),
        (marlin.step_distance, "1 / M92"), printable,
        "Marlin's full-radius height (radius tapered above)", where="M665 H")
    return marlin, values


def import_marlin(path: str | Path, folder: str | Path, effector_radius: float | None = None,
                  rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
    """Write ``folder/printer.toml`` of an ``M503`` capture (the module's documentation).

    Args:
        path: The capture.
        folder: An existing folder.
        effector_radius: Effector centre to each ball pair's midpoint [mm] (default 30).
        rod_spacing: Between a pair's two balls [mm] (default 50).
        nozzle_drop: The nozzle below the effector's ball plane [mm] (default 30).

    Raises:
        InputError: the capture's first problem, or no printable volume.
    """
    marlin, values = marlin_imported_values(path)
    written, taken = write_imported(folder, values, effector_radius, rod_spacing, nozzle_drop)
    said = f"wrote {written}: Marlin's model of {path} (M665 R {marlin.radius:g} mm){taken}"
    return PrinterImport((written,), (said,))
