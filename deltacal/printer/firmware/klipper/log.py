"""Klipper's probe results read from a log: ``klippy.log`` or a console saved from Mainsail or Fluidd.

Klipper answers each probe (of ``PROBE``, ``PROBE_ACCURACY``, ``DELTA_CALIBRATE``...) on its
console and in its log (``klippy/extras/probe.py``; x, y with ``%.3f``, z with ``%.6f``):

* releases before 2026: ``probe at X,Y is z=Z``, the toolhead's (commanded nozzle) position at
  the trigger; ``PROBE`` closes with ``Result is z=Z`` (the samples' average, not read);
* releases from 2026: ``probe: at X,Y bed will contact at z=Z``, the probe's position:
  X, Y = the nozzle's + the probe's ``x_offset``, ``y_offset``, Z = the nozzle's - its ``z_offset``;
  ``PROBE`` closes with ``Result: at X,Y estimate contact at z=Z`` (the samples' average, read only
  when no sample of it is in the log).

Every sample is a row, in the log's order. ``Probe samples exceed tolerance. Retrying...`` drops
the samples Klipper drops (those of the current point), so does the error ``Probe samples exceed
samples_tolerance``; a result a fork marks as discarded (``[discarded]``, ``SKIPPED``) is left out.
The 2026 lines need the probe's offsets from ``printer.cfg`` (:func:`probe_offsets`); each row then
carries the probe's ``z_offset`` as its trigger height (the nozzle's height above the bed at the
trigger). A ``klippy.log`` holds the configuration Klipper ran, dumped at each start between
``===== Config file =====`` and a line of ``=`` (``configfile.py``, ``log_config``): its probe's
offsets are those of the rows after it (:func:`logged_probes`), with or without ``--config``; a
``--config`` that disagrees is warned of, naming both values. A console shows the lines after
``// ``, a log after its time.
"""

from __future__ import annotations

import re
from pathlib import Path
from warnings import warn

import numpy as np

from ....exceptions import InputError, InputWarning
from ..probe_log import ProbeLog, ProbeOffsets, log_text
from .config import PROBE_SECTIONS, KlipperConfig, config_from_text

__all__ = ["PROBE_SECTIONS", "ProbeLog", "ProbeOffsets", "is_console", "is_probe_log", "logged_probes",
           "probe_offsets", "read_probe_log"]

_NUMBER = r"([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)"
#: Klipper's answer to a probe before 2026: the toolhead's position.
PROBE_RESULT = re.compile(rf"probe at {_NUMBER},{_NUMBER} is z={_NUMBER}")
#: Klipper's answer to a probe from 2026: the probe's position, its offsets applied.
PROBE_CONTACT = re.compile(rf"probe: at {_NUMBER},{_NUMBER} bed will contact at z={_NUMBER}")
#: ``PROBE``'s closing line from 2026: the average of its samples.
PROBE_ESTIMATE = re.compile(rf"Result: at {_NUMBER},{_NUMBER} estimate contact at z={_NUMBER}")
#: Lines that end a command's samples: ``PROBE``'s closing lines, ``PROBE_ACCURACY``'s.
_CLOSING = re.compile(r"Result is z=|Result: at |PROBE_ACCURACY at |probe accuracy results:")
#: Klipper dropping the samples of the current point.
_DROPPED = re.compile(r"Probe samples exceed (?:tolerance\. Retrying|samples_tolerance)")
#: What forks add to a result they do not keep.
_DISCARDED = re.compile(r"\[discarded\]|SKIPPED", re.IGNORECASE)
#: A line only a log or a console has: Klipper's start banner or its config dump, or a console's ``// ``.
_LOG_MARK = re.compile(r"^(?:Start printer at|===== Config file =====|Args: )", re.MULTILINE)
#: A console's marks (Mainsail's or Fluidd's ``// `` answers, a ``$ `` command): a RepRapFirmware
#: ``config.g`` or a Marlin ``Configuration.h`` may have ``//`` lines too.
_CONSOLE_MARK = re.compile(r"^(?:// |\$ )", re.MULTILINE)
#: The first and the last line of the configuration a ``klippy.log`` dumps at each start.
CONFIG_DUMP = ("===== Config file =====", "=======================")


