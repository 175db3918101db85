"""RepRapFirmware's ``config.g`` / ``config-override.g`` read as RRF runs it, and its lines written.

RRF runs ``config.g`` line by line at start-up (``src/GCodes``): a ``;`` starts a comment outside
a quoted string, ``(...)`` is a comment, parameter letters are read in any case, a list is
``a:b:c``. deltacal runs the lines that set the delta kinematics, in order, later values winning:

* ``M665 L R H B X Y Z`` and ``M666 X Y Z A B`` (:mod:`.model` gives each value's meaning;
  ``LinearDeltaKinematics::Configure``): ``L`` one number or ``a:b:c``;
* ``M92 X Y Z [S]``: steps per mm; with ``S`` the value is for that microstepping and is scaled
  to the current one (``Platform::SetDriveStepsPerUnit``); ``M350 X Y Z`` changes the
  microstepping (default x16) and scales the steps per mm already set (``GCodes::ChangeMicrostepping``);
* ``M208``: the Z minimum (``S1 Z``, or ``Zmin:max``); ``M564 S``: the limits on or off;
* ``M669 K`` (the kinematics): only 3 (linear delta) is read;
* ``M501`` runs ``config-override.g`` and ``M98 P"file"`` the file named, where they stand (RRF's
  ``/sys``, config.g's folder, for a relative name, ``/sys/x.g`` and ``0:/sys/x.g`` in it, another
  absolute name under the folder above: :func:`macro_path`); one not there is skipped with a
  warning naming the line, a file calling itself refused;
* ``G31 X Y Z`` of the first Z probe (``K0``, or no ``K``): the probe's offsets from the nozzle
  and its trigger height (``ZProbe::HandleG31``; RRF's defaults X0 Y0 Z0.7), for the probe's
  results (:func:`rrf_probe_offsets`); ``M558 H`` of the same probe: its dive height above the
  trigger height (``H5``, or ``H5:2`` in RRF 3.5.1; default 5), for the probe program's travel;
  ``M558 P0`` of that probe: no probe, RRF's manual probing (:func:`rrf_manual_probe`);
* ``M579`` (axis scaling, ``GCodes::ToolOffsetTransform``) and ``M556 S X Y Z`` (axis skew,
  ``Move::AxisTransform``) move the nozzle off RRF's delta model: deltacal does not model them, so
  a value other than the identity (scale 1, skew 0) is refused naming its line.

Meta commands (:mod:`.meta`): a delta setting inside an ``if``/``elif``/``else``/``while`` block is
refused naming its line; a variable set to a plain number (``global rodLength = 280``) is read
where a parameter is exactly that variable (``M665 L{global.rodLength}``). Any other value RRF
computes at run time (``{...}``) cannot be read: it is refused naming its line. Every value is held
to what a printer can be (:data:`BOUNDS`). Everything else is left alone. Errors are one line
naming the file, the line and the key.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from warnings import warn

import numpy as np

from ....exceptions import GeometryError, InputError, InputWarning
from ....io.atomic import atomic_write_text
from ..bounds import (
    ADJUSTMENT,
    LENGTH,
    MICROSTEPS,
    POSITION,
    PROBE_OFFSET,
    STEPS_PER_MM,
    TILT_PERCENT,
    TRIM_ANGLE,
)
from ..content import is_rrf_commands, read_commands
from ..probe_log import ProbeOffsets
from .meta import Blocks, Variables, substitute
from .model import (
    DEFAULT_DIAGONAL,
    DEFAULT_HOMED_HEIGHT,
    DEFAULT_MICROSTEPPING,
    DEFAULT_PRINT_RADIUS,
    DEFAULT_RADIUS,
    RRFDelta,
)

#: The M-codes deltacal runs.
READ_CODES = (92, 208, 350, 501, 558, 564, 665, 666, 669)
#: The M-code that runs another file: ``M98 P"file"``.
CALLS = (98,)
#: What moves the nozzle off RRF's delta model and deltacal does not model: ``M556`` (axis skew),
#: ``M579`` (axis scaling); read to refuse a value that is not the identity.
UNREAD_GEOMETRY = (556, 579)
#: ``M669 K``: RRF's kinematics number of a linear delta.
LINEAR_DELTA = 3
#: RRF's Z probe trigger height when no ``G31 Z`` sets it (``DefaultZProbeTriggerHeight``) [mm].
DEFAULT_TRIGGER_HEIGHT = 0.7
#: The file ``M501`` runs.
OVERRIDE = "config-override.g"
#: How to put the lines :func:`rrf_config_text` writes into the printer (its header's second line) when
#: the configuration is not known (:func:`~.apply.rrf_apply_note` says it for one): ``M500`` saves
#: ``M665`` and ``M666`` to config-override.g, not ``M92``, and rewrites that file.
APPLY_NOTE = ("Replace the M665, M666 and M92 lines where the printer's configuration sets them last: "
              "M665 and M666 in config-override.g when config.g runs M501 after its own (M500 saves them "
              "there), else in config.g; M92 in config.g (M500 does not save M92).")
#: What each value deltacal reads can be (:mod:`..bounds`), by its command and key.
BOUNDS = {"M665 L": LENGTH, "M665 R": LENGTH, "M665 B": LENGTH, "M665 H": POSITION, "M665 X": TRIM_ANGLE,
          "M665 Y": TRIM_ANGLE, "M665 Z": TRIM_ANGLE, "M666 X": ADJUSTMENT, "M666 Y": ADJUSTMENT,
          "M666 Z": ADJUSTMENT, "M666 A": TILT_PERCENT, "M666 B": TILT_PERCENT, "M92 X": STEPS_PER_MM,
          "M92 Y": STEPS_PER_MM, "M92 Z": STEPS_PER_MM, "M92 S": MICROSTEPS, "M350 X": MICROSTEPS,
          "M350 Y": MICROSTEPS, "M350 Z": MICROSTEPS, "M208 Z": POSITION, "G31 X": PROBE_OFFSET,
          "G31 Y": PROBE_OFFSET, "G31 Z": PROBE_OFFSET, "M558 H": PROBE_OFFSET}
#: A line's command: an optional line number, then G/M/T and its number.
_COMMAND = re.compile(r"^\s*(?:N\d+\s*)?([GMT])(\d+)(?:\.\d+)?(?![0-9.])", re.IGNORECASE)
#: A parameter: a letter, then its value (to the next letter outside quotes; an expression ``{...}``
#: whole; an ``E`` after a digit is an exponent, as RRF's ``StringParser::Seen`` takes it).
_PARAM = re.compile(r"([A-Za-z])\s*((?:\"[^\"]*\"|\{[^}]*\}?|(?<=[0-9.])[eE][-+]?(?=\d)|[^A-Za-z\"{])*)")
#: ``M98``'s file: ``P"name"``, or (RRF 1.x/2.x) ``Pname`` up to white space.
_FILE_NAME = re.compile(r"[Pp]\s*(?:\"([^\"]*)\"|([^\s\"]+))")


@dataclass
class RRFLine:
    """One command of a configuration file.

    Attributes:
        source: The file.
        line: Its line number (1-based).
        code: ``"M665"``...
        params: Letter (upper case) -> value text.
        rest: The line's text after the command, its comment stripped.
    """

    source: str
    line: int
    code: str
    params: dict[str, str]
    rest: str = ""

    def error(self, key: str, detail: str) -> InputError:
        """A one-line error naming the file, the line and the key."""
        return InputError(detail, self.source, f"line {self.line}, {self.code} {key}")

    def numbers(self, key: str, count: int = 1) -> list[float]:
        """A parameter's numbers (``a:b:c`` gives several): 1 or ``count`` of them, within :data:`BOUNDS`."""
        text = self.params[key].strip()
        if "{" in text:
            raise self.error(
                key, f"value {text!r} is an expression RRF computes when it runs: write the number"
            )
        parts = text.split(":")
        try:
            values = [float(v) for v in parts]
        except ValueError:
            raise self.error(key, f"value {text!r} is not a number") from None
        if not all(math.isfinite(v) for v in values):
            raise self.error(key, f"value {text!r} is not a finite number")
        bound = BOUNDS.get(f"{self.code} {key}")
        problems = [bound.problem(v) for v in values] if bound is not None else []
        problem = next((p for p in problems if p is not None), None)
        if problem is not None:
            raise self.error(key, f"value {text!r} {problem}")
        if len(values) not in (1, count):
            raise self.error(key, f"value {text!r}: give 1 or {count} numbers")
        return values

    def number(self, key: str, above: float | None = None) -> float:
        """A parameter's one number (above ``above`` when given)."""
        values = self.numbers(key)
        if len(values) != 1:
            raise self.error(key, f"value {self.params[key]!r}: give one number")
        if above is not None and not values[0] > above:
            raise self.error(key, f"value {self.params[key]!r} must be above {above:g}")
        return values[0]


