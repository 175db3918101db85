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
        limits: The controller's limits (those in force now, see :meth:`switch`).
        count: Commands refused so far.
        lines: Their lines in the input file, in order (the first :data:`KEPT_COMMANDS`).
        first: Where the first refused command is (``"line 412"``), or "".
        by: What set the limits the first refused commands broke (``"line 3 (M211 S1)"``), or "":
            the controller's own.
    """

    def __init__(self, limits: CommandLimits) -> None:
        self.limits = limits
        self.count = 0
        self.lines: list[int] = []
        self.first = ""
        self.by = ""
        self._kept: list[np.ndarray] = []
        self._judged = limits  # the limits the kept commands broke: the refusal's value is theirs

    def switch(self, limits: CommandLimits, by: str) -> None:
        """Check the commands from here on against ``limits``, which ``by`` set (a program's line).

        Commands already refused keep the refusal's value; later ones are counted and named.
        """
        if not self.count:
            self._judged, self.by = limits, by
        self.limits = limits

    def check(self, commands: np.ndarray, lines: np.ndarray, where=None) -> bool:
        """Check commands as written; keep those refused. Returns whether all pass.

        Args:
            commands: The commands as the file holds them [mm], (N, 3).
            lines: Each command's line in the input file, (N,) (0: not written, not checked).
            where: ``where(k)``: how a message names command k (default ``"line N"``).
        """
        lines = np.asarray(lines)
        bad = (self.limits.outside(commands) != 0) & (lines != 0)
        if not np.any(bad):
            return True
        index = np.flatnonzero(bad)
        if not self.first:
            k = int(index[0])
            self.first = where(k) if where is not None else f"line {int(lines[k])}"
        room = KEPT_COMMANDS - len(self.lines)
        if self.limits is self._judged:
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
        detail = self._judged.refusal(np.concatenate(self._kept))
        if self.by:
            detail += f" (the limits {self.by} set)"
        if self.count > 1:
            lines = sorted(set(self.lines))
            shown = ", ".join(str(n) for n in lines[:10]) + (", ..." if len(lines) > 10 else "")
            kept = f" (the value from the first {len(self.lines):,})" if self.count > len(self.lines) else ""
            units = unit + ("s" if len(lines) > 1 else "")
            detail += f"; {self.count:,} commands refused in all{kept}, on {units} {shown}"
        return InputError(detail, source, self.first)
