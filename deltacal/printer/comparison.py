"""deltacal's whole path on a simulated printer, beside its firmware's own calibration.

One seeded true printer (:func:`~deltacal.printer.simulation.random_true_printer`) runs a firmware's
nominal values (Klipper's by default; Marlin's or RepRapFirmware's, the same printer for a seed). It
is measured twice, with measurements of the same kind (commanded probe triggers, σ
:data:`PROBE_SIGMA`; caliper distances of a printed object, σ :data:`DISTANCE_SIGMA`):

* the firmware's way (:meth:`~deltacal.printer.firmware.base.Firmware.own_calibrations`, radius
  :data:`PROBE_RADIUS`): Klipper's 7 probe points and its object's 12 distances, for its basic and
  enhanced calibration (:func:`~deltacal.printer.firmware.klipper.calibrate.klipper_basic`,
  ``klipper_enhanced``); Marlin's ``G33``, probing again at each iteration
  (:func:`~deltacal.printer.firmware.marlin.calibrate.marlin_g33`); RepRapFirmware's ``G32`` with 6
  and 8 factors (:func:`~deltacal.printer.firmware.rrf.calibrate.rrf_g32`);
* deltacal's way: the planned object (:func:`~deltacal.printer.printed.plan.plan_object`: 49
  probe heights on Klipper's round mesh and 40 distances), read through the firmware's
  inverse into readings and identified (:func:`~deltacal.printer.identification.fit.identify_printer`,
  complete model, iterated, the kit's tolerances as priors, scaled by the measurements' evidence).

Each method is judged on the TRUE printer over the printable volume (:data:`WORKSPACE`, the
anchor's: radius 92 mm, z 0.2 to 100 mm; :func:`~deltacal.printer.firmware.klipper.fit.printable_grid`)
and over the first layer (z = 0.2 mm, :func:`~deltacal.printer.firmware.klipper.fit.first_layer`):

* the firmware's values (nominal, its own calibrations) and deltacal's exported values (the
  firmware's values fitted to the identified printer as ``export`` fits them,
  :meth:`~deltacal.printer.firmware.base.Firmware.fit` with ``minimax``: the least largest error,
  the first layer as flat as the least squares with each first-layer weight asked leave it; with
  ``best``, also fitted to the TRUE printer, the least largest error the firmware's values can leave
  with the first layer as flat as the exported values leave it): the nozzle where the true printer
  puts it when the firmware commands the target with those values;
* the G-code route: the corrected targets that make the identified printer land on the targets
  (:func:`~deltacal.controller.corrected_targets`), sent through the firmware's NOMINAL values to
  the true printer (:func:`gcode_refused` counts those its limits would not take).

Figures (:class:`~deltacal.printer.firmware.klipper.fit.ErrorStats`): 3-D max and RMS over the volume,
first-layer flatness (max |z| and peak to valley), raw and less the bed motion no probe or caliper
measures (a shift along the bed and a turn about its normal,
:func:`~deltacal.printer.robot.less_bed_motion`, fitted to each method's volume errors the same
way; it moves nothing vertically, so flatness is the same either way). Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..calibration import Calibration
from ..controller import corrected_targets
from ..geometry import DeltaGeometry, Tolerances, Workspace
from ..identification.result import IdentificationResult
from .firmware.base import Firmware, FirmwareModel
from .firmware.fitting import ErrorStats, first_layer, nozzle_errors, printable_grid
from .firmware.klipper.calibrate import BASIC_TITLE, ENHANCED_TITLE
from .firmware.klipper.firmware import KLIPPER
from .identification.fit import PrinterMeasurements, identify_printer
from .printed.plan import ObjectPlan
from .robot import NominalLinearDelta, less_bed_motion
from .simulation import (
    KIT_BED_TILT_DEG,
    WELL_BUILT_BED_TILT_DEG,
    TruePrinter,
    nozzle_positions,
    printed_distances,
    probe_heights,
    random_true_printer,
    typical_kit,
    well_built,
)

#: The printable volume judged (the anchor's): radius 92 mm, z 0.2 to 100 mm.
WORKSPACE = Workspace(radius=92.0, height=100.0, top_z=100.0)
#: Klipper's probe radius ([delta_calibrate] radius) [mm].
PROBE_RADIUS = 115.0
#: σ of a probe trigger and of a caliper distance [mm].
PROBE_SIGMA = 0.010
DISTANCE_SIGMA = 0.020
#: The tolerance classes: build tolerances and σ of the bed's tilts [deg].
CLASSES: dict[str, tuple[Tolerances, float]] = {
    "well built": (well_built(), WELL_BUILT_BED_TILT_DEG),
    "typical kit": (typical_kit(), KIT_BED_TILT_DEG),
}
#: The methods' names (the exported values get their weight appended).
UNCALIBRATED, BASIC, ENHANCED = "uncalibrated", BASIC_TITLE, ENHANCED_TITLE
EXPORTED, GCODE = "deltacal exported values", "deltacal G-code route"
BEST = "best possible values"


def exported_name(weight: float) -> str:
    """The method name of the exported values fitted with this first-layer weight."""
    return f"{EXPORTED} (w {weight:g})"


def best_name(weight: float) -> str:
    """The method name of the firmware's values fitted to the TRUE printer with this first-layer weight."""
    return f"{BEST} (w {weight:g})"


