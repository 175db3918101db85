"""``export --controller klipper --config printer.cfg --live -o OUTDIR``: the live module and its data.

Writes ``deltacal_geometry.py`` (:mod:`.deltacal_geometry`, the Klipper extra, as the package holds
it) and ``deltacal_geometry.cfg``, its ``[deltacal_geometry]`` section: the Klipper values the
correction was computed for (the module refuses to start under others), the volume it covers,
the correction at the nodes of its grid (:mod:`.field`), where the calibration holds (its σ grid
and the bound a correction's σ is accepted within: the module weights the correction as the
offline route does), the bound that cuts long moves, and the sampling error measured against the
offline route's exact correction. Both are written once everything is
computed, each atomically. Units: mm.
"""

from __future__ import annotations

import base64
import math
import re
import zlib
from dataclasses import dataclass
from functools import singledispatch
from importlib import resources
from pathlib import Path

import numpy as np

from .....calibration import Calibration
from .....exceptions import InputError, UsageError
from .....holds import DEFAULT_BOUND, WhereItHolds
from .....io.atomic import atomic_write_text
from ..config import LIVE_OFF, LIVE_SECTION, LIVE_SECTION_FILE, load_klipper, read_klipper_config
from ..model import KlipperController, KlipperDelta
from ..rotary_controller import KlipperRotaryController
from ..rotary_importer import printable_radius
from ..rotary_model import KlipperRotaryDelta
from .deltacal_geometry import FORMAT, TOWERS
from .field import (
    COVERAGE_NODES,
    DEFAULT_STEP_MM,
    TRUST_NODES,
    CorrectionField,
    LiveVolume,
    RotaryLiveVolume,
    SamplingError,
    correction_field,
    curvature_bounds,
    sampling_error,
)

#: The module's file: copied into ``klippy/extras/``.
MODULE_FILE = f"{LIVE_SECTION}.py"
#: The section's file: ``[include]``d in ``printer.cfg``.
SECTION_FILE = LIVE_SECTION_FILE
#: The files ``export --live`` writes, in its output folder.
LIVE_FILES = (MODULE_FILE, SECTION_FILE)
#: How far a long move's nozzle may leave its straight line [mm]: below a step (0.0125 mm on most
#: printers); the bound is conservative (the path strays less: tests/test_klipper_live.py).
SPLIT_TOLERANCE_MM = 0.01
#: The unit of the correction's values written [mm] (1 nm): 32-bit integers of it.
VALUE_UNIT_MM = 1e-6
#: Characters of a line of the correction's encoded values.
LINE_CHARS = 76
#: How to install it, as the export says and the section's header repeats.
INSTALL_NOTE = ("copy deltacal_geometry.py into klippy/extras/, add [include deltacal_geometry.cfg] to "
                f"printer.cfg and restart Klipper; DELTACAL_GEOMETRY reports it, {LIVE_OFF} turns it off")


@dataclass(frozen=True)
class LiveExport:
    """What ``export --live`` computed and wrote.

    Attributes:
        field: The correction on its grid.
        error: Its sampling error.
        files: The files written (module, section).
        lines: What the command prints.
    """

    field: CorrectionField
    error: SamplingError
    files: tuple[Path, Path]
    lines: tuple[str, ...]


def module_text() -> str:
    """The live module's source, as the package holds it."""
    return resources.files(__package__).joinpath(MODULE_FILE).read_text(encoding="utf-8")


