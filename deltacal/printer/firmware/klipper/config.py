"""Klipper's ``printer.cfg`` read as Klipper reads it, into its delta model (conventions: printers).

What Klipper does with the file (``klippy/configfile.py``), and so what deltacal does:

* a ``#`` starts a comment anywhere on a line; ``;`` starts one at a line's start or after
  white space; options are ``key: value`` or ``key = value``, keys case-insensitive, indented
  lines continue a value; a section given twice is merged, a later value of an option wins;
* ``[include PATTERN]`` reads the files matching the pattern (relative to the including file,
  sorted; a pattern without wildcards must match a file) at that point; a file including itself
  is an error;
* the ``SAVE_CONFIG`` block at the end (after the ``#*# <---- SAVE_CONFIG ---->`` header, every
  line prefixed ``#*# ``) is read after the rest. An option both in it and in the rest keeps the
  rest's value (Klipper comments the block's copy out; ``SAVE_CONFIG`` itself comments out the
  rest's copy when it writes): deltacal warns where the section is one it reads
  (:data:`READ_SECTIONS`; the ``[extruder]`` PID keys both places hold, say, stay quiet). A block
  with other lines after its header, or ``#*#`` lines before it, is ignored with a warning, as
  Klipper does.

Unlike Klipper, an include file that does not exist (a configuration copied off the printer
without its ``mainsail.cfg``, ``macros.cfg``, or a dangling link) is skipped, all of them named in
one warning; a key the delta kinematics need and cannot find then names them as where it may be.

deltacal's own live correction (``export --live``: ``[include deltacal_geometry.cfg]``, its
``[deltacal_geometry]`` section) is found where Klipper would load it: the section in a file read,
or an include of that file's name that does not exist here (copied off the printer without it):
:attr:`KlipperConfig.live`, the routes' to ask.

Only ``[printer]``, ``[stepper_a]`` .. ``[stepper_c]`` and ``[delta_calibrate]`` are interpreted
(:mod:`.model` gives each value's meaning, :mod:`.saved` the saved measurements'); every other
section is left alone. Errors are one line naming the file, section,
key and value.
"""

from __future__ import annotations

import configparser
import glob
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from warnings import warn

import numpy as np

from ....exceptions import GeometryError, InputError, InputWarning
from ....io.atomic import atomic_write_text
from ....io.inputs import NOT_FOUND, input_problem
from ..bounds import ANGLE, FULL_STEPS, LENGTH, MICROSTEPS, POSITION, PROBE_OFFSET, STEP_DISTANCE, Bound
from .model import DEFAULT_ANGLES_DEG, DEFAULT_FULL_STEPS, KlipperDelta

#: How to put the keys :func:`klipper_config_text` writes into the printer (its header's second line).
APPLY_NOTE = "Replace these keys in printer.cfg (and delete their copies in a SAVE_CONFIG block, if any)."
#: The line that opens Klipper's SAVE_CONFIG block.
AUTOSAVE_MARK = "#*# <---------------------- SAVE_CONFIG ---------------------->"
#: Klipper's header of the block: the mark, a warning line and an empty ``#*#`` line.
AUTOSAVE_HEADER = ("\n" + AUTOSAVE_MARK + "\n#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are "
                   "auto-generated.\n#*#\n")
