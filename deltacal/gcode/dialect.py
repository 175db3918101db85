"""A controller's own reading of G-code: the rules where firmwares differ, as one value.

The rewriter (:mod:`deltacal.gcode.rewriter`) reads a program as the controller that runs it
does. Where controllers differ, it asks a :class:`Dialect`:

* whether G91 makes E relative (:attr:`Dialect.g91_moves_e`): Klipper's ``gcode_move.py`` reads
  E as an increment when either G91 or M83 holds (``absolute_coord`` and ``absolute_extrude``),
  so nothing is ambiguous; RepRapFirmware's reads E as an increment exactly when M83 holds
  (:attr:`Dialect.e_by_m83`: G90/G91 set ``axesRelative``, M82/M83 ``drivesRelative``,
  ``GCodes2.cpp``), so nothing is ambiguous either;
  Marlin 2's G90 and G91 set E's mode too (:attr:`Dialect.distance_sets_e`:
  ``GcodeSuite::set_relative_mode`` clears the M82/M83 override), the last of G90, G91, M82 and
  M83 decides; without a rule (:data:`GENERIC`) G91 without
  M83, and G90 after M83, are ambiguous (firmwares differ) and a split extruding move there is refused;
* what a ``P`` word on an arc means (:attr:`Dialect.arc_p`): Klipper's ``gcode_arcs.py`` never
  reads it (one turn at most, a full turn where the ends meet); Marlin (built with
  ``ARC_P_CIRCLES``) turns P full circles before the arc, Z and E spread over the whole sweep
  (``G2_G3.cpp``); elsewhere it is refused;
* where a homing (G28) leaves the TCP (:attr:`Dialect.home`);
* G and M commands the controller runs that the correction cannot follow (:attr:`Dialect.rules`,
  :class:`CommandRule`): refused by their line where they change the very values the program is
  corrected for (Marlin's G33, M665, M666, M92 X Y Z, M501, M502; RepRapFirmware's G32, M98 of
  ``config-override.g`` ...), or kept with a warning;
* the macros the controller defines (:attr:`Dialect.macros`, by upper-case name), each read for
  where it leaves the nozzle (:class:`MacroEffect`), and how a line names one
  (:meth:`Dialect.command`);
* how it finds a line's command (:class:`LineReading`): what a line of axis words without a G word
  (``X40 Y0 Z10``) does, and one with text before its command's first letter (a byte-order mark
  where two files were joined, a NUL, a digit: ``1G1 X40``), the blanks it skips before a command,
  and whether a NUL byte ends a line.

A firmware gives its dialect (:meth:`deltacal.printer.firmware.base.Firmware.dialect`); a
rotary Delta's controller reads G-code as :data:`GENERIC` does. Units: mm.
"""

from __future__ import annotations

import enum
import re
import shlex
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

__all__ = ["GENERIC", "ArcP", "CommandRule", "Dialect", "LineReading", "MacroEffect", "MacroStep", "Unread",
           "command_params"]

#: A Klipper command's name: its first word of letters and underscores, and the text to the next
#: letter (``klippy/gcode.py``: ``START_PRINT``, ``M600``, ``G28``), after a line number.
_COMMAND = re.compile(r"[ \t]*(?:N[ \t]*[0-9]+[ \t]*)?([A-Z_]+)([^A-Z_*;]*)")
#: A named command's name, in any case (its parameters follow).
_NAMED = re.compile(r"[ \t]*(?:[Nn][ \t]*[0-9]+[ \t]*)?[A-Za-z_]+")


class ArcP(enum.Enum):
    """What a ``P`` word (a count of turns in some firmwares) on a G2/G3 line does."""

    REFUSED = "refused"  #: firmwares differ: refused by the line
    IGNORED = "ignored"  #: never read (Klipper): the arc as if it had none
    CIRCLES = "circles"  #: P full circles before the arc, an integer 0..100 (Marlin's ARC_P_CIRCLES)


class Unread(enum.Enum):
    """What a controller does with a line whose command it does not find where a G-code reader would."""

    MODAL = "modal"  #: axis words alone repeat the motion mode (LinuxCNC), as a reader of G-code does
    IGNORED = "ignored"  #: an unknown command, not run: the line is kept, the position not moved, a warning
    REFUSED = "refused"  #: the controller's reading depends on how it is built or set up: refused by the line


