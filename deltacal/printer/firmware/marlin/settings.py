"""Marlin's settings as ``M503`` reports them, read into its delta model, and written back as G-code.

What ``M503`` prints (``module/settings.cpp``, each ``Mxxx_report``), as a console shows it: every
line may start with ``echo:`` (and a host's ``Recv:``); a heading is a comment line
(``echo:; Delta config:``), a setting a command (``echo:  M665 L250.00 R124.00 H250.00 S200.00 X0.00
Y0.00 Z0.00 A0.00 B0.00 C0.00``); deltacal reads

* ``M665 L R H S X Y Z A B C`` (``gcode/calibrate/M665.cpp``; in Marlin 2.0's report ``B`` was the
  calibration radius, read as a rod trim only beside ``A`` or ``C``);
* ``M666 X Y Z`` (``M666.cpp``; each <= 0);
* ``M92 X Y Z E`` (``gcode/config/M92.cpp``, steps per mm);
* ``M851 X Y Z`` (``gcode/probe/M851.cpp``, only with a probe; else 0);
* ``M211 S`` and the line after it, ``Min:  X Y Z  Max:  X Y Z`` (``gcode/host/M211.cpp``; without
  it Marlin's delta defaults, :meth:`~.model.SoftEndstops.default`).

``M503`` opens with the units it reports in (``G21 ; (mm)``, or ``G20 ; (in)`` after a ``G20``,
with ``INCH_MODE_SUPPORT``): in inches every value of ``M665`` but ``S``, of ``M666``, ``M92`` and
``M851`` is printed divided by 25.4 (``LINEAR_UNIT``, ``module/settings.cpp`` and each
``Mxxx_report``), to 2 decimals, which is 0.254 mm: such a report is refused naming its line (send
``G21``, then ``M503``). ``M211``'s limits are printed in mm whatever the units (``print_pos``).
Every value is held to what a printer can be (:data:`BOUNDS`).

A later line wins, as Marlin applies them in turn. Every other line is left alone. Errors are one
line naming the file, the line and the key. Units: mm, trims in degrees.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ....exceptions import GeometryError, InputError
from ....io.inputs import input_problem
from ..bounds import (
    ADJUSTMENT,
    LENGTH,
    POSITION,
    PROBE_OFFSET,
    SEGMENTS_PER_SECOND,
    STEPS_PER_MM,
    TRIM_ANGLE,
    Bound,
)
from ..content import HEAD, file_commands, is_marlin_capture
from .model import DEFAULT_SEGMENTS_PER_SECOND, MarlinDelta, SoftEndstops

#: A host's and Marlin's prefixes of a console line.
_PREFIX = re.compile(r"^\s*(?:(?:Recv|Send):\s*)?(?:echo:\s*)*", re.IGNORECASE)
#: A word of a report: a letter and what follows it up to white space (M503 separates its words).
_WORD = re.compile(r"([A-Za-z])(\S*)")
_LIMITS = re.compile(r"Min:\s*(?P<min>.*?)\s*Max:\s*(?P<max>.*)$", re.IGNORECASE)
#: What a Marlin ``Configuration.h`` holds: its version, or a delta's compiled geometry.
_CONFIGURATION_H = re.compile(r"^[ \t]*#define[ \t]+(?:CONFIGURATION_H_VERSION|DELTA_DIAGONAL_ROD|"
                              r"DELTA_RADIUS|DELTA_PRINTABLE_RADIUS)\b", re.MULTILINE)
#: Why a ``Configuration.h`` is refused, and what to give instead.
CONFIGURATION_H_REFUSED = ("a Marlin Configuration.h holds the compiled defaults, which the printer's saved "
                           "settings override (EEPROM: M500, G33, the LCD's menus): send M503 to the printer "
                           "and save its whole answer (the console's text) in a file, then give that file")
#: The commands read, and the keys each holds.
KEYS = {"M665": "LRHSXYZABCIJK", "M666": "XYZ", "M92": "XYZE", "M851": "XYZ", "M211": "S", "M206": "XYZ"}
#: What each value deltacal reads can be (:mod:`..bounds`), by command and key (``M665 B``: a rod trim
#: beside ``A`` and ``C``, Marlin 2.0's calibration radius otherwise, so bounded as a position).
BOUNDS: dict[tuple[str, str], Bound] = {
    ("M665", "L"): LENGTH, ("M665", "R"): LENGTH, ("M665", "H"): POSITION, ("M665", "S"): SEGMENTS_PER_SECOND,
    **{("M665", k): TRIM_ANGLE for k in "XYZ"}, ("M665", "A"): ADJUSTMENT, ("M665", "B"): POSITION,
    ("M665", "C"): ADJUSTMENT, **{("M665", k): TRIM_ANGLE for k in "IJK"},
    **{("M666", k): ADJUSTMENT for k in "XYZ"},
    **{("M206", k): POSITION for k in "XYZ"},
    **{("M92", k): STEPS_PER_MM for k in "XYZE"}, **{("M851", k): PROBE_OFFSET for k in "XYZ"},
    **{("M211", k): POSITION for k in ("Min X", "Min Y", "Min Z", "Max X", "Max Y", "Max Z")},
}


@dataclass
class MarlinSettings:
    """The values of an ``M503`` capture, by command and key, with the line each came from.

    Attributes:
        source: The file.
        values: Command -> key -> value.
        lines: (command, key) -> the 1-based line of its value.
        limits: ``Min`` and ``Max`` of ``M211``'s report, or None.
        old_report: The line of the last ``M665`` line with ``L``, when it has no ``H`` (a Marlin
            1.1.0's report, its homed height compiled in), else 0.
    """

    source: str
    values: dict[str, dict[str, float]] = field(default_factory=dict)
    lines: dict[tuple[str, str], int] = field(default_factory=dict)
    limits: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    old_report: int = 0

    def error(self, command: str, key: str, detail: str) -> InputError:
        """A one-line error naming the file, the line and the key."""
        line = self.lines.get((command, key))
        where = f"line {line}, {command} {key}" if line else f"{command} {key}"
        return InputError(detail, self.source, where)

    def get(self, command: str, key: str, default: float | None = None) -> float:
        """A value, or the default; a missing one without default is an error naming the command."""
        value = self.values.get(command, {}).get(key)
        if value is None:
            if default is None:
                raise InputError(f"no {command} {key} (Marlin's delta settings need it: capture M503's whole "
                                 "report)", self.source, f"{command} {key}")
            return default
        return value


def is_marlin_settings(path: str | Path) -> bool:
    """Whether a file is Marlin's: an ``M503`` capture, or a ``Configuration.h``.

    A capture is told by the commands it runs, never by its comments
    (:func:`~..content.is_marlin_capture`: ``M665`` with Marlin's ``echo:`` lines or its report's
    commands); a ``Configuration.h`` by its ``#define`` lines, and refused when read
    (:data:`CONFIGURATION_H_REFUSED`).
    """
    if input_problem(path) is not None:
        return False  # the reader of the file taken instead names the problem
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = f.read(HEAD)
    except OSError:
        return False
    return is_marlin_capture(file_commands(head)) or _CONFIGURATION_H.search(head) is not None


def read_marlin_settings(path: str | Path) -> MarlinSettings:
    """Every value of the commands deltacal reads in an ``M503`` capture (module docstring).

    Raises:
        InputError: naming the file, line and key of a value that is not a number.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"not a text file (byte {exc.start} is not UTF-8)", source) from None
    header = _CONFIGURATION_H.search(text)
    if header is not None:
        defined = text.count("\n", 0, header.start()) + 1
        raise InputError(CONFIGURATION_H_REFUSED, source, f"line {defined}")
    settings = MarlinSettings(source)
    inches = 0  # the line of a G20 in force (Marlin then reports lengths in inches), else 0
    for number, raw in enumerate(text.splitlines(), start=1):
        line = _PREFIX.sub("", raw, count=1).strip()
        body = line.lstrip(";").strip()
        limits = _LIMITS.match(body) if body.lower().startswith("min:") else None
        if limits:
            settings.limits = (_xyz(limits["min"], source, number, "Min"),
                               _xyz(limits["max"], source, number, "Max"))
            continue
        line = line.split(";", 1)[0].strip()
        command = line.split(None, 1)[0].upper() if line else ""
        if command in ("G20", "G21"):
            inches = number if command == "G20" else 0
        if command not in KEYS:
            continue
        if inches and command != "M211":
            raise InputError(f"reported in inches (G20, line {inches}): Marlin prints each length divided by "
                             "25.4 to 2 decimals (0.254 mm, and M92 as steps per mm / 25.4), too coarse to "
                             "calibrate: send G21, then M503, and capture that", source,
                             f"line {number}, {command}")
        words = _WORD.findall(line[len(command):])
        for key, value in words:
            key = key.upper()
            if key not in KEYS[command]:
                continue
            settings.values.setdefault(command, {})[key] = _number(value, source, number, command, key)
            settings.lines[(command, key)] = number
        given = {key.upper() for key, _ in words}
        if command == "M665" and "L" in given:  # a report's line; an added 'M665 H' alone is not one
            settings.old_report = 0 if "H" in given else number
    return settings