def strip_comment(line: str) -> str:
    """A line without its ``;`` comment and ``(...)`` comments (quoted strings kept)."""
    out, quoted, depth = [], False, 0
    for ch in line:
        if ch == '"':
            quoted = not quoted
        elif not quoted and ch == ";":
            break
        elif not quoted and ch == "(":
            depth += 1
            continue
        elif not quoted and ch == ")" and depth:
            depth -= 1
            continue
        if not depth:
            out.append(ch)
    return "".join(out)


def parse_line(text: str, source: str, number: int) -> RRFLine | None:
    """A line's command and parameters, or None (no G/M/T command: a comment, a meta command)."""
    text = strip_comment(text)
    match = _COMMAND.match(text)
    if match is None:
        return None
    code = match.group(1).upper() + str(int(match.group(2)))
    rest = text[match.end() :]
    params = {m.group(1).upper(): m.group(2).strip() for m in _PARAM.finditer(rest)}
    return RRFLine(source, number, code, params, rest)


def is_rrf_config(path: str | Path) -> bool:
    """Whether a file is a RepRapFirmware configuration: a ``*.g`` file that runs M665 or M669.

    Told by the commands it runs, never by its comments, and no Marlin ``M503`` capture
    (:func:`~..content.is_rrf_commands`).
    """
    if Path(path).suffix.lower() != ".g":
        return False
    commands = read_commands(path)
    return commands is not None and is_rrf_commands(path, commands)