@dataclass(frozen=True)
class LineReading:
    """How a controller finds a line's command, where controllers differ.

    Attributes:
        axis_words: What a line of axis words without a G word first (``X40 Y0 Z10``) does.
        axis_words_why: What the controller does with one, for the message (its firmware's words).
        junk: What a line with text before its command's first letter (a byte-order mark, a NUL, a
            digit: ``1G1 X40``) does (never :attr:`Unread.MODAL`).
        unknown: The controller's answer to a command it does not know, for messages.
        blanks: The characters the controller skips before a command, or None: any whitespace (as
            Python's ``str.strip``, Klipper's). A line whose command follows another blank is refused:
            a host (OctoPrint) strips it and sends the command, the controller reading its own card
            does not run it.
        nul_ends_line: Whether a NUL byte ends a line, what follows it running as a line of its own
            (RepRapFirmware): a line holding one is refused.
    """

    axis_words: Unread = Unread.MODAL
    axis_words_why: str = ""
    junk: Unread = Unread.REFUSED
    unknown: str = "Unknown command"
    blanks: str | None = None
    nul_ends_line: bool = False


def _always(params: Mapping[str, str]) -> bool:
    return True


@dataclass(frozen=True)
class CommandRule:
    """What the reader does with a G or M command the controller runs that the correction cannot follow.

    Attributes:
        why: What the line does, why it is refused or what to do (the message after the command's
            name: ``M665: ...``).
        warn: Whether the line is kept, with a warning (a bed mesh turned on), rather than refused.
        applies: Whether the rule holds for a line of these parameters (upper-case letter -> the
            text of its value, a quoted string with its quotes); by default, always.
        limits: How the line changes the controller's limits on its commands (Marlin's ``M211 S1``
            switches its soft endstops on), or None: ``limits(before, params)`` -> the limits after
            it (:class:`~deltacal.controller.limits.CommandLimits`, the firmware's model); the line is
            kept and the commands after it are checked against them (``why`` is then unused).
    """

    why: str
    warn: bool = False
    applies: Callable[[Mapping[str, str]], bool] = _always
    limits: Callable[[Any, Mapping[str, str]], Any] | None = None

    @staticmethod
    def given(letters: str) -> Callable[[Mapping[str, str]], bool]:
        """A rule's ``applies``: one of ``letters`` is given (``M92 X``, not ``M92 E``)."""
        return lambda params: any(letter in params for letter in letters)

    @staticmethod
    def nonzero(letter: str) -> Callable[[Mapping[str, str]], bool]:
        """A rule's ``applies``: ``letter`` is given, alone or with a number other than 0 (``M211 S1``).

        A letter alone is true, as Marlin's ``parser.value_bool()`` reads it (``M420 S``).
        """
        def applies(params: Mapping[str, str]) -> bool:
            try:
                return letter in params and float(params[letter] or "1") != 0.0
            except ValueError:
                return True  # not a number: the firmware's reading is not known
        return applies


class MacroStep(enum.Enum):
    """One thing a macro does to the position and the modes, in order (:class:`MacroEffect`)."""

    HOME = "home"  #: G28: every carriage at its endstop
    ABSOLUTE = "absolute"  #: G90
    RELATIVE = "relative"  #: G91
    E_ABSOLUTE = "e_absolute"  #: M82
    E_RELATIVE = "e_relative"  #: M83
    MOVE = "move"  #: G0/G1 with literal numbers (``values``: axis -> number)
    SET_E = "set_e"  #: G92 E (``values``: {"E": number})
    E_UNKNOWN = "e_unknown"  #: an E whose number a Jinja expression gives
    SAVE = "save"  #: SAVE_GCODE_STATE (``name``; ``values`` {"CONDITIONAL": 1} under a Jinja condition)
    RESTORE = "restore"  #: RESTORE_GCODE_STATE (``name``; ``values`` {"MOVE": 1} moves back; "CONDITIONAL")


