"""A printer as its ``printer.cfg`` finds it: the robot file and the measurements Klipper saved.

``deltacal import printer.cfg`` (conventions, "Printers as they are found"): the robot file
(``kind = "linear"``) of exactly the printer Klipper's model of the configuration describes, and,
when the SAVE_CONFIG block holds a ``[delta_calibrate]`` section, its measurements in deltacal's
files (:mod:`.saved`):

* per tower: ``rod_length_mm`` = ``arm_length``; ``endstop_height_mm`` = ``position_endstop +
  sqrt(arm_length² − delta_radius²) + nozzle drop``; ``step_distance_mm`` = Klipper's step
  distance; each a number when the three towers agree, ``[a, b, c]`` otherwise;
  ``tower_azimuth_deg`` = each ``angle``;
* ``tower_radius_mm`` = ``delta_radius`` + the effector radius; ``nozzle_mm`` = ``[0, 0, −drop]``;
  the effector radius, the rod spacing and the nozzle drop are not in a configuration: given
  (measured), or defaults that the file names;
* ``[workspace]``: ``radius_mm`` = ``print_radius``, else ``[delta_calibrate] radius``, else
  Klipper's default (``delta_radius``), never beyond Klipper's own bound ``min(arm_length) −
  delta_radius``; ``height_mm`` = Klipper's height up to which the full radius is printable
  (``min(carriage top − arm_length)``, its ``limit_z``);
* probe heights: the commanded positions (through the configuration's values) of the steps of
  each ``heightN_pos`` and ``manual_heightN_pos``, with the trigger height ``heightN`` (0 for a
  manual height: the nozzle touched the bed there); distances: those of ``distanceN_pos1`` and
  ``distanceN_pos2``, with ``distanceN``.

Units: mm and deg in the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...files.importer import (
    OUTPUT_FILES,
    ImportedValues,
    Measured,
    check_stale_outputs,
    printer_file_text,
    within_reach,
    write_printer_file,
)
from ...files.measurements import write_printed_distances, write_probe_heights
from .config import STEPPERS, KlipperConfig, klipper_from_config, read_klipper_config
from .model import DEFAULT_ANGLES_DEG, KlipperDelta
from .saved import SavedCalibration, read_saved_calibration, saved_positions


@dataclass(frozen=True)
class ImportedPrinter:
    """A printer read from its Klipper configuration.

    Attributes:
        text: The robot file's text.
        klipper: Klipper's model of the configuration.
        saved: The measurements its ``[delta_calibrate]`` holds.
        probe: Commanded nozzle positions of the saved heights [mm], (N, 3).
        pairs: Commanded positions of the saved distances' ends ``x1..z2`` [mm], (M, 6).
        defaults: What was taken by default (effector radius, rod spacing, nozzle drop), as said.
        values: Klipper's model in deltacal's words.
        measured: What the configuration does not say (given or defaults).
    """

    text: str
    klipper: KlipperDelta
    saved: SavedCalibration
    probe: np.ndarray
    pairs: np.ndarray
    defaults: tuple[str, ...]
    values: ImportedValues
    measured: Measured


def import_klipper(path: str | Path, effector_radius: float | None = None, rod_spacing: float | None = None,
                   nozzle_drop: float | None = None) -> ImportedPrinter:
    """The robot file and the saved measurements of a ``printer.cfg``.

    Args:
        path: The configuration.
        effector_radius: Effector centre to each ball pair's midpoint [mm] (default 30).
        rod_spacing: Between a pair's two balls [mm] (default 50).
        nozzle_drop: The nozzle below the effector's ball plane [mm] (default 30).

    Raises:
        InputError: the configuration's first problem, or values no printer can have.
    """
    config = read_klipper_config(path)
    klipper = klipper_from_config(config)
    measured = Measured.given(effector_radius, rod_spacing, nozzle_drop)
    saved = read_saved_calibration(config)
    def positions(steps: np.ndarray) -> np.ndarray:
        return klipper.positions(steps, check=False)

    probe = saved_positions(positions, saved.height_steps, config, "height")
    ends = saved_positions(positions, saved.pair_steps.reshape(-1, 3), config, "distance")
    values = _values(config, klipper)
    text = printer_file_text(values, measured)
    return ImportedPrinter(text, klipper, saved, probe, ends.reshape(-1, 6), measured.defaults, values,
                           measured)


def _values(config: KlipperConfig, klipper: KlipperDelta) -> ImportedValues:
    """Klipper's model of the configuration in deltacal's words (:class:`~...importer.ImportedValues`)."""
    rho = klipper.delta_radius
    angles = [config.number(s, "angle", d) for s, d in zip(STEPPERS, DEFAULT_ANGLES_DEG, strict=True)]
    return ImportedValues(
        "Klipper", config.source, (rho, "delta_radius"), (klipper.arm_length, "arm_length"),
        (np.array(angles, dtype=float), "angle"),
        (klipper.position_endstop + np.sqrt(klipper.arm_length**2 - rho**2),
         "position_endstop + sqrt(arm_length^2 - delta_radius^2)"),
        (klipper.step_distance, ""), _printable_radius(config, klipper),
        "Klipper's full-radius height (radius tapered above)",
        where="sections [stepper_a..c], key position_endstop")


def _printable_radius(config: KlipperConfig, klipper: KlipperDelta) -> tuple[float, str]:
    """The printable radius [mm] and where it came from."""
    if config.has("printer", "print_radius"):
        radius, note = config.number("printer", "print_radius", above=0.0), "print_radius"
    elif config.has("delta_calibrate", "radius"):
        radius, note = config.number("delta_calibrate", "radius", above=0.0), "[delta_calibrate] radius"
    else:
        radius, note = klipper.delta_radius, "Klipper's default print_radius (delta_radius)"
    return within_reach(radius, note, klipper.reach_radius,
                        "Klipper's own reach (a carriage at most 12 times faster than the nozzle)")


def write_import(imported: ImportedPrinter, out_dir: str | Path) -> list[Path]:
    """Write ``printer.toml`` and, with saved measurements, ``probe.csv`` and ``distances.csv``.

    Returns:
        The files written.

    Raises:
        UsageError: the folder holds ``probe.csv`` or ``distances.csv`` not written here
            (:func:`~deltacal.printer.files.importer.check_stale_outputs`).
    """
    out = Path(out_dir)
    saved = imported.saved
    writes = [OUTPUT_FILES[0]] + [name for name, rows in zip(OUTPUT_FILES[1:], (saved.height, saved.distance),
                                                             strict=True) if rows.size]
    check_stale_outputs(out, writes, "its SAVE_CONFIG block holds no [delta_calibrate] measurements of them")
    written = [write_printer_file(out / OUTPUT_FILES[0], imported.values, imported.measured)]
    if saved.height.size:
        written.append(write_probe_heights(out / OUTPUT_FILES[1], imported.probe[:, :2], imported.probe[:, 2],
                                           trigger_height=saved.height))
    if saved.distance.size:
        written.append(write_printed_distances(out / OUTPUT_FILES[2], imported.pairs, saved.distance))
    return written
