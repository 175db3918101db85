"""RepRapFirmware's reading of G-code (:class:`~deltacal.gcode.dialect.Dialect`) with ``config.g``.

What differs from a generic reader, from RRF's source (``src/GCodes``) and its G-code reference:

* E is relative exactly when M83 holds; a ``P`` on an arc is never a count of turns; G28 runs
  ``homedelta.g`` (:func:`~.homing.homed_position`);
* how a line's command is found (:data:`RRF_LINES`, ``GCodeBuffer/StringParser.cpp``);
* the commands a corrected program cannot hold (:func:`rrf_rules`): those that change the values the
  program is corrected for are refused by their line: ``G32`` (``bed.g``, the delta
  auto-calibration), ``G30`` with ``S`` 0 or more (the calibration of ``bed.g``'s last line),
  ``M665``, ``M666``, ``M669`` with values, ``M92 X Y Z``, the scales and skew of ``M579`` and
  ``M556``, ``M501`` (it runs ``config-override.g``), ``M502`` (``config.g``'s values again) and
  ``M98`` of ``config.g``, ``config-override.g`` or ``bed.g``; ``G29`` that turns the mesh bed
  compensation on (``G29``, ``S0``, ``S1``) is kept with a warning that says how to turn it off
  (``G29 S2``); ``M564 S`` (limits on or off) and ``M208`` (``S1 Z`` or ``Zmin:max``: the Z minimum)
  set the limits the commands after them are checked against.

Units: mm.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np

from ....gcode.dialect import ArcP, CommandRule, Dialect, LineReading, Unread
from .model import RRFDelta

__all__ = ["RRF_LINES", "rrf_dialect", "rrf_rules"]

#: How RepRapFirmware finds a line's command (``GCodes/GCodeBuffer/StringParser.cpp``: ``Put`` skips
#: the spaces and tabs of the indentation and a line number, and ends the line at a NUL as at a
#: newline; ``DecodeCommand`` takes G, M or T first, repeats the last G0-G3 for an axis letter first
#: in CNC and laser mode only, and else answers "Bad command").
RRF_LINES = LineReading(axis_words=Unread.REFUSED, axis_words_why="RepRapFirmware repeats the last G0/G1 "
                        "in CNC or laser mode (M453, M452) and answers 'Bad command' in FFF mode (M451)",
                        junk=Unread.IGNORED, unknown="Bad command", blanks=" \t", nul_ends_line=True)
#: What to do instead of a command that changes the values the program is corrected for.
_INSTEAD = ("the program is corrected for the values of the configuration given, which the printer would "
            "no longer have: set them in config.g (or save them to config-override.g with M500) and "
            "remove the line from the program")
#: The files whose M98 sets the values a program is corrected for.
_CONFIG_FILES = ("config.g", "config-override.g", "bed.g")


def _calibrates(params: Mapping[str, str]) -> bool:
    """``G30 ... S<n>``, n >= 0: the last line of ``bed.g``, which calibrates (``S-1`` only reports)."""
    try:
        return "S" in params and float(params["S"] or "0") >= 0.0
    except ValueError:
        return True


def _runs_config(params: Mapping[str, str]) -> bool:
    """``M98 P"..."`` of one of :data:`_CONFIG_FILES` (in any folder, any case)."""
    name = params.get("P", "").strip('"').replace("\\", "/").rsplit("/", 1)[-1].lower()
    return name in _CONFIG_FILES


def _loads_mesh(params: Mapping[str, str]) -> bool:
    """``G29``, ``G29 S0`` (probe, then compensate) or ``G29 S1`` (load the height map); not S2, S3."""
    return params.get("S", "0").strip() in ("", "0", "1")


def _limits_on(before: RRFDelta, params: Mapping[str, str]) -> RRFDelta:
    """The limits after ``M564 S..``: on or off."""
    return before.with_limits(CommandRule.nonzero("S")(params))


def _minimum_z(before: RRFDelta, params: Mapping[str, str]) -> RRFDelta:
    """The limits after ``M208 ... Z``: the Z minimum of ``Zmin:max``, or of ``S1 Z`` (else Z is the maximum).

    A value that is not a number (an expression) leaves the minimum as it was.
    """
    values = params["Z"].split(":")
    if len(values) < 2 and params.get("S", "0").strip() != "1":
        return before  # Z alone (S0, the default): the maximum
    try:
        return before.with_minimum_z(float(values[0]))
    except ValueError:
        return before


def rrf_rules(model: RRFDelta) -> MappingProxyType:
    """The commands of a program that RRF runs and the correction cannot follow (see the module's text).

    Args:
        model: RRF's values, from the configuration the program is corrected for.
    """
    given = CommandRule.given
    return MappingProxyType({
        "G32": CommandRule(f"it runs bed.g, RepRapFirmware's delta auto-calibration, which changes M665 and "
                           f"M666: {_INSTEAD}"),
        "G30": CommandRule(f"with S 0 or more it calibrates the delta from the points probed (bed.g's last "
                           f"line), changing M665 and M666: {_INSTEAD}", applies=_calibrates),
        "M665": CommandRule(f"it sets RepRapFirmware's delta values (L, R, H, B, the angle corrections X Y "
                            f"Z): {_INSTEAD}", applies=given("LRHBXYZ")),
        "M666": CommandRule(f"it sets the endstop corrections and the bed tilt: {_INSTEAD}",
                            applies=given("XYZAB")),
        "M669": CommandRule(f"it sets the kinematics and their values: {_INSTEAD}", applies=bool),
        "M92": CommandRule(f"it sets the towers' steps per mm: {_INSTEAD}", applies=given("XYZ")),
        "M579": CommandRule(f"it scales the coordinates the moves are given in: {_INSTEAD}",
                            applies=given("XYZ")),
        "M556": CommandRule(f"it corrects the axes' skew on top of the moves: {_INSTEAD}",
                            applies=given("SXYZ")),
        "M501": CommandRule(f"it runs config-override.g, whose M665 and M666 need not be the "
                            f"configuration's: {_INSTEAD}"),
        "M502": CommandRule(f"it sets config.g's values again, without config-override.g's: {_INSTEAD}"),
        "M98": CommandRule(f"it runs config.g, config-override.g or bed.g, which set M665 and M666: "
                           f"{_INSTEAD}", applies=_runs_config),
        "G29": CommandRule("it turns RepRapFirmware's mesh bed compensation on (G29 and G29 S0 probe the "
                           "bed, G29 S1 loads the height map): RRF adds the mesh to every move, on top of "
                           "deltacal's correction, which already holds the bed the calibration measured (the "
                           "first layer corrected twice): leave it out, or send G29 S2 after it", warn=True,
                           applies=_loads_mesh),
        "M564": CommandRule("it switches RepRapFirmware's limits on or off", applies=CommandRule.given("S"),
                            limits=_limits_on),
        "M208": CommandRule("it sets the axes' limits", applies=CommandRule.given("Z"), limits=_minimum_z),
    })


def rrf_dialect(model: RRFDelta, home: np.ndarray) -> Dialect:
    """RRF's reading of G-code with ``config.g``'s values ``model``; G28 leaves the nozzle at ``home``."""
    return Dialect("RepRapFirmware", arc_p=ArcP.IGNORED, home=tuple(np.asarray(home, dtype=float).tolist()),
                   e_by_m83=True, rules=rrf_rules(model), lines=RRF_LINES)
