"""What the reader says of a program without refusing it: warnings gathered by kind, said at its end.

Some lines are right to keep but worth a word: a line the controller does not run (an unknown
command, kept as it is, the position not moved), a command that turns on a correction of the
controller's own on top of deltacal's (a bed mesh). Each kind is said once, as a
:class:`~deltacal.exceptions.InputWarning` naming the program, its first line and its text, and how
many lines of that kind there are in all, so that a program of a million such lines gives one line
on stderr, not a million.
"""

from __future__ import annotations

import warnings

from ..exceptions import InputWarning

__all__ = ["Notes"]

#: Lines named in a warning at most (the rest are counted).
NAMED_LINES = 5


class Notes:
    """Warnings on a program's lines, by kind (see the module's documentation).

    Attributes:
        source: The program's name, for the messages.
    """

    def __init__(self, source: str) -> None:
        self.source = source
        self._kinds: dict[str, tuple[str, list[int]]] = {}
        self._counts: dict[str, int] = {}

    def add(self, kind: str, number: int, text: str) -> None:
        """Line ``number`` is of ``kind``; ``text``, the first one's, says what it is and does."""
        entry = self._kinds.get(kind)
        if entry is None:
            self._kinds[kind] = (text, [number])
        elif len(entry[1]) < NAMED_LINES:
            entry[1].append(number)
        self._counts[kind] = self._counts.get(kind, 0) + 1

    def say(self) -> None:
        """Each kind's warning, in the order of their first lines."""
        for kind, (text, lines) in sorted(self._kinds.items(), key=lambda item: item[1][1][0]):
            count = self._counts[kind]
            more = ""
            if count > 1:
                others = ", ".join(str(n) for n in lines[1:]) + (", ..." if count > len(lines) else "")
                more = f" (also line{'s' if count > 2 else ''} {others}: {count:,} lines in all)"
            warnings.warn(f"{self.source}: line {lines[0]}: {text}{more}", InputWarning, stacklevel=3)
