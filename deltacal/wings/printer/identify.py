"""A printer's identification: its probe heights and printed distances, through its firmware.

The measurements are of commanded positions: each is turned into the readings the firmware
commanded (steps below the endstops, counted in the printer's nominal step distance) through
the firmware's own inverse model (the configuration they were made with), then
:func:`~deltacal.printer.identification.fit.identify_printer` finds the full geometry on the true bed.
A measurement the nominal printer cannot assemble, or that does not fit the others, is refused by
its file and line before the fit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np

from ...calibration import Calibration
from ...errormodels import ErrorModel, get_model
from ...exceptions import AssemblyError, IdentificationError, InputError, PoorFitError
from ...geometry import DeltaGeometry
from ...identification.result import IdentificationResult
from ...io import save_calibration
from ...io.tables import data_row
from ...kinematics import exact
from ...printer.files.measurements import (
    PAIR_COLUMNS,
    PROBE_COLUMNS,
    read_printed_distances,
    read_probe_heights,
)
from ...printer.files.same_printer import ENDSTOP_MM, check_step_distance
from ...printer.firmware.base import FirmwareModel, classical_name
from ...printer.firmware.config_file import read_firmware_config
from ...printer.identification.anchor import measured_record
from ...printer.identification.errormodels import kit_tolerances
from ...printer.identification.fit import (
    PrinterFitOptions,
    PrinterMeasurements,
    identify_printer,
    measured_combinations,
    printer_outliers,
)
from ...printer.identification.outliers import Outliers
from ...printer.identification.where import holds_in_words, values_in_words
from ...printer.owner import measured_covariance, owner_lines, printer_errors
from ...printer.printed.object import probe_grid
from ...printer.robot import NominalLinearDelta
from ..base import Done, check_files, warn
from ..requests import IdentifyRequest

#: Probe points across the bed of the heights that would add to the distances alone (Klipper's usual 7).
HEIGHTS_GRID = 7
#: Probe heights fewer than this are not checked for their spread (a few may agree by chance).
MIN_HEIGHTS_SPREAD = 5
#: Measurements named at most in one clause of a refusal.
MAX_NAMED = 3


def identify_from_prints(request: IdentifyRequest, printer: NominalLinearDelta) -> Done:
    """``deltacal identify`` of a printer: the calibration file written, the report said."""
    model = request.printer_model()
    assert request.controller is not None
    paths = [str(p) for p in request.measurements]
    check_files([request.nominal, request.controller, *paths], request.output)
    config = read_firmware_config(request.controller, request.firmware)
    firmware, values = config.firmware, config.values
    live = firmware.live_correction(request.controller)
    if live is not None and not request.live_correction_off:  # measured through it: the corrected printer
        raise live.refuse_identify()
    off = () if live is None else (live.taken_off(),)
    check_step_distance(printer.step_distance, values.step_distance, request.nominal, request.controller,
                        firmware.step_distance_keys)
    firmware.check_same_printer(firmware.nominal(printer), values, str(request.nominal),
                                str(request.controller))
    start = printer.geometry()
    data, files = read_prints(request, start, Commanded(values, printer.step_distance), printer.name)
    options = PrinterFitOptions(method="linear" if request.linear else "iterated",
                                tolerances=kit_tolerances(get_model(model)),
                                tolerance_scale=request.tolerance_scale or "evidence",
                                workspace=printer.workspace, accept_poor_fit=request.accept_poor_fit,
                                calibrated_start=firmware.calibrated_from_saved(request.controller))
    result = fit_prints(request, start, model, options, data, files)
    save_calibration(replace(Calibration.from_result(result), controller=config.record(),
                             measured=measured_record(data, options, result.tolerance_scale)), request.output)
    if result.outliers:
        warn([f"{files.where(k)} does not fit the other measurements (see the report): check it, or "
              "remove it and identify again" for k in result.outliers])
    where: tuple[str, ...] = ()
    if result.holds is not None:
        where = (f"where it holds: {holds_in_words(result.holds)}",)
        if result.holds.values:
            words = values_in_words(result.holds, lambda name: firmware.value_name(classical_name(name)))
            where += (f"firmware values: {words}",)
    owner = _owner_part(result, start, data, firmware, request)
    if not data.probe.size:
        owner = (*owner, _heights_would_add(start, data, values, printer))
    return Done((*off, *owner, *where, "\nThe engineer's part:", result.report(),
                 f"\nwrote {request.output}"))


class Inverse(Protocol):
    """A firmware's inverse model: the readings it commands for nozzle targets in its frame."""

    def inverse(self, targets: np.ndarray, step_distance: Any, check: bool = True) -> np.ndarray:
        """The readings, (N, 3), for targets [mm], (N, 3)."""


