"""Whether two files are of one printer: differences no build, no calibration could make.

A printer's files come in pairs: its robot file (or its calibration) and its firmware's configuration.
Given those of two different printers, every command would compute on, and write, nonsense that looks
right (the readings of one counted in the other's steps; corrections of one sent to the other). The
bounds here are far beyond what a build or a calibration moves a value by. The build tolerances of a
kit (:meth:`~deltacal.geometry.Tolerances.printer_kit`, σ): towers placed to 0.3 mm and leaning
0.15 deg (about 1.2 mm at the bed), endstops to 0.5 mm, rods to 0.1 mm, step distances to 0.3 %. On 10
simulated kit printers of ``models/kossel.toml`` (seeds 0-9, bed tilted 0.05 deg and 0.5 mm high), the
Klipper values of the true printer (:meth:`~.firmware.base.Firmware.start`), the nominal ones and the
ones fitted to it (``export --controller klipper``) differ by at most 0.86 mm in radius, 1.42 mm in an
arm, 1.63 mm in an endstop and 0.86 % in a step distance:

* step distance: :data:`STEP_DISTANCE_RTOL` (a tuned ``rotation_distance`` is within 1-2 %; another
  microstepping is a factor 2, another pulley 20 %);
* a firmware's radius and arm lengths: :data:`LENGTH_RTOL` of the value (6.7 mm of a Kossel's radius,
  8 times the largest above, 13 mm of its arms; a hand-tuned radius moves by a few mm at most);
* endstops: :data:`ENDSTOP_MM` (12 times the largest above; a glass plate or a new bed moves them by a
  few mm).

Printers of other sizes are further apart: an FLSUN QQS (``delta_radius`` 130, ``arm_length`` 280) is
within 5 % of a Kossel's radius (134.4) and arms (269), but its ``position_endstop`` (370) is 74 mm
from the Kossel's (295.6) and its step distance 20 % off.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...exceptions import InputError

#: Relative difference of two step distances beyond any build or tuning.
STEP_DISTANCE_RTOL = 0.05
#: Relative difference of a radius or of an arm length beyond any build or calibration.
LENGTH_RTOL = 0.05
#: Difference of an endstop beyond any build or calibration [mm].
ENDSTOP_MM = 20.0


def check_step_distance(step_distance: np.ndarray | float, config_steps: np.ndarray, robot_file: str | Path,
                        config_file: str | Path, config_keys: str) -> None:
    """Refuse a configuration whose towers step in another step distance than the robot file's.

    Args:
        step_distance: The robot file's nominal step distance [mm], one or one per tower (3,).
        config_steps: The configuration's step distance of each tower [mm], (3,).
        robot_file: The robot file, for the message.
        config_file: The configuration, for the message.
        config_keys: Where the configuration sets them (:attr:`Firmware.step_distance_keys`).

    Raises:
        InputError: naming both files, their keys and values.
    """
    steps = np.asarray(config_steps, dtype=float).reshape(-1)
    ours = np.broadcast_to(np.asarray(step_distance, dtype=float), steps.shape)
    apart = np.abs(steps / ours - 1.0)
    if not np.any(apart > STEP_DISTANCE_RTOL):
        return
    k = int(np.argmax(apart))
    raise InputError(f"key geometry.step_distance_mm = {ours[k]:.9g} mm, but {config_file}: "
                     f"{config_keys} gives {steps[k]:.9g} mm per step (tower {'ABC'[k]}), "
                     f"{steps[k] / ours[k]:.4g} times: the files of different printers (another "
                     "microstepping? another pulley?)",
                     str(robot_file))


def check_same_values(name: str, ours: np.ndarray, theirs: np.ndarray, tolerance: np.ndarray | float,
                      our_source: str, their_source: str, unit: str = "mm", part: str = "tower") -> None:
    """Refuse two sets of values of one printer further apart than ``tolerance``.

    Args:
        name: What the values are (``"delta_radius"``).
        ours: The first file's values, (3,) or a scalar.
        theirs: The second file's.
        tolerance: The largest difference a build or calibration makes, per value.
        our_source: The first file and where in it the values come from, for the message.
        their_source: The second.
        unit: The values' unit.
        part: What each of three values belongs to (``tower``; a rotary printer's ``arm``).

    Raises:
        InputError: naming both values and where they come from.
    """
    a = np.atleast_1d(np.asarray(ours, dtype=float))
    b = np.broadcast_to(np.atleast_1d(np.asarray(theirs, dtype=float)), a.shape)
    tol = np.broadcast_to(np.asarray(tolerance, dtype=float), a.shape)
    apart = np.abs(a - b) - tol
    if not np.any(apart > 0.0):
        return
    k = int(np.argmax(apart))
    tower = f" ({part} {'ABC'[k]})" if a.size == 3 else ""
    raise InputError(f"{name}{tower} is {a[k]:.6g} {unit} in {our_source} but {b[k]:.6g} {unit} in "
                     f"{their_source}: further apart than any build could be ({tol[k]:.3g} {unit}): "
                     "the files of different printers")