#: The three towers' sections, in Klipper's order.
STEPPERS = ("stepper_a", "stepper_b", "stepper_c")
#: The sections deltacal reads (a duplicate key in another section is Klipper's business alone).
READ_SECTIONS = ("printer", *STEPPERS, "delta_calibrate")
#: The section of deltacal's live correction (Klipper loads ``klippy/extras/deltacal_geometry.py`` for it),
#: the file ``export --live`` writes it in, and the commands that turn the correction off and on.
LIVE_SECTION = "deltacal_geometry"
LIVE_SECTION_FILE = f"{LIVE_SECTION}.cfg"
LIVE_OFF = "DELTACAL_GEOMETRY ENABLE=0"
LIVE_ON = "DELTACAL_GEOMETRY ENABLE=1"
#: Klipper's probe sections, each with ``x_offset``, ``y_offset`` (default 0) and ``z_offset``.
PROBE_SECTIONS = ("probe", "bltouch", "smart_effector", "load_cell_probe")
#: What each value deltacal reads can be (:mod:`..bounds`), by section (``stepper`` for the three
#: towers', ``probe`` for any of :data:`PROBE_SECTIONS`) and key.
BOUNDS: dict[tuple[str, str], Bound] = {
    ("printer", "delta_radius"): LENGTH, ("printer", "print_radius"): LENGTH,
    ("printer", "minimum_z_position"): POSITION, ("stepper", "arm_length"): LENGTH,
    ("stepper", "position_endstop"): POSITION, ("stepper", "angle"): ANGLE,
    ("stepper", "rotation_distance"): LENGTH, ("stepper", "step_distance"): STEP_DISTANCE,
    ("stepper", "microsteps"): MICROSTEPS, ("stepper", "full_steps_per_rotation"): FULL_STEPS,
    ("delta_calibrate", "radius"): LENGTH, ("probe", "x_offset"): PROBE_OFFSET,
    ("printer", "shoulder_radius"): LENGTH, ("printer", "shoulder_height"): LENGTH,
    ("stepper", "upper_arm_length"): LENGTH, ("stepper", "lower_arm_length"): LENGTH,
    ("probe", "y_offset"): PROBE_OFFSET, ("probe", "z_offset"): PROBE_OFFSET,
}

#: A Klipper configuration's ``[printer]`` section header, on a line of its own.
_PRINTER_SECTION = re.compile(r"^[ \t]*\[printer\][ \t]*(?:[#;].*)?$", re.MULTILINE)
#: What opens the configuration ``klippy.log`` holds (a log, not a configuration).
_LOG_DUMP = re.compile(r"^(?:===== Config file =====|Start printer at)", re.MULTILINE)
_COMMENT = re.compile(r"[#;].*$")
_FIELD = re.compile(r"[^A-Za-z0-9_].*$")


@dataclass
class KlipperConfig:
    """The options of a Klipper configuration as Klipper resolves them.

    Attributes:
        source: The main file.
        sections: Section name -> option (lower case) -> value text.
        origin: (section, option) -> the file its value came from.
        missing: The include files that do not exist: (the including file, its line, the path).
        files: Every file read, in order (the main file first, then its includes).
        live: Where the configuration includes deltacal's live correction (:data:`LIVE_SECTION`), in
            its words (``[deltacal_geometry] from deltacal_geometry.cfg``, or the include of a
            :data:`LIVE_SECTION_FILE` that does not exist here, by its line), or "" (it does not).
    """

    source: str
    sections: dict[str, dict[str, str]] = field(default_factory=dict)
    origin: dict[tuple[str, str], str] = field(default_factory=dict)
    missing: list[tuple[str, int, str]] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    live: str = ""

    def missing_hint(self) -> str:
        """Where a value not found may be: `` (it may be in the missing include X, Y)``, or ""."""
        if not self.missing:
            return ""
        names = ", ".join(os.path.basename(path) for _, _, path in self.missing)
        return f" (it may be in the missing include{'s' if len(self.missing) > 1 else ''} {names})"

    def error(self, section: str, option: str, detail: str) -> InputError:
        """A one-line error naming the file the option came from, its section and key."""
        source = self.origin.get((section, option), self.source)
        return InputError(detail, source, f"section [{section}], key {option}")

    def has(self, section: str, option: str) -> bool:
        """Whether the section sets the option."""
        return option in self.sections.get(section, {})

    def text(self, section: str, option: str) -> str:
        """An option's text; a missing one is an error naming the section and key."""
        if not self.has(section, option):
            raise InputError(f"missing required key {option!r} (Klipper's delta kinematics needs it)"
                             f"{self.missing_hint()}", self.source, f"section [{section}]")
        return self.sections[section][option]

    def number(self, section: str, option: str, default: float | None = None, above: float | None = None,
               integer: bool = False) -> float:
        """An option's number as Klipper's ``getfloat``/``getint`` parse it (bounded), or the default."""
        if default is not None and not self.has(section, option):
            return default
        text = self.text(section, option)
        try:
            value = float(int(text)) if integer else float(text)
        except ValueError:
            what = "an integer" if integer else "a number"
            raise self.error(section, option, f"value {text!r} is not {what}") from None
        if not math.isfinite(value):
            raise self.error(section, option, f"value {text!r} is not a finite number")
        family = "stepper" if section in STEPPERS else "probe" if section in PROBE_SECTIONS else section
        bound = BOUNDS.get((family, option))
        problem = bound.problem(value) if bound is not None else None
        if problem is not None:
            raise self.error(section, option, f"value {text!r} {problem}")
        if above is not None and value <= above:
            raise self.error(section, option, f"value {text!r} must be above {above:g}")
        return value