@dataclass(frozen=True)
class SimulatedMeasuring:
    """A true printer measured through a firmware's values (:class:`~.firmware.base.Measuring`).

    Attributes:
        truth: The true printer (its bed z = 0).
        step_distance: Its nominal step distance [mm].
        rng: The measurements' noise, drawn in the order they are made.
        distance_sigma: σ of a distance [mm] (a probe's: :data:`PROBE_SIGMA`).
    """

    truth: DeltaGeometry
    step_distance: np.ndarray | float
    rng: np.random.Generator
    distance_sigma: float = DISTANCE_SIGMA

    def heights(self, model: FirmwareModel, xy: np.ndarray) -> np.ndarray:
        """The commanded z at which the probe triggers at commanded x, y [mm], (N, 2) -> (N,)."""
        return probe_heights(self.truth, model, self.step_distance, xy, PROBE_SIGMA, self.rng)[:, 2]

    def distances(self, model: FirmwareModel, pairs: np.ndarray) -> np.ndarray:
        """Caliper distances between features printed at commanded positions [mm], (M, 6) -> (M,)."""
        return printed_distances(self.truth, model, self.step_distance, pairs, self.distance_sigma, self.rng)


@dataclass(frozen=True)
class PrinterRun:
    """One simulated printer, what it measured and what each method made of it.

    Attributes:
        truth: The true printer and how it was made.
        firmware: The firmware's nominal values it runs.
        step_distance: The printer's nominal step distance [mm].
        probe: deltacal's commanded probe triggers (z as measured) [mm], (N, 3).
        distances: The planned object's distances as measured [mm], (M,).
        result: The identification.
        configs: The firmware's values of each method by name (uncalibrated, its own calibrations,
            exported, best possible).
        firmware_type: The firmware (its object: Klipper, Marlin, RepRapFirmware).
        data: The measurements identified, at the readings the firmware commanded (None: not kept).
    """

    truth: TruePrinter
    firmware: FirmwareModel
    step_distance: np.ndarray | float
    probe: np.ndarray
    distances: np.ndarray
    result: IdentificationResult
    configs: dict[str, FirmwareModel] = field(default_factory=dict)
    firmware_type: Firmware = KLIPPER
    data: PrinterMeasurements | None = None


