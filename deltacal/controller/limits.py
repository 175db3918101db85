"""A controller's limits on the commands it takes, and the commands of a file they refuse.

A controller that checks its commands (a printer's firmware: Klipper refuses a move out of its
range) gives its :class:`CommandLimits`; what writes commands for it (``compensate``'s corrected
targets, the G-code filter) checks every command as written and gathers those refused over the
whole file in a :class:`RefusedCommands`, so that one refusal names the first line and the value
that admits them all. A program may switch the limits itself (Marlin's ``M211 S0`` turns its soft
endstops off): :meth:`RefusedCommands.switch` records it, and the commands of the lines after a
switch off are not checked, as the controller does not. Units: mm.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..exceptions import InputError

#: Refused commands kept for the refusal's value at most (the rest are counted).
KEPT_COMMANDS = 100_000


class CommandLimits(Protocol):
    """The limits a controller puts on the commands it takes."""

    def outside(self, commands: np.ndarray) -> np.ndarray:
        """Which limit each command breaks, (N, 3) [mm] -> (N,) integers (0: none)."""

    def refusal(self, commands: np.ndarray) -> str:
        """One line on refused commands (the first named): the limit, the key and value that admit them."""


class RefusedCommands:
    """The commands of a file that a controller's limits refuse, gathered as the file is written.

    Attributes:
        limits: The controller's limits.
        count: Commands refused so far.
        lines: Their lines in the input file, in order (the first :data:`KEPT_COMMANDS`).
        first: Where the first refused command is (``"line 412"``), or "".
    """

    def __init__(self, limits: CommandLimits) -> None:
        self.limits = limits
        self.count = 0
        self.lines: list[int] = []
        self.first = ""
        self._kept: list[np.ndarray] = []
        self._switched_at: list[int] = []  # the lines of the program's switches, in order
        self._switched_on: list[bool] = [True]  # the limits before the first switch, and after each

    def switch(self, line: int, enabled: bool) -> None:
        """The program switches the limits on or off at ``line`` (read in order): later lines follow it."""
        self._switched_at.append(int(line))
        self._switched_on.append(bool(enabled))

    def enabled(self, lines: np.ndarray) -> np.ndarray:
        """Whether the limits hold at each line, as the program's switches before it leave them, (N,)."""
        if not self._switched_at:
            return np.ones(np.shape(lines), dtype=bool)
        state = np.asarray(self._switched_on)
        return state[np.searchsorted(np.asarray(self._switched_at), np.asarray(lines), side="left")]

    def check(self, commands: np.ndarray, lines: np.ndarray, where=None) -> bool:
        """Check commands as written; keep those refused. Returns whether all pass.

        Args:
            commands: The commands as the file holds them [mm], (N, 3).
            lines: Each command's line in the input file, (N,) (0: not written, not checked).
            where: ``where(k)``: how a message names command k (default ``"line N"``).
        """
        lines = np.asarray(lines)
        bad = (self.limits.outside(commands) != 0) & (lines != 0)
        if self._switched_at and np.any(bad):
            bad &= self.enabled(lines)
        if not np.any(bad):
            return True
        index = np.flatnonzero(bad)
        if not self.first:
            k = int(index[0])
            self.first = where(k) if where is not None else f"line {int(lines[k])}"
        room = KEPT_COMMANDS - len(self.lines)
        self._kept.append(np.asarray(commands, dtype=float)[index[:room]])
        self.lines.extend(int(v) for v in lines[index[:room]])
        self.count += index.size
        return False

    def error(self, source: str, unit: str = "line") -> InputError | None:
        """The one-line refusal naming the first command's place, or None if none was refused.

        Args:
            source: The input file, for the message.
            unit: What a place is called (``"line"``).
        """
        if not self.count:
            return None
        detail = self.limits.refusal(np.concatenate(self._kept))
        if self.count > 1:
            lines = sorted(set(self.lines))
            shown = ", ".join(str(n) for n in lines[:10]) + (", ..." if len(lines) > 10 else "")
            kept = f" (the value from the first {len(self.lines):,})" if self.count > len(self.lines) else ""
            units = unit + ("s" if len(lines) > 1 else "")
            detail += f"; {self.count:,} commands refused in all{kept}, on {units} {shown}"
        return InputError(detail, source, self.first)