def is_klipper_config(path: str | Path) -> bool:
    """Whether a file is a Klipper configuration by its content: a ``[printer]`` section, and not a log.

    (``klippy.log`` holds its configuration after ``===== Config file =====``.)
    """
    if input_problem(path) is not None:
        return False  # the reader of the file taken instead names the problem
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = f.read(1 << 16)
    except OSError:
        return False
    return _PRINTER_SECTION.search(head) is not None and _LOG_DUMP.search(head) is None


def is_klipper_config_name(path: str | Path) -> bool:
    """Whether a file is named as a Klipper configuration is: ``*.cfg``."""
    return Path(path).suffix.lower() == ".cfg"


def read_klipper_config(path: str | Path) -> KlipperConfig:
    """Every option of a Klipper configuration, includes and the SAVE_CONFIG block resolved.

    Raises:
        InputError: naming the file (and line) of a syntax error, a missing include or a
            recursive one.
    """
    source = str(path)
    data = _read_text(source, source)
    regular, autosave, first = _split_autosave(data, source)
    config = KlipperConfig(source)
    _parse(regular, source, config, set())
    if autosave:
        saved = KlipperConfig(source)
        _parse(_strip_duplicates(autosave, config, source), source, saved, set(), first)
        for section, options in saved.sections.items():
            config.sections.setdefault(section, {}).update(options)
            for option in options:
                config.origin[(section, option)] = f"{source} (SAVE_CONFIG block)"
        config.live = config.live or saved.live
    if config.missing:
        base = os.path.dirname(source)
        where = ", ".join(f"{os.path.relpath(path, base)} (line {line}"
                          f"{'' if parent == source else ' of ' + os.path.relpath(parent, base)})"
                          for parent, line, path in config.missing)
        say(f"{source}: include file{'s' if len(config.missing) > 1 else ''} not found, skipped (a "
            f"configuration copied off the printer?): {where}")
    return config


def say(message: str) -> None:
    """Warn (:class:`~deltacal.exceptions.InputWarning`) from this line, whoever reads the file.

    Python's warning registry says a warning once per place it is issued from: issued here, one
    warning is said once however many times one command reads the same configuration.
    """
    warn(message, InputWarning, stacklevel=1)


def _read_text(filename: str, source: str) -> str:
    try:
        return Path(filename).read_text(encoding="utf-8").replace("\r\n", "\n")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the Klipper configuration file {filename}: {exc}", source) from None


def _split_autosave(data: str, source: str) -> tuple[str, str, int]:
    """The regular part, the SAVE_CONFIG block's lines without their ``#*# `` prefix, and a line number.

    The number is the file line of the returned block's first line (an empty line before the block's
    own), so that errors in the block name the file's lines.
    """
    pos = data.find(AUTOSAVE_HEADER)
    if pos < 0:
        return data, "", 1
    rest = data[pos + len(AUTOSAVE_HEADER):]
    regular, block = data[:pos], rest.strip()
    # the block's first line: after the header's three (the mark's is the line after ``pos``) and any
    # blank lines strip() took
    first = data.count("\n", 0, pos) + 5 + rest[: len(rest) - len(rest.lstrip())].count("\n")
    if "\n#*# " in regular:
        say(f"{source}: '#*#' lines before the SAVE_CONFIG block: Klipper ignores the block, so does "
            "deltacal")
        return data, "", 1
    again = block.find(AUTOSAVE_HEADER)
    if again >= 0:
        line = first + block.count("\n", 0, again) + 1
        say(f"{source}: line {line}: a second SAVE_CONFIG block: Klipper ignores both ('autosave state "
            "corrupted'), so does deltacal")
        return data, "", 1
    lines = block.split("\n")
    bad = [n for n, line in enumerate(lines)
           if not line.startswith("#*#") or (len(line) >= 4 and line[3] != " ")]
    if block and bad:
        say(f"{source}: line {first + bad[0]}: the SAVE_CONFIG block was edited ({lines[bad[0]]!r} after "
            "its header): Klipper ignores the block, so does deltacal")
        return data, "", 1
    return regular, "\n".join(["", *(line[4:] for line in lines), ""]), first - 1


