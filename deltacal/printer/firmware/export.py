"""A firmware's values that fit an identified printer best: one route for every firmware (``export``).

Through the firmware interface alone (:class:`~deltacal.printer.firmware.base.Firmware`): its values
that leave the least largest nozzle error over the printable volume of the identified printer (its
true bed as z = 0; ``minimax``: :func:`~deltacal.printer.firmware.fitting.least_largest`), judged in
the printed part's frame, with the first layer's height errors weighted
(:data:`~deltacal.printer.firmware.fitting.EXPORT_FIRST_LAYER_WEIGHT`) so that its flatness is not
traded for the volume's. The fit starts from the configuration the printer runs (``--config``,
whose other values it keeps: RRF's print radius, its microstepping; a firmware whose values need it
says so: :attr:`~deltacal.printer.firmware.base.Firmware.export_needs_config`), else from the
calibration's nominal printer. What the values leave, in all and of each error source alone
(:func:`~deltacal.printer.firmware.budget.error_budget`: what ``compensate`` corrects through the
firmware), is kept as comment lines; where the firmware's exported values carry its lowest Z
(:attr:`~deltacal.printer.firmware.base.Firmware.exports_minimum_z`), it is lowered to admit the
corrected bed (:meth:`~deltacal.printer.firmware.base.Firmware.bed_minimum_z`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ...calibration import Calibration
from ...exceptions import ConvergenceError, GeometryError, InputError, UnreachableError, UsageError
from ...geometry import DeltaGeometry, Workspace
from ...holds import DEFAULT_BOUND
from ..identification.where import holds_in_words
from . import check_config_firmware
from .base import ErrorFigures, Firmware, FirmwareModel, undetermined_values
from .budget import BED_TILT, error_budget
from .config_file import check_printer_values, refuse_deltacal_file
from .fitting import EXPORT_FIRST_LAYER_WEIGHT


@dataclass(frozen=True)
class ExportStart:
    """What a firmware's values are fitted from: the calibration, the settings, the start, the volume.

    Attributes:
        geometry: The identified printer (its true bed is z = 0).
        nominal: Its nominal geometry.
        config: The firmware's values of ``--config``, or None.
        step: The printer's nominal step distances [mm], (3,).
        start: The values the fit starts from (``--config``'s, else the nominal printer's).
        workspace: The printable volume.
        where: Where the volume comes from, for the messages (``" of kossel.toml"``).
        kept: The classical values the calibration's measurements do not determine: kept at the
            start's (:func:`~deltacal.printer.firmware.base.undetermined_values`).
    """

    geometry: DeltaGeometry
    nominal: DeltaGeometry
    config: Any
    step: np.ndarray
    start: Any
    workspace: Workspace
    where: str
    kept: tuple[str, ...] = ()


@dataclass(frozen=True)
class FirmwareExport:
    """A firmware's values fitted to a calibration, and what they leave.

    Attributes:
        firmware: The firmware.
        values: The values to write.
        lines: What they leave, line by line (printed, and kept as comments in the file).
        title: The file's first comment.
    """

    firmware: Firmware[Any]
    values: Any
    lines: tuple[str, ...]
    title: str

    def save(self, path: str | Path, config: str | Path | None = None) -> Path:
        """Write the values (the firmware's file; ``config``: the configuration the printer runs)."""
        return self.firmware.save_config(path, self.values, config, title=self.title, notes=list(self.lines))


def export_firmware_values(firmware: Firmware[Any], calibration: Calibration, source: str | Path,
                           workspace: Workspace, where: str, config: str | Path | None = None,
                           hold_step_distance: bool = False,
                           volume_source: str | Path | None = None,
                           sigma_bound: float = DEFAULT_BOUND) -> FirmwareExport:
    """The firmware's values that fit a printer's calibration best over its printable volume (see the module).

    Args:
        firmware: The firmware.
        calibration: A printer's calibration (or geometry file read as one).
        source: Its file, for the messages.
        workspace: The printable volume.
        where: Where the volume comes from, for the messages.
        config: The configuration the printer runs (its values start the fit), or None.
        hold_step_distance: Keep the step distances (``--keep-rotation-distance``).
        volume_source: The file whose ``[workspace]`` is the volume (the messages name it), or None.
        sigma_bound: Where the calibration knows where it holds
            (:attr:`~deltacal.calibration.Calibration.holds`), the values are fitted over the part of
            the volume where the nozzle's σ is within this [mm], and those its measurements do not
            determine are kept at the start's.

    Raises:
        UsageError: a deltacal file as ``config``, or no ``config`` where the firmware needs it.
        InputError: a file's first problem, a target out of the firmware's reach, no convergence, a
            calibration that holds nowhere within ``sigma_bound``.
    """
    unchanged = _nothing_to_change(firmware, calibration, source, workspace, config, sigma_bound)
    if unchanged is not None:
        return unchanged
    begun = export_start(firmware, calibration, source, workspace, where, config, hold_step_distance,
                         sigma_bound)
    workspace = begun.workspace
    whose = f"{firmware.title}'s"
    with fit_refusals(begun, whose, source, volume_source):
        fit = firmware.fit(begun.geometry, begun.start, begun.step, workspace,
                           hold_step_distance=hold_step_distance,
                           first_layer_weight=EXPORT_FIRST_LAYER_WEIGHT, minimax=True, hold=begun.kept)
        budget = source_budget(firmware, begun, hold_step_distance)
    lines = summary(firmware, fit.before, fit.after, budget, begun, fit.held, config is not None)
    values = fit.values
    lowest = (firmware.bed_minimum_z(values, calibration, begun.step, workspace.radius, sigma_bound)
              if firmware.exports_minimum_z else None)
    if lowest is not None:
        values = values.with_minimum_z(lowest)
        lines.append(f"{firmware.minimum_z_key} {lowest:g} mm: the true bed is below these values' z 0 over "
                     f"radius {workspace.radius:g} mm; a corrected first layer goes there (compensate "
                     "--controller)")
    return FirmwareExport(firmware, values, tuple(lines),
                          f"{firmware.title} delta values fitted by deltacal to {source}")


#: A firmware's values fit the measurements when their RMS residual is within this many σ given.
FITS_SIGMAS = 2.0


@dataclass(frozen=True)
class MeasuredResiduals:
    """What a firmware's values leave of a calibration's measurements (``[measured]``) [mm].

    Attributes:
        heights: Each probe height's residual: the firmware's nozzle height at the trigger's readings
            (the probe's offset added) less the trigger height, (N,).
        distances: Each distance's: the firmware's distance between its two ends less the measured, (M,).
        height_sigma: The σ given of a height.
        distance_sigma: The σ given of a distance.
    """

    heights: np.ndarray
    distances: np.ndarray
    height_sigma: float
    distance_sigma: float

    @property
    def fits(self) -> bool:
        """Each kind's RMS within :data:`FITS_SIGMAS` of its σ (the values already fit the measurements)."""
        kinds = ((self.heights, self.height_sigma), (self.distances, self.distance_sigma))
        return all(r.size == 0 or float(np.sqrt(np.mean(r**2))) <= FITS_SIGMAS * s for r, s in kinds)

    def words(self) -> str:
        """``7 heights: RMS 0.006, max 0.011 mm (σ 0.01)`` and the same of the distances."""
        out = []
        for r, what, s in ((self.heights, "heights", self.height_sigma),
                           (self.distances, "distances", self.distance_sigma)):
            if r.size:
                out.append(f"{r.size} {what}: RMS {np.sqrt(np.mean(r**2)):.4f}, max "
                           f"{np.max(np.abs(r)):.4f} mm (σ {s:g})")
        return "; ".join(out)


def measured_residuals(firmware: Firmware[Any], values: FirmwareModel,
                       calibration: Calibration) -> MeasuredResiduals | None:
    """The residuals of the calibration's recorded measurements through the firmware's values (None: none)."""
    record, step = calibration.measured, calibration.geometry.step_distance
    if record is None or step is None:
        return None
    controller = firmware.controller(values, step)
    heights = (controller.forward(record.probe, check=False)[:, 2] + record.probe_offset[2]
               - record.trigger_height)
    ends = controller.forward(record.pairs.reshape(-1, 3), check=False).reshape(-1, 2, 3)
    distances = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1) - record.distance
    return MeasuredResiduals(heights, distances, record.height_sigma, record.distance_sigma)


