"""What keeps a path from being read as an input file: absent, or not a regular file.

A folder, a FIFO (named pipe: reading it waits for a writer) or a device (``/dev/zero`` never ends)
given where a file is read is refused before it is opened, whether the command line names it or a
file names it (Klipper's ``[include ...]``, RepRapFirmware's ``M98 P"..."``).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

#: :func:`input_problem`'s answer for a path that does not exist (or a link to nothing).
NOT_FOUND = "file not found"


def input_problem(path: str | Path) -> str | None:
    """Why ``path`` cannot be read as an input file (:data:`NOT_FOUND`, ``"not a file (a FIFO ...)"``)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return NOT_FOUND
    except OSError as exc:
        return exc.strerror or str(exc)
    if stat.S_ISREG(info.st_mode):
        return None
    kind = ("a folder" if stat.S_ISDIR(info.st_mode)
            else "a FIFO (named pipe)" if stat.S_ISFIFO(info.st_mode)
            else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
            else "a socket" if stat.S_ISSOCK(info.st_mode) else "not a regular file")
    return f"not a file ({kind})"
