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
* G codes the controller runs that the correction cannot follow (:attr:`Dialect.refused`, by G
  number: Marlin's G33 changes the very values the program is corrected for);
* the M code whose ``S`` switches the controller's limits off (``S0``) and on (Marlin's ``M211``:
  :attr:`Dialect.limits_switch`), followed for the commands after it;
* the macros the controller defines (:attr:`Dialect.macros`, by upper-case name), each read for
  where it leaves the nozzle (:class:`MacroEffect`), and how a line names one
  (:meth:`Dialect.command`).

A firmware gives its dialect (:meth:`deltacal.printer.firmware.base.Firmware.dialect`); a
rotary Delta's controller reads G-code as :data:`GENERIC` does. Units: mm.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

__all__ = ["GENERIC", "ArcP", "Dialect", "MacroEffect", "MacroStep"]

#: A Klipper command's name: its first word of letters and underscores, and the text to the next
#: letter (``klippy/gcode.py``: ``START_PRINT``, ``M600``, ``G28``), after a line number.
_COMMAND = re.compile(r"[ \t]*(?:N[ \t]*[0-9]+[ \t]*)?([A-Z_]+)([^A-Z_*;]*)")
#: The S word of an M code that switches the limits, and its number (``M211 S0``; ``S`` alone is on).
_SWITCH = re.compile(r"[Ss]\s*([-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))?")


class ArcP(enum.Enum):
    """What a ``P`` word (a count of turns in some firmwares) on a G2/G3 line does."""

    REFUSED = "refused"  #: firmwares differ: refused by the line
    IGNORED = "ignored"  #: never read (Klipper): the arc as if it had none
    CIRCLES = "circles"  #: P full circles before the arc, an integer 0..100 (Marlin's ARC_P_CIRCLES)


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
    SAVE = "save"  #: SAVE_GCODE_STATE (``name``)
    RESTORE = "restore"  #: RESTORE_GCODE_STATE (``name``; ``values`` {"MOVE": 1} moves back)


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
    """

    name: str
    steps: tuple[tuple[MacroStep, Mapping[str, float], str], ...] = ()
    unknown: str = ""
    builtin: bool = False

    @property
    def moves(self) -> bool:
        """Whether it moves the nozzle or changes the modes (else it leaves everything as it was)."""
        return bool(self.steps) or bool(self.unknown)


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
        refused: G codes refused by their line (G number -> why), the controller's own.
        limits_switch: The M number whose ``S0`` switches the controller's limits off and ``S1``
            on (Marlin's soft endstops, ``M211``), or None.
    """

    name: str = "generic"
    g91_moves_e: bool = False
    arc_p: ArcP = ArcP.REFUSED
    home: tuple[float, float, float] | None = None
    macros: Mapping[str, MacroEffect] = field(default_factory=lambda: MappingProxyType({}))
    e_by_m83: bool = False
    distance_sets_e: bool = False
    refused: Mapping[float, str] = field(default_factory=lambda: MappingProxyType({}))
    limits_switch: int | None = None

    def with_home(self, home) -> Dialect:
        """The same dialect with where a homing leaves the TCP [mm] (None: unknown)."""
        value = None if home is None else tuple(float(v) for v in home)
        return replace(self, home=value)  # type: ignore[arg-type]

    def switches_limits(self, code: str, words: str) -> bool | None:
        """Whether an M code's line switches the controller's limits on (True) or off (False), or None.

        Args:
            code: The M number as written, without leading zeros (``"211"``).
            words: The line's words after it, its comment cut (``" S0"``).
        """
        if self.limits_switch is None or code != str(self.limits_switch):
            return None
        value = _SWITCH.search(words)
        if value is None:  # M211 alone reports the soft endstops
            return None
        return value.group(1) is None or float(value.group(1)) != 0.0

    def macro(self, line: str) -> MacroEffect | None:
        """The macro a program's line calls (by its command's name, any case), or None."""
        if not self.macros:
            return None
        match = _COMMAND.match(line.upper())
        if match is None:
            return None
        return self.macros.get((match.group(1) + match.group(2)).strip())


#: The reading of a controller with no rules of its own: ambiguities refused, arcs' P refused.
GENERIC = Dialect()