def _nothing_to_change(firmware: Firmware[Any], calibration: Calibration, source: str | Path,
                       workspace: Workspace, config: str | Path | None,
                       sigma_bound: float) -> FirmwareExport | None:
    """The configuration's values unchanged where the calibration holds nowhere and they fit its measurements.

    Bed-level heights alone determine the first layer's height, not the nozzle along the bed nor above
    it: the calibration holds nowhere (its 3-D σ), yet a firmware calibrated from the same heights
    (Klipper's saved ``DELTA_CALIBRATE``) already fits what they determine. Its values then are the
    answer (written unchanged, the residuals said); None otherwise (the fit, or its refusal, follows).
    """
    holds = calibration.where_held()
    if holds is None or config is None or holds.held_volume(workspace, sigma_bound) is not None:
        return None
    refuse_deltacal_file(config, "--config")
    check_config_firmware(config, firmware)
    values = firmware.read_config(config)
    residuals = measured_residuals(firmware, values, calibration)
    if residuals is None or not residuals.fits:
        return None
    lines = (f"nothing to change: {config}'s values already fit {source}'s measurements "
             f"({residuals.words()}: within {FITS_SIGMAS:g} σ), and the calibration holds nowhere else "
             f"within σ {sigma_bound:g} mm ({holds_in_words(holds, sigma_bound)}); its values are written "
             "unchanged",)
    return FirmwareExport(firmware, values, lines, f"{firmware.title} delta values of {config}, unchanged: "
                          f"they already fit {source}'s measurements")


