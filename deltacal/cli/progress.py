"""A progress line on the terminal for long work; nothing when stderr is not a terminal."""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: Work shorter than this [s] shows no progress line.
DELAY = 2.0

#: The progress line on the terminal now, if any: a warning clears it first (see :func:`clear`).
_shown: list[Progress] = []


def clear() -> None:
    """Clear the progress line, if one is shown, so that a message starts on a clean line.

    The next update draws it again, below the message.
    """
    for progress in _shown:
        progress.stream.write("\r\x1b[K")
        progress.stream.flush()
        progress.shown = False
    _shown.clear()


class Progress:
    """``label: 42%`` rewritten in place on stderr, from :data:`DELAY` seconds on, TTY only.

    Use as a context manager: the line is cleared at the end, whatever happens.
    """

    def __init__(self, label: str, stream: TextIO | None = None, delay: float = DELAY) -> None:
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.delay = delay
        self.shown = False
        self._start = time.monotonic()
        self._on = bool(getattr(self.stream, "isatty", lambda: False)())

    def __enter__(self) -> Progress:
        return self

    def update(self, fraction: float, detail: str = "") -> None:
        """Show the fraction done (0..1), once the work has lasted :data:`DELAY` seconds."""
        if not self._on or time.monotonic() - self._start < self.delay:
            return
        text = f"\r{self.label}: {100.0 * min(max(fraction, 0.0), 1.0):3.0f}%{' ' + detail if detail else ''}"
        self.stream.write(text + "\x1b[K")
        self.stream.flush()
        self.shown = True
        if self not in _shown:
            _shown.append(self)

    def __exit__(self, *exc: object) -> None:
        if self.shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
        if self in _shown:
            _shown.remove(self)
