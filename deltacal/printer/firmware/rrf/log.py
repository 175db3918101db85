"""RepRapFirmware's probe results read from its console: the program ``plan --object`` writes, run.

The probe program (:mod:`.probing`) echoes each point before probing it: ``echo "probe at X,Y"``
prints ``probe at X,Y`` (x, y of the nozzle, ``%.3f``), then ``G30 S-1`` answers ``Stopped at height
Z mm`` (``GCodes4.cpp``, ``probingAtPoint7``: ``%.3f``), Z the machine's Z when the probe triggered
(``GetCurrentMachinePosition`` without bed compensation, less ``G30 H``, which the program does not
give): the nozzle's commanded height, in RRF's frame (its ``M666 A B`` tilt applied). A console
from Duet Web Control, a USB terminal or ``M929``'s event log, with or without time stamps or
``ok`` lines, reads the same.

Each ``Stopped at height`` is a row at the last point echoed (several at one point are several
samples). An error of the probe (``Probe was not triggered during probing move``, ``Probe already
triggered ...``) drops the results at that point until the next echo. ``G29`` (mesh) and ``G32``
(``G30 P... S-1``: ``G32 bed probe heights: ...``) say no point's x, y on the console and are not
read. The trigger height (the nozzle's height above the bed when the probe triggers) is the
configuration's ``G31 Z`` (:func:`~.config.rrf_probe_offsets`). Units: mm.
"""

from __future__ import annotations

import re
from pathlib import Path

from ....exceptions import InputError
from ..probe_log import ProbeLog, ProbeOffsets, log_text, probe_log

_NUMBER = r"([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)"
#: The program's echo of the point it probes next.
POINT_ECHO = re.compile(rf"probe at {_NUMBER},{_NUMBER}\s*$")
#: ``G30 S-1``'s answer: the machine's Z at the trigger.
STOPPED = re.compile(rf"Stopped at height {_NUMBER} mm")
#: RRF's errors of a probing move: no result at that point.
PROBE_ERROR = re.compile(r"Probe (?:was not triggered|already triggered)")


def is_rrf_probe_log(text: str) -> bool:
    """Whether a file's text holds RRF's answers to ``G30 S-1``."""
    return STOPPED.search(text) is not None


def read_rrf_probe_log(path: str | Path, text: str | None = None,
                       offsets: ProbeOffsets | None = None) -> ProbeLog:
    """The probe results of an RRF console, in its order (the module's documentation).

    Args:
        path: The console's text file.
        text: Its text, if already read.
        offsets: The probe's offsets (:func:`~.config.rrf_probe_offsets`): with them, every row
            carries the trigger height ``G31 Z``.

    Raises:
        InputError: the file cannot be read, a ``Stopped at height`` follows no echoed point, or
            there is no result.
    """
    source, text = log_text(path, text)
    rows: list[list[float]] = []
    lines: list[int] = []
    point: list[float] | None = None
    failed = False
    for number, line in enumerate(text.splitlines(), start=1):
        echo = POINT_ECHO.search(line)
        if echo is not None:
            point, failed = [float(v) for v in echo.groups()], False
            continue
        if PROBE_ERROR.search(line):
            failed = True
            continue
        stopped = STOPPED.search(line)
        if stopped is None or failed:
            continue
        if point is None:
            raise InputError("'Stopped at height' follows no 'probe at X,Y' echo: where the nozzle was is "
                             "not known (probe with the program plan --object writes, probe.gcode)", source,
                             f"line {number}")
        rows.append([*point, float(stopped.group(1))])
        lines.append(number)
    if not rows:
        raise InputError("no probe result in this log (RepRapFirmware's 'Stopped at height Z mm' after "
                         "'probe at X,Y'): run the program plan --object writes, probe.gcode", source)
    return probe_log(rows, lines, None if offsets is None else offsets.z)
