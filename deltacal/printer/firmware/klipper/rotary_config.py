"""A ``printer.cfg`` with ``[printer] kinematics: rotary_delta`` read as Klipper reads it.

The file itself (includes, the SAVE_CONFIG block, duplicates) is read by :mod:`.config`, as for a
linear Delta; this module gives the rotary keys Klipper's meaning (``RotaryDeltaKinematics``,
:mod:`.rotary_model`):

* ``[printer]`` ``shoulder_radius``, ``shoulder_height`` (both required, above 0),
  ``minimum_z_position`` (default 0, at most the lowest ``position_endstop``);
* ``[stepper_a]`` ``upper_arm_length``, ``lower_arm_length``, ``position_endstop`` (required), each
  the default of ``[stepper_b]`` and ``[stepper_c]``; ``angle`` per stepper (default 30, 150, 270);
* the step distance ``2π / (full_steps_per_rotation (default 200) × microsteps × gear_ratio)``
  [rad]: ``gear_ratio`` is required and ``rotation_distance`` is not Klipper's for these
  steppers (it refuses the key).

:func:`rotary_config_text` writes the values back as those keys (the export's text to paste).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ....exceptions import GeometryError, InputError, UnreachableError
from .config import APPLY_NOTE, DEG_DECIMALS, MM_DECIMALS, STEPPERS, KlipperConfig, gear_ratio
from .model import DEFAULT_FULL_STEPS
from .rotary_model import ROTARY_ANGLES_DEG, KlipperRotaryDelta

#: The ``[printer] kinematics`` word of Klipper's rotary Delta.
ROTARY_KINEMATICS = "rotary_delta"


def is_rotary_config(config: KlipperConfig) -> bool:
    """Whether the configuration's ``[printer] kinematics`` is Klipper's rotary Delta."""
    return config.sections.get("printer", {}).get("kinematics", "").strip() == ROTARY_KINEMATICS


def rotary_from_config(config: KlipperConfig) -> KlipperRotaryDelta:
    """Klipper's rotary delta model from a configuration already read (:func:`~.config.read_klipper_config`).

    Raises:
        InputError: naming the file, section, key and value of the first problem found.
    """
    kinematics = config.text("printer", "kinematics").strip()
    if kinematics != ROTARY_KINEMATICS:
        raise config.error("printer", "kinematics", f"value {kinematics!r}: not Klipper's rotary Delta "
                                                    f"(kinematics: {ROTARY_KINEMATICS})")
    radius = config.number("printer", "shoulder_radius", above=0.0)
    height = config.number("printer", "shoulder_height", above=0.0)
    for stepper in STEPPERS:
        if stepper not in config.sections:
            raise InputError(f"missing section [{stepper}] (a rotary delta printer has three arms)"
                             f"{config.missing_hint()}", config.source)
    upper_a = config.number("stepper_a", "upper_arm_length", above=0.0)
    lower_a = config.number("stepper_a", "lower_arm_length", above=0.0)
    endstop_a = config.number("stepper_a", "position_endstop")
    angles, uppers, lowers, endstops, steps = [], [], [], [], []
    for stepper, angle in zip(STEPPERS, ROTARY_ANGLES_DEG, strict=True):
        angles.append(config.number(stepper, "angle", angle))
        uppers.append(config.number(stepper, "upper_arm_length", upper_a, above=0.0))
        lowers.append(config.number(stepper, "lower_arm_length", lower_a, above=0.0))
        endstops.append(config.number(stepper, "position_endstop", endstop_a))
        steps.append(_arm_step(config, stepper))
    minimum_z = config.number("printer", "minimum_z_position", 0.0)
    if minimum_z > min(endstops):  # Klipper's maxval: the lowest position_endstop
        raise config.error("printer", "minimum_z_position", f"value {minimum_z:g} must be at most "
                           f"{min(endstops):g}, the lowest position_endstop (Klipper refuses it)")
    try:
        model = KlipperRotaryDelta(radius, height, np.radians(angles), np.array(uppers), np.array(lowers),
                                   np.array(endstops), np.array(steps), name=Path(config.source).name,
                                   minimum_z_position=minimum_z)
        _ = model.endstop_angles  # Klipper computes them at start-up: an endstop out of reach is its error
    except GeometryError as exc:
        raise InputError(str(exc), config.source) from None
    except UnreachableError:
        raise InputError("the nozzle at (0, 0, position_endstop) is out of the arms' reach (Klipper's "
                         "endstop "
                         f"angles), position_endstop {endstops}", config.source,
                         "sections [stepper_a..c], key position_endstop") from None
    return model


def _arm_step(config: KlipperConfig, stepper: str) -> float:
    """An arm's rotation per (micro)step [rad]: ``2π / (full steps × microsteps × gear ratio)``, Klipper's."""
    if config.has(stepper, "rotation_distance"):
        value = config.text(stepper, "rotation_distance")
        raise config.error(stepper, "rotation_distance", f"value {value!r}: "
                           "Klipper's rotary_delta arms take gear_ratio instead (it refuses this key)")
    if not config.has(stepper, "gear_ratio"):
        raise InputError("missing required key 'gear_ratio' (Klipper's rotary_delta arms need it)"
                         f"{config.missing_hint()}", config.source, f"section [{stepper}]")
    microsteps = config.number(stepper, "microsteps", integer=True, above=0.0)
    full = config.number(stepper, "full_steps_per_rotation", float(DEFAULT_FULL_STEPS), integer=True,
                         above=0.0)
    if full % 4:
        raise config.error(stepper, "full_steps_per_rotation", f"value {int(full)} must be a multiple of 4")
    return 2.0 * math.pi / (full * microsteps * gear_ratio(config, stepper))


def rotary_config_text(klipper: KlipperRotaryDelta, title: str = "",
                       notes: list[str] | tuple[str, ...] = ()) -> str:
    """Klipper's rotary values as ``printer.cfg`` text, the keys it reads, to replace the printer's own.

    ``[printer]`` ``shoulder_height`` and ``shoulder_radius``; each ``[stepper_a..c]``'s ``angle``
    [deg, 4 decimals], ``upper_arm_length``, ``lower_arm_length`` and ``position_endstop`` [mm, 6
    decimals], every stepper's written (not left to stepper A's defaults). Read back (the printer's
    configuration with these keys) they give the same values to the written decimals; the gearing and
    ``minimum_z_position`` stay the printer's.

    Args:
        klipper: The values.
        title: A first comment line (what the values are).
        notes: More comment lines (what the values leave), each written after ``# ``.
    """
    lines = [f"# {title}" if title else "# Klipper rotary_delta values written by deltacal",
             f"# {APPLY_NOTE}",
             *(f"# {note}".rstrip() for note in notes),
             "", "[printer]", f"shoulder_height: {klipper.shoulder_height:.{MM_DECIMALS}f}",
             f"shoulder_radius: {klipper.shoulder_radius:.{MM_DECIMALS}f}"]
    for i, stepper in enumerate(STEPPERS):
        lines += ["", f"[{stepper}]", f"angle: {math.degrees(klipper.angle[i]):.{DEG_DECIMALS}f}",
                  f"upper_arm_length: {klipper.upper_arm[i]:.{MM_DECIMALS}f}",
                  f"lower_arm_length: {klipper.lower_arm[i]:.{MM_DECIMALS}f}",
                  f"position_endstop: {klipper.position_endstop[i]:.{MM_DECIMALS}f}"]
    return "\n".join(lines) + "\n"
