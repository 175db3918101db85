"""The ``[gcode_macro NAME]`` sections of ``printer.cfg``, read for where each leaves the nozzle.

Klipper (``klippy/extras/gcode_macro.py``) registers each macro under its name in upper case
(names are case-insensitive) and runs its ``gcode:`` option as a Jinja2 template whose
expressions are ``{...}`` and statements ``{% ... %}``; ``rename_existing`` keeps the built-in
command of the same name under a new one. deltacal does not run the templates: it reads them,
line by line, for what moves the nozzle or changes the modes (:class:`~deltacal.gcode.dialect.MacroStep`):

* G28 (every carriage at its endstop), G0/G1 with literal numbers, G90/G91, M82/M83, G92 E,
  ``SAVE_GCODE_STATE`` and ``RESTORE_GCODE_STATE`` (``MOVE=1`` moves back);
* a call of another macro, read the same way (nested at most :data:`MAX_DEPTH` deep; Klipper
  refuses a macro that calls itself);
* anything else (heating, waiting, fans, messages, ``{% set %}``) leaves the position as it was.

The end position is unknown (:attr:`~deltacal.gcode.dialect.MacroEffect.unknown`, said by
naming the macro) where a Jinja condition or loop (``{% if %}``, ``{% for %}``) holds a homing, a
move, a mode or a macro that moves; where an expression gives a move's X, Y or Z
(``G1 Z{params.Z}``) or the command itself; and after an arc, a probing or a calibration
(``PROBE``, ``BED_MESH_CALIBRATE``, ``DELTA_CALIBRATE``, ...), which leave the nozzle where only
the printer knows. An E an expression gives makes the extruder's position unknown.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from types import MappingProxyType

from ....gcode.dialect import MacroEffect, MacroStep, command_params
from .config import KlipperConfig

__all__ = ["MAX_DEPTH", "MESH_ON", "MOVING_COMMANDS", "read_macros", "with_moving_commands"]

#: Macros nested deeper than this are not followed (their caller's end is unknown).
MAX_DEPTH = 10
#: Klipper's commands that leave the nozzle where only the printer knows.
MOVING_COMMANDS = frozenset((
    "G2", "G3", "G29", "G30", "G38.2", "G38.3", "G38.4", "G38.5", "PROBE", "PROBE_ACCURACY",
    "PROBE_CALIBRATE", "BED_MESH_CALIBRATE", "DELTA_CALIBRATE", "DELTA_ANALYZE", "Z_TILT_ADJUST",
    "QUAD_GANTRY_LEVEL", "SCREWS_TILT_CALCULATE", "BED_TILT_CALIBRATE", "MANUAL_PROBE",
    "Z_ENDSTOP_CALIBRATE", "SET_KINEMATIC_POSITION", "FORCE_MOVE", "RESUME",
))
#: What a command that turns Klipper's bed mesh on does (said of the program's line that runs it).
MESH_ON = ("turns Klipper's bed mesh on: Klipper adds it to every move, on top of deltacal's correction, "
           "which already holds the bed the calibration measured (the first layer corrected twice): leave "
           "it out, or send BED_MESH_CLEAR after it")
#: Why a program's line running one of them leaves the position unknown.
_COMMAND_UNKNOWN = "it leaves the nozzle where only the printer knows"
#: A placeholder for the value of a Jinja expression.
_EXPRESSION = "\x00"
_PARTS = re.compile(r"([A-Z_]+|[A-Z*])")  # klippy/gcode.py's split of a command line
_TRADITIONAL = re.compile(r"[A-Z][0-9]")
_STATES = (MacroStep.SAVE, MacroStep.RESTORE)
_OPEN = ("if", "for", "macro", "call", "filter", "with", "raw")
_CLOSE = ("endif", "endfor", "endmacro", "endcall", "endfilter", "endwith", "endraw")


def with_moving_commands(macros: MappingProxyType) -> MappingProxyType:
    """The macros, and Klipper's own commands that a program's line may run and that move the nozzle.

    A program's ``BED_MESH_CALIBRATE`` or ``PROBE`` leaves the nozzle where only the printer
    knows, as in a macro; a macro of the same name (``rename_existing``) is the macro. The G-codes
    of :data:`MOVING_COMMANDS` (arcs, G29, G30, G38.x) are read as G-code, and ``RESUME`` in a
    program goes back where its ``PAUSE`` left the program. A program's own ``SAVE_GCODE_STATE``
    and ``RESTORE_GCODE_STATE`` save and restore states as in a macro, with the line's ``NAME`` and
    ``MOVE`` (:meth:`~deltacal.gcode.dialect.MacroEffect.on_line`).

    Args:
        macros: The configuration's macros (:func:`read_macros`).

    Returns:
        Name (upper case) -> effect, the macros' first.
    """
    commands = {name: MacroEffect(name, unknown=_COMMAND_UNKNOWN, builtin=True)
                for name in MOVING_COMMANDS if not _TRADITIONAL.match(name) and name != "RESUME"}
    for name, step in (("SAVE_GCODE_STATE", MacroStep.SAVE), ("RESTORE_GCODE_STATE", MacroStep.RESTORE)):
        commands[name] = MacroEffect(name, ((step, {}, ""),), builtin=True, from_line=True)
    commands["BED_MESH_CALIBRATE"] = replace(commands["BED_MESH_CALIBRATE"], warning=f"it probes the bed and "
                                             f"{MESH_ON}")
    commands["BED_MESH_PROFILE"] = MacroEffect("BED_MESH_PROFILE", builtin=True, warning=f"it {MESH_ON}",
                                               warn_with="LOAD")
    return MappingProxyType({**commands, **macros})


@dataclass(frozen=True)
class _Line:
    """A line of a template: its text (expressions as a placeholder), and whether a condition holds it."""

    text: str
    conditional: bool


@dataclass
class _Reading:
    """What a macro does, gathered step by step (the first reason its end is unknown)."""

    steps: list = field(default_factory=list)
    unknown: str = ""
    refused: str = ""
    warning: str = ""

    def unknowable(self, why: str) -> None:
        if not self.unknown:
            self.unknown = why

    def refuse(self, why: str) -> None:
        if not self.refused:
            self.refused = why

    def warn(self, what: str) -> None:
        if not self.warning:
            self.warning = what


def read_macros(config: KlipperConfig) -> MappingProxyType:
    """Every ``[gcode_macro NAME]`` of a configuration, read (name upper case -> its effect)."""
    templates: dict[str, str] = {}
    renamed: dict[str, str] = {}  # a built-in's new name -> its own
    for section, options in config.sections.items():
        words = section.split()
        if len(words) == 2 and words[0].lower() == "gcode_macro":
            name = words[1].upper()
            templates[name] = options.get("gcode", "")
            if options.get("rename_existing"):
                renamed[options["rename_existing"].strip().upper()] = name
    reader = _MacroReader(templates, renamed)
    return MappingProxyType({name: reader.effect(name, ()) for name in templates})


class _MacroReader:
    """Reads the macros' templates, each once (nested calls from the readings before)."""

    def __init__(self, templates: dict[str, str], renamed: dict[str, str]) -> None:
        self.templates = templates
        self.renamed = renamed
        self.done: dict[str, MacroEffect] = {}

    def effect(self, name: str, calling: tuple[str, ...]) -> MacroEffect:
        """The effect of macro ``name``, called through ``calling``."""
        if name in self.done:
            return self.done[name]
        if name in calling:
            return MacroEffect(name, (), f"it calls itself through {' -> '.join((*calling, name))}")
        if len(calling) >= MAX_DEPTH:
            return MacroEffect(name, (), f"macros nested more than {MAX_DEPTH} deep")
        reading = _Reading()
        for line in _lines(self.templates[name]):
            self.command(line, reading, (*calling, name))
        effect = MacroEffect(name, tuple(reading.steps), reading.unknown, refused=reading.refused,
                             warning=reading.warning)
        self.done[name] = effect
        return effect

    def command(self, line: _Line, reading: _Reading, calling: tuple[str, ...]) -> None:
        """One line of a template: its steps, or why the end is unknown."""
        text = line.text.split(";", 1)[0].strip().upper()
        if not text:
            return
        parts = _PARTS.split(text)
        cmd = "".join(parts[:3]).strip()
        params = {parts[i]: parts[i + 1].strip().lstrip("=").strip() for i in range(3, len(parts) - 1, 2)}
        if _EXPRESSION in cmd or not cmd:
            reading.unknowable(f"a Jinja expression gives the command {line.text.strip()!r}")
            return
        if cmd in self.renamed:  # the built-in a macro replaced, under its new name
            cmd = self.renamed[cmd]
        elif cmd in self.templates:
            self.nested(cmd, line, reading, calling)
            return
        loads = cmd == "BED_MESH_PROFILE" and "LOAD" in (command_params(text) or {})
        if cmd == "BED_MESH_CALIBRATE" or loads:
            reading.warn(f"it runs {line.text.strip()}, which {MESH_ON}")
        if _TRADITIONAL.match(cmd) and cmd[0] in "GM":
            _traditional(cmd, params, line, reading)
        elif cmd in ("SAVE_GCODE_STATE", "RESTORE_GCODE_STATE"):
            _state(cmd, line, reading)
        elif cmd in MOVING_COMMANDS or cmd == "SET_GCODE_OFFSET" and params.get("MOVE", "0") not in ("0", ""):
            reading.unknowable(f"{cmd} leaves the nozzle where only the printer knows")

    def nested(self, cmd: str, line: _Line, reading: _Reading, calling: tuple[str, ...]) -> None:
        """A call of another macro."""
        effect = self.effect(cmd, calling)
        if effect.warning:
            reading.warn(f"it runs {cmd}: {effect.warning}")
        if not effect.moves:
            return
        if line.conditional:
            reading.unknowable(f"{cmd}, which moves the nozzle, under a Jinja condition")
        if effect.unknown:
            reading.unknowable(f"{cmd}: {effect.unknown}")
        if effect.refused:
            reading.refuse(f"{cmd}: {effect.refused}")
        conditional = {"CONDITIONAL": 1.0} if line.conditional else {}
        reading.steps.extend((step, {**values, **conditional} if step in _STATES else values, name)
                             for step, values, name in effect.steps)