@dataclass(frozen=True)
class Commanded:
    """How commanded positions become the readings a firmware commanded: its model, the step distance counted.

    Attributes:
        firmware: The firmware's model (``inverse(targets, step_distance, check)``; a rotary printer's
            ignores the step distance: its readings are angles).
        step_distance: The nominal step distance the readings count in [mm] (a rotary printer's: unused).
    """

    firmware: Inverse
    step_distance: np.ndarray | float = 1.0


def read_prints(request: IdentifyRequest, start: DeltaGeometry, commanded: Commanded,
                name: str) -> tuple[PrinterMeasurements, MeasuredFiles]:
    """A printer's measurement files read through its firmware, checked at ``start`` (the nominal ``name``).

    Raises:
        InputError: a row read wrong, or one the nominal printer cannot assemble (by file and line).
    """
    assert request.probe_offset is not None
    paths = [str(p) for p in request.measurements]
    files = _read(paths, commanded, request.sigma_height, float(request.probe_offset[2]))
    data = PrinterMeasurements(files.probe, files.pairs, files.distance, probe_offset=request.probe_offset,
                               height_sigma=request.sigma_height, distance_sigma=request.sigma_distance,
                               trigger_height=files.trigger)
    _check_assembled(start, data, files, name)
    return data, files


def fit_prints(request: IdentifyRequest, start: DeltaGeometry, model: str | ErrorModel,
               options: PrinterFitOptions, data: PrinterMeasurements, files: MeasuredFiles
               ) -> IdentificationResult:
    """A printer's measurements (:func:`read_prints`) identified from ``start``; a misfit row refused.

    Raises:
        InputError: a row that does not fit the others (by file and line).
        IdentificationError: a poor fit (the file holding most of its misfit named).
    """
    found = None
    if not request.accept_poor_fit:
        found = printer_outliers(start, data, model, options)
        if found.indices.size:
            raise _outlier_error(found, data, files)
    try:
        return identify_printer(start, data, model, options=options)
    except PoorFitError as exc:
        raise IdentificationError(f"{_dominant(exc.result, data, files)}: {exc}{_single(found, files)}; "
                                  "nothing written (--accept-poor-fit keeps such a fit)") from None


def _owner_part(result, start: DeltaGeometry, data: PrinterMeasurements, firmware, request: IdentifyRequest
                ) -> tuple[str, ...]:
    """The printer's errors in its owner's words, its firmware's, first (the complete model's fit only)."""
    if result.model != "printer":
        return ()
    keys = firmware.owner_keys
    errors = printer_errors(Calibration.from_result(result), names=keys.towers,
                            reference=measured_covariance(start, data))
    step = (f"next: deltacal export {request.output} --controller {firmware.name} --config "
            f"{request.controller} -o {firmware.export_file} writes {firmware.title}'s values "
            f"({keys.where}); "
            f"deltacal compensate {request.output} PART.gcode --controller {request.controller} corrects "
            "everything, where the calibration holds")
    return (*owner_lines(errors, keys, firmware.title), step)


def _heights_would_add(start: DeltaGeometry, data: PrinterMeasurements, firmware: FirmwareModel,
                       printer: NominalLinearDelta) -> str:
    """What probe heights (:data:`HEIGHTS_GRID` across the bed) would add to the distances alone."""
    assert printer.workspace is not None  # a printer's identification needs its printable cylinder
    grid = probe_grid(printer.workspace.radius, HEIGHTS_GRID)
    heights = replace(data, probe=firmware.inverse(grid, printer.step_distance),
                      trigger_height=np.zeros(len(grid)))
    alone, both = measured_combinations(start, data), measured_combinations(start, heights)
    added = [name for name in both.base_names if name not in alone.base_names]
    return (f"no probe heights: the {data.distance.size} distances alone determine {alone.rank} of the "
            f"{len(alone.names)} complete-model combinations (the printer's shape); probe heights (plan's "
            f"probe.csv, by hand: the paper test) would add {both.rank - alone.rank}: "
            f"{', '.join(added) or 'none'} (where the bed lies under the nozzle: its height and tilt, "
            "which the distances do not see)")


@dataclass(frozen=True)
class MeasuredFiles:
    """A printer's measurements as read, with where each came from."""

    probe: np.ndarray  # readings [mm], (N, 3)
    pairs: np.ndarray  # readings [mm], (M, 2, 3)
    distance: np.ndarray  # [mm], (M,)
    heights: np.ndarray  # the probe file's z_mm, (N,)
    trigger: np.ndarray  # the probe file's trigger_height_mm, (N,) (empty without the column)
    sources: list[tuple[str, int]]  # per measurement: its file and line

    def place(self, k: int) -> tuple[str, str]:
        """The file of measurement k and its place there (``line 8 (data row 7)``)."""
        source, line = self.sources[k]
        row = k + 1 - next(i for i, (s, _) in enumerate(self.sources) if s == source)
        return source, data_row(line, row)

    def where(self, k: int) -> str:
        """``probe.csv: line 8 (data row 7)`` of measurement k."""
        return ": ".join(self.place(k))


