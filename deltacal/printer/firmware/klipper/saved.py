"""The measurements Klipper saved: ``[delta_calibrate]`` in a configuration's SAVE_CONFIG block.

What Klipper writes there (``klippy/extras/delta_calibrate.py``, ``save_state``), numbered from 0
until the first absent number, as Klipper reads them back:

* ``heightN`` and ``heightN_pos``: a probe result of ``DELTA_CALIBRATE``: the probe's ``z_offset``
  (the nozzle's height above the bed when the probe triggered) and the "stable position" where
  it triggered;
* ``manual_heightN`` and ``manual_heightN_pos``: a height given with ``DELTA_ANALYZE
  MANUAL_HEIGHT`` and the stable position where it was given;
* ``distanceN``, ``distanceN_pos1`` and ``distanceN_pos2``: a distance measured on the printed
  calibration object and the stable positions of its two ends.

A stable position is ``a,b,c``: each carriage's steps below its endstop (``%.3f``), so it does
not depend on the configuration's values. Units: mm and steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ....exceptions import InputError
from .config import KlipperConfig

#: The section Klipper saves its calibration measurements in.
SECTION = "delta_calibrate"
#: Klipper reads at most this many of each (``range(999)``).
MAX_ENTRIES = 999


@dataclass(frozen=True)
class SavedCalibration:
    """The measurements of a ``[delta_calibrate]`` section.

    Attributes:
        height_steps: Steps below the endstops where each height was taken, (N, 3).
        height: The nozzle's height above the bed there [mm], (N,): ``heightN`` then
            ``manual_heightN``.
        manual: Whether each height was given by hand (``manual_heightN``), (N,).
        keys: The key of each height (``height0``, ``manual_height0``...), (N,).
        pair_steps: Steps below the endstops of each distance's two ends, (M, 2, 3).
        distance: The distances measured [mm], (M,).
    """

    height_steps: np.ndarray
    height: np.ndarray
    manual: np.ndarray
    keys: tuple[str, ...]
    pair_steps: np.ndarray
    distance: np.ndarray

    @property
    def empty(self) -> bool:
        """Whether the section holds no measurement."""
        return self.height.size == 0 and self.distance.size == 0


def read_saved_calibration(config: KlipperConfig) -> SavedCalibration:
    """The measurements saved in a configuration's ``[delta_calibrate]`` (none without one).

    Raises:
        InputError: a value that is not a number, or a position that is not three numbers,
            naming the file, section and key.
    """
    heights, steps, manual, keys = [], [], [], []
    for prefix in ("height", "manual_height"):
        for i in range(MAX_ENTRIES):
            key = f"{prefix}{i}"
            if not config.has(SECTION, key):
                break
            heights.append(config.number(SECTION, key))
            steps.append(_stable(config, f"{key}_pos"))
            manual.append(prefix == "manual_height")
            keys.append(key)
    distance, pairs = [], []
    for i in range(MAX_ENTRIES):
        key = f"distance{i}"
        if not config.has(SECTION, key):
            break
        distance.append(config.number(SECTION, key))
        pairs.append([_stable(config, f"{key}_pos1"), _stable(config, f"{key}_pos2")])
    return SavedCalibration(np.array(steps, dtype=float).reshape(-1, 3), np.array(heights, dtype=float),
                            np.array(manual, dtype=bool), tuple(keys),
                            np.array(pairs, dtype=float).reshape(-1, 2, 3), np.array(distance, dtype=float))


def saved_positions(positions: Callable[[np.ndarray], np.ndarray], steps: np.ndarray, config: KlipperConfig,
                    what: str) -> np.ndarray:
    """Commanded nozzle positions of saved stable positions through the configuration's values [mm], (N, 3).

    Args:
        positions: The configuration's model: steps below the endstops -> nozzle positions, NaN rows where
            the arms or rods do not meet (``KlipperDelta.positions``, ``KlipperRotaryDelta.step_positions``
            with ``check=False``).
        steps: The stable positions, (N, 3).
        config: The configuration (named in a refusal).
        what: ``"height"`` or ``"distance"``.

    Raises:
        InputError: steps out of the values' reach (another printer's measurements?), naming the first.
    """
    out = positions(steps)
    bad = np.flatnonzero(~np.all(np.isfinite(out), axis=1))
    if bad.size:
        raise InputError(f"the saved {what} at steps {steps[bad[0]].tolist()} is out of the reach of this "
                         "configuration's values (another printer's measurements?)", config.source,
                         f"section [{SECTION}]")
    return out


def _stable(config: KlipperConfig, key: str) -> list[float]:
    """A stable position ``a,b,c`` (steps below each endstop), as Klipper's ``load_config_stable``."""
    if not config.has(SECTION, key):
        raise InputError(f"missing key {key!r}: a measurement without its stable position", config.source,
                         f"section [{SECTION}]")
    text = config.text(SECTION, key)
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise config.error(SECTION, key, f"value {text!r} is not a stable position (three step counts "
                                         "'a,b,c')")
    return values