@dataclass
class RRFSettings:
    """The delta settings of a configuration as RRF leaves them after running it.

    Attributes:
        source: The file.
        values: Key (``"M665 L"``) -> its value(s).
        where: Key -> the line that set it last (for messages).
        microstepping: Each tower's microstepping (M350), (3,).
        overrides: The ``M501`` lines run, in order (``config-override.g`` read when it is there).
    """

    source: str
    values: dict[str, list[float]] = field(default_factory=dict)
    where: dict[str, RRFLine] = field(default_factory=dict)
    microstepping: list[float] = field(default_factory=lambda: [float(DEFAULT_MICROSTEPPING)] * 3)
    overrides: list[RRFLine] = field(default_factory=list)

    def set(self, line: RRFLine, key: str, values: list[float]) -> None:
        """Keep a value and the line that set it."""
        self.values[f"{line.code} {key}"] = values
        self.where[f"{line.code} {key}"] = line

    def get(self, key: str, default: float) -> float:
        """A key's one value, or the default."""
        return self.values[key][0] if key in self.values else default

    def error(self, key: str, detail: str) -> InputError:
        """A one-line error naming the line that set ``key``, or the file."""
        line = self.where.get(key)
        if line is None:
            return InputError(detail, self.source, f"key {key}")
        return line.error(key.split()[1], detail)


def read_rrf_settings(path: str | Path) -> RRFSettings:
    """The delta settings a configuration leaves, its lines run in order (``M501`` and ``M98`` included).

    Raises:
        InputError: naming the file, line and key of the first problem found.
    """
    settings = RRFSettings(str(path))
    _run(Path(path), settings, [], Variables(), Path(path).parent)
    return settings


