"""Marlin 2's reading of G-code (:class:`~deltacal.gcode.dialect.Dialect`) with an ``M503`` capture's values.

What differs from a generic reader, from Marlin's source (``Marlin/src``):

* G90 and G91 set E's mode too, M82/M83 override it until the next G90/G91 (``gcode.h``,
  ``set_relative_mode``); a ``P`` on an arc is that many full circles (``G2_G3.cpp`` with
  ``ARC_P_CIRCLES``); G28 leaves the nozzle at ``(0, 0, H - M851 Z)``;
* how a line's command is found (:data:`MARLIN_LINES`, ``gcode/parser.cpp``);
* the commands a corrected program cannot hold (:func:`marlin_rules`): those that change the values
  the program is corrected for, from the capture's, are refused by their line: ``G33`` (the delta
  auto-calibration), ``M665`` and ``M666`` with values, ``M92 X Y Z``, ``M851 Z`` (it moves where
  ``G28`` leaves the nozzle), ``M501`` (the EEPROM's settings) and ``M502`` (the firmware's defaults);
  those that turn Marlin's bed levelling on (``M420 S1``, ``G29``) are kept with a warning that
  says how to turn it off (``M420 S0``); ``M211 S1`` (``S0``) switches the soft endstops on (off):
  the commands after it are checked against them (a capture with ``M211 S0`` and a program that
  switches them on: a corrected first layer below Min Z is refused naming that line).

Units: mm.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from ....gcode.dialect import ArcP, CommandRule, Dialect, LineReading, Unread
from .model import MarlinDelta

__all__ = ["MARLIN_LINES", "marlin_dialect", "marlin_rules"]

#: How Marlin finds a line's command (``gcode/parser.cpp``, ``GCodeParser::parse``): spaces and an ``N``
#: line number skipped, the next character must be G, M or T, else the line is an unknown command;
#: built with ``GCODE_MOTION_MODES`` (off by default) an axis letter first repeats the last G0-G3. A NUL
#: ends the command's text (``queue.cpp`` stores it, ``parse`` reads a C string).
MARLIN_LINES = LineReading(axis_words=Unread.REFUSED, axis_words_why="Marlin repeats the last G0/G1 only "
                           "when built with GCODE_MOTION_MODES, else answers 'Unknown command' and does "
                           "not move", junk=Unread.IGNORED, blanks=" ")
#: What to do instead of a command that changes the values the program is corrected for.
_INSTEAD = ("the program is corrected for the values of the M503 capture, which the printer would no "
            "longer have: send it once (then M500), capture M503 again, and remove it from the program")
#: What a bed mesh turned on does to a corrected program.
_TWICE = ("the firmware adds its mesh to every move, on top of deltacal's correction, which already holds "
          "the bed the calibration measured (the first layer corrected twice)")
#: Why a program's G33 is refused.
G33_REFUSED = ("Marlin's delta auto-calibration changes M665 and M666, the settings the program is "
               "corrected for: run G33 and M500 once, capture M503 again, and remove G33 from the program")


def _soft_endstops(before: MarlinDelta, params: Mapping[str, str]) -> MarlinDelta:
    """The limits after ``M211 S..``: the soft endstops on or off (``S`` alone: on, as Marlin reads it)."""
    return before.with_soft_endstops(CommandRule.nonzero("S")(params))


def marlin_rules(model: MarlinDelta) -> MappingProxyType:
    """The commands of a program that Marlin runs and the correction cannot follow (see the module's text).

    Args:
        model: Marlin's values, from the capture the program is corrected for.
    """
    given = CommandRule.given
    return MappingProxyType({
        "G33": CommandRule(G33_REFUSED),
        "M665": CommandRule(f"it sets Marlin's delta values (L, R, H, the trims X Y Z and A B C): {_INSTEAD}",
                            applies=given("LRHXYZABC")),
        "M666": CommandRule(f"it sets Marlin's endstop adjustments: {_INSTEAD}", applies=given("XYZ")),
        "M92": CommandRule(f"it sets the towers' steps per mm: {_INSTEAD}", applies=given("XYZ")),
        "M851": CommandRule(f"it sets the probe's Z offset, and with it where G28 leaves the nozzle "
                            f"(H - M851 Z): {_INSTEAD}", applies=given("Z")),
        "M501": CommandRule(f"it loads the settings saved in the EEPROM, which need not be the capture's: "
                            f"{_INSTEAD}"),
        "M502": CommandRule(f"it resets Marlin's settings to the firmware's defaults: {_INSTEAD}"),
        "M420": CommandRule(f"it turns Marlin's bed levelling on: {_TWICE}: leave it out, or send M420 S0 "
                            "after it", warn=True, applies=CommandRule.nonzero("S")),
        "G29": CommandRule(f"it probes the bed, and most builds then turn Marlin's bed levelling on: "
                           f"{_TWICE}: leave it out, or send M420 S0 after it", warn=True),
        "M211": CommandRule("it switches Marlin's soft endstops on or off", applies=CommandRule.given("S"),
                            limits=_soft_endstops),
    })


def marlin_dialect(model: MarlinDelta) -> Dialect:
    """Marlin 2's reading of G-code with the values ``model`` of an ``M503`` capture."""
    return Dialect("Marlin", arc_p=ArcP.CIRCLES, home=(0.0, 0.0, model.home_height), distance_sets_e=True,
                   rules=marlin_rules(model), lines=MARLIN_LINES)