def _strip_duplicates(block: str, config: KlipperConfig, source: str) -> str:
    """The block without the options the rest already sets (Klipper keeps the rest's), with a warning."""
    lines = block.split("\n")
    section = ""
    duplicate = False
    for n, line in enumerate(lines):
        pruned = _COMMENT.sub("", line).rstrip()
        if not pruned:
            continue
        if pruned[0].isspace():
            if duplicate:
                lines[n] = "#" + line
            continue
        duplicate = False
        if pruned[0] == "[":
            section = pruned[1:-1].strip()
            continue
        option = _FIELD.sub("", pruned).lower()
        if config.has(section, option):
            duplicate = True
            lines[n] = "#" + line
            if section not in READ_SECTIONS:
                continue
            say(f"{source}: section [{section}], key {option}: set both in the configuration and in its "
                f"SAVE_CONFIG block; Klipper keeps the configuration's value "
                f"{config.sections[section][option]!r}, so does deltacal")
    return "\n".join(lines)


def _parse(data: str, filename: str, config: KlipperConfig, visited: set[str], first: int = 1) -> None:
    """Klipper's parse of one file: the lines between includes as one unit, includes where they stand.

    ``visited``: the real paths of the files being read (each including the next); ``first``: the file
    line of ``data``'s first line (the SAVE_CONFIG block's, say).
    """
    path = os.path.realpath(filename)
    visited.add(path)
    config.files.append(filename)
    buffer: list[str] = []
    start = first
    for number, line in enumerate(data.split("\n"), start=first):
        pos = line.find("#")
        if pos >= 0:
            line = line[:pos]
        match = configparser.RawConfigParser.SECTCRE.match(line)
        header = match.group("header") if match else None
        if header and header.startswith("include "):
            _parse_unit(buffer, start, filename, config)
            _include(filename, header[len("include "):].strip(), config, visited, number)
            buffer, start = [], number + 1
        else:
            buffer.append(line)
    _parse_unit(buffer, start, filename, config)
    visited.discard(path)


def _include(filename: str, spec: str, config: KlipperConfig, visited: set[str], number: int) -> None:
    """Read the files ``[include spec]`` (line ``number`` of ``filename``) names, as Klipper does.

    A file already being read (by its real path: a link to a folder above it, say) is a recursive
    include; a path that is not a regular file (a folder, a pipe, a device) is refused as an input
    given directly is (:func:`~deltacal.io.inputs.input_problem`).
    """
    pattern = os.path.join(os.path.dirname(filename), spec)
    found = sorted(glob.glob(pattern))
    if not found and not glob.has_magic(pattern):
        found = [pattern]
    for name in found:
        problem = input_problem(name)
        if problem == NOT_FOUND:  # absent, or a link to nothing
            config.missing.append((filename, number, name))
            if os.path.basename(name) == LIVE_SECTION_FILE and not config.live:
                config.live = (f"[include {spec}] at line {number} of {filename}: not found here, taken "
                               "as the section's file by its name")
            continue
        if problem is not None:
            raise InputError(f"[include {spec}]: {name}: {problem}", filename, f"line {number}")
        if os.path.realpath(name) in visited:
            link = "" if os.path.realpath(name) == os.path.abspath(name) else f" (through a link: {name})"
            raise InputError(f"recursive include of this file{link}, by [include {spec}] at line {number} of "
                             f"{filename}", os.path.realpath(name))
        _parse(_read_text(name, filename), name, config, visited)


def config_from_text(text: str, source: str, first_line: int = 1) -> KlipperConfig:
    """The options of a configuration's text, no includes read (the configuration a ``klippy.log`` dumps).

    Args:
        text: The text (``[section]`` headers and ``key = value`` options).
        source: Its file, for messages.
        first_line: The line of the text's first line in that file.

    Raises:
        InputError: a syntax error, naming the file and line.
    """
    config = KlipperConfig(source)
    _parse_unit(text.split("\n"), first_line, source, config)
    return config