def export_live(calibration: Calibration, config: str | Path, folder: str | Path, source: str = "",
                step: float = DEFAULT_STEP_MM, bound: float = DEFAULT_BOUND,
                rotary: KlipperRotaryController | None = None) -> LiveExport:
    """Compute the live correction of ``calibration`` for Klipper's values in ``config``; write both files.

    Args:
        calibration: The printer's calibration (a linear printer's readings count in its
            ``step_distance``; a rotary printer's in Klipper's frame, the bed's, as ``compensate`` moves it).
        config: The ``printer.cfg`` the printer runs.
        folder: The output folder (made if missing; its parent must exist).
        source: The calibration's file, for the section and the messages.
        step: The grid's spacing [mm].
        bound: The σ of a correction accepted [mm] where the calibration knows where it holds (the
            offline route's ``--sigma-bound``; ``math.inf``: the whole correction everywhere).
        rotary: Klipper's rotary_delta of ``config`` as the controller (a rotary printer's), or None: a
            linear one's ``config``.

    Raises:
        UsageError: a bound below the correction's resolution (:data:`VALUE_UNIT_MM`: the weights
            cannot use it).
        InputError: the configuration's first problem, or a calibration without its step distance.
    """
    if not bound >= VALUE_UNIT_MM:  # half of it may round to 0: the module's weights divide by it
        raise UsageError(f"--sigma-bound {float(bound)!r}: below {VALUE_UNIT_MM:g} mm, the resolution of "
                         "the correction the section writes (its correction_unit), a bound the weights "
                         f"cannot use; give {VALUE_UNIT_MM:g} or more (inf: the whole correction everywhere)")
    klipper: KlipperDelta | KlipperRotaryDelta
    controller: KlipperController | KlipperRotaryController
    if rotary is None:
        klipper = load_klipper(config)
        steps = calibration.geometry.step_distance
        if steps is None:
            raise InputError("no step_distance_mm: the step distance the printer's readings count in is not "
                             "known (identify the printer again)", source, "key geometry.step_distance_mm")
        controller, volume = KlipperController(klipper, steps), LiveVolume.of(klipper)
    else:
        klipper, controller = rotary.firmware, rotary
        printable = printable_radius(read_klipper_config(config), klipper)[0]
        volume = RotaryLiveVolume.of_rotary(klipper, printable)
    field = correction_field(calibration, controller, volume, step, bound)
    error = sampling_error(field, calibration, controller)
    lines = _summary(field, error, klipper)
    text = section_text(field, error, klipper, source, lines)
    folder = Path(folder)
    folder.mkdir(exist_ok=True)
    files = (atomic_write_text(folder / MODULE_FILE, module_text()),
             atomic_write_text(folder / SECTION_FILE, text))
    said = (f"wrote the live correction of {source or 'the calibration'} for {config} to {files[0]} and "
            f"{files[1]}", *lines, f"to install: {INSTALL_NOTE}")
    return LiveExport(field, error, files, said)


def _summary(field: CorrectionField, error: SamplingError,
             klipper: KlipperDelta | KlipperRotaryDelta) -> tuple[str, ...]:
    """The lines the export prints (and the section keeps as comments)."""
    v = field.volume
    nx, ny, nz = field.shape
    lines = [f"correction field: grid {field.step:g} mm, {nx} x {ny} x {nz} nodes over Klipper's volume "
             f"(radius {v.radius:.2f} mm, z {v.min_z:g} to {v.max_z:.2f} mm), Catmull-Rom interpolation; "
             f"{field.refused} nodes of it, or within {TRUST_NODES * field.step:g} mm of it, refused by the "
             "library (out of the printer's reach, near a singularity): the correction blends to Klipper's "
             "own command there",
             f"sampling error against the exact correction at {error.points} points of the volume"
             f"{_held(field)}: max "
             f"{error.max_full_speed:.4f} mm within radius {v.slow_radius:.2f} mm ({v.inner}), "
             f"{error.max:.4f} mm out to the rim ({v.rim}); RMS {error.rms:.5f} mm"]
    limits = _limits_note(field)
    if limits:
        lines.append(limits)
    return tuple(lines)


def _held(field: CorrectionField) -> str:
    """How the correction is weighted, in words for the sampling error's line ("" without a σ grid)."""
    if field.holds is None:
        return ""
    if not math.isfinite(field.bound):
        return " (the whole correction everywhere: an infinite bound)"
    return (f" (weighted where the calibration holds within σ {field.bound:g} mm, as compensate "
            f"--sigma-bound {field.bound:g} does: its σ grid goes with the section)")


