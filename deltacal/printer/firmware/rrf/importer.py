"""A printer as its ``config.g`` finds it: the robot file of RepRapFirmware's model of it.

``deltacal import config.g -o DIR`` writes ``DIR/printer.toml`` (by the one writer,
:func:`~...importer.write_printer_file`) of exactly the printer RRF's model of the configuration
(:func:`~.config.load_rrf`, ``config-override.g`` read by its ``M501``) describes, its tilt aside:

* ``tower_radius_mm`` = ``M665 R`` + the effector radius; ``rod_length_mm`` = ``M665 L`` (per
  tower ``a:b:c``); ``tower_azimuth_deg`` = (210, 330, 90) + ``M665 X Y Z`` (``Recalc()``);
* ``endstop_height_mm`` = ``M665 H + sqrt(L_i² − R²) + M666 X Y Z`` (``homedCarriageHeights``) + the
  nozzle drop; ``step_distance_mm`` = ``1 / M92 X Y Z`` at the ``M350`` microstepping;
* ``[workspace] radius_mm`` = ``M665 B`` (RRF's default 80 without it), never beyond the reach of
  the rods at the bed with a margin (:func:`~...files.importer.reach_radius`);
* the bed tilt ``M666 A B`` is RRF's plane of the bed under its model, not a value of a robot
  file, whose printer stands on its bed (z = 0): the file says so (when it is not 0). Measurements
  are taken through ``--controller config.g``, whose model has the tilt: the identified printer's
  true bed is its z = 0, and the tilt is found as the printer's lean; ``export`` fits ``M666 A B``
  again.

Config.g holds no measurements: no probe.csv, no distances.csv (the probe's results are read from
its console, :mod:`.log`). Units: mm and deg in the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...files.importer import ImportedValues, PrinterImport, reach_radius, within_reach, write_imported
from .config import read_rrf_settings, rrf_from_settings
from .model import BASE_ANGLES_DEG, DEFAULT_PRINT_RADIUS, RRFDelta


def rrf_imported_values(path: str | Path) -> tuple[RRFDelta, ImportedValues]:
    """RRF's model of ``config.g`` and its values in deltacal's words (the module's documentation).

    Raises:
        InputError: the configuration's first problem.
    """
    settings = read_rrf_settings(path)
    rrf = rrf_from_settings(settings)
    note = "M665 B"
    if "M665 B" not in settings.values:
        note = f"RepRapFirmware's default M665 B{DEFAULT_PRINT_RADIUS:g}"
    radius, note = within_reach(rrf.print_radius, note, reach_radius(rrf.diagonal, rrf.radius),
                                "the rods' reach (a carriage at most 12 times faster than the nozzle)")
    a, b = rrf.tilt * 100.0
    tilt = (f"Bed tilt M666 A{a:g} B{b:g} (percent) of {Path(path).name}: not a robot file value (its "
            "printer stands on its bed, z = 0). identify --controller config.g takes the commanded "
            "positions through RRF's model with that tilt: the identified printer's true bed is its z = 0, "
            "the tilt found as the printer's lean; export fits M666 A B again.")
    # the azimuths in degrees as the file gives them (no float noise of a round trip through radians)
    azimuth = np.array(BASE_ANGLES_DEG) + np.array([settings.get(f"M665 {k}", 0.0) for k in "XYZ"])
    values = ImportedValues(
        "RepRapFirmware", str(path), (rrf.radius, "M665 R"), (rrf.diagonal, "M665 L"),
        (azimuth, "(210, 330, 90) + M665 X Y Z"),
        (rrf.carriage_top, "M665 H + sqrt(L^2 - R^2) + M666 X Y Z"),
        (rrf.step_distance, "1 / M92 X Y Z (at the M350 microstepping)"), (radius, note),
        "the full radius's height: min(carriage top - L)", notes=(tilt,) if np.any(rrf.tilt) else (),
        where="M665 H")
    return rrf, values


def import_rrf(path: str | Path, folder: str | Path, effector_radius: float | None = None,
               rod_spacing: float | None = None, nozzle_drop: float | None = None) -> PrinterImport:
    """Write ``folder/printer.toml`` of ``config.g`` (the module's documentation).

    Args:
        path: ``config.g`` (or ``config-override.g``).
        folder: An existing folder.
        effector_radius: Effector centre to each ball pair's midpoint [mm] (default 30).
        rod_spacing: Between a pair's two balls [mm] (default 50).
        nozzle_drop: The nozzle below the effector's ball plane [mm] (default 30).

    Raises:
        InputError: the configuration's first problem, or no printable volume.
    """
    rrf, values = rrf_imported_values(path)
    written, defaults = write_imported(folder, values, effector_radius, rod_spacing, nozzle_drop)
    tilt = f"; its bed tilt M666 A B ({', '.join(f'{v * 100:g}' for v in rrf.tilt)} %) is not in the file" \
        if np.any(rrf.tilt) else ""
    return PrinterImport((written,), (f"wrote {written}: RepRapFirmware's model of {path} (M665 R "
                                      f"{rrf.radius:g} mm){defaults}{tilt}",
                                      "config.g holds no measurements: no probe.csv, no distances.csv"))


