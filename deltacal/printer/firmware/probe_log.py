"""A firmware's probe results read from its log, whatever the firmware: the rows and the probe's offsets.

Each firmware says a probe's result on its console in its own words (Klipper's ``probe at X,Y is
z=Z``, RepRapFirmware's ``Stopped at height Z mm``); its reader
(:meth:`~.base.Firmware.read_probe_log`) gives the same value: the commanded nozzle positions at
the triggers, with the nozzle's height above the bed there when the probe's offsets are known.
Units: mm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...exceptions import InputError


@dataclass(frozen=True)
class ProbeOffsets:
    """A probe's offsets from the nozzle, as a firmware's configuration gives them [mm].

    Attributes:
        x: The probe's x less the nozzle's (Klipper's ``x_offset``, RepRapFirmware's ``G31 X``).
        y: The probe's y less the nozzle's (``y_offset``, ``G31 Y``).
        z: The nozzle's height above the bed when the probe triggers (``z_offset``, ``G31 Z``).
    """

    x: float
    y: float
    z: float


@dataclass(frozen=True)
class ProbeLog:
    """The probe results of a log.

    Attributes:
        commanded: Commanded nozzle positions at each trigger [mm], (N, 3).
        lines: The line of each result in the log, (N,).
        trigger_height: The nozzle's height above the bed at each trigger [mm], (N,), when the
            probe's offsets were given; else None.
        trigger_source: Where the trigger height comes from, for messages (``"z_offset of
            printer.cfg"``), or "".
    """

    commanded: np.ndarray
    lines: np.ndarray
    trigger_height: np.ndarray | None = None
    trigger_source: str = ""


def log_text(path: str | Path, text: str | None = None) -> tuple[str, str]:
    """A log's name for messages and its text (read unless given; bytes not UTF-8 replaced).

    Raises:
        InputError: the file cannot be read.
    """
    source = str(path)
    if text is None:
        try:
            text = Path(path).read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            raise InputError(f"cannot read the log ({exc.strerror})", source) from None
    return source, text


def probe_log(rows: Sequence[Sequence[float]] | np.ndarray, lines: Sequence[int],
              trigger_height: float | None = None) -> ProbeLog:
    """The probe results of a log from its rows, their lines and the trigger height, if known.

    Args:
        rows: Commanded nozzle positions at the triggers [mm], (N, 3).
        lines: The line of each in the log, (N,).
        trigger_height: The nozzle's height above the bed at every trigger [mm], or None.
    """
    heights = None if trigger_height is None else np.full(len(rows), trigger_height)
    return ProbeLog(np.array(rows), np.array(lines, dtype=int), heights)
