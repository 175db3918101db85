"""A G-code program's text as read: its file name, its lines with their endings, its first line.

The lines are read with their endings (LF, CR LF, CR) and every byte kept (``surrogateescape``),
so that what the rewriter does not change is written back byte for byte. A UTF-8 byte-order mark
before the first line is kept in the output, and the line after it is read without it, as a sender
(OctoPrint, Pronterface ...) sends it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from itertools import chain
from pathlib import Path

from ..exceptions import InputError

#: File name endings read as G-code (in any case).
SUFFIXES = (".gcode", ".gco", ".g", ".nc")
#: A UTF-8 byte-order mark, as read (kept in the output, the line after it read as senders do).
_BOM = "\ufeff"


def line_ending(line: str) -> str:
    """A line's ending: LF, CR LF, CR or ""."""
    return "\r\n" if line.endswith("\r\n") else "\n" if line.endswith("\n") else \
        "\r" if line.endswith("\r") else ""


def is_gcode_path(path: str | Path) -> bool:
    """Whether a targets file is read as G-code: its name ends in one of :data:`SUFFIXES`."""
    return Path(path).suffix.lower() in SUFFIXES


def read_lines(path: str | Path, opened: list | None = None) -> Iterator[str]:
    """The file's lines, one at a time, each with its line ending; bytes kept (surrogateescape).

    Args:
        path: The G-code file.
        opened: If given, the open file is appended to it (to ask how far the reading is).

    Raises:
        InputError: the file cannot be read.
    """
    try:
        f = open(path, encoding="utf-8", errors="surrogateescape", newline="")
    except FileNotFoundError:
        raise InputError("file not found", str(path)) from None
    except IsADirectoryError:
        raise InputError("is a folder, not a file", str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read file ({exc.strerror})", str(path)) from None
    with f:
        if opened is not None:
            opened.append(f)
        yield from f


def opened_lines(lines: Iterator[str], marker: str | None, items: list,
                 after_mark: Callable[[str], None] | None = None) -> Iterator[str]:
    """The program's lines, the first without its UTF-8 byte-order mark.

    The mark and the marker line go to ``items``, the output's start. The mark is kept byte for
    byte; the line after it is read as a sender (OctoPrint, Pronterface ...) sends it: without it,
    and handed to ``after_mark`` (which may refuse it: a firmware reading its own card does not).
    """
    first = next(lines, None)
    opening = ""
    if first is not None and first.startswith(_BOM):
        opening, first = _BOM, first[1:]
        if after_mark is not None:
            after_mark(first)
    if marker is not None:
        ending = "" if first is None else line_ending(first)
        opening += marker + (ending or "\n")
    if opening:
        items.append(opening)
    return lines if first is None else chain((first,), lines)  # in C: no cost per line