def _parse_unit(buffer: list[str], start: int, filename: str, config: KlipperConfig) -> None:
    """Lines of one file between includes, read by configparser with Klipper's settings."""
    if not any(line.strip() for line in buffer):
        return
    parser = configparser.RawConfigParser(strict=False, inline_comment_prefixes=(";", "#"))
    try:
        parser.read_string("\n".join(buffer), source=filename)
    except configparser.MissingSectionHeaderError as exc:
        line = buffer[exc.lineno - 1] if 0 < exc.lineno <= len(buffer) else ""
        raise InputError(f"an option outside any [section]: {line.strip()!r}", filename,
                         f"line {start + exc.lineno - 1}") from None
    except configparser.ParsingError as exc:
        lineno = exc.errors[0][0]
        line = buffer[lineno - 1] if 0 < lineno <= len(buffer) else ""
        raise InputError(f"not an option ('key: value') nor a [section]: {line.strip()!r}", filename,
                         f"line {start + lineno - 1}") from None
    for section in parser.sections():
        if section == LIVE_SECTION and not config.live:
            config.live = f"[{LIVE_SECTION}] from {filename}"
        options = config.sections.setdefault(section, {})
        for option, value in parser.items(section):
            options[option] = value
            config.origin[(section, option)] = filename


def load_klipper(path: str | Path) -> KlipperDelta:
    """Klipper's delta model from a ``printer.cfg`` (``[printer] kinematics: delta``).

    Raises:
        InputError: naming the file, section, key and value of the first problem found.
    """
    return klipper_from_config(read_klipper_config(path))


def klipper_from_config(config: KlipperConfig) -> KlipperDelta:
    """Klipper's delta model from a configuration already read (:func:`load_klipper`).

    Raises:
        InputError: naming the file, section, key and value of the first problem found.
    """
    kinematics = config.text("printer", "kinematics").strip()
    if kinematics != "delta":
        raise config.error("printer", "kinematics", f"value {kinematics!r}: deltacal reads Klipper's linear "
                                                    "Delta printers (kinematics: delta)")
    _say_unfollowed(config)
    radius = config.number("printer", "delta_radius", above=0.0)
    endstop_a = config.number("stepper_a", "position_endstop")
    arm_a = config.number("stepper_a", "arm_length", above=radius)
    angles, arms, endstops, steps = [], [], [], []
    for stepper, angle in zip(STEPPERS, DEFAULT_ANGLES_DEG, strict=True):
        if stepper not in config.sections:
            raise InputError(f"missing section [{stepper}] (a delta printer has three towers)"
                             f"{config.missing_hint()}", config.source)
        angles.append(config.number(stepper, "angle", angle))
        arms.append(config.number(stepper, "arm_length", arm_a, above=radius))
        endstops.append(config.number(stepper, "position_endstop", endstop_a))
        steps.append(_step_distance(config, stepper))
    print_radius = config.number("printer", "print_radius", above=0.0) \
        if config.has("printer", "print_radius") else None
    minimum_z = config.number("printer", "minimum_z_position", 0.0)
    if minimum_z > min(endstops):  # Klipper's maxval: the lowest position_endstop
        raise config.error("printer", "minimum_z_position", f"value {minimum_z:g} must be at most "
                           f"{min(endstops):g}, the lowest position_endstop (Klipper refuses it)")
    try:
        return KlipperDelta(radius, np.radians(angles), np.array(arms), np.array(endstops), np.array(steps),
                            name=Path(config.source).name, print_radius=print_radius,
                            minimum_z_position=minimum_z)
    except GeometryError as exc:
        raise InputError(str(exc), config.source) from None


def _say_unfollowed(config: KlipperConfig) -> None:
    """Warn of what the configuration does to a program that deltacal does not follow.

    ``[homing_override]`` replaces ``G28`` with its gcode (deltacal takes ``G28`` to leave every
    carriage at its endstop, as Klipper's delta homing does); a saved mesh ``[bed_mesh NAME]``, once
    loaded, adds its heights to every move, on top of deltacal's correction.
    """
    def origin(name: str) -> str:
        return next((f for (section, _), f in config.origin.items() if section == name), config.source)

    if "homing_override" in config.sections:
        say(f"{origin('homing_override')}: section [homing_override]: G28 runs its gcode, which deltacal "
            "does not follow: a program's G28 is taken to leave every carriage at its endstop, as Klipper's "
            "own delta homing does (make its gcode end there, or home without it)")
    meshes = [section for section in config.sections if section.startswith("bed_mesh ")]
    if meshes:
        name = meshes[0][len("bed_mesh "):].strip()
        say(f"{origin(meshes[0])}: section [{meshes[0]}]: a saved bed mesh; once loaded (BED_MESH_PROFILE "
            f"LOAD={name} in a start macro, or at start-up by Klipper before 2023) it adds its heights to "
            "deltacal's correction: turn it off (BED_MESH_CLEAR) before a corrected program, or remove it "
            f"(BED_MESH_PROFILE REMOVE={name}, then SAVE_CONFIG)")


