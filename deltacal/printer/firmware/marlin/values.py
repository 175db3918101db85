"""Marlin's values of a given delta model, written by Marlin's own rules.

Marlin's model (:class:`~.model.MarlinDelta`) is the classical delta with one radius and, per
tower, an angle, a rod and a carriage height at the endstop ``E_i``: the same model as Klipper's
(:class:`~..klipper.model.KlipperDelta`) with ``delta_radius = R``, ``angle_i = 210/330/90 + trim_i``,
``arm_length_i = L + trim_i``, ``position_endstop_i = H − M851 Z − adj_i`` and ``rotation_distance``
over its microsteps ``= 1 / M92``. Marlin spells the per-tower values with more numbers than
freedoms; deltacal writes them as Marlin's ``G33`` leaves them (``gcode/calibrate/G33.cpp``):

* ``M666`` adjustments <= 0, the largest 0, ``H`` lowered by what was taken off
  ("adjust delta_height and endstops by the max amount"); an adjustment that would be within
  ``MIN_STEPS_PER_SEGMENT`` steps of 0 but not 0, which ``G28`` would not move, is avoided by
  lowering all of them and ``H`` alike by those steps (the same model);
* ``L`` the towers' mean rod, ``A B C`` each tower's difference (``G33`` leaves them alone; any
  split gives the same model);
* the angle trims' sum 0 ("normalise angles to least squares"): their common part turns the whole
  printer about its centre, which only turns the printed part on the bed.

Units: mm; Marlin's trims in degrees.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ....geometry import DeltaGeometry
from ...robot import NominalLinearDelta
from ..classical import on_axis
from ..klipper.model import KlipperDelta
from .model import BASE_ANGLES_DEG, MIN_STEPS_PER_SEGMENT, MarlinDelta


def marlin_values(radius: float, angle: np.ndarray, rods: np.ndarray, carriage_top: np.ndarray,
                  step_distance: np.ndarray, template: MarlinDelta | None = None,
                  turn: bool = False) -> MarlinDelta:
    """Marlin's values of a delta model, normalised as ``G33`` leaves them (module docstring).

    Args:
        radius: ρ [mm].
        angle: Tower azimuths [rad], (3,).
        rods: Each tower's rod [mm], (3,).
        carriage_top: Each carriage point's height at its endstop, ``E_i`` [mm], (3,).
        step_distance: Each tower's step distance [mm], (3,).
        template: The settings whose other values (``M851``, ``M211``, ``M665 S``, ``M92 E``,
            name) are kept; Marlin's defaults without one.
        turn: Bring the angle trims' sum to 0 (turns the model about z: only where the part's turn
            on the bed does not matter).
    """
    template = template if template is not None else MarlinDelta(radius, float(np.mean(rods)), 0.0)
    trim = np.degrees(np.asarray(angle, dtype=float)) - np.array(BASE_ANGLES_DEG)
    trim = (trim + 180.0) % 360.0 - 180.0
    if turn:
        trim = trim - trim.mean()
    rods = np.asarray(rods, dtype=float)
    rod = float(rods.mean())
    steps_per_mm = 1.0 / np.asarray(step_distance, dtype=float)
    base = np.asarray(carriage_top, dtype=float) - np.sqrt(rods**2 - radius**2)  # E_i − sqrt(l_i² − ρ²)
    home = float(base.min())
    adj = home - base  # <= 0, the largest 0
    dead = MIN_STEPS_PER_SEGMENT / steps_per_mm
    if np.any((adj < 0.0) & (adj >= -dead)):  # G28 would not move it: all lower, none within
        lower = float(np.max(dead)) * (1.0 + 1e-6)
        adj, home = adj - lower, home - lower
    return replace(template, radius=float(radius), rod=rod, height=home + float(template.probe_offset[2]),
                   angle_trim=trim, rod_trim=rods - rod, endstop_adj=adj, steps_per_mm=steps_per_mm)


def from_klipper(klipper: KlipperDelta, template: MarlinDelta | None = None,
                 turn: bool = False) -> MarlinDelta:
    """Marlin's values of Klipper's model of the same printer (:func:`marlin_values`)."""
    return marlin_values(klipper.delta_radius, klipper.angle, klipper.arm_length, klipper.carriage_top,
                         klipper.step_distance, template, turn)


def to_klipper(marlin: MarlinDelta) -> KlipperDelta:
    """Klipper's values of Marlin's model: the same commanded steps for every target."""
    return KlipperDelta(marlin.radius, marlin.angle, marlin.rods,
                        marlin.carriage_top - np.sqrt(marlin.rods**2 - marlin.radius**2),
                        marlin.step_distance, marlin.name)


def marlin_from_printer(printer: NominalLinearDelta, template: MarlinDelta | None = None) -> MarlinDelta:
    """The values that make Marlin's model the perfect printer built to these values.

    Raises:
        GeometryError: the nozzle is off the effector's axis (Marlin's point effector).
    """
    on_axis(printer.tool, "Marlin")
    named = replace(template, name=template.name or printer.name) if template is not None else None
    values = from_klipper(KlipperDelta.from_printer(printer), named)
    return values if named is not None else replace(values, name=printer.name)


def marlin_from_geometry(geometry: DeltaGeometry, template: MarlinDelta | None = None) -> MarlinDelta:
    """Marlin's values of a printer's geometry at its tolerances' centre (a fit's start).

    Raises:
        GeometryError: not a printer's geometry, or a nozzle off the effector's axis.
    """
    values = from_klipper(KlipperDelta.from_geometry(geometry), template)
    return values if template is not None else replace(values, name=geometry.name)
