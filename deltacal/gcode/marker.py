"""The first line of a corrected program, which says it is one, so that it is not corrected twice.

A program corrected for a controller holds targets for that controller's model, not the intended
points: corrected again, every point would be moved by the correction twice. The command line
writes :func:`marker_line` as the corrected program's first line (after a UTF-8 byte-order mark,
if the program had one), a comment every firmware skips; the reader refuses a program with a line
that starts with :data:`MARKER`.
"""

from __future__ import annotations

from .._version import __version__

#: How a corrected program's marker line starts.
MARKER = "; corrected by deltacal "


def marker_line(controller: str, calibration: str) -> str:
    """The marker comment (without its line ending) of a program corrected for ``controller``.

    Args:
        controller: The controller's file, as given.
        calibration: The calibration's file, as given.

    Returns:
        ``; corrected by deltacal <version> for <controller> with <calibration>``, with any
        character that is not printable (a line break in a file name) written ``?``, so the
        marker stays one comment line.
    """
    text = f"{MARKER}{__version__} for {controller} with {calibration}"
    return "".join(c if c.isprintable() else "?" for c in text)


def is_marker(line: str) -> bool:
    """Whether a line (leading blanks stripped) is a corrected program's marker."""
    return line.startswith(MARKER)
