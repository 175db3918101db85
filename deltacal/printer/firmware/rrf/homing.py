"""Where RepRapFirmware's ``G28`` leaves the nozzle: ``homedelta.g`` read for its literal moves.

On a delta ``G28`` runs ``homedelta.g`` (in ``sys/``, beside ``config.g``). Its ``G1 H1`` moves
stop each carriage at its endstop (``OnHomingSwitchTriggered``); what follows the last of them
moves the nozzle on from there, typically ``G1 Z-5 F...`` under ``G91``, then ``G90`` and ``G1 X0
Y0``. RRF 2.x and earlier took ``S`` for ``H`` (``G1 S1 X750 Y750 Z750``, then ``G1 S2 X-5 Y-5 Z-5``:
``GCodes::DoStraightMove`` of 2.05 reads the move type from ``H`` or ``S``), and so does deltacal on a
move without ``H``.

:func:`homed_position` starts at every carriage on its endstop and applies the moves after the
last ``H1`` line: ``G90``/``G91`` (absolute to start with, RRF's default), ``G0``/``G1`` with
literal X, Y, Z (its modal position), and ``G1 H2`` moves of single motors under ``G91``, each
carriage moved up by its X, Y, Z (RRF moves the motors by that many mm, the nozzle goes where its
model puts the carriages; RRF refuses them to absolute positions on a delta, so does deltacal). A
move whose end cannot be known without running the file is refused naming its line: a probing or
homing command (``G28``, ``G29``, ``G30``, ``G32``), a macro call (``M98``), a condition or a loop
(``if``, ``while``), an expression. Without ``homedelta.g`` beside the configuration (a
configuration copied alone), ``G28`` leaves every carriage at its endstop. Units: mm.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ....exceptions import InputError
from .config import RRFLine, parse_line, strip_comment
from .model import RRFDelta

#: The file RRF runs for ``G28`` on a delta.
HOME_FILE = "homedelta.g"
#: Commands after the last ``H1`` move whose end position is not known without running them.
_UNKNOWN = ("G28", "G29", "G30", "G32", "M98")
#: Meta commands that make what follows conditional.
_CONDITION = re.compile(r"^\s*(?:if|elif|else|while)\b", re.IGNORECASE)


def homed_position(config: str | Path, rrf: RRFDelta) -> tuple[np.ndarray, str]:
    """Where ``G28`` leaves the nozzle with ``config``'s values, and what says so (module documentation).

    Args:
        config: ``config.g``; ``homedelta.g`` is looked for beside it.
        rrf: RRF's model of ``config``.

    Returns:
        The nozzle's position [mm], (3,), and ``"homedelta.g"`` or ``"the endstops"``.

    Raises:
        InputError: a move after the last ``G1 H1`` whose end cannot be known, naming its line.
    """
    path = Path(config).with_name(HOME_FILE)
    home = np.array(rrf.home_position, dtype=float)
    if not path.is_file():
        return home, "the endstops"
    try:
        text = path.read_text(encoding="utf-8", errors="replace").replace("\r\n", "\n").split("\n")
    except OSError as exc:
        raise InputError(f"cannot read the homing file ({exc.strerror})", str(path)) from None
    parsed = [parse_line(raw, str(path), number) for number, raw in enumerate(text, start=1)]
    homing = [k for k, line in enumerate(parsed) if _is_move(line) and _move_type(line) in (1.0, 3.0)]
    if not homing:
        return home, "the endstops"
    relative = False
    for line in parsed[: homing[-1]]:
        relative = _mode(line, relative)
    for number, raw in enumerate(text[homing[-1] + 1 :], start=homing[-1] + 2):
        line = parsed[number - 1]
        if _CONDITION.match(strip_comment(raw)):
            raise _unknown(path, number, "a condition or a loop")
        if line is None:
            continue
        if line.code in _UNKNOWN:
            raise _unknown(path, number, line.code)
        relative = _mode(line, relative)
        if _is_move(line) and _move_type(line) == 2.0:
            home = _motor_move(line, rrf, home, relative, path)
        elif _is_move(line):
            if _move_type(line) != 0.0:
                raise _unknown(path, number, f"{line.code} H{_move_type(line):g}")
            for axis, key in enumerate("XYZ"):
                if key in line.params:
                    home[axis] = line.number(key) + (home[axis] if relative else 0.0)
    return home, HOME_FILE


def _is_move(line: RRFLine | None) -> bool:
    return line is not None and line.code in ("G0", "G1")


def _move_type(line: RRFLine | None) -> float:
    """A move's type: its ``H``, else its ``S`` (RRF 2.x and earlier), else 0 (an ordinary move)."""
    if line is None:
        return 0.0
    key = "H" if "H" in line.params else "S" if "S" in line.params else ""
    return line.number(key) if key else 0.0


def _motor_move(line: RRFLine, rrf: RRFDelta, nozzle: np.ndarray, relative: bool, path: Path) -> np.ndarray:
    """Where ``G1 H2`` (single motors) leaves the nozzle: each carriage moved up by its X, Y, Z [mm]."""
    if not relative:
        raise InputError(f"{line.code} {'H' if 'H' in line.params else 'S'}2 moves single motors to absolute "
                         "positions, which RRF refuses on a delta: move them under G91", str(path),
                         f"line {line.line}")
    steps = rrf.steps(nozzle[None])[0]
    for axis, key in enumerate("XYZ"):
        if key in line.params:
            steps[axis] -= line.number(key) / rrf.step_distance[axis]
    return rrf.positions(steps[None])[0]


def _mode(line: RRFLine | None, relative: bool) -> bool:
    """Relative after a ``G91``, absolute after a ``G90``, else as it was."""
    if line is not None and line.code in ("G90", "G91"):
        return line.code == "G91"
    return relative


def _unknown(path: Path, number: int, what: str) -> InputError:
    return InputError(f"{what} after the last G1 H1: where G28 leaves the nozzle is not known without "
                      "running it (end the file with literal moves: G90, then G1 X Y Z)", str(path),
                      f"line {number}")