def probe_offsets(config: KlipperConfig) -> ProbeOffsets:
    """The offsets of a configuration's probe (``[probe]``, ``[bltouch]``, ``[smart_effector]``...).

    Raises:
        InputError: no probe section, or an offset that is not a number (``z_offset`` is required).
    """
    for section in PROBE_SECTIONS:
        if section in config.sections:
            if not config.has(section, "z_offset"):
                raise InputError("missing required key 'z_offset' (the probe's offsets are needed to read "
                                 "Klipper's 'probe: at X,Y bed will contact at z=Z')", config.source,
                                 f"section [{section}]")
            return ProbeOffsets(config.number(section, "x_offset", 0.0),
                                config.number(section, "y_offset", 0.0), config.number(section, "z_offset"))
    raise InputError(f"no probe section ([{'], ['.join(PROBE_SECTIONS)}]): the probe's offsets are needed to "
                     "read Klipper's 'probe: at X,Y bed will contact at z=Z'", config.source)


def logged_probes(text: str, source: str) -> list[tuple[int, int, str, ProbeOffsets | None]]:
    """The probe of each configuration a log dumps, in order.

    Returns:
        (the dump's first line, its last line, its probe section's name or "", its offsets or None
        without a probe section): one for each dump (Klipper's at each start).

    Raises:
        InputError: a dump that is not a configuration, or a probe without its ``z_offset``.
    """
    lines = text.splitlines()
    dumps = []
    start = None
    for number, line in enumerate(lines, start=1):
        if line.strip() == CONFIG_DUMP[0]:
            start = number
        elif start is not None and line.strip() == CONFIG_DUMP[1]:
            config = config_from_text("\n".join(lines[start:number - 1]), source, start + 1)
            section = next((name for name in PROBE_SECTIONS if name in config.sections), "")
            dumps.append((start, number, section, probe_offsets(config) if section else None))
            start = None
    return dumps


def is_probe_log(text: str) -> bool:
    """Whether a file's text is Klipper's log: its probe results, or the marks only ``klippy.log`` has."""
    return any(pattern.search(text) is not None
               for pattern in (PROBE_RESULT, PROBE_CONTACT, PROBE_ESTIMATE, _LOG_MARK))


def is_console(text: str) -> bool:
    """Whether a file's text has a console's ``// `` (or ``$ ``) lines, which other files may have too."""
    return _CONSOLE_MARK.search(text) is not None