def _state(cmd: str, line: _Line, reading: _Reading) -> None:
    """SAVE_GCODE_STATE or RESTORE_GCODE_STATE in a template: ``NAME`` as written (case kept), ``MOVE``."""
    params = command_params(line.text.replace(_EXPRESSION, "{...}"))
    if params is None:
        reading.refuse(f"{line.text.strip()!r}: Klipper answers 'Malformed command' (parameters are "
                       "KEY=value)")
        return
    name = params.get("NAME", "default")
    if "{...}" in name:
        reading.refuse(f"{cmd} NAME={name}: a Jinja expression gives the state's name: which state "
                       "RESTORE_GCODE_STATE brings back cannot be known")
        return
    values = {"CONDITIONAL": 1.0} if line.conditional else {}
    if cmd == "SAVE_GCODE_STATE":
        reading.steps.append((MacroStep.SAVE, values, name))
        return
    move = params.get("MOVE", "0")
    if "{...}" in move:
        reading.unknowable(f"RESTORE_GCODE_STATE MOVE={move}: a Jinja expression says whether it moves back")
    elif move.lstrip("+-").isdigit() and int(move):
        values["MOVE"] = 1.0
        if line.conditional:
            reading.unknowable("RESTORE_GCODE_STATE MOVE=1 under a Jinja condition")
    elif not move.lstrip("+-").isdigit():
        reading.refuse(f"RESTORE_GCODE_STATE MOVE={move}: not an integer, Klipper stops there")
    reading.steps.append((MacroStep.RESTORE, values, name))