def export_start(firmware: Firmware[Any], calibration: Calibration, source: str | Path, workspace: Workspace,
                 where: str, config: str | Path | None = None,
                 hold_step_distance: bool = False, sigma_bound: float = DEFAULT_BOUND) -> ExportStart:
    """Read what the fit starts from: the configuration's values, the step distances, the start, the volume.

    The volume is where the calibration holds within ``sigma_bound`` (all of ``workspace`` for a
    calibration that does not say where it holds).

    Raises:
        UsageError: a deltacal file as ``config``, or no ``config`` where the firmware needs it.
        InputError: a file's first problem (named by its line or key), a configuration of another
            printer, a calibration that holds nowhere within ``sigma_bound``, or a printer's
            calibration that does not say where it holds (no ``[holds]``).
    """
    holds = calibration.where_held()  # a printer's calibration without it refused
    if config is not None:
        refuse_deltacal_file(config, "--config")
        check_config_firmware(config, firmware)
    values = firmware.read_config(config) if config is not None else None
    step = step_distance(calibration.geometry.step_distance, values, source,
                         "geometry.step_distance_mm" if calibration.base else "step_distance_mm")
    if firmware.export_needs_config and config is None and not hold_step_distance:
        raise UsageError(firmware.export_needs_config)
    geometry, nominal = calibration.geometry, calibration.nominal
    if values is not None:
        check_printer_values(firmware, replace(geometry, step_distance=step), values, source, str(config))
    try:
        start = values if values is not None else firmware.start(replace(nominal, step_distance=step))
    except GeometryError as exc:
        raise InputError(str(exc), str(source), "key nominal") from None
    if holds is not None:
        held = holds.held_volume(workspace, sigma_bound)
        if held is None:
            raise InputError(f"the calibration holds nowhere within σ {sigma_bound:g} mm (--sigma-bound): "
                             f"{holds_in_words(holds, sigma_bound)}; no value to export", str(source))
        workspace, where = held, f"{where}, where the calibration holds (σ within {sigma_bound:g} mm)"
    return ExportStart(geometry, nominal, values, step, start, workspace, where, undetermined_values(holds))


