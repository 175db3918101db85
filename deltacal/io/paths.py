"""A job's input and output paths, checked before any work is done (usage errors: status 2).

A job (:mod:`deltacal.wings`) checks its files first, so that a missing input or a bad output costs
nothing: an input must be an existing regular file (not a folder, a FIFO or a device); an output must be
one deltacal may write (:func:`~deltacal.io.atomic.output_problem`) and none of the inputs; a folder of
outputs is checked as each of its files, or as a new output in its parent when the job makes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..exceptions import UsageError
from .atomic import check_output_path, output_problem
from .inputs import input_problem


def check_input(path: str | Path) -> None:
    """A usage error (exit 2) unless ``path`` is a regular file (:func:`~.inputs.input_problem`)."""
    problem = input_problem(path)
    if problem is not None:
        raise UsageError(f"{path}: {problem}")


def check_inputs(paths: Sequence[str | Path | None]) -> None:
    """:func:`check_input` of each path given (None: an option not given)."""
    for path in paths:
        if path is not None:
            check_input(path)


def check_output(path: str | Path, inputs: Sequence[str | Path | None] = ()) -> None:
    """A usage error (exit 2) if ``path`` cannot be an output file, or is one of the inputs.

    Called before any work is done, so that a bad ``-o`` costs nothing (see
    :func:`deltacal.io.atomic.output_problem` for what is refused).
    """
    check_output_path(path)
    out = Path(path)
    for source in inputs:
        if source is not None and Path(source).exists() and out.resolve() == Path(source).resolve():
            raise UsageError(f"{path}: the output would overwrite an input file")


def check_output_folder(folder: str | Path, names: Sequence[str], inputs: Sequence[str | Path | None],
                        what: str) -> list[Path]:
    """The output files ``names`` in ``folder``, checked as :func:`check_output` checks one (status 2).

    A folder that does not exist yet is made by the job, once its work is done: it is checked as
    a new output in its parent (which must exist and be writable), as every other output is.

    Args:
        folder: The ``-o`` folder.
        names: The files written there.
        inputs: The job's inputs (none may be overwritten).
        what: What writes there, for the message (``"plan --object"``).

    Raises:
        UsageError: naming the folder (or a file in it) and what is wrong.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{folder}: {what} writes {len(names)} files in a folder; this is a file")
    outputs = [folder / name for name in names]
    if folder.exists():
        for path in outputs:
            check_output(path, inputs)
        return outputs
    problem = output_problem(folder)
    parent = folder.parent if str(folder.parent) else Path(".")
    if problem is not None and not parent.exists():
        problem = (f"the folder {str(parent)!r} does not exist ({what} makes its output folder, not the "
                   "folders above it)")
    if problem is not None:
        raise UsageError(f"{folder}: {problem}")
    return outputs