def _traditional(cmd: str, params: dict[str, str], line: _Line, reading: _Reading) -> None:
    """A G or M command of a template."""
    known = {"G28": MacroStep.HOME, "G90": MacroStep.ABSOLUTE, "G91": MacroStep.RELATIVE,
             "M82": MacroStep.E_ABSOLUTE, "M83": MacroStep.E_RELATIVE}
    number = cmd[1:].lstrip("0") or "0"
    cmd = cmd[0] + number
    if cmd in known:
        if line.conditional:
            reading.unknowable(f"{cmd} under a Jinja condition")
        reading.steps.append((known[cmd], {}, ""))
    elif cmd in ("G0", "G1"):
        _move(cmd, params, line, reading)
    elif cmd == "G92":
        if set(params) & set("XYZ") or not params:
            reading.unknowable("G92 sets X, Y or Z")
        elif "E" in params:
            value = _number(params["E"])
            step = MacroStep.E_UNKNOWN if value is None or line.conditional else MacroStep.SET_E
            reading.steps.append((step, {} if value is None else {"E": value}, ""))
    elif cmd in MOVING_COMMANDS:
        reading.unknowable(f"{cmd} leaves the nozzle where only the printer knows")


def _move(cmd: str, params: dict[str, str], line: _Line, reading: _Reading) -> None:
    """G0/G1 in a template."""
    values: dict[str, float] = {}
    for axis in "XYZ":
        if axis in params:
            value = _number(params[axis])
            if value is None:
                reading.unknowable(f"{cmd} {axis}{params[axis].replace(_EXPRESSION, '{...}')}: "
                                   "a Jinja expression gives the coordinate")
            else:
                values[axis] = value
    if values and line.conditional:
        reading.unknowable(f"{cmd} under a Jinja condition")
    if "E" in params:
        value = _number(params["E"])
        if value is None or line.conditional:
            reading.steps.append((MacroStep.E_UNKNOWN, {}, ""))
        else:
            values["E"] = value
    if values:
        reading.steps.append((MacroStep.MOVE, values, ""))


def _number(text: str) -> float | None:
    """A literal number, or None (an expression, or not a number)."""
    try:
        return float(text)
    except ValueError:
        return None


def _lines(template: str) -> list[_Line]:
    """The template's lines, expressions replaced by a placeholder (``action_...`` calls by nothing)."""
    lines: list[_Line] = []
    text: list[str] = []
    conditional = False
    depth = 0
    i = 0
    while i < len(template):
        c = template[i]
        if c == "{" and template.startswith("{%", i):
            end = template.find("%}", i + 2)
            end = len(template) if end < 0 else end + 2
            word = template[i + 2:end - 2].strip().lstrip("-+").strip().split(" ", 1)[0]
            depth += (word in _OPEN) - (word in _CLOSE)
            conditional = conditional or depth > 0
            i = end
        elif c == "{":
            end, level = i + 1, 1
            while end < len(template) and level:
                level += {"{": 1, "}": -1}.get(template[end], 0)
                end += 1
            expression = template[i + 1:end - 1].strip()
            text.append("" if expression.startswith("action_") else _EXPRESSION)
            conditional = conditional or depth > 0
            i = end
        elif c == "\n":
            lines.append(_Line("".join(text), conditional))
            text, conditional = [], False
            i += 1
        else:
            text.append(c)
            conditional = conditional or (depth > 0 and not c.isspace())
            i += 1
    lines.append(_Line("".join(text), conditional))
    return lines
