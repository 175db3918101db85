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

#: The steps that move the nozzle.
_MOVES = frozenset((MacroStep.HOME, MacroStep.MOVE, MacroStep.RESTORE))


def apply_macro(state: ModalState, effect: MacroEffect, number: int, home, start) -> None:
    """The state after the macro ``effect`` called on line ``number``.

    Args:
        state: The program's modal state, changed in place.
        effect: The macro, as read from the controller's configuration.
        number: The line that calls it.
        home: Where a homing leaves the TCP [mm], or None (unknown after it).
        start: The program's start position (``--start``) [mm], or None.
    """
    if not effect.moves:
        return
    by = effect.name if effect.builtin else f"the macro {effect.name}"
    for step, values, name in effect.steps:
        _step(state, step, values, name, home)
    if effect.unknown:
        state.at_home = False
        if state.fresh and start is not None:  # --start: where the program's moves start
            state.pos = tuple(start)
        else:
            state.pos = (None, None, None)
            state.unknown_since, state.unknown_why = number, f"{by} ({effect.unknown})"
            state.homed = 0
            return
    if effect.unknown or any(step in _MOVES for step, _, _ in effect.steps):
        if None in state.pos:
            state.unknown_since = number
            state.unknown_why = f"{by} (its moves start from an unknown position)"
            state.homed = 0
        else:  # the controller stands at a point of its own (its home, or the macro's literal move)
            state.homed, state.homed_by = number, by


def _step(state: ModalState, step: MacroStep, values, name: str, home) -> None:
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
    elif step is MacroStep.SAVE:
        state.saved[name] = (state.relative, state.m83, state.pos)
    elif step is MacroStep.RESTORE:
        relative, m83, pos = state.saved.get(name, (state.relative, state.m83, state.pos))
        state.set_distance(relative)
        state.set_extruder(m83)
        if values.get("MOVE"):
            state.pos = pos
            state.at_home = False
