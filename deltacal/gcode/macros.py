"""A controller's macro, called by a program's line, applied to the program's modal state.

The controller runs the macro's moves as they are written (uncorrected), so after a macro that
moves, the controller stands at a point of its own, as after a homing: the position is that point
(the program's next absolute move starts there) and a relative move right after it is refused. A
macro that leaves the position unknown (:attr:`~deltacal.gcode.dialect.MacroEffect.unknown`)
makes it unknown, named in the message of the first move that needs it; before any move of the
program, ``--start`` gives where such a macro leaves the nozzle. A controller's own command that
moves the nozzle where only the printer knows (a probing, a bed mesh) is read the same way. A
macro that only heats, waits or sets fans changes nothing. Units: mm.
"""

from __future__ import annotations

from .dialect import MacroEffect, MacroStep
from .state import ModalState

__all__ = ["apply_macro"]

#: The steps that move the nozzle (and RESTORE_GCODE_STATE with MOVE=1).
_MOVES = frozenset((MacroStep.HOME, MacroStep.MOVE))


def apply_macro(state: ModalState, effect: MacroEffect, number: int, home, start) -> str | None:
    """The state after the macro ``effect`` called on line ``number``; why the line is refused, or None.

    ``SAVE_GCODE_STATE`` and ``RESTORE_GCODE_STATE`` follow Klipper's ``gcode_move.py``: a state
    holds G90/G91, M82/M83, the position and the extruder's (G-code) position; restoring it sets
    the two modes and the extruder's position back (``base_position[3]`` moved by the extrusion
    since), and the position only with ``MOVE=1`` (the controller moves back to the point it
    saved). Refused: restoring a state not saved before in the program (Klipper stops the print:
    "Unknown g-code state"), one saved under a Jinja condition, or a restore under a condition that
    would change the modes or E.

    Args:
        state: The program's modal state, changed in place.
        effect: The macro, as read from the controller's configuration.
        number: The line that calls it.
        home: Where a homing leaves the TCP [mm], or None (unknown after it).
        start: The program's start position (``--start``) [mm], or None.
    """
    by = effect.name if effect.builtin else f"the macro {effect.name}"
    if effect.refused:
        return effect.refused if effect.builtin else f"{by}: {effect.refused}"
    if not effect.moves:
        return None
    moved = False
    for step, values, name in effect.steps:
        if step is MacroStep.SAVE or step is MacroStep.RESTORE:
            why = _state(state, step, values, name)
            if why:
                return why if effect.builtin else f"{by}: {why}"
        else:
            _step(state, step, values, home)
        moved = moved or step in _MOVES or (step is MacroStep.RESTORE and bool(values.get("MOVE")))
    if effect.unknown:
        state.at_home = False
        if state.fresh and start is not None:  # --start: where the program's moves start
            state.pos = tuple(start)
        else:
            state.pos = (None, None, None)
            state.unknown_since, state.unknown_why = number, f"{by} ({effect.unknown})"
            state.homed = 0
            return None
    if effect.unknown or moved:
        if None in state.pos:
            state.unknown_since = number
            state.unknown_why = f"{by} (its moves start from an unknown position)"
            state.homed = 0
        else:  # the controller stands at a point of its own (its home, or the macro's literal move)
            state.homed, state.homed_by = number, by
    return None


def _state(state: ModalState, step: MacroStep, values, name: str) -> str:
    """SAVE_GCODE_STATE or RESTORE_GCODE_STATE (see :func:`apply_macro`); why it is refused, or ""."""
    if step is MacroStep.SAVE:
        conditional = bool(values.get("CONDITIONAL"))
        state.saved[name] = (state.relative, state.m83, state.pos, state.e_pos, conditional)
        return ""
    if name not in state.saved:
        return (f"RESTORE_GCODE_STATE NAME={name}: no state {name!r} saved before it in the program (Klipper "
                "stops the print with 'Unknown g-code state' unless one was saved before the program ran): "
                "its modes cannot be known")
    relative, m83, pos, e_pos, conditional = state.saved[name]
    if conditional:
        return (f"RESTORE_GCODE_STATE NAME={name}: the state was saved under a Jinja condition: the modes "
                "and E it brings back cannot be known")
    if values.get("CONDITIONAL") and (relative, m83, e_pos) != (state.relative, state.m83, state.e_pos):
        return (f"RESTORE_GCODE_STATE NAME={name} under a Jinja condition: G90/G91, M82/M83 or E after "
                "it depend on the condition")
    state.set_distance(relative)
    state.set_extruder(m83)
    state.e_pos = e_pos  # Klipper moves base_position[3] by the extrusion since the save
    if values.get("MOVE"):
        state.pos = pos
        state.at_home = False
    return ""


def _step(state: ModalState, step: MacroStep, values, home) -> None:
    """One step of a macro."""
    if step is MacroStep.HOME:
        state.pos = (None, None, None) if home is None else tuple(home)
        state.at_home = home is not None
    elif step is MacroStep.ABSOLUTE or step is MacroStep.RELATIVE:
        state.set_distance(step is MacroStep.RELATIVE)
    elif step is MacroStep.E_ABSOLUTE or step is MacroStep.E_RELATIVE:
        state.set_extruder(step is MacroStep.E_RELATIVE)
    elif step is MacroStep.MOVE:
        if state.relative:
            state.pos = tuple(None if p is None else p + values.get(a, 0.0)
                              for p, a in zip(state.pos, "XYZ", strict=True))
        else:
            state.pos = tuple(values.get(a, p) for p, a in zip(state.pos, "XYZ", strict=True))
        if "E" in values:
            state.extrude(values["E"], state.extrusion)
        state.at_home = False
    elif step is MacroStep.SET_E:
        state.e_pos = values["E"]
    elif step is MacroStep.E_UNKNOWN:
        state.e_pos = None