def _run(path: Path, settings: RRFSettings, running: list[Path], variables: Variables, sys_dir: Path) -> None:
    """Run one file's lines (``running``: the files calling it; ``sys_dir``: RRF's ``/sys``)."""
    try:
        text = path.read_text(encoding="utf-8").replace("\r\n", "\n")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the RepRapFirmware configuration file: {exc}", str(path)) from None
    running.append(path.resolve())
    blocks = Blocks()
    for number, raw in enumerate(text.split("\n"), start=1):
        bare = strip_comment(raw)
        block = blocks.enter(bare, number)
        if variables.read(bare, str(path), number, block):
            continue
        line = parse_line(raw, str(path), number)
        if line is None or not _is_read(line):
            continue
        if block is not None:
            raise InputError(f"{line.code} inside the '{block.keyword}' block of line {block.line}: which "
                             "branch RRF runs is known only when it runs the file: write the values that "
                             "apply without the condition", str(path), f"line {number}")
        try:
            line.params = substitute(line.params, variables, str(path), number, line.code)
        except InputError:
            if line.code != "M558":  # the dive height: refused where the probe program needs it alone
                raise
        if line.code in ("M98", "M501"):
            _call(line, settings, running, variables, sys_dir)
        elif line.code == "G31":
            _apply_g31(line, settings)
        else:
            _apply(line, settings)
    running.pop()


def _is_read(line: RRFLine) -> bool:
    """Whether deltacal runs the command (:data:`READ_CODES`, ``M98``, ``G31``, :data:`UNREAD_GEOMETRY`)."""
    return line.code == "G31" or (line.code[0] == "M" and int(line.code[1:]) in (*READ_CODES, *CALLS,
                                                                                   *UNREAD_GEOMETRY))


def _call(line: RRFLine, settings: RRFSettings, running: list[Path], variables: Variables,
          sys_dir: Path) -> None:
    """Run the file ``M501`` (config-override.g) or ``M98 P"file"`` calls, where RRF finds it."""
    if line.code == "M501":
        name, called = OVERRIDE, sys_dir / OVERRIDE
        if called.resolve() in running:
            return  # config-override.g running M501 again: RRF reads its values once
        settings.overrides.append(line)
    else:
        given = _FILE_NAME.search(line.rest)
        if given is None or "{" in given.group(0):
            raise line.error("P", f"value {line.params.get('P', '')!r}: the file RRF runs is not known "
                             "without running it (an expression, or none): write its name")
        name = given.group(1) if given.group(1) is not None else given.group(2)
        called = macro_path(name, sys_dir)
        if called.resolve() in running:
            raise line.error("P", f"{name} calls itself (through {Path(running[-1]).name}): RRF would run it "
                             "until its macro stack is full")
    if not called.exists():
        # issued from this line (stacklevel 1): Python's registry says it once however many times one
        # command reads config.g (plan reads it for the model and again for the probe's travel)
        warn(f"{line.source}: line {line.line}: {line.code} runs {name}, not found at {called}: its values "
             "(if any) are not read", InputWarning, stacklevel=1)
        return
    if not called.is_file():
        raise InputError(f"{line.code} runs {called}, not a regular file (a folder, a pipe, a device)",
                         line.source, f"line {line.line}")
    _run(called, settings, running, variables.in_file() if line.code == "M98" else variables, sys_dir)


def macro_path(name: str, sys_dir: Path) -> Path:
    """Where RRF finds the file ``M98 P"name"`` runs: relative to ``/sys`` (``sys_dir``), or absolute.

    ``0:/sys/x.g`` and ``/sys/x.g`` are in ``sys_dir``; another absolute path (``/macros/x.g``) is
    under the SD card's root, the folder above ``sys_dir``.
    """
    name = re.sub(r"^\d+:", "", name.replace("\\", "/"))
    if not name.startswith("/"):
        return sys_dir / name
    parts = [part for part in name.split("/") if part]
    if parts and parts[0].lower() == "sys":
        return sys_dir.joinpath(*parts[1:])
    return sys_dir.parent.joinpath(*parts)