def _step_distance(config: KlipperConfig, stepper: str) -> float:
    """``rotation_distance / (full_steps_per_rotation × microsteps × gear ratio)`` [mm], as Klipper's."""
    if not config.has(stepper, "rotation_distance") and config.has(stepper, "step_distance"):
        return config.number(stepper, "step_distance", above=0.0)  # Klipper's older format
    rotation = config.number(stepper, "rotation_distance", above=0.0)
    microsteps = config.number(stepper, "microsteps", integer=True, above=0.0)
    full = config.number(stepper, "full_steps_per_rotation", float(DEFAULT_FULL_STEPS), integer=True,
                         above=0.0)
    if full % 4:
        raise config.error(stepper, "full_steps_per_rotation", f"value {int(full)} must be a multiple of 4")
    return rotation / (full * microsteps * gear_ratio(config, stepper))


def gear_ratio(config: KlipperConfig, stepper: str) -> float:
    """The product of ``gear_ratio``'s ``a:b`` pairs (comma separated), 1 without one."""
    if not config.has(stepper, "gear_ratio"):
        return 1.0
    text = config.text(stepper, "gear_ratio")
    ratio = 1.0
    for pair in (p.strip() for p in text.split(",") if p.strip()):
        parts = [v.strip() for v in pair.split(":")]
        try:
            first, second = (float(v) for v in parts) if len(parts) == 2 else (math.nan, math.nan)
        except ValueError:
            first = second = math.nan
        if not (math.isfinite(first) and math.isfinite(second) and first > 0.0 and second > 0.0):
            raise config.error(stepper, "gear_ratio",
                               f"value {text!r} is not a list of ratios such as '57:11, 2:1'")
        ratio *= first / second
    return ratio


#: Decimals written: lengths [mm] and angles [deg].
MM_DECIMALS = 6
DEG_DECIMALS = 4
#: The microstepping a complete configuration is written with when no source configuration gives one.
DEFAULT_MICROSTEPS = 16
#: The ``[printer]`` options a complete configuration adds to the values (Klipper requires the
#: kinematics and the limits; velocity [mm/s], acceleration [mm/s²]).
PRINTER_OPTIONS = (("kinematics", "delta"), ("max_velocity", "300"), ("max_accel", "3000"))


def _rotation_factor(config: KlipperConfig | None, stepper: str) -> tuple[float, bool]:
    """Steps per ``rotation_distance`` (full steps × microsteps × gear ratio), and whether it was assumed."""
    if config is None or not config.has(stepper, "microsteps"):
        return float(DEFAULT_FULL_STEPS * DEFAULT_MICROSTEPS), True
    microsteps = config.number(stepper, "microsteps", integer=True, above=0.0)
    full = config.number(stepper, "full_steps_per_rotation", float(DEFAULT_FULL_STEPS), integer=True,
                         above=0.0)
    return full * microsteps * gear_ratio(config, stepper), False


