"""A firmware's values fitted to a rotary Delta printer's calibration, as the file to write (``export``).

What :meth:`~deltacal.printer.firmware.base.Firmware.rotary_export` returns: the firmware's keys with
what the values leave as comments, and those lines to print.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ...io.atomic import atomic_write_text


@dataclass(frozen=True)
class RotaryValues:
    """A firmware's values fitted to a rotary Delta printer's calibration.

    Attributes:
        text: The file to write: the firmware's keys, what the values leave as comments.
        lines: What the values leave, line by line (printed).
    """

    text: str
    lines: tuple[str, ...]

    def save(self, path: str | Path) -> None:
        """Write :attr:`text` to ``path`` (whole or not at all)."""
        atomic_write_text(path, self.text)