def _apply(line: RRFLine, settings: RRFSettings) -> None:
    """One command's effect on the settings (see the module's documentation)."""
    p = line.params
    if line.code == "M665":
        if "L" in p:
            settings.set(line, "L", line.numbers("L", 3))
        for key in ("R", "H", "B", "X", "Y", "Z"):
            if key in p:
                settings.set(line, key, [line.number(key, 0.0 if key in "RB" else None)])
    elif line.code == "M666":
        for key in ("X", "Y", "Z", "A", "B"):
            if key in p:
                settings.set(line, key, [line.number(key)])
    elif line.code == "M92":
        scale = line.number("S", 0.0) if "S" in p else None
        for i, key in enumerate("XYZ"):
            if key in p:
                value = line.number(key, 0.0)
                if scale is not None:
                    value *= settings.microstepping[i] / scale
                settings.set(line, key, [value])
    elif line.code == "M350":
        for i, key in enumerate("XYZ"):
            if key in p:
                new = line.number(key, 0.0)
                if "M92 " + key in settings.values:
                    settings.values["M92 " + key] = [
                        settings.values["M92 " + key][0] * new / settings.microstepping[i]
                    ]
                settings.microstepping[i] = new
    elif line.code == "M208":
        _apply_m208(line, settings)
    elif line.code == "M564" and "S" in p:
        settings.set(line, "S", [line.number("S")])
    elif line.code == "M669" and "K" in p:
        settings.set(line, "K", [line.number("K")])
    elif line.code == "M558" and p.get("K", "0").strip() in ("0", ""):
        _apply_m558(line, settings)
    elif line.code == "M579" or (line.code == "M556" and "S" in p):
        _refuse_unread(line)


def _apply_m558(line: RRFLine, settings: RRFSettings) -> None:
    """``M558 P H`` of the first Z probe: its type (0: none, RRF's manual probing) and its dive height.

    A value RRF computes (an expression) is kept as NaN: refused only where it is needed (the
    probe program's travel; whether the probe is manual).
    """
    for key, count in (("P", 1), ("H", 2)):
        if key in line.params:
            try:
                settings.set(line, key, line.numbers(key, count))
            except InputError:
                settings.set(line, key, [math.nan])


def rrf_manual_probe(settings: RRFSettings) -> RRFLine | None:
    """The ``M558 P0`` line that leaves the first Z probe manual (``ZProbeType::none``), or None.

    With it, ``G30`` asks the user to jog the nozzle down to the bed (``GCodes::DoManualBedProbe``,
    "Adjust height until the nozzle just touches the bed, then press OK") and ``G30 S-1`` answers
    ``Stopped at height Z mm``, Z the nozzle's height the user left it at (``probingAtPoint4``):
    the height of the paper test, not less ``G31 Z``. A configuration without ``M558`` is read as
    having a probe (RRF's defaults), as before.

    Raises:
        InputError: an ``M558 P`` that is not a number (an expression RRF computes), naming its line.
    """
    probe_type = settings.values.get("M558 P")
    if probe_type is None:
        return None
    if not np.isfinite(probe_type[0]):
        raise settings.error("M558 P", "the probe's type is not a number deltacal reads (an expression RRF "
                                       "computes?): whether the printer probes by hand (P0) is not known; "
                                       "write the number")
    return settings.where["M558 P"] if probe_type[0] == 0 else None


def _refuse_unread(line: RRFLine) -> None:
    """Refuse an ``M579`` axis scaling other than 1, an ``M556`` axis skew other than 0."""
    scaling = line.code == "M579"
    for key in ("X", "Y", "Z"):
        if key in line.params and line.number(key) != (1.0 if scaling else 0.0):
            what = ("axis scaling (M579: RRF multiplies each coordinate by it before its delta kinematics, "
                    "GCodes::ToolOffsetTransform)" if scaling else
                    "axis skew compensation (M556: RRF shears X and Y with Z before its delta kinematics, "
                    "Move::AxisTransform)")
            raise line.error(key, f"value {line.params[key]!r}: {what} is not in deltacal's model of RRF: "
                                  "remove it (M579 X1 Y1 Z1, M556 S1 X0 Y0 Z0) and let the calibration find "
                                  "the geometry")


