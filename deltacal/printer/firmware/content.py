"""Which firmware's file a text is, told by the commands it runs, never by its comments.

A RepRapFirmware ``config.g`` and a Marlin ``M503`` capture both set ``M665`` and ``M666``, and
their comments share words (an RRF ``config.g`` says "; Delta Settings" or "; endstop adjustments",
Marlin's report prints "echo:; Delta settings:" headings). What tells them apart is what they run
(:func:`file_commands`): each line's host prefix (``Recv:``, ``Send:``, Pronterface's ``>>>`` and
``SENDING:``) and Marlin's ``echo:`` set aside, then its comment (``;`` to the end of the line,
anywhere in it) stripped, the G/M command it starts with.

* A Marlin capture (:func:`is_marlin_capture`) runs ``M665`` and has Marlin's ``echo:`` lines, or
  runs a command of Marlin's report that RRF's configuration does not (:data:`MARLIN_REPORT`: the
  ``M503`` sent, ``M851``, ``M211``, the ``M500`` after settings written to send...) and none of
  RRF's (:data:`RRF_CONFIG`).
* An RRF configuration (:func:`is_rrf_commands`) is a ``*.g`` file that runs ``M665`` or ``M669``
  and is no Marlin capture.

The two are exclusive, so a file is one firmware's or the other's, whatever its comments say.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ...io.inputs import input_problem

#: The commands of Marlin's ``M503`` report (or of its capture, or of its settings written to send it)
#: that RRF's configuration does not run: the ``M503`` sent, the probe's offset ``M851``, the soft
#: endstops ``M211``, the preheat presets ``M145``, linear advance ``M900``, power-loss recovery
#: ``M413``, and ``M500`` that saves the settings sent (to Marlin's EEPROM; RRF's ``config.g`` runs
#: ``M501``, never ``M500``).
MARLIN_REPORT = frozenset({"M503", "M851", "M211", "M145", "M900", "M413", "M500"})
#: Commands an RRF ``config.g`` runs and Marlin's report never prints: the kinematics ``M669``,
#: drive mapping ``M584``, microstepping ``M350``, the Z probe ``M558`` and ``G31``, another file run
#: ``M98``, ``config-override.g`` run ``M501``, drive directions ``M569``, endstops ``M574``, motor
#: currents ``M906``, the machine's name ``M550``, the network ``M552``.
RRF_CONFIG = frozenset({"M669", "M584", "M350", "G31", "M558", "M98", "M501", "M569", "M574", "M906",
                        "M550", "M552"})
#: The commands that set a delta's geometry in RRF's configuration.
RRF_DELTA = frozenset({"M665", "M669"})
#: How much of a file is read to tell it [characters].
HEAD = 1 << 20

#: A host's prefixes of a console line (OctoPrint's ``Recv:``/``Send:``, Pronterface's ``>>>``,
#: ``SENDING:``), then Marlin's ``echo:``.
_HOST = re.compile(r"^\s*(?:(?:Recv|Send|SENDING)\s*:\s*|>>>\s*)*", re.IGNORECASE)
_ECHO = re.compile(r"^echo:\s*", re.IGNORECASE)
#: A line's command: an optional line number, then G or M and its number.
_COMMAND = re.compile(r"^\s*(?:N\d+\s*)?([GM])(\d+)(?![\d.])", re.IGNORECASE)


@dataclass(frozen=True)
class FileCommands:
    """What a file runs.

    Attributes:
        codes: Every G/M command a line starts with once comments and prefixes are set aside (``"M665"``).
        echo: Whether a line is Marlin's ``echo:`` (after a host's prefix).
    """

    codes: frozenset[str]
    echo: bool

    def runs(self, codes: frozenset[str] | set[str]) -> bool:
        """Whether the file runs any of ``codes``."""
        return not self.codes.isdisjoint(codes)


def file_commands(text: str) -> FileCommands:
    """The commands ``text`` runs, its comments (``;`` to the end of a line) stripped."""
    codes: set[str] = set()
    echo = False
    for raw in text.splitlines():
        line = _HOST.sub("", raw, count=1)
        marked = _ECHO.match(line)
        if marked is not None:
            echo = True
            line = line[marked.end():]
        command = _COMMAND.match(line.split(";", 1)[0])
        if command is not None:
            codes.add(f"{command.group(1).upper()}{int(command.group(2))}")
    return FileCommands(frozenset(codes), echo)


def read_commands(path: str | Path) -> FileCommands | None:
    """The commands a file runs (its first :data:`HEAD` characters), or None: not a readable file."""
    if input_problem(path) is not None:
        return None  # the reader of the file taken instead names the problem
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return file_commands(f.read(HEAD))
    except OSError:
        return None


def is_marlin_capture(commands: FileCommands) -> bool:
    """Whether a file's commands are a Marlin ``M503`` capture's (module docstring)."""
    return "M665" in commands.codes and (
        commands.echo or (commands.runs(MARLIN_REPORT) and not commands.runs(RRF_CONFIG)))


def is_rrf_commands(path: str | Path, commands: FileCommands) -> bool:
    """Whether a file (of ``commands``) is an RRF configuration: a ``*.g`` that runs M665 or M669."""
    return (Path(path).suffix.lower() == ".g" and commands.runs(RRF_DELTA)
            and not is_marlin_capture(commands))