def read_probe_log(path: str | Path, text: str | None = None, offsets: ProbeOffsets | None = None,
                   offsets_source: str = "the configuration given") -> ProbeLog:
    """The probe results of a log, in its order.

    Args:
        path: The log.
        text: Its text, if already read.
        offsets: The probe's offsets (:func:`probe_offsets` of ``--config``): needed by Klipper's lines
            from 2026; with them, every row carries the trigger height ``z_offset``. The rows after
            a configuration the log dumps take that one's instead (:func:`logged_probes`), with a
            warning naming both values where they differ.
        offsets_source: Where ``offsets`` come from, for messages (``"printer.cfg"``).

    Raises:
        InputError: the file cannot be read, holds no probe result, or holds a line from 2026
            without the offsets.
    """
    source, text = log_text(path, text)
    dumps = logged_probes(text, source)
    _warn_disagreement(dumps, offsets, source, offsets_source)
    ends = {end: (start, section, logged) for start, end, section, logged in dumps if logged is not None}
    rows: list[list[float]] = []
    lines: list[int] = []
    current, origin = offsets, ""  # the offsets in effect, and the dump they come from ("": offsets)
    trigger_source = ""
    open_from = 0  # the first row of the command whose samples are being read
    for number, line in enumerate(text.splitlines(), start=1):
        if number in ends:
            start, section, current = ends[number]
            origin = f"[{section}] z_offset of the log's own configuration (line {start})"
        row = _sample(line, number, current, source)
        estimate = PROBE_ESTIMATE.search(line)
        if estimate and len(rows) == open_from and not _DISCARDED.search(line[estimate.end():]):
            row = _from_probe([float(v) for v in estimate.groups()], number, current, source, "Result: at")
        if row is not None:
            rows.append([*row, np.nan if current is None else current.z])
            lines.append(number)
            if current is not None:
                trigger_source = origin or f"z_offset of {offsets_source}"
        if _DROPPED.search(line):
            rows, lines = _drop_point(rows, lines, open_from)
        if _CLOSING.search(line):
            open_from = len(rows)
    if not rows:
        raise InputError("no probe result in this log (Klipper's 'probe at X,Y is z=Z' or 'probe: at X,Y bed "
                         "will contact at z=Z' lines): probe with PROBE, or save the console after probing",
                         source)
    table = np.array(rows)
    heights = table[:, 3]
    if np.all(np.isnan(heights)):
        return ProbeLog(table[:, :3], np.array(lines, dtype=int))
    return ProbeLog(table[:, :3], np.array(lines, dtype=int), heights, trigger_source)


def _warn_disagreement(dumps: list[tuple[int, int, str, ProbeOffsets | None]], offsets: ProbeOffsets | None,
                       source: str, offsets_source: str) -> None:
    """Warn of each configuration the log dumps whose probe's offsets are not those given."""
    if offsets is None:
        return
    for start, _, section, logged in dumps:
        if logged is None or logged == offsets:
            continue
        keys = [(key, getattr(logged, axis), getattr(offsets, axis))
                for key, axis in (("x_offset", "x"), ("y_offset", "y"), ("z_offset", "z"))
                if getattr(logged, axis) != getattr(offsets, axis)]
        theirs = ", ".join(f"{key} = {ours:g}" for key, ours, _ in keys)
        given = ", ".join(f"{given:g}" for _, _, given in keys)
        warn(f"{source}: line {start}: the log's own configuration (Klipper's dump at its start) has "
             f"[{section}] {theirs} where {offsets_source} has {given}: the log's is taken, the one the "
             "printer probed with", InputWarning, stacklevel=3)


def _sample(line: str, number: int, offsets: ProbeOffsets | None, source: str) -> list[float] | None:
    """The commanded nozzle position of a line's probe sample, or None."""
    for pattern in (PROBE_RESULT, PROBE_CONTACT):
        match = pattern.search(line)
        if match and not _DISCARDED.search(line[match.end():]):
            values = [float(v) for v in match.groups()]
            return values if pattern is PROBE_RESULT else _from_probe(values, number, offsets, source,
                                                                       "probe: at")
    return None


def _from_probe(values: list[float], number: int, offsets: ProbeOffsets | None, source: str,
                what: str) -> list[float]:
    """The commanded nozzle position of the probe's position in a line from 2026."""
    if offsets is None:
        raise InputError(f"Klipper's '{what} X,Y ... z=Z' is the probe's position, its [probe] offsets "
                         "applied: give the printer's configuration with --config printer.cfg", source,
                         f"line {number}")
    return [values[0] - offsets.x, values[1] - offsets.y, values[2] + offsets.z]


def _drop_point(rows: list[list[float]], lines: list[int],
                open_from: int) -> tuple[list[list[float]], list[int]]:
    """The rows without the current point's samples (those since ``open_from`` at the last one's x, y)."""
    keep = len(rows)
    while keep > open_from and rows[keep - 1][:2] == rows[-1][:2]:
        keep -= 1
    return rows[:keep], lines[:keep]
