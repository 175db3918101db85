"""The robot file of a printer as a firmware's configuration describes it, whatever the firmware.

``deltacal import`` (conventions, "Printers as they are found") reads a firmware's configuration
(Klipper's ``printer.cfg``, RepRapFirmware's ``config.g``) into the values of its classical model
(:class:`ImportedValues`), and :func:`write_printer_file` writes the robot file (``kind =
"linear"``) of exactly that model, the one writer of every firmware:

* ``tower_radius_mm`` = the model's radius ρ (carriage point to effector point, horizontal) + the
  effector radius; ``rod_length_mm`` = each tower's rod; ``tower_azimuth_deg`` = each tower's
  azimuth; ``endstop_height_mm`` = each carriage point's height at its endstop (the nozzle's frame)
  + the nozzle drop; ``step_distance_mm`` = each tower's step distance; a per-tower value is a number
  when the three towers agree, ``[a, b, c]`` otherwise (the azimuths always three);
* ``nozzle_mm`` = ``[0, 0, −drop]``; the effector radius, the rod spacing and the nozzle drop are
  in no firmware's configuration: given (measured), or defaults that the file names;
* ``[workspace]``: ``radius_mm`` = the printable radius, never beyond what the rods reach with a
  margin (:func:`reach_radius`), ``height_mm`` = the height up to which the full radius is
  reachable, ``min(carriage top − rod)``.

Each line names the firmware's words it came from. A folder that holds an output this import does
not write (another printer's ``probe.csv``, say) is refused before anything is written
(:func:`check_stale_outputs`): left beside the new ``printer.toml`` it would be taken for its
measurements. Units: mm and deg in the file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...exceptions import InputError, UsageError
from ...io.atomic import atomic_write_text
from ...io.toml import toml_value
from ...towers import written_per_tower

#: What a configuration does not say, when not given [mm] (those of deltacal's models/kossel.toml).
DEFAULT_EFFECTOR_RADIUS = 30.0
DEFAULT_ROD_SPACING = 50.0
DEFAULT_NOZZLE_DROP = 30.0
#: The files ``deltacal import`` of a configuration writes in its folder.
OUTPUT_FILES = ("printer.toml", "probe.csv", "distances.csv")
#: The options that give what a configuration does not say.
MEASURED_OPTIONS = "--effector-radius, --rod-spacing, --nozzle-drop"
#: How much faster than the nozzle a carriage may move at the rim of an imported printable radius
#: (Klipper's ``4 × SLOW_RATIO``): the rods' reach with a margin (:func:`reach_radius`).
REACH_SLOPE = 12.0


@dataclass(frozen=True)
class Measured:
    """What a firmware's configuration does not say: given (measured) or defaults [mm].

    Attributes:
        effector_radius: Effector centre to each ball pair's midpoint.
        rod_spacing: Between a pair's two balls.
        nozzle_drop: The nozzle below the effector's ball plane.
        defaults: Which were taken by default, as said (``"effector radius 30 mm"``).
    """

    effector_radius: float
    rod_spacing: float
    nozzle_drop: float
    defaults: tuple[str, ...]

    @classmethod
    def given(cls, effector_radius: float | None, rod_spacing: float | None,
              nozzle_drop: float | None) -> Measured:
        """The values given, the defaults (:data:`DEFAULT_EFFECTOR_RADIUS`...) for those not."""
        given = {"effector radius": (effector_radius, DEFAULT_EFFECTOR_RADIUS),
                 "rod spacing": (rod_spacing, DEFAULT_ROD_SPACING),
                 "nozzle drop": (nozzle_drop, DEFAULT_NOZZLE_DROP)}
        defaults = tuple(f"{what} {default:g} mm" for what, (value, default) in given.items()
                         if value is None)
        a, c, drop = (default if value is None else float(value) for value, default in given.values())
        return cls(a, c, drop, defaults)


@dataclass(frozen=True)
class ImportedValues:
    """A firmware's model of a printer in deltacal's words, each value with the firmware's words for it.

    Attributes:
        firmware: The firmware's name users read (``"Klipper"``).
        source: The configuration file.
        radius: ρ, carriage point to effector point, horizontal [mm], and its words.
        rods: Each tower's rod [mm], (3,), and its words.
        azimuth_deg: Each tower's azimuth [deg], (3,), and its words.
        carriage_top: Each carriage point's height at its endstop, nozzle frame [mm], (3,), and its words.
        step_distance: Each tower's step distance [mm], (3,), and its words ("": none written).
        printable: The printable radius [mm] and where it came from.
        height_words: What the workspace's height is called.
        notes: Comment lines the file carries after its first (what the model has that a robot
            file has not, say).
        where: The configuration's key to name when no volume is printable.
    """

    firmware: str
    source: str
    radius: tuple[float, str]
    rods: tuple[np.ndarray, str]
    azimuth_deg: tuple[np.ndarray, str]
    carriage_top: tuple[np.ndarray, str]
    step_distance: tuple[np.ndarray, str]
    printable: tuple[float, str]
    height_words: str
    notes: tuple[str, ...] = ()
    where: str = ""


def reach_radius(rods: np.ndarray, rho: float) -> float:
    """The radius the rods reach at the bed with a margin: ``S min(rods) / sqrt(S² + 1) − ρ`` [mm].

    At ``min(rods) − ρ`` the rod of the tower opposite lies flat (its carriage at the nozzle's
    height): the rim is not reachable. Held to :data:`REACH_SLOPE` instead, where that rod is
    ``atan(1/S)`` (4.8°) above flat and its carriage moves ``S`` times faster than the nozzle, the
    bound Klipper puts on its own radius (``ratio_to_xy(4 × SLOW_RATIO)``).

    Args:
        rods: Each tower's rod [mm], (3,).
        rho: ρ, carriage point to effector point, horizontal [mm].
    """
    return REACH_SLOPE * float(np.min(rods)) / math.hypot(REACH_SLOPE, 1.0) - rho


def within_reach(radius: float, words: str, bound: float, reach: str) -> tuple[float, str]:
    """A printable radius held to what the rods reach (:func:`reach_radius`), and where it came from.

    Args:
        radius: The firmware's printable radius [mm] (its print radius, soft limits...).
        words: Where it came from (``"print_radius"``).
        bound: The radius the rods reach [mm].
        reach: The words for the bound (``"Klipper's reach ..."``).

    Returns:
        The radius [mm] and its words: ``words`` when within the reach, else the reach and both said.
    """
    if radius > bound:
        return bound, f"{words} {radius:g} mm, held to {reach} {bound:.6g} mm"
    return radius, words


def printer_file_text(values: ImportedValues, measured: Measured) -> str:
    """The robot file (``kind = "linear"``) of the firmware's model (the module's documentation).

    Raises:
        InputError: no printable volume above the bed (the full-radius height is not positive).
    """
    rho = values.radius[0]
    rods, top = np.asarray(values.rods[0], float), np.asarray(values.carriage_top[0], float)
    height = math.floor(float(np.min(top - rods)) * 1e6) / 1e6
    if height <= 0.0:
        raise InputError(f"{values.firmware}'s full-radius height min({values.carriage_top[1]} - "
                         f"{values.rods[1]}) is {height:g} mm: no printable volume above the bed",
                         values.source, values.where)
    source = Path(values.source)
    drop = measured.nozzle_drop
    steps = values.step_distance[1]
    taken = ", ".join(measured.defaults)
    defaults = [f"# Not in a {values.firmware} configuration, taken by default: {taken} "
                f"(measure them and give {MEASURED_OPTIONS})."] if measured.defaults else []
    lines = [f"# Imported by deltacal from {source.name}: {values.firmware}'s model of that configuration.",
             *defaults,
             *(f"# {note}" for note in values.notes),
             f"name = {toml_value(source.stem)}",
             f"description = {toml_value(f'imported from {source.name} ({values.radius[1]} {rho:g} mm)')}",
             'kind = "linear"', "", "[geometry]",
             f"tower_radius_mm = {rho + measured.effector_radius!r}   # {values.radius[1]} + effector radius",
             f"effector_radius_mm = {measured.effector_radius!r}",
             f"rod_length_mm = {_per_tower(rods)}   # {values.rods[1]}",
             f"rod_spacing_mm = {measured.rod_spacing!r}",
             f"tower_azimuth_deg = {toml_value([float(v) for v in values.azimuth_deg[0]])}   "
             f"# {values.azimuth_deg[1]}",
             f"nozzle_mm = {toml_value([0.0, 0.0, -drop])}",
             f"endstop_height_mm = {_per_tower(top + drop)}   # {values.carriage_top[1]} + nozzle drop",
             f"step_distance_mm = {_per_tower(values.step_distance[0])}" + (f"   # {steps}" if steps else ""),
             "", "[workspace]",
             f"radius_mm = {values.printable[0]!r}   # {values.printable[1]}",
             f"height_mm = {height!r}   # {values.height_words}"]
    return "\n".join(lines) + "\n"


def write_printer_file(path: str | Path, values: ImportedValues, measured: Measured) -> Path:
    """Write :func:`printer_file_text` to ``path`` atomically; returns the path.

    Raises:
        InputError: no printable volume above the bed.
    """
    return atomic_write_text(path, printer_file_text(values, measured))


def write_imported(folder: str | Path, values: ImportedValues, effector_radius: float | None,
                   rod_spacing: float | None, nozzle_drop: float | None) -> tuple[Path, str]:
    """Write ``folder/printer.toml`` of a firmware's values, what it does not say given or by default.

    Args:
        folder: An existing folder.
        values: The firmware's model in deltacal's words.
        effector_radius: Effector centre to each ball pair's midpoint [mm], or None (the default).
        rod_spacing: Between a pair's two balls [mm], or None.
        nozzle_drop: The nozzle below the effector's ball plane [mm], or None.

    Returns:
        The file written, and ``"; defaults taken: ..."`` naming the defaults taken (or "").

    Raises:
        InputError: no printable volume above the bed.
    """
    measured = Measured.given(effector_radius, rod_spacing, nozzle_drop)
    check_stale_outputs(folder, OUTPUT_FILES[:1], "its configuration holds no measurements")
    written = write_printer_file(Path(folder) / OUTPUT_FILES[0], values, measured)
    return written, f"; defaults taken: {', '.join(measured.defaults)}" if measured.defaults else ""


def check_stale_outputs(folder: str | Path, writes: Sequence[str], why: str) -> None:
    """Refuse a folder holding outputs of ``deltacal import`` that this import does not write.

    A ``probe.csv`` or ``distances.csv`` of an earlier import (another printer's, or measurements the
    configuration no longer holds), left beside the new ``printer.toml``, would be identified as its
    measurements; deleting it could lose a user's file. Nothing is written.

    Args:
        folder: The output folder.
        writes: The names of :data:`OUTPUT_FILES` this import writes.
        why: Why it writes no others (``"its configuration holds no measurements"``).

    Raises:
        UsageError: naming the folder and each file left over.
    """
    stale = [name for name in OUTPUT_FILES if name not in writes and (Path(folder) / name).exists()]
    if stale:
        them = " and ".join(stale)
        raise UsageError(f"{folder}: holds {them}, which this import does not write ({why}): left beside "
                         f"the new {OUTPUT_FILES[0]} they would be taken for its measurements; move or "
                         f"delete {'them' if len(stale) > 1 else 'it'}, or import into another folder")


@dataclass(frozen=True)
class PrinterImport:
    """What ``deltacal import`` of a configuration wrote, and what it says of it.

    Attributes:
        written: The files written, ``printer.toml`` first.
        said: One line for each, for the user (the library never prints).
    """

    written: tuple[Path, ...]
    said: tuple[str, ...]


def _per_tower(values: np.ndarray) -> str:
    """A per-tower value as TOML: a number when the three towers agree, ``[a, b, c]`` otherwise."""
    return toml_value(written_per_tower(np.asarray(values, dtype=float)))
