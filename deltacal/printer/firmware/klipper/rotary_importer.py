"""A rotary Delta printer as its ``printer.cfg`` finds it: the rotary robot file of Klipper's model.

``deltacal import printer.cfg`` of a ``kinematics: rotary_delta`` configuration writes
``printer.toml``, a rotary robot file (no ``kind``: conventions, "Nominal robot file") of exactly
the printer Klipper's model describes (:mod:`.rotary_model`), in deltacal's base frame {O} (origin at
the shoulders' centre, z up):

* ``base_radius_mm`` = ``shoulder_radius`` + the effector radius; ``plate_radius_mm`` = the effector
  radius; ``arm_length_mm`` = ``upper_arm_length``; ``rod_length_mm`` = ``lower_arm_length``;
  ``limb_azimuth_deg`` = each stepper's ``angle`` (30, 150, 270 by default); ``tool_mm`` =
  ``[0, 0, −nozzle drop]``; the effector radius, rod spacing and nozzle drop are not in a
  configuration: given (``--effector-radius``...), or the defaults that the file names;
* Klipper's bed (z = 0) is at ``z = −(shoulder_height + nozzle drop)`` in {O} (a comment line says so);
* ``[workspace]``: ``radius_mm`` = ``[delta_calibrate] radius``, else Klipper's ``max_xy``;
  from ``minimum_z_position`` up to Klipper's full-radius height ``limit_z`` (both moved into {O}).

A robot file holds one arm length and one rod length: arms that the configuration gives different
lengths are refused, naming the key. The measurements a SAVE_CONFIG block's ``[delta_calibrate]``
holds (:mod:`.saved`: Klipper's rotary ``DELTA_CALIBRATE`` and ``DELTA_ANALYZE``) are written as the
linear printer's (:mod:`.importer`): ``probe.csv``, the commanded positions (in Klipper's frame, the
bed's) of each ``heightN_pos`` and ``manual_heightN_pos`` through the configuration's own values
(Klipper's ``get_position_from_stable``: each arm's endstop angle less its steps times its step
angle) with the trigger height ``heightN``; ``distances.csv``, those of ``distanceN_pos1`` and
``distanceN_pos2`` with ``distanceN``. Units: mm and deg in the file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ....exceptions import InputError
from ....io.atomic import atomic_write_text
from ....io.robot import load_nominal
from ....io.toml import toml_value
from ...files.importer import MEASURED_OPTIONS, OUTPUT_FILES, Measured, PrinterImport, check_stale_outputs
from ...files.measurements import write_printed_distances, write_probe_heights
from .config import KlipperConfig
from .rotary_config import rotary_from_config
from .rotary_model import KlipperRotaryDelta
from .saved import SavedCalibration, read_saved_calibration, saved_positions


@dataclass(frozen=True)
class ImportedRotary:
    """A rotary printer read from its Klipper configuration.

    Attributes:
        text: The robot file's text.
        klipper: Klipper's model of the configuration.
        measured: What the configuration does not say (given or defaults).
        saved: The measurements its SAVE_CONFIG block's ``[delta_calibrate]`` holds.
        probe: Commanded nozzle positions of the saved heights in Klipper's frame [mm], (N, 3).
        pairs: Commanded positions of the saved distances' ends ``x1..z2`` [mm], (M, 6).
    """

    text: str
    klipper: KlipperRotaryDelta
    measured: Measured
    saved: SavedCalibration
    probe: np.ndarray
    pairs: np.ndarray


def import_rotary(config: KlipperConfig, effector_radius: float | None = None,
                  rod_spacing: float | None = None, nozzle_drop: float | None = None) -> ImportedRotary:
    """The rotary robot file of a ``kinematics: rotary_delta`` configuration already read.

    Raises:
        InputError: the configuration's first problem, arms of different lengths, no printable volume, or
            a saved measurement out of the values' reach.
    """
    klipper = rotary_from_config(config)
    for key, values in (("upper_arm_length", klipper.upper_arm), ("lower_arm_length", klipper.lower_arm)):
        if np.ptp(values) > 0.0:
            lengths = ", ".join(f"{v:g}" for v in values)
            raise InputError(f"the arms' {key} differ ({lengths} mm): a rotary robot "
                             "file holds one length, per-arm lengths are not imported yet", config.source,
                             f"sections [stepper_a..c], key {key}")
    measured = Measured.given(effector_radius, rod_spacing, nozzle_drop)
    text = _robot_text(config, klipper, measured)
    saved = read_saved_calibration(config)

    def positions(steps: np.ndarray) -> np.ndarray:
        return klipper.step_positions(steps, check=False)

    probe = saved_positions(positions, saved.height_steps, config, "height")
    ends = saved_positions(positions, saved.pair_steps.reshape(-1, 3), config, "distance")
    return ImportedRotary(text, klipper, measured, saved, probe, ends.reshape(-1, 6))


def printable_radius(config: KlipperConfig, klipper: KlipperRotaryDelta) -> tuple[float, str]:
    """The printable radius [mm]: ``[delta_calibrate] radius``, else Klipper's ``max_xy``; and what it is."""
    if config.has("delta_calibrate", "radius"):
        return config.number("delta_calibrate", "radius", above=0.0), "[delta_calibrate] radius"
    return klipper.max_radius, ("Klipper's max_xy: min(shoulder_radius + upper arm, lower arm - "
                                "shoulder_radius)")