def _read(paths: list[str], commanded_by: Commanded, height_sigma: float, probe_drop: float) -> MeasuredFiles:
    """Readings of the probe heights (the first file, unless all are distances) and of the printed pairs."""
    firmware, step_distance = commanded_by.firmware, commanded_by.step_distance
    probe_file = paths[0] if _heights_given(paths[0], paths[1:]) else None
    distance_files = paths[1:] if probe_file is not None else paths
    probe, commanded, trigger = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    sources: list[tuple[str, int]] = []
    if probe_file is not None:
        heights = read_probe_heights(probe_file)
        commanded, trigger = heights.commanded, heights.heights
        _check_heights(commanded[:, 2], heights.lines, probe_file, height_sigma, probe_drop, trigger)
        probe = _readings(firmware, commanded, step_distance, probe_file, heights.lines)
        sources = [(probe_file, int(n)) for n in heights.lines]
    pairs, distance = [np.zeros((0, 2, 3))], [np.zeros(0)]
    for path in distance_files:
        printed = read_printed_distances(path)
        both = _readings(firmware, printed.pairs.reshape(-1, 3), step_distance, path,
                         np.repeat(printed.lines, 2))
        pairs.append(both.reshape(-1, 2, 3))
        distance.append(printed.distance)
        sources += [(path, int(n)) for n in printed.lines]
    return MeasuredFiles(probe, np.concatenate(pairs), np.concatenate(distance), commanded[:, 2], trigger,
                         sources)


def _heights_given(probe_file: str, distance_files: list[str]) -> bool:
    """Whether the first file holds probe heights; False: every file holds distances (no probe heights).

    Raises:
        InputError: probe heights given after distances (the files swapped).
    """
    probe_columns = _header(probe_file)
    if not set(PAIR_COLUMNS) <= probe_columns or set(PROBE_COLUMNS[:2]) <= probe_columns:
        return True
    swapped = next((path for path in distance_files if set(PROBE_COLUMNS[:2]) <= _header(path)), None)
    if swapped is None:
        return False
    heights = ", ".join(PROBE_COLUMNS)
    raise InputError(f"holds distances ({PAIR_COLUMNS[0]}..{PAIR_COLUMNS[-1]}, distance_mm) and {swapped} "
                     f"probe heights ({heights}): the files look swapped; identify takes PRINTER.toml "
                     "PROBE.csv DISTANCES.csv, the probe heights first (or DISTANCES.csv alone)", probe_file,
                     "line 1")


def _header(path: str) -> set[str]:
    """The column names of a CSV file's first non-blank line (empty when it cannot be read)."""
    try:
        with open(path, encoding="utf-8", newline="") as handle:
            line = next((text for text in handle if text.strip()), "")
    except (OSError, UnicodeDecodeError):
        return set()
    return {name.strip().strip('"') for name in line.split(",")}


def _check_heights(z: np.ndarray, lines: np.ndarray, source: str, sigma: float, probe_z: float,
                   trigger: np.ndarray) -> None:
    """Refuse probe heights no printer gives: in another unit, or far from any bed.

    The commanded height at which the probe triggers is where the firmware puts the bed, plus the
    probe point's height above it then (``trigger_height_mm``: a probe's ``z_offset``, 22 to 24 mm
    on FLSUN's deltas), less the probe's offset ``probe_z`` [mm]: beyond
    :data:`~deltacal.printer.files.same_printer.ENDSTOP_MM` from it, no build's endstops are
    (micrometres, or another printer's file). A printer's probe heights scatter by the probe's σ at
    least (and by tenths of a mm to mm across the bed, for its tilt and its towers' errors): heights
    in metres span a thousandth of that.
    """
    far = np.flatnonzero(np.abs(z + probe_z - trigger) > ENDSTOP_MM)
    if far.size:
        k = int(far[0])
        above = f" (its trigger height {trigger[k]:g} mm, trigger_height_mm, taken off)" if trigger[k] else ""
        raise InputError(f"the probe triggered at z_mm = {z[k]:g}, more than {ENDSTOP_MM:g} mm from the bed "
                         f"the firmware knows{above}: no printer's endstops are so far off (micrometres? "
                         f"deltacal reads millimetres); {far.size} of {z.size} rows", source,
                         f"{data_row(lines[k], k + 1)}, column z_mm")
    if z.size < MIN_HEIGHTS_SPREAD or np.ptp(z) == 0.0 or np.ptp(z) >= sigma:
        return
    raise InputError(f"the probe heights span only {np.ptp(z):.3g} mm ({z.min():.6g} to {z.max():.6g}), less "
                     f"than the probe's σ {sigma:g} mm: metres? deltacal reads millimetres", source,
                     f"lines {int(lines[0])}-{int(lines[-1])}, column z_mm")


