"""The modal state of a G-code program as it is read, and the modes it holds, as enums.

A G-code line is read in the modes set by the lines before it: the motion mode (:class:`Motion`,
G0/G1/G2/G3), the distance mode (G90 absolute, G91 relative: :attr:`ModalState.relative`), the
arc plane (:class:`Plane`, G17/G18/G19) and the extruder's mode (M82/M83, read with the distance
mode as an :class:`Extrusion`). :class:`ModalState` holds them with the positions known so far.

Units: mm.
"""

from __future__ import annotations

import enum


class Motion(enum.Enum):
    """The motion mode (modal G0/G1/G2/G3); the value is the G number."""

    RAPID = 0  #: G0: a straight move at the travel speed
    LINEAR = 1  #: G1: a straight move at the feed rate
    CLOCKWISE = 2  #: G2: a clockwise arc
    COUNTER_CLOCKWISE = 3  #: G3: a counter-clockwise arc


class Plane(enum.Enum):
    """The plane of arcs (modal G17/G18/G19); the value is the G number."""

    XY = 17  #: G17
    ZX = 18  #: G18
    YZ = 19  #: G19


class Extrusion(enum.Enum):
    """How an E word is read: the extruder's position (M82), an increment (M83), or either.

    ``AMBIGUOUS`` where firmwares differ: M83 then G90 with no M82/M83 since (Marlin 1
    and Repetier keep E relative, Marlin 2 and Smoothieware make it absolute), or G91 without M83
    (whether G91 makes E relative).
    """

    ABSOLUTE = "absolute"
    RELATIVE = "relative"
    AMBIGUOUS = "ambiguous"


#: Motion modes by their G number (the number as read, a float).
MOTIONS = {float(m.value): m for m in Motion}
#: Planes by their G number (the number as read, a float).
PLANES = {float(p.value): p for p in Plane}


class ModalState:
    """The modal state of the program as read so far (positions in mm).

    Attributes:
        pos: TCP position (X, Y, Z) [mm], each None while unknown.
        relative: Distance mode: True after G91 (increments), False after G90 (positions).
        m83: Whether the extruder was last set relative (M83; with ``distance_sets_e``, G91 too).
        m83_ended: Whether G90 was read after M83 (firmwares differ on its effect).
        extrusion: How E words are read now (from ``relative``, ``m83`` and ``m83_ended``).
        e_pos: Extruder position [mm], or None while unknown.
        motion: The motion mode, or None before the first G0/G1/G2/G3.
        plane: The plane of arcs.
        unknown_since: Line of the homing that made the position unknown (0: the start).
        unknown_why: What made it unknown there ("": a homing or probing line; else a macro).
        homed: Line of a homing (or a macro) that left the controller at a point of its own (its
            home, a macro's literal move) rather than a corrected one, until a move (0: none).
        homed_by: What left it there ("the homing", "the macro START_PRINT").
        at_home: Whether that point is the home (every carriage at its endstop).
        fresh: Whether no move has been read yet.
        g91_moves_e: The controller's rule: G91 makes E relative, G90 leaves M83's (Klipper).
        distance_sets_e: The controller's rule: G90 and G91 set E's mode too (Marlin 2).
        e_by_m83: The controller's rule: E is relative exactly when M83 holds (RepRapFirmware).
        saved: States saved by name (SAVE_GCODE_STATE): G91, M83, the position, E's position, and
            whether a Jinja condition held the save.
    """

    __slots__ = ("pos", "relative", "m83", "m83_ended", "extrusion", "e_pos", "motion", "plane",
                 "unknown_since", "unknown_why", "homed", "homed_by", "at_home", "fresh", "g91_moves_e",
                 "distance_sets_e", "e_by_m83", "saved")

    def __init__(self, start, g91_moves_e: bool = False, distance_sets_e: bool = False,
                 e_by_m83: bool = False) -> None:
        self.pos: tuple = (None, None, None) if start is None else tuple(float(v) for v in start)
        self.relative = False
        self.m83 = False
        self.m83_ended = False
        self.extrusion = Extrusion.ABSOLUTE
        self.e_pos: float | None = None
        self.motion: Motion | None = None
        self.plane = Plane.XY
        self.unknown_since = 0
        self.unknown_why = ""
        self.homed = 0
        self.homed_by = "the homing"
        self.at_home = False
        self.fresh = True
        self.g91_moves_e = g91_moves_e
        self.distance_sets_e = distance_sets_e
        self.e_by_m83 = e_by_m83
        self.saved: dict[str, tuple] = {}

    def set_extruder(self, relative: bool) -> None:
        """M83 (``relative``) or M82: the extruder's mode, on a line of its own."""
        self.m83, self.m83_ended = relative, False
        self._update_extrusion()

    def set_distance(self, relative: bool) -> None:
        """G91 (``relative``) or G90: the distance mode (G90 after M83 makes E ambiguous)."""
        self.relative = relative
        if self.distance_sets_e:  # Marlin 2: E follows G90/G91 until the next M82/M83
            self.m83, self.m83_ended = relative, False
        elif not relative:
            self.m83_ended = self.m83
        self._update_extrusion()

    def _update_extrusion(self) -> None:
        """:attr:`extrusion` from the distance and extruder modes."""
        if self.distance_sets_e or self.e_by_m83:
            self.extrusion = Extrusion.RELATIVE if self.m83 else Extrusion.ABSOLUTE
        elif self.g91_moves_e:
            self.extrusion = Extrusion.RELATIVE if self.relative or self.m83 else Extrusion.ABSOLUTE
        elif self.relative:
            self.extrusion = Extrusion.RELATIVE if self.m83 else Extrusion.AMBIGUOUS
        elif self.m83:
            self.extrusion = Extrusion.AMBIGUOUS if self.m83_ended else Extrusion.RELATIVE
        else:
            self.extrusion = Extrusion.ABSOLUTE

    def extrude(self, value: float, mode: Extrusion) -> None:
        """The extruder position after an E word of ``value`` [mm] read in ``mode``."""
        if mode is Extrusion.ABSOLUTE:
            self.e_pos = value
        elif mode is Extrusion.RELATIVE:
            self.e_pos = None if self.e_pos is None else self.e_pos + value
        else:
            self.e_pos = None