def _number(text: str, source: str, line: int, command: str, key: str) -> float:
    """A value of the report, within :data:`BOUNDS`."""
    where = f"line {line}, {command} {key}"
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"value {text!r} is not a number", source, where) from None
    bound = BOUNDS.get((command, key))
    problem = "is not a finite number" if not math.isfinite(value) else \
        bound.problem(value) if bound is not None else None
    if problem is not None:
        raise InputError(f"value {text!r} {problem}", source, where)
    return value


def _xyz(text: str, source: str, line: int, where: str) -> tuple[float, float, float]:
    """``X.. Y.. Z..`` of the soft endstops' report."""
    words = {k.upper(): v for k, v in _WORD.findall(text)}
    if not all(k in words for k in "XYZ"):
        raise InputError(f"expected X, Y and Z, got {text.strip()!r}", source, f"line {line}, M211 {where}")
    x, y, z = (_number(words[k], source, line, "M211", f"{where} {k}") for k in "XYZ")
    return x, y, z


def _refuse_old_report(settings: MarlinSettings) -> None:
    """Refuse the report of a Marlin before 1.1.x (``M665 L R S [A B C] [I J K]``, no ``H``) by what it lacks.

    Its homed height is compiled in (``MANUAL_Z_HOME_POS``, moved by the ``M206 Z`` home offset), not
    in the report; its ``M665 I J K`` are tower angle trims deltacal does not read.
    """
    m665 = settings.values.get("M665", {})
    first = min((line for (command, _), line in settings.lines.items() if command == "M665"), default=0)
    if m665 and "H" not in m665:
        offset = settings.values.get("M206", {}).get("Z")
        plus = f"plus this report's M206 Z{offset:g}" if offset is not None else "plus its M206 Z home offset"
        raise InputError(f"no M665 H: the report of a Marlin without it (1.1.0 or older: 'M665 L R S ...'), "
                         "whose homed height is compiled in (MANUAL_Z_HOME_POS of its Configuration.h, "
                         f"{plus}), so not in the report: add a line 'M665 H<that height>' to the capture, "
                         "or update Marlin and capture M503 again", settings.source, f"line {first}")
    trims = [key for key in "IJK" if m665.get(key, 0.0) != 0.0]
    if trims:
        raise settings.error("M665", trims[0], f"value {m665[trims[0]]:g}: M665 I J K are the tower angle "
                             "trims of Marlin 1.1.0's report, which deltacal does not read: update Marlin "
                             "(M665 X Y Z) and capture M503 again")