def _limits_note(field: CorrectionField) -> str:
    """What Klipper's limits refuse of the corrected volume (its bed disk and a sample), or ""."""
    v = field.volume
    ring = np.arange(0.0, v.radius + 1e-9, 5.0)
    angle = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    bed = np.stack([np.outer(ring, np.cos(angle)).ravel(), np.outer(ring, np.sin(angle)).ravel(),
                    np.full(ring.size * angle.size, v.min_z)], axis=-1)
    points = np.concatenate([bed, v.sample(4000, np.random.default_rng(7))])
    commands = points + field.applied(points)
    refused = ~v.admits(commands)
    if not np.any(refused):
        return ""
    low = refused & (commands[:, 2] < v.min_z)
    parts = []
    if np.any(low):
        lowest = float(np.min(commands[low, 2]))
        parts.append(f"{int(low.sum())} below minimum_z_position {v.min_z:g} (down to Z {lowest:.4f}: "
                     f"[printer] minimum_z_position: {math.floor(lowest * 100.0) / 100.0:.2f} admits them)")
    if np.any(refused & ~low):
        parts.append(f"{int(np.sum(refused & ~low))} beyond Klipper's radius at the rim or its taper near "
                     "the top (keep the program off them)")
    return (f"note: of {len(points)} points of the volume (its bed and a sample), corrected, "
            f"{'; '.join(parts)}: the module refuses such a move, naming the limit")


def _number(value: float) -> str:
    """A value as the section writes it (exact: the shortest text that reads back the same float)."""
    return repr(float(value))


@singledispatch
def klipper_keys(klipper: object) -> dict[str, str]:
    """The section's keys of Klipper's values the correction was computed for: its kinematics, its values.

    The module's :data:`~.deltacal_geometry.VALUE_KEYS` (linear, ``kinematics: delta``) or
    :data:`~.deltacal_geometry.ROTARY_VALUE_KEYS` (``rotary_delta``), exact; angles in degrees.
    """
    raise TypeError(f"no live section for {type(klipper).__name__}")


@klipper_keys.register
def _linear_keys(klipper: KlipperDelta) -> dict[str, str]:
    values = {"delta_radius": klipper.delta_radius}
    for k, tower in enumerate(TOWERS):
        values |= {f"angle_{tower}": math.degrees(klipper.angle[k]),
                   f"arm_length_{tower}": klipper.arm_length[k],
                   f"position_endstop_{tower}": klipper.position_endstop[k],
                   f"step_distance_{tower}": klipper.step_distance[k]}
    return {"kinematics": "delta", **{key: _number(value) for key, value in values.items()}}


@klipper_keys.register
def _rotary_keys(klipper: KlipperRotaryDelta) -> dict[str, str]:
    values = {"shoulder_radius": klipper.shoulder_radius, "shoulder_height": klipper.shoulder_height}
    for k, tower in enumerate(TOWERS):
        values |= {f"angle_{tower}": math.degrees(klipper.angle[k]),
                   f"upper_arm_length_{tower}": klipper.upper_arm[k],
                   f"lower_arm_length_{tower}": klipper.lower_arm[k],
                   f"position_endstop_{tower}": klipper.position_endstop[k],
                   f"step_distance_{tower}": klipper.step_distance[k]}
    return {"kinematics": "rotary_delta", **{key: _number(value) for key, value in values.items()}}


