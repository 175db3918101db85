"""Where a RepRapFirmware configuration keeps the values deltacal writes, and how to put them there.

:func:`rrf_config_files` lists the files the configuration runs (none may be overwritten by an
output); :func:`rrf_apply_note` says where the values go.

RRF runs ``config.g`` at start-up; its ``M501`` runs ``config-override.g``, the file ``M500``
rewrites with the values of ``M665`` and ``M666`` (among others, never ``M92``). Values sent to
the printer last until the next start-up only: they live where the configuration sets them last.
A ``config.g`` that sets ``M665``/``M666`` itself and runs no ``M501`` after them must have those
lines replaced (``M500`` would write a file never read); one whose ``M501`` runs after them (or whose
``config-override.g`` sets them) takes them by ``M500`` too. ``M92`` is always replaced where it
stands. :func:`rrf_apply_note` says it in one line, naming each file and line.
"""

from __future__ import annotations

import re
from pathlib import Path

from .config import APPLY_NOTE, OVERRIDE, RRFLine, RRFSettings, parse_line, read_rrf_settings
from .homing import HOME_FILE

#: A drive prefix of an RRF path (``0:/sys/delta.g``).
_DRIVE = re.compile(r"^\d+:")

#: The keys of each command deltacal writes (:func:`~.config.rrf_config_text`).
WRITTEN = {"M665": "LRHBXYZ", "M666": "XYZAB", "M92": "XYZ"}
#: The commands ``M500`` saves in ``config-override.g``.
SAVED_BY_M500 = ("M665", "M666")


def rrf_apply_note(source: str | Path | None) -> str:
    """How to put the values written for a configuration into the printer, in one line.

    Args:
        source: The configuration the printer runs (``config.g``, its ``M501`` followed), or None
            (:data:`~.config.APPLY_NOTE`: where each goes in either case).

    Raises:
        InputError: the configuration's first problem.
    """
    if source is None:
        return APPLY_NOTE
    return apply_note_of(read_rrf_settings(source))


def setting_lines(settings: RRFSettings, code: str) -> list[RRFLine]:
    """The lines that set the keys deltacal writes of ``code`` last, in their files' order."""
    lines = {(line.source, line.line): line for key, line in settings.where.items()
             if key.split()[0] == code and key.split()[1] in WRITTEN[code]}
    return [lines[k] for k in sorted(lines)]


def apply_note_of(settings: RRFSettings) -> str:
    """:func:`rrf_apply_note` of settings already read."""
    config = Path(settings.source).name
    where = {code: setting_lines(settings, code) for code in WRITTEN}
    parts = [_place(code, lines, config) for code, lines in where.items()]
    note = f"Replace {', '.join(parts[:-1])} and {parts[-1]} with these"
    saved = [line for code in SAVED_BY_M500 for line in where[code]]
    if config == OVERRIDE or (saved and all(_m500_holds(line, settings) for line in saved)):
        return note + " (or send M665 and M666, then M500; M500 does not save M92)."
    if not settings.overrides:
        return note + (f": {config} runs no M501, so M500 (config-override.g) would be lost at the next "
                       "start-up.")
    late = next((line for line in saved if not _m500_holds(line, settings)), None)
    if late is None:  # none set: added lines hold as the file stands
        return note + "."
    return note + (f": {Path(late.source).name}'s {late.code} (line {late.line}) runs after its M501 (line "
                   f"{settings.overrides[-1].line}), so M500 (config-override.g) would not hold them.")


def _place(code: str, lines: list[RRFLine], config: str) -> str:
    """``the M665 line of config.g (line 6)``, or where to add one."""
    if not lines:
        return f"(add) an {code} line in {config}"
    return " and ".join(f"the {code} line of {Path(line.source).name} (line {line.line})" for line in lines)


def _m500_holds(line: RRFLine, settings: RRFSettings) -> bool:
    """Whether a value set at ``line`` is overridden by ``config-override.g`` at start-up (M500 holds it)."""
    if Path(line.source).name == OVERRIDE:
        return True
    return any(m501.source == line.source and m501.line > line.line for m501 in settings.overrides)


def rrf_config_files(path: str | Path) -> tuple[Path, ...]:
    """``config.g`` and the files it runs at start-up, in order, and ``homedelta.g`` (what ``G28`` runs).

    ``M501`` runs ``config-override.g`` beside it; ``M98 P"file"`` runs a file of ``/sys`` (a path
    without a folder, ``/sys/...`` or ``0:/sys/...``: beside ``config.g``) or of the card (``/macros/x``:
    beside the ``sys`` folder); each is read for the files it runs in turn. A file that does not exist
    is listed all the same (an output there would be run).

    Raises:
        InputError: a file that cannot be read.
    """
    main = Path(path)
    files: list[Path] = []
    _collect(main, main.parent, files)
    home = main.with_name(HOME_FILE)
    return (*files, *([] if home in files else [home]))


def _collect(path: Path, sys: Path, files: list[Path]) -> None:
    """``path`` and the files its lines run (``M501``, ``M98 P``), depth first, each once."""
    if path in files:
        return
    files.append(path)
    if not path.is_file():
        return
    text = path.read_text(encoding="utf-8", errors="replace")
    for number, raw in enumerate(text.split("\n"), start=1):
        line = parse_line(raw, str(path), number)
        if line is None:
            continue
        if line.code == "M501":
            _collect(path.with_name(OVERRIDE), sys, files)
        elif line.code == "M98" and "P" in line.params:
            _collect(_called(line.params["P"], sys), sys, files)


def _called(spec: str, sys: Path) -> Path:
    """The file ``M98 P"spec"`` runs, ``sys`` being the folder of ``config.g``."""
    name = _DRIVE.sub("", spec.strip().strip('"'))
    if not name.startswith("/"):
        return sys / name
    parts = Path(name).parts[1:]
    return sys.joinpath(*parts[1:]) if parts[:1] == ("sys",) else sys.parent.joinpath(*parts)