def load_marlin(path: str | Path) -> MarlinDelta:
    """Marlin's delta model with the values of an ``M503`` capture.

    Raises:
        InputError: naming the file, line and key of the first problem found.
    """
    return marlin_from_settings(read_marlin_settings(path))


def marlin_from_settings(settings: MarlinSettings) -> MarlinDelta:
    """Marlin's delta model with the values of an ``M503`` capture already read (:func:`load_marlin`).

    Raises:
        InputError: naming the file, line and key of the first problem found.
    """
    _refuse_old_report(settings)
    get = settings.get
    height = get("M665", "H")
    if settings.old_report:  # Marlin 1.1.0 homes up to MANUAL_Z_HOME_POS + M206 Z, M851 Z apart
        height += get("M851", "Z", 0.0)
    trims = settings.values.get("M665", {})
    rod_b = get("M665", "B", 0.0) if ("A" in trims or "C" in trims) else 0.0
    for key, test, words in (("L", lambda v: v > 0.0, "a positive length"), ("R", lambda v: v > 0.0,
                             "a positive length")):
        if not test(get("M665", key)):
            raise settings.error("M665", key, f"value {get('M665', key):g} must be {words}")
    for key in "XYZ":
        if get("M666", key, 0.0) > 0.0:
            raise settings.error("M666", key, f"value {get('M666', key):g} must be <= 0 (Marlin refuses a "
                                 "positive endstop adjustment: ?M666 offsets must be <= 0)")
        if get("M92", key) <= 0.0:
            raise settings.error("M92", key, f"value {get('M92', key):g} steps per mm must be positive")
    limits = SoftEndstops.default()
    if settings.limits is not None:
        low, high = settings.limits
        limits = SoftEndstops(low, (high[0], high[1]), high[2])
    limits = SoftEndstops(limits.minimum, limits.maximum_xy, limits.maximum_z,
                          bool(get("M211", "S", 1.0)))
    try:
        return MarlinDelta(
            radius=get("M665", "R"), rod=get("M665", "L"), height=height,
            angle_trim=np.array([get("M665", k, 0.0) for k in "XYZ"]),
            rod_trim=np.array([get("M665", "A", 0.0), rod_b, get("M665", "C", 0.0)]),
            endstop_adj=np.array([get("M666", k, 0.0) for k in "XYZ"]),
            steps_per_mm=np.array([get("M92", k) for k in "XYZ"]),
            probe_offset=np.array([get("M851", k, 0.0) for k in "XYZ"]),
            soft_endstops=limits,
            segments_per_second=get("M665", "S", DEFAULT_SEGMENTS_PER_SECOND),
            extruder_steps_per_mm=settings.values.get("M92", {}).get("E"),
            name=Path(settings.source).name,
            compiled_height=bool(settings.old_report),
        )
    except GeometryError as exc:
        raise InputError(str(exc), settings.source, "M665") from None