def klipper_config_text(klipper: KlipperDelta, source_config: str | Path | KlipperConfig | None = None,
                        title: str = "", notes: list[str] | tuple[str, ...] = (),
                        complete: bool = False) -> str:
    """Klipper's values as ``printer.cfg`` text: ``[printer]`` and ``[stepper_a..c]``.

    Writes ``delta_radius`` and each tower's ``angle`` [deg, 4 decimals], ``arm_length``,
    ``position_endstop`` and ``rotation_distance`` [mm, 6 decimals], and ``[printer]``'s
    ``print_radius`` and ``minimum_z_position`` where the values set them. ``rotation_distance`` is
    the step distance times the source configuration's ``full_steps_per_rotation × microsteps × gear
    ratio``. Only keys Klipper knows; read back by :func:`load_klipper` they give the same values to
    the written decimals.

    By default only those keys, to replace the printer's own (the header says so); without a
    source's microstepping no ``rotation_distance`` is written (a comment says the printer's own
    stays): it cannot be known. With ``complete``, a whole configuration of Klipper's
    delta kinematics that Klipper and :func:`load_klipper` read: ``kinematics``, ``max_velocity``
    and ``max_accel`` (:data:`PRINTER_OPTIONS`) added to ``[printer]``, each tower's microstepping
    (the source's, or 200 full steps × 16 microsteps) written, and every value written exactly
    (the shortest text that reads back the same float; angles as their degrees do).

    Args:
        klipper: The values.
        source_config: The configuration the printer runs (a path or one already read), for its
            steppers' microstepping and gears.
        title: A first comment line (what the values are).
        notes: More comment lines (what the values leave), each written after ``# ``.
        complete: A whole configuration, values exact (see above).
    """
    config = read_klipper_config(source_config) if isinstance(source_config, (str, Path)) else source_config
    lines = [f"# {title}" if title else "# Klipper delta values written by deltacal"]
    if not complete:
        lines.append(f"# {APPLY_NOTE}")
    lines += [f"# {note}".rstrip() for note in notes]
    unknown = []
    body = ["", "[printer]", *(f"{key}: {value}" for key, value in PRINTER_OPTIONS if complete),
            f"delta_radius: {_number(klipper.delta_radius, MM_DECIMALS, complete)}",
            *_limits(klipper, complete)]
    for i, stepper in enumerate(STEPPERS):
        factor, guess = _rotation_factor(config, stepper)
        rotation = f"rotation_distance: {_number(klipper.step_distance[i] * factor, MM_DECIMALS, complete)}"
        if guess and not complete:
            unknown.append(stepper)
        body += ["", f"[{stepper}]", *(_stepping(config, stepper) if complete else []),
                 f"angle: {_number(math.degrees(klipper.angle[i]), DEG_DECIMALS, complete)}",
                 f"arm_length: {_number(klipper.arm_length[i], MM_DECIMALS, complete)}",
                 f"position_endstop: {_number(klipper.position_endstop[i], MM_DECIMALS, complete)}",
                 *([] if guess and not complete else [rotation])]
    if unknown:
        lines.append(f"# no rotation_distance for {', '.join(unknown)}: its microsteps are not known (no "
                     "source configuration gave them); keep the printer's own")
    return "\n".join(lines + body) + "\n"


def _limits(klipper: KlipperDelta, complete: bool) -> list[str]:
    """``[printer]``'s limits where not Klipper's defaults: ``print_radius``, ``minimum_z_position``."""
    lines = [] if klipper.print_radius is None else \
        [f"print_radius: {_number(klipper.print_radius, MM_DECIMALS, complete)}"]
    if klipper.minimum_z_position != 0.0:
        lines.append(f"minimum_z_position: {_number(klipper.minimum_z_position, MM_DECIMALS, complete)}")
    return lines


def _number(value: float, decimals: int, exact: bool) -> str:
    """A value's text: with ``decimals`` decimals, or (``exact``) the shortest that reads back the same."""
    return repr(float(value)) if exact else f"{value:.{decimals}f}"


def _stepping(config: KlipperConfig | None, stepper: str) -> list[str]:
    """A complete configuration's microstepping of a tower: the source's, else 200 full steps × 16."""
    if config is None or not config.has(stepper, "microsteps"):
        return [f"microsteps: {DEFAULT_MICROSTEPS}", f"full_steps_per_rotation: {DEFAULT_FULL_STEPS}"]
    microsteps = config.number(stepper, "microsteps", integer=True, above=0.0)
    full = config.number(stepper, "full_steps_per_rotation", float(DEFAULT_FULL_STEPS), integer=True,
                         above=0.0)
    gear = [f"gear_ratio: {config.text(stepper, 'gear_ratio')}"] if config.has(stepper, "gear_ratio") else []
    return [f"microsteps: {int(microsteps)}", f"full_steps_per_rotation: {int(full)}", *gear]


def save_klipper_config(path: str | Path, klipper: KlipperDelta,
                        source_config: str | Path | KlipperConfig | None = None, title: str = "",
                        notes: list[str] | tuple[str, ...] = (), complete: bool = False) -> Path:
    """Write :func:`klipper_config_text` to ``path`` atomically; returns the path."""
    return atomic_write_text(path, klipper_config_text(klipper, source_config, title, notes, complete))