@dataclass(frozen=True)
class MacroEffect:
    """Where a macro leaves the nozzle, read from its template without running it.

    Attributes:
        name: The macro's name, upper case (as the controller registers it).
        steps: What it does, in order: (step, values, state name) (see :class:`MacroStep`).
        unknown: Why its end position cannot be known (a homing or a move under a Jinja
            condition, a move whose coordinates an expression gives, a probing command ...), or
            "" (known).
        builtin: Whether it is one of the controller's own commands (``BED_MESH_CALIBRATE``), not a
            macro of its configuration (messages name it as it is).
        refused: Why a program's line that calls it is refused (a state whose ``NAME`` a Jinja
            expression gives, a malformed command), or "".
        from_line: Whether its steps take the ``NAME`` and ``MOVE`` of the line that calls it
            (Klipper's own ``SAVE_GCODE_STATE`` and ``RESTORE_GCODE_STATE``: :meth:`on_line`).
        warning: What a warning says of a program's line that calls it (it turns a bed mesh on), or "".
        warn_with: The parameter the line must give for the warning (``LOAD`` of
            ``BED_MESH_PROFILE``), or "": always.
    """

    name: str
    steps: tuple[tuple[MacroStep, Mapping[str, float], str], ...] = ()
    unknown: str = ""
    builtin: bool = False
    refused: str = ""
    from_line: bool = False
    warning: str = ""
    warn_with: str = ""

    @property
    def moves(self) -> bool:
        """Whether it moves the nozzle or changes the modes (else it leaves everything as it was)."""
        return bool(self.steps) or bool(self.unknown)

    def on_line(self, line: str) -> MacroEffect:
        """The command called by a program's line, its steps given the line's ``NAME`` and ``MOVE``.

        As Klipper's ``gcode_move.py`` reads them (``gcmd.get('NAME', 'default')``,
        ``gcmd.get_int('MOVE', 0)``) from the extended parameters (:func:`command_params`); a
        malformed line or a ``MOVE`` that is not an integer stops Klipper's print: refused.
        """
        if self.warn_with:
            params = command_params(line)
            return replace(self, warning=self.warning if params and self.warn_with in params else "",
                           warn_with="")
        if not self.from_line:
            return self
        params = command_params(line)
        if params is None:
            return replace(self, refused=f"{line.strip()!r}: Klipper answers 'Malformed command' "
                                         "(parameters are KEY=value): the print stops there")
        name = params.get("NAME", "default")
        steps = []
        for step, values, _ in self.steps:
            if step is MacroStep.RESTORE:
                try:
                    values = {"MOVE": 1.0} if int(params.get("MOVE", "0")) else {}
                except ValueError:
                    return replace(self, refused=f"{self.name} MOVE={params['MOVE']}: not an integer, "
                                                 "Klipper stops the print there")
            steps.append((step, values, name))
        return replace(self, steps=tuple(steps), from_line=False)


@dataclass(frozen=True)
class Dialect:
    """A controller's reading of G-code (see the module's documentation).

    Attributes:
        name: The controller's name (its firmware's), for messages.
        g91_moves_e: Whether G91 makes E relative and G90 leaves M83's relative E (Klipper).
        e_by_m83: Whether E is relative exactly when M83 holds, G90 and G91 never touching it
            (RepRapFirmware).
        arc_p: What a ``P`` word on an arc does.
        home: Where a homing (G28) leaves the TCP [mm] (X, Y, Z), or None: unknown after it.
        macros: The controller's macros by upper-case name.
        distance_sets_e: Whether G90 and G91 set E's mode too, forgetting M82/M83 (Marlin 2).
        rules: What is done with the G and M commands the correction cannot follow, by command
            (``"G33"``, ``"M665"``: upper case, the number without leading zeros).
        lines: How it finds a line's command.
    """

    name: str = "generic"
    g91_moves_e: bool = False
    arc_p: ArcP = ArcP.REFUSED
    home: tuple[float, float, float] | None = None
    macros: Mapping[str, MacroEffect] = field(default_factory=lambda: MappingProxyType({}))
    e_by_m83: bool = False
    distance_sets_e: bool = False
    rules: Mapping[str, CommandRule] = field(default_factory=lambda: MappingProxyType({}))
    lines: LineReading = LineReading()

    def with_home(self, home) -> Dialect:
        """The same dialect with where a homing leaves the TCP [mm] (None: unknown)."""
        value = None if home is None else tuple(float(v) for v in home)
        return replace(self, home=value)  # type: ignore[arg-type]

    def macro(self, line: str) -> MacroEffect | None:
        """The macro a program's line calls (by its command's name, any case), or None."""
        if not self.macros:
            return None
        match = _COMMAND.match(line.upper())
        if match is None:
            return None
        effect = self.macros.get((match.group(1) + match.group(2)).strip())
        return None if effect is None else effect.on_line(line)


def command_params(line: str) -> dict[str, str] | None:
    """The ``KEY=value`` parameters of a named command's line, as Klipper reads them; None: malformed.

    Klipper (``gcode.py``, ``_get_extended_params``) takes the text after the command's name, split
    as a shell does (quotes, ``#`` and ``;`` comments), each word ``KEY=value``: the key in upper
    case, the value as written (``NAME=park`` and ``NAME=PARK`` are two states).
    """
    found = _NAMED.match(line)
    if found is None:
        return None
    lexer = shlex.shlex(line[found.end():], posix=True)
    lexer.whitespace_split = True
    lexer.commenters = "#;"
    try:
        pairs = [word.split("=", 1) for word in lexer]
        return {key.upper(): value for key, value in pairs}
    except ValueError:  # a word without '=', a quote not closed
        return None


#: The reading of a controller with no rules of its own: ambiguities refused, arcs' P refused.
GENERIC = Dialect()
