"""The robot file of a printer as a firmware's settings describe it, whatever the firmware.

``deltacal import`` reads a firmware's settings (Klipper's ``printer.cfg``, Marlin's ``M503``) into
the values of its classical model; :func:`imported_robot_text` writes the robot file (``kind =
"linear"``) of exactly that model: ``tower_radius_mm`` = the model's radius ρ + the effector
radius, per-tower rods, azimuths, endstop heights (each carriage's ball-pair midpoint at its
endstop: the model's carriage point + the nozzle drop) and step distances (a number when the
three towers agree, ``[a, b, c]`` otherwise), ``nozzle_mm = [0, 0, -drop]``, and the workspace.
Each line names the firmware's own words it came from. Units: mm and deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import InputError
from ..io.toml import _toml_value
from ..towers import written_per_tower


@dataclass(frozen=True)
class ImportedValues:
    """A firmware's model of a printer, in deltacal's words, with the firmware's words for each.

    Attributes:
        firmware: The firmware's name (``Klipper``).
        source: The settings file.
        radius: ρ, carriage point to effector point, horizontal [mm], and its words.
        rods: Each tower's rod [mm], (3,), and its words.
        azimuth_deg: Each tower's azimuth [deg], (3,), and its words.
        carriage_top: Each carriage point's height at its endstop, nozzle frame [mm], (3,), and its words.
        step_distance: Each tower's step distance [mm], (3,), and its words.
        printable: The printable radius [mm] and where it came from.
    """

    firmware: str
    source: str
    radius: tuple[float, str]
    rods: tuple[np.ndarray, str]
    azimuth_deg: tuple[np.ndarray, str]
    carriage_top: tuple[np.ndarray, str]
    step_distance: tuple[np.ndarray, str]
    printable: tuple[float, str]


def imported_robot_text(values: ImportedValues, effector_radius: float, rod_spacing: float,
                        nozzle_drop: float, defaults: tuple[str, ...], where: str) -> str:
    """The robot file of the firmware's model (module documentation).

    Args:
        values: The firmware's model.
        effector_radius: Effector centre to each ball pair's midpoint [mm] (not in the settings).
        rod_spacing: Between a pair's two balls [mm] (not in the settings).
        nozzle_drop: The nozzle below the effector's ball plane [mm] (not in the settings).
        defaults: Which of them were taken by default, as said ("effector radius 30 mm").
        where: The settings' key to name when no volume is printable.

    Raises:
        InputError: no printable volume above the bed (the full-radius height is not positive).
    """
    rho, rods, top = values.radius[0], values.rods[0], values.carriage_top[0]
    height = math.floor(float(np.min(top - rods)) * 1e6) / 1e6
    if height <= 0.0:
        raise InputError(f"{values.firmware}'s full-radius height min({values.carriage_top[1]} - rod) is "
                         f"{height:g} mm: no printable volume above the bed", values.source, where)
    source = Path(values.source)
    per = lambda v: _toml_value(written_per_tower(np.asarray(v, dtype=float)))  # noqa: E731
    flags = "--effector-radius, --rod-spacing, --nozzle-drop"
    lines = [f"# Imported by deltacal from {source.name}: {values.firmware}'s model of those settings.",
             *([f"# Not in {values.firmware}'s settings, taken by default: {', '.join(defaults)} (measure "
                f"them and give {flags})."] if defaults else []),
             f"name = {_toml_value(source.stem)}",
             f"description = {_toml_value(f'imported from {source.name} ({values.radius[1]} {rho:g} mm)')}",
             'kind = "linear"', "", "[geometry]",
             f"tower_radius_mm = {rho + effector_radius!r}   # {values.radius[1]} + effector radius",
             f"effector_radius_mm = {effector_radius!r}",
             f"rod_length_mm = {per(rods)}   # {values.rods[1]}",
             f"rod_spacing_mm = {rod_spacing!r}",
             f"tower_azimuth_deg = {per(values.azimuth_deg[0])}   # {values.azimuth_deg[1]}",
             f"nozzle_mm = {_toml_value([0.0, 0.0, -nozzle_drop])}",
             f"endstop_height_mm = {per(top + nozzle_drop)}   # {values.carriage_top[1]} + nozzle drop",
             f"step_distance_mm = {per(values.step_distance[0])}   # {values.step_distance[1]}", "",
             "[workspace]", f"radius_mm = {values.printable[0]!r}   # {values.printable[1]}",
             f"height_mm = {height!r}   # {values.firmware}'s full-radius height (radius tapered above)"]
    return "\n".join(lines) + "\n"