def section_text(field: CorrectionField, error: SamplingError, klipper: KlipperDelta | KlipperRotaryDelta,
                 source: str, notes: tuple[str, ...] = ()) -> str:
    """The ``[deltacal_geometry]`` section (see the module's documentation for its keys)."""
    name = re.sub(r"[#;\x00-\x1f]", "?", Path(source).name) if source else "?"
    v = field.volume
    keys = {"format": FORMAT, "calibration": name,
            "sampling_error": f"max {error.max_full_speed:.4f} mm within radius {v.slow_radius:.2f} mm, "
                              f"{error.max:.4f} mm to the rim", **klipper_keys(klipper)}
    keys |= {"build_radius": _number(v.radius), "minimum_z": _number(v.min_z), "maximum_z": _number(v.max_z),
             "coverage_margin": _number(COVERAGE_NODES * field.step),
             "split_tolerance": f"{SPLIT_TOLERANCE_MM:g}",
             "grid_origin": ", ".join(_number(x) for x in field.origin), "grid_step": _number(field.step),
             "grid_shape": ", ".join(str(n) for n in field.shape),
             "correction_unit": f"{VALUE_UNIT_MM:g}", "sigma_bound": _number(field.bound)}
    bound, cells = curvature_bounds(field)
    lines = ["# deltacal's live correction: the [deltacal_geometry] section deltacal_geometry.py reads.",
             f"# To install: {INSTALL_NOTE}.",
             "# Computed for the Klipper values below: the module refuses to start under others (export "
             "again).",
             *(f"# {line}" for line in notes), "", "[deltacal_geometry]",
             *(f"{key}: {value}" for key, value in keys.items()), *holds_lines(field.holds),
             "# split_curvature: per ring of grid_step (from the axis), the bound at each z node [1/mm]",
             "split_curvature:", *("  " + ", ".join(f"{k:.3g}" for k in row) for row in bound),
             "# split_cells: base64 of the zlib-compressed little-endian float64 bound [1/mm] in each cell "
             "of the grid (from node (i, j, k) to (i+1, j+1, k+1); i slowest, k fastest)",
             "split_cells:", *("  " + line for line in encode_floats(cells)),
             "# correction: base64 of the zlib-compressed little-endian int32 values (in correction_unit), "
             "3 per node, x slowest, then y, z, the component fastest",
             "correction:", *("  " + line for line in encode_values(field.values))]
    return "\n".join(lines) + "\n"


def holds_lines(holds: WhereItHolds | None) -> list[str]:
    """The section's lines of where the calibration holds: its σ grid's nodes and σ, exact (none: [])."""
    if holds is None:
        return []
    sigma = np.concatenate([holds.horizontal.ravel(), holds.vertical.ravel()])
    return [f"holds_radius: {', '.join(_number(r) for r in holds.radius)}",
            f"holds_azimuth: {', '.join(_number(a) for a in holds.azimuth)}",
            f"holds_height: {', '.join(_number(z) for z in holds.height)}",
            "# holds_sigma: base64 of the zlib-compressed little-endian float64 σ [mm] of the correction's "
            "horizontal part, then of its vertical part, at the nodes of holds_radius x holds_azimuth x "
            "holds_height (the radius slowest, the height fastest)",
            "holds_sigma:", *("  " + line for line in encode_floats(sigma)),
            "# holds_significance: whether the horizontal part is weighted by its significance too (a "
            "calibration measured at one height: deltacal.holds.WhereItHolds.bed_level)",
            f"holds_significance: {holds.bed_level}"]


def encode_floats(values: np.ndarray) -> list[str]:
    """Values as the section's lines, exact: base64 of zlib-compressed little-endian float64, in C order."""
    text = base64.b64encode(zlib.compress(np.asarray(values, dtype="<f8").tobytes(), 9)).decode("ascii")
    return [text[k:k + LINE_CHARS] for k in range(0, len(text), LINE_CHARS)]


def encode_values(values: np.ndarray) -> list[str]:
    """The correction's values as the section's lines: base64 of zlib-compressed little-endian int32.

    In :data:`VALUE_UNIT_MM`, node after node (x slowest, then y, z), the 3 components together.
    """
    data = np.rint(np.asarray(values) / VALUE_UNIT_MM).astype("<i4").tobytes()
    text = base64.b64encode(zlib.compress(data, 9)).decode("ascii")
    return [text[k:k + LINE_CHARS] for k in range(0, len(text), LINE_CHARS)]