def plan_measurements(firmware: FirmwareModel, step_distance: np.ndarray | float, plan: ObjectPlan,
                      probe: np.ndarray, distances: np.ndarray,
                      distance_sigma: float = DISTANCE_SIGMA) -> PrinterMeasurements:
    """The planned object's measurements as the identification takes them: readings through the firmware.

    Args:
        firmware: The configuration the probing and the print were commanded with.
        step_distance: The printer's nominal step distance [mm].
        plan: The planned object.
        probe: Commanded probe triggers [mm], (N, 3).
        distances: The distances measured between the plan's pairs [mm], (M,).
        distance_sigma: Their σ [mm].
    """
    readings = firmware.inverse(probe, step_distance)
    ends = firmware.inverse(plan.pair_positions.reshape(-1, 3), step_distance).reshape(-1, 2, 3)
    return PrinterMeasurements(readings, ends, np.asarray(distances, dtype=float),
                               height_sigma=PROBE_SIGMA, distance_sigma=distance_sigma)


def firmware_calibrations(truth: DeltaGeometry, firmware: FirmwareModel, step_distance: np.ndarray | float,
                         rng: np.random.Generator, distance_sigma: float = DISTANCE_SIGMA,
                         firmware_type: Firmware = KLIPPER) -> dict[str, FirmwareModel]:
    """A firmware's own calibration of a true printer: its values uncalibrated, then each of its own.

    Klipper's (the default): its 7 probe heights and its object's 12 distances are measured with
    ``rng`` (in that order); ``DELTA_CALIBRATE`` gives the basic values, with ``DELTA_ANALYZE`` the
    enhanced ones. Keys :data:`UNCALIBRATED`, then
    :meth:`~deltacal.printer.firmware.base.Firmware.own_calibrations`' (:data:`BASIC`, :data:`ENHANCED`).
    """
    measuring = SimulatedMeasuring(truth, step_distance, rng, distance_sigma)
    return {UNCALIBRATED: firmware, **firmware_type.own_calibrations(firmware, measuring, PROBE_RADIUS)}


def run_printer(printer: NominalLinearDelta, plan: ObjectPlan, seed: int, tolerances: Tolerances,
                bed_tilt_deg: float, weights: tuple[float, ...] = (10.0,),
                distance_sigma: float = DISTANCE_SIGMA, firmware_type: Firmware = KLIPPER,
                best: bool = False) -> PrinterRun:
    """Make a seeded printer, measure it both ways and calibrate it with each method.

    The printer depends on the seed alone (the same for every firmware); the measurements are drawn
    after it, the firmware's own first.

    Args:
        printer: The nominal printer.
        plan: deltacal's planned object for it (commanded through the firmware's nominal values).
        seed: Seed of the printer and of its measurements' noise.
        tolerances: Its build tolerances (a class of :data:`CLASSES`).
        bed_tilt_deg: σ of each of its bed's tilts [deg].
        weights: First-layer weights of the exported values to fit.
        distance_sigma: σ of every distance, the firmware's and deltacal's [mm] (default a caliper's).
        firmware_type: The firmware the printer runs (default Klipper).
        best: Also the firmware's values fitted to the TRUE printer (:func:`best_name`, each weight):
            the least largest error with the first layer as flat as the exported values leave it.
    """
    firmware = firmware_type.nominal(printer)
    step = printer.step_distance
    rng = np.random.default_rng(seed)
    made = random_true_printer(printer, rng, tolerances, bed_tilt_deg)
    truth = made.geometry
    configs = firmware_calibrations(truth, firmware, step, rng, distance_sigma, firmware_type)
    probe = probe_heights(truth, firmware, step, plan.probe[:, :2], PROBE_SIGMA, rng)
    distances = printed_distances(truth, firmware, step, plan.pair_positions, distance_sigma, rng)
    data = plan_measurements(firmware, step, plan, probe, distances, distance_sigma)
    result = identify_printer(printer.geometry(), data, "printer", method="iterated",
                              tolerances=Tolerances.printer_kit())
    for w in weights:
        configs[exported_name(w)] = firmware_type.fit(result.geometry, firmware, step, WORKSPACE,
                                                      first_layer_weight=w, minimax=True).values
    for w in weights if best else ():
        layer = nozzle_errors(truth, configs[exported_name(w)], step, first_layer(WORKSPACE))[:, 2]
        configs[best_name(w)] = firmware_type.fit(truth, firmware, step, WORKSPACE, first_layer_weight=w,
                                                  minimax=True, flatness=float(np.max(np.abs(layer)))).values
    return PrinterRun(made, firmware, step, probe, distances, result, configs, firmware_type, data)