def _apply_g31(line: RRFLine, settings: RRFSettings) -> None:
    """``G31 X Y Z`` of the first Z probe (``K0`` or no ``K``): its offsets and trigger height."""
    if "K" in line.params and line.number("K") != 0:
        return
    for key in ("X", "Y", "Z"):
        if key in line.params:
            settings.set(line, key, [line.number(key)])


def rrf_probe_offsets(settings: RRFSettings) -> ProbeOffsets:
    """The first Z probe's ``G31 X Y`` offsets and ``G31 Z`` trigger height (RRF's defaults if unset) [mm]."""
    return ProbeOffsets(settings.get("G31 X", 0.0), settings.get("G31 Y", 0.0),
                        settings.get("G31 Z", DEFAULT_TRIGGER_HEIGHT))


def _apply_m208(line: RRFLine, settings: RRFSettings) -> None:
    """``M208``'s Z minimum: ``Zmin:max``, or ``S1 Z`` (a lone Z without S1 is the maximum)."""
    if "Z" not in line.params:
        return
    values = line.numbers("Z", 2)
    if len(values) == 2:
        if not values[1] > values[0]:
            raise line.error("Z", f"value {line.params['Z']!r}: the maximum must be above the minimum")
        settings.set(line, "Z", [values[0]])
    elif "S" in line.params and line.number("S") == 1:
        settings.set(line, "Z", values)


def rrf_from_settings(settings: RRFSettings) -> RRFDelta:
    """RRF's delta model from the settings a configuration leaves (:func:`read_rrf_settings`).

    Raises:
        InputError: naming the file, line and key of the first problem found.
    """
    if "M669 K" in settings.values and settings.values["M669 K"][0] != LINEAR_DELTA:
        raise settings.error(
            "M669 K",
            f"value {settings.values['M669 K'][0]:g}: deltacal reads RRF's linear delta "
            f"printers (M669 K{LINEAR_DELTA})",
        )
    if "M665 L" not in settings.values and "M665 R" not in settings.values:
        raise InputError(
            "no M665 (the delta's rods and radius): not a linear delta's configuration", settings.source
        )
    for key in ("M92 X", "M92 Y", "M92 Z"):
        if key not in settings.values:
            raise InputError(f"no {key} (the towers' steps per mm)", settings.source)
    diagonal = settings.values.get("M665 L", [DEFAULT_DIAGONAL])
    steps = np.array([settings.values[k][0] for k in ("M92 X", "M92 Y", "M92 Z")])
    try:
        return RRFDelta(
            diagonal=np.broadcast_to(diagonal, 3).copy(),
            radius=settings.get("M665 R", DEFAULT_RADIUS),
            homed_height=settings.get("M665 H", DEFAULT_HOMED_HEIGHT),
            angle_correction=np.radians([settings.get(f"M665 {k}", 0.0) for k in "XYZ"]),
            endstop_adjustment=np.array([settings.get(f"M666 {k}", 0.0) for k in "XYZ"]),
            tilt=np.array([settings.get("M666 A", 0.0), settings.get("M666 B", 0.0)]) / 100.0,
            step_distance=1.0 / steps,
            print_radius=settings.get("M665 B", DEFAULT_PRINT_RADIUS),
            z_min=settings.get("M208 Z", 0.0),
            limit_axes=settings.get("M564 S", 1.0) > 0.0,
            name=Path(settings.source).name,
        )
    except GeometryError as exc:
        key = "M665 L" if "diagonal" in str(exc) else "M665 R"
        raise settings.error(key, str(exc)) from None


def load_rrf(path: str | Path) -> RRFDelta:
    """RRF's delta model from a ``config.g`` or ``config-override.g``.

    Raises:
        InputError: naming the file, line and key of the first problem found.
    """
    return rrf_from_settings(read_rrf_settings(path))


#: Decimals written: lengths [mm], angles [deg], tilt [%], steps per mm.
MM_DECIMALS = 4
DEG_DECIMALS = 4
TILT_DECIMALS = 4
STEPS_DECIMALS = 4