#: How to put the lines :func:`marlin_settings_text` writes into the printer (its header's second line).
APPLY_NOTE = "Send these lines to the printer: M665, M666 and M92 set the values, the last, M500, saves them."
#: Decimals written: lengths [mm] and trims [deg]; ``M92`` steps per mm.
MM_DECIMALS = 4
STEPS_DECIMALS = 6


def marlin_settings_text(marlin: MarlinDelta, title: str = "", notes: list[str] | tuple[str, ...] = (),
                         complete: bool = False) -> str:
    """Marlin's values as G-code: ``M665``, ``M666``, ``M92`` (then ``M500`` to keep them).

    Lengths and trims with 4 decimals, steps per mm with 6 (Marlin keeps floats of 7 digits).
    ``M665 H`` is the height with the printer's ``M851 Z`` (written as a comment; with ``complete``,
    an ``M851`` line too). With ``complete``, every value exactly (the shortest text that reads back
    the same float) and the soft endstops as a comment ``; Min: .. Max: ..`` that
    :func:`load_marlin` reads (Marlin's own are compiled in, ``M211`` only switches them).
    """
    def num(value: float, decimals: int = MM_DECIMALS) -> str:
        return repr(float(value)) if complete else f"{value:.{decimals}f}"

    def words(letters: str, values) -> str:
        return " ".join(f"{k}{num(v)}" for k, v in zip(letters, values, strict=True))

    lines = [f"; {title}" if title else "; Marlin delta values written by deltacal"]
    if not complete:
        lines.append(f"; {APPLY_NOTE}")
    lines += [f"; {note}".rstrip() for note in notes]
    lines.append(f"; M665 H is for the probe offset M851 Z{num(marlin.probe_offset[2])}")
    extruder = marlin.extruder_steps_per_mm
    e = "" if extruder is None else f" E{num(extruder, STEPS_DECIMALS)}"
    lines += [f"M665 L{num(marlin.rod)} R{num(marlin.radius)} H{num(marlin.height)} "
              f"S{num(marlin.segments_per_second, 2)} {words('XYZ', marlin.angle_trim)} "
              f"{words('ABC', marlin.rod_trim)}",
              f"M666 {words('XYZ', marlin.endstop_adj)}",
              "M92 " + " ".join(f"{k}{num(v, STEPS_DECIMALS)}" for k, v in zip("XYZ", marlin.steps_per_mm,
                                                                               strict=True)) + e]
    if complete:
        limits = marlin.soft_endstops
        top = marlin.home_height if limits.maximum_z is None else limits.maximum_z
        lines += [f"M851 {words('XYZ', marlin.probe_offset)}", f"M211 S{int(limits.enabled)}",
                  f"; Min: {words('XYZ', limits.minimum)}  Max: {words('XYZ', (*limits.maximum_xy, top))}"]
    lines.append("M500 ; save to EEPROM")
    return "\n".join(lines) + "\n"