def gcode_commands(run: PrinterRun, targets: np.ndarray) -> np.ndarray:
    """The G-code route's commands: corrected targets through the firmware's nominal values [mm], (N, 3).

    As ``compensate`` sends them: in the controller's frame along the bed, where the calibration holds.
    """
    controller = run.firmware_type.controller(run.firmware, run.step_distance)
    return corrected_targets(Calibration.from_result(run.result), controller, targets).commands


def gcode_route_errors(run: PrinterRun, targets: np.ndarray) -> np.ndarray:
    """The true nozzle's errors, the corrected targets sent through the firmware's nominal values [mm]."""
    commands = gcode_commands(run, targets)
    return nozzle_positions(run.truth.geometry, run.firmware, run.step_distance, commands) - targets


def gcode_refused(run: PrinterRun) -> int:
    """How many of the G-code route's commands over the volume and the first layer the firmware refuses.

    Its limits are the nominal values' with the lowest Z lowered to admit the corrected bed
    (:meth:`~deltacal.printer.firmware.base.Firmware.admit_bed`, as ``compensate`` and the demo
    write them); a command outside them (:meth:`~deltacal.printer.firmware.base.FirmwareModel.outside`)
    is one the firmware would refuse, clamp or move.
    """
    limits = run.firmware_type.admit_bed(run.firmware, Calibration.from_result(run.result),
                                         run.step_distance, WORKSPACE.radius)
    targets = np.concatenate([printable_grid(WORKSPACE), first_layer(WORKSPACE)])
    return int(np.count_nonzero(limits.outside(gcode_commands(run, targets))))


def stats_of(volume: np.ndarray, errors: np.ndarray, layer_errors: np.ndarray,
             bed_motion_removed: bool = False) -> ErrorStats:
    """The figures of nozzle errors over the volume's grid and the first layer [mm].

    Args:
        volume: The volume's targets [mm], (N, 3).
        errors: The nozzle's errors there [mm], (N, 3).
        layer_errors: Its errors over the first layer [mm], (K, 3).
        bed_motion_removed: Less the shift along the bed and the turn about its normal that fit
            the volume's errors best (no vertical motion: the first layer's z is unchanged).
    """
    if bed_motion_removed:
        errors = less_bed_motion(volume, errors)[0]
    norm = np.linalg.norm(errors, axis=1)
    z = layer_errors[:, 2]
    return ErrorStats(float(norm.max()), float(np.sqrt(np.mean(norm**2))), float(np.max(np.abs(z))),
                      float(z.max() - z.min()))


def evaluate(run: PrinterRun) -> dict[str, dict[str, ErrorStats]]:
    """Each method's figures on the true printer: ``{"raw" | "less bed motion": {method: ErrorStats}}``."""
    volume, layer = printable_grid(WORKSPACE), first_layer(WORKSPACE)
    truth = run.truth.geometry
    errors = {name: (nozzle_errors(truth, config, run.step_distance, volume),
                     nozzle_errors(truth, config, run.step_distance, layer))
              for name, config in run.configs.items()}
    errors[GCODE] = (gcode_route_errors(run, volume), gcode_route_errors(run, layer))
    return {label: {name: stats_of(volume, e, z, removed) for name, (e, z) in errors.items()}
            for label, removed in (("raw", False), ("less bed motion", True))}