def _number(value: float, decimals: int, exact: bool) -> str:
    return repr(float(value)) if exact else f"{value:.{decimals}f}"


def rrf_config_text(
    rrf: RRFDelta,
    source: str | Path | None = None,
    title: str = "",
    notes: list[str] | tuple[str, ...] = (),
    complete: bool = False,
    apply_note: str = APPLY_NOTE,
) -> str:
    """RRF's values as ``M665``, ``M666`` and ``M92`` lines for ``config-override.g`` (or ``config.g``).

    Writes ``M665 L a:b:c R H B X Y Z``, ``M666 X Y Z A B`` and ``M92 X Y Z``, the steps per mm for
    the microstepping the printer runs (``M350`` of ``source`` if it has one, else x16; ``M92``
    carries ``S`` with it so that RRF scales it should the microstepping differ). Read back by
    :func:`load_rrf` they give the same values to the written decimals (:data:`MM_DECIMALS`...);
    with ``complete`` every value is written exactly (the shortest text that reads back the same
    float), with ``M669 K3``, ``M208 S1 Z`` and ``M564 S`` for the limits.

    Args:
        rrf: The values.
        source: The configuration the printer runs, for its microstepping.
        title: A first comment line (what the values are).
        notes: More comment lines, each after ``; ``.
        complete: A whole configuration, values exact.
        apply_note: How to put the lines into the printer (the second line; not with ``complete``):
            :func:`~.apply.rrf_apply_note` of ``source``.
    """
    micro = (
        read_rrf_settings(source).microstepping if source is not None else [float(DEFAULT_MICROSTEPPING)] * 3
    )
    if len(set(micro)) != 1:
        raise InputError(
            f"the towers' microstepping differs ({', '.join(f'{m:g}' for m in micro)}): "
            "RRF's M92 S applies one to the three",
            str(source),
            "M350",
        )
    mm, deg = (lambda v: _number(v, MM_DECIMALS, complete)), (lambda v: _number(v, DEG_DECIMALS, complete))
    lines = [f"; {title}" if title else "; RepRapFirmware delta values written by deltacal"]
    if not complete:
        lines.append(f"; {apply_note}")
    lines += [f"; {note}".rstrip() for note in notes]
    if complete:
        lines.append(f"M669 K{3}")
    angles = np.degrees(rrf.angle_correction)
    lines.append(
        f"M665 L{':'.join(mm(v) for v in rrf.diagonal)} R{mm(rrf.radius)} H{mm(rrf.homed_height)} "
        f"B{mm(rrf.print_radius)} X{deg(angles[0])} Y{deg(angles[1])} Z{deg(angles[2])}"
    )
    tilt = rrf.tilt * 100.0
    lines.append(
        f"M666 X{mm(rrf.endstop_adjustment[0])} Y{mm(rrf.endstop_adjustment[1])} "
        f"Z{mm(rrf.endstop_adjustment[2])} A{_number(tilt[0], TILT_DECIMALS, complete)} "
        f"B{_number(tilt[1], TILT_DECIMALS, complete)}"
    )
    steps = rrf.steps_per_mm
    lines.append(
        f"M92 X{_number(steps[0], STEPS_DECIMALS, complete)} Y{_number(steps[1], STEPS_DECIMALS, complete)} "
        f"Z{_number(steps[2], STEPS_DECIMALS, complete)} S{micro[0]:g}"
    )
    if complete:
        lines += [f"M208 S1 Z{_number(rrf.z_min, MM_DECIMALS, True)}", f"M564 S{1 if rrf.limit_axes else 0}"]
    return "\n".join(lines) + "\n"


def save_rrf_config(
    path: str | Path,
    rrf: RRFDelta,
    source: str | Path | None = None,
    title: str = "",
    notes: list[str] | tuple[str, ...] = (),
    complete: bool = False,
) -> Path:
    """Write :func:`rrf_config_text` to ``path`` atomically; returns the path."""
    return atomic_write_text(path, rrf_config_text(rrf, source, title, notes, complete))
