"""Atomic outputs: the one place where deltacal writes a file (a temporary beside it, then a rename)."""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

from ..exceptions import UsageError

#: Prefix and suffix of the temporary file written beside an output: short and fixed, so that any
#: output name the file system accepts (up to its NAME_MAX, 255 bytes) still leaves room for it.
TEMPORARY_PREFIX = ".deltacal-"
TEMPORARY_SUFFIX = ".tmp"


def output_problem(path: str | Path) -> str | None:
    """Why ``path`` cannot be an output file of deltacal, or None if it can.

    Only a regular file, or a new name in an existing folder deltacal may write in,
    is an output: ``-``, a path ending in ``/``, a folder, a FIFO, a device or a
    socket, a read-only file, a name longer than the file system accepts, and a
    folder that does not exist or is not writable are refused before any work is
    done (see docs/errors.md, "Outputs").
    """
    text = str(path)
    if text == "-":
        return "'-' (standard output) is not an output file here: give a file name"
    if text.endswith(("/", os.sep)):
        return "ends with '/': give the output file's name, not a folder"
    p = Path(text)
    folder = p.parent if str(p.parent) else Path(".")
    try:
        info = os.stat(p)
    except FileNotFoundError:
        info = None
    except NotADirectoryError:
        return "a part of the path is a file, not a folder"
    except OSError as exc:
        if exc.errno != errno.ENAMETOOLONG:  # a name too long is said below, with the limit
            return exc.strerror or str(exc)
        info = None
    if info is not None:
        if stat.S_ISDIR(info.st_mode):
            return "is a folder; give the output file's name"
        if not stat.S_ISREG(info.st_mode):
            kind = ("a FIFO (named pipe)" if stat.S_ISFIFO(info.st_mode)
                    else "a device" if stat.S_ISCHR(info.st_mode) or stat.S_ISBLK(info.st_mode)
                    else "a socket" if stat.S_ISSOCK(info.st_mode) else "not a regular file")
            return f"is {kind}: deltacal writes regular files only"
        if not info.st_mode & 0o222:
            return (f"the output file is read-only (mode {stat.S_IMODE(info.st_mode):04o}): "
                    "make it writable to replace it, or choose another name")
    if not folder.is_dir():
        return "the output folder does not exist"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"the output folder {str(folder)!r} is not writable"
    try:
        name_max = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    if len(p.name.encode("utf-8", "surrogateescape")) > name_max:
        return f"the file name is {len(p.name.encode('utf-8', 'surrogateescape'))} bytes, " \
               f"longer than the {name_max} the file system accepts"
    return None


def check_output_path(path: str | Path) -> None:
    """Raise :class:`~deltacal.exceptions.UsageError` naming ``path`` if it cannot be an output."""
    problem = output_problem(path)
    if problem is not None:
        raise UsageError(f"{path}: {problem}")


# --------------------------------------------------------------------------- writing
@contextlib.contextmanager
def atomic_output(path: str | Path, suffix: str = TEMPORARY_SUFFIX) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; it replaces ``path`` when the block succeeds.

    The one place where deltacal writes an output file; ``path`` is checked first
    (:func:`check_output_path`). If anything fails, an
    existing file at ``path`` is left exactly as it was and the temporary file is
    removed. The new file gets the permissions of the file it replaces, or the
    usual ones (``0o666`` less the umask) for a new file.
    """
    check_output_path(path)
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, name = tempfile.mkstemp(prefix=TEMPORARY_PREFIX, suffix=suffix, dir=folder)
    except OSError as exc:  # name the user's path, not the random temporary one
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        # mkstemp creates the file 0o600: give the output the mode a plain open() would
        try:
            mode = path.stat().st_mode & 0o7777
        except OSError:
            mode = 0o666 & ~_umask()
        os.chmod(tmp, mode)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.filename is not None and Path(exc.filename) == tmp:  # name the user's path
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write bytes to ``path`` atomically (see :func:`atomic_output`); returns the path."""
    with atomic_output(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write UTF-8 text to ``path`` atomically (see :func:`atomic_output`); returns the path."""
    with atomic_output(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    return Path(path)


def _umask() -> int:
    """The process's file creation mask (read without leaving it changed)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