def _readings(firmware: Inverse, commanded: np.ndarray, step_distance: np.ndarray | float, source: str,
              lines: np.ndarray) -> np.ndarray:
    """The readings the firmware commanded for positions; a position it cannot reach is named by line."""
    readings = firmware.inverse(commanded, step_distance, check=False)
    bad = np.flatnonzero(~np.all(np.isfinite(readings), axis=1))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"the firmware cannot reach the commanded position {commanded[k].tolist()} mm "
                         "(another printer's file?)", source, f"line {int(lines[k])}")
    return readings


def _check_assembled(start: DeltaGeometry, data: PrinterMeasurements, files: MeasuredFiles,
                     name: str) -> None:
    """Refuse, by file and line, the first measurement the nominal printer cannot assemble."""
    chain, N = start.chain, data.probe.shape[0]
    for offset, readings, per in ((0, data.probe, 1), (N, data.pairs.reshape(-1, 3), 2)):
        if not readings.size:
            continue
        try:
            exact.forward(start, readings)
        except AssemblyError as exc:
            i = int(exc.indices[0])
            shown = np.round(chain.reading_to_file(readings[i]), 3).tolist()
            raise InputError(f"the nominal {chain.words.robot} {name!r} cannot be assembled at the "
                             f"{chain.words.part} travels {shown} {chain.words.reading_unit} the firmware "
                             "commands there (a gross error in the row? another printer's file?); "
                             f"{len(exc.indices)} reading(s) in all",
                             *files.place(offset + i // per)) from None


def _outlier_error(found: Outliers, data: PrinterMeasurements, files: MeasuredFiles) -> InputError:
    """The first measurement that does not fit the others, in one line: where, its value and the fit's."""
    N = data.probe.shape[0]
    k = int(found.indices[0])
    r = float(found.residual[k])  # whitened: measured − model
    if k < N:
        column, value = "z_mm", float(files.heights[k])
        expected, what = value + r * data.height_sigma, "probe height"
    else:
        column, value = "distance_mm", float(data.distance[k - N])
        expected, what = value - r * data.distance_sigma, "distance"
    others = ", ".join(files.where(int(j)) for j in found.indices[1:])
    more = f"; {found.indices.size} measurements in all, also {others}" if found.indices.size > 1 else ""
    return InputError(f"{column} = {value:g} mm does not fit the other measurements: they give "
                      f"{expected:.6g} mm ({abs(value - expected):.3g} mm, {abs(r):.0f} σ of a {what} off: "
                      "a typo, a misread caliper?); measure it again and correct the row, or delete the row "
                      f"to identify without it, or keep it with --accept-poor-fit{more}",
                      files.sources[k][0], f"{files.place(k)[1]}, column {column}")


def _dominant(result, data: PrinterMeasurements, files: MeasuredFiles) -> str:
    """The file whose rows hold the most of a fit's misfit (χ² in units of each row's σ), and its share."""
    residual = np.asarray(result.residual_after, dtype=float)
    N, M = data.probe.shape[0], data.distance.shape[0]
    sigma = np.r_[np.full(N, data.height_sigma), np.full(M, data.distance_sigma)]
    if residual.size != N + M:
        return files.sources[0][0]
    share: dict[str, float] = {}
    for k, (source, _) in enumerate(files.sources):
        share[source] = share.get(source, 0.0) + float((residual[k] / sigma[k]) ** 2)
    total = sum(share.values())
    name = max(share, key=lambda path: (share[path], -list(share).index(path)))  # the first on equal shares
    return f"{name} (its rows hold {100.0 * share[name] / total:.0f} % of the misfit)" if total > 0 else name


def _single(found: Outliers | None, files: MeasuredFiles) -> str:
    """What one measurement's error would explain of a poor fit, in clauses ("" when nothing).

    Several measurements any one of which, left out, leaves the others at their noise (the others
    cannot tell which); measurements whose own error the others would not see.
    """
    if found is None:
        return ""
    out = ""
    if found.undecided.size:
        where = "; ".join(files.where(int(k)) for k in found.undecided[:MAX_NAMED])
        more = f" and {found.undecided.size - MAX_NAMED} more" if found.undecided.size > MAX_NAMED else ""
        out += (f"; or one of {where}{more} is off: without any one of them the others fit, and they cannot "
                "tell which (measure those again)")
    if found.unseen.size:
        where = "; ".join(files.where(int(k)) for k in found.unseen[:MAX_NAMED])
        more = f" and {found.unseen.size - MAX_NAMED} more" if found.unseen.size > MAX_NAMED else ""
        out += (f"; the other measurements would not see an error in {where}{more} alone (nothing checks "
                "it: measure it with care)")
    return out
