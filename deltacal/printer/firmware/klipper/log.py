"""Klipper's probe results read from a log: ``klippy.log`` or a console saved from Mainsail or Fluidd.

Each probe of Klipper's ``PROBE`` (and of every command that probes: ``DELTA_CALIBRATE``,
``PROBE_ACCURACY``...) answers ``probe at X,Y is z=Z`` (``klippy/extras/probe.py``: ``%.3f`` for
the toolhead's X and Y, ``%.6f`` for its Z at the trigger): the commanded nozzle position at
which the probe triggered. A console shows the line after ``// ``, a log after its time; a result
a fork marks as discarded (``[discarded]``, ``SKIPPED``) is left out. Klipper releases from 2026
answer ``probe: at X,Y bed will contact at z=Z`` instead, with the probe's offsets applied: not
read (no commanded position in it).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ....exceptions import InputError

_NUMBER = r"([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)"
#: Klipper's answer to a probe.
PROBE_RESULT = re.compile(rf"probe at {_NUMBER},{_NUMBER} is z={_NUMBER}")
#: What forks add to a result they do not keep.
_DISCARDED = re.compile(r"\[discarded\]|SKIPPED", re.IGNORECASE)
#: A line only a log or a console has: Klipper's start banner or its config dump, or a console's ``// ``.
_LOG_MARK = re.compile(r"^(?:Start printer at|===== Config file =====|// |\$ |Args: )", re.MULTILINE)


@dataclass(frozen=True)
class ProbeLog:
    """The probe results of a log.

    Attributes:
        commanded: Commanded nozzle positions at each trigger [mm], (N, 3).
        lines: The line of each result in the log, (N,).
    """

    commanded: np.ndarray
    lines: np.ndarray


def is_probe_log(text: str) -> bool:
    """Whether a file's text is a log (Klipper's or a console's), told by its content."""
    return PROBE_RESULT.search(text) is not None or _LOG_MARK.search(text) is not None


def read_probe_log(path: str | Path, text: str | None = None) -> ProbeLog:
    """The probe results of a log, in its order.

    Args:
        path: The log.
        text: Its text, if already read.

    Raises:
        InputError: the file cannot be read, or holds no probe result.
    """
    source = str(path)
    if text is None:
        try:
            text = Path(path).read_text(encoding="utf-8", errors="replace")
        except OSError as exc:
            raise InputError(f"cannot read the log ({exc.strerror})", source) from None
    rows, lines = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        match = PROBE_RESULT.search(line)
        if match and not _DISCARDED.search(line[match.end():]):
            rows.append([float(v) for v in match.groups()])
            lines.append(number)
    if not rows:
        raise InputError("no probe result in this log (Klipper's 'probe at X,Y is z=Z' lines): probe with "
                         "PROBE, or save the console after probing", source)
    return ProbeLog(np.array(rows), np.array(lines, dtype=int))