def _robot_text(config: KlipperConfig, klipper: KlipperRotaryDelta, measured: Measured) -> str:
    """The robot file's text (the module's documentation)."""
    source = Path(config.source)
    base = klipper.base_height(measured.nozzle_drop)
    top, bottom = klipper.limit_z, klipper.minimum_z_position
    if top <= bottom:
        raise InputError(f"Klipper's full-radius height limit_z {top:g} mm is not above minimum_z_position "
                         f"{bottom:g} mm: no printable volume", config.source,
                         "sections [stepper_a..c], key position_endstop")
    radius, note = printable_radius(config, klipper)
    a, drop = measured.effector_radius, measured.nozzle_drop
    defaults = [f"# Not in a Klipper configuration, taken by default: {', '.join(measured.defaults)} "
                f"(measure them and give {MEASURED_OPTIONS})."] if measured.defaults else []
    description = (f"imported from {source.name} (Klipper rotary_delta, shoulder_radius "
                   f"{klipper.shoulder_radius:g} mm)")
    azimuths = toml_value([round(float(v), 9) for v in np.degrees(klipper.angle)])
    lines = [f"# Imported by deltacal from {source.name}: Klipper's rotary_delta model of that "
             "configuration.",
             *defaults,
             "# Frame: origin at the shoulders' centre, z up; Klipper's bed (z = 0) is at z = "
             f"-(shoulder_height + nozzle drop) = {-base!r} mm.",
             "# Arm angle q = -(Klipper's arm angle): q > 0 lowers the elbow.",
             f"name = {toml_value(source.stem)}",
             f"description = {toml_value(description)}",
             "", "[geometry]",
             f"base_radius_mm = {klipper.shoulder_radius + a!r}   # shoulder_radius + effector radius",
             f"plate_radius_mm = {a!r}   # effector radius",
             f"arm_length_mm = {float(klipper.upper_arm[0])!r}   # upper_arm_length",
             f"rod_length_mm = {float(klipper.lower_arm[0])!r}   # lower_arm_length",
             f"rod_spacing_mm = {measured.rod_spacing!r}",
             f"limb_azimuth_deg = {azimuths}   # angle",
             f"tool_mm = {toml_value([0.0, 0.0, -drop])}   # the nozzle, its drop below the effector's balls",
             "", "[workspace]",
             f"radius_mm = {radius!r}   # {note}",
             f"height_mm = {top - bottom!r}   # minimum_z_position up to Klipper's limit_z",
             f"top_z_mm = {top - base!r}   # limit_z {top:.6g} mm above the bed"]
    return "\n".join(lines) + "\n"


def write_rotary_import(imported: ImportedRotary, source: str | Path, out_dir: str | Path) -> PrinterImport:
    """Write ``printer.toml`` (its reader checks it first), the saved measurements; say what was written.

    ``probe.csv`` and ``distances.csv`` when the SAVE_CONFIG block holds such measurements.

    Raises:
        InputError: the robot file's reader refuses it (a workspace out of the arms' reach).
        UsageError: the folder holds ``probe.csv`` or ``distances.csv`` this import does not write
            (:func:`check_stale_outputs`).
    """
    out = Path(out_dir)
    saved = imported.saved
    writes = [OUTPUT_FILES[0]] + [name for name, rows in zip(OUTPUT_FILES[1:], (saved.height, saved.distance),
                                                             strict=True) if rows.size]
    check_stale_outputs(out, writes, "its SAVE_CONFIG block holds no [delta_calibrate] measurements of them")
    path = out / OUTPUT_FILES[0]
    written = atomic_write_text(path, imported.text)
    try:
        load_nominal(written)
    except InputError as exc:
        path.unlink()
        where = f"{exc.location}: " if exc.location else ""
        raise InputError(f"Klipper's model of it gives a robot file deltacal refuses ({where}{exc.detail})",
                         str(source)) from None
    measured = imported.measured
    defaults = f"; defaults taken: {', '.join(measured.defaults)}" if measured.defaults else ""
    bed = -imported.klipper.base_height(measured.nozzle_drop)
    said = [f"wrote {written}: Klipper's rotary_delta model of {source} (shoulder_radius "
            f"{imported.klipper.shoulder_radius:g} mm, bed at z = {bed:g}"
            f" mm){defaults}"]
    files = [written]
    if saved.empty:
        said.append("no [delta_calibrate] measurements in its SAVE_CONFIG block: no probe.csv, no "
                    "distances.csv")
    if saved.height.size:
        files.append(write_probe_heights(out / OUTPUT_FILES[1], imported.probe[:, :2], imported.probe[:, 2],
                                         trigger_height=saved.height))
    if saved.distance.size:
        files.append(write_printed_distances(out / OUTPUT_FILES[2], imported.pairs, saved.distance))
    for file in files[1:]:
        rows = saved.height.size if file.name == OUTPUT_FILES[1] else saved.distance.size
        said.append(f"wrote {file}: {rows} rows saved by Klipper's rotary DELTA_CALIBRATE / DELTA_ANALYZE "
                    "(commanded positions in Klipper's frame through its values)")
    return PrinterImport(tuple(files), tuple(said))