@contextmanager
def fit_refusals(begun: ExportStart, whose: str, source: str | Path,
                 volume_source: str | Path | None = None) -> Iterator[None]:
    """A fit's failures as one line naming the file: a target out of reach, no convergence.

    Args:
        begun: What the fit starts from.
        whose: Whose the values are (``"Klipper's"``).
        source: The calibration's file.
        volume_source: The file whose ``[workspace]`` is the volume, or None (the calibration's).

    Raises:
        InputError: in place of the fit's UnreachableError or ConvergenceError.
    """
    try:
        yield
    except UnreachableError as exc:
        k = exc.indices[0] if exc.indices else 0
        volume = f"{volume_text(begun.workspace)}{begun.where}"
        raise InputError(f"a target of the printable volume ({volume}) is out of {whose} reach (row {k + 1} "
                         "of the fit's grid): give --robot with a [workspace] it reaches",
                         str(volume_source or source), "key workspace") from None
    except ConvergenceError as exc:
        raise InputError(f"{whose} values could not be fitted: {exc}", str(source)) from None


def volume_line(begun: ExportStart) -> str:
    """The summary's first line: the volume the errors are judged over, in the printed part's frame."""
    return (f"nozzle error over the printable volume ({volume_text(begun.workspace)}{begun.where}), of the "
            "printed part (less the shift along the bed and turn about its normal, which no measurement "
            "sees):")


def step_distance(known: np.ndarray | None, config: FirmwareModel | None, source: str | Path,
                  key: str) -> np.ndarray:
    """The printer's nominal step distances (3,): the calibration's, else the configuration's (equal)."""
    if known is not None:
        return known
    if config is not None and np.all(config.step_distance == config.step_distance[0]):
        return np.array(config.step_distance)
    raise InputError("no step_distance_mm: the step distance the printer's readings count in is not known "
                     "(identify the printer again, or give --config printer.cfg with one rotation_distance "
                     "on its three towers)", str(source), f"key {key}")


def volume_text(workspace: Workspace) -> str:
    """The printable volume in words, for the messages and the summary."""
    return f"radius {workspace.radius:g} mm, z from 0.2 to {workspace.top_z:g} mm"


def source_budget(firmware: Firmware[Any], begun: ExportStart,
                  hold_step_distance: bool) -> dict[str, ErrorFigures]:
    """What the firmware's values leave of each error source of the identified printer alone [mm].

    The printer's errors are its deviation from its nominal geometry, on its bed (no bed motion:
    the bed's tilt is in the towers' lean and positions):
    :func:`~deltacal.printer.firmware.budget.error_budget`.
    """
    geometry, nominal = begun.geometry, begun.nominal
    return error_budget(firmware, nominal, geometry.deviation_from(nominal), np.eye(3), np.zeros(3),
                        begun.start, begun.step, begun.workspace, hold_step_distance)


def summary(firmware: Firmware[Any], before: ErrorFigures, after: ErrorFigures,
            budget: dict[str, ErrorFigures], begun: ExportStart, held: list[str],
            from_config: bool) -> list[str]:
    """What the firmware's values leave, line by line [mm]: the whole, and each error source alone."""
    start = "the --config values" if from_config else "the nominal values"
    lines = [volume_line(begun),
             f"  these values: 3-D max {after.max_3d:.3f} mm, RMS {after.rms_3d:.3f} mm; first layer "
             f"(z 0.2 mm) max |dz| {after.flatness:.3f} mm, peak to valley {after.flatness_pv:.3f} mm",
             f"  {start}: 3-D max {before.max_3d:.3f} mm, RMS {before.rms_3d:.3f} mm; first layer "
             f"max |dz| {before.flatness:.3f} mm, peak to valley {before.flatness_pv:.3f} mm"]
    if held:
        lines.append(f"  held (not fitted): {', '.join(held)}")
    if begun.kept:
        lines.append(f"  kept at {start} (the measurements do not determine them better than the build "
                     f"tolerances): {', '.join(firmware.value_name(name) for name in begun.kept)}")
    lines.append(f"what {firmware.title}'s values cannot hold of each error source alone (3-D max / first "
                 "layer max |dz|; deltacal compensate corrects them):")
    width = max(len(label) for label in budget)
    lines += [f"  {label:{width}s}  {stats.max_3d:.3f} / {stats.flatness:.3f} mm"
              for label, stats in budget.items() if label != BED_TILT]
    lines.append("  (the bed's tilt is in the towers' lean and positions: the printer is expressed on its "
                 "bed)")
    return lines
