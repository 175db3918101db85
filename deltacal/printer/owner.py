"""A printer's errors in its owner's words: each tower's endstop, lean, travel and rods, and the bed.

A printer's calibration holds 54 parameters of its full geometry (:mod:`.identification.errormodels`);
its owner asks other questions first: which tower's endstop is off and by how much, which tower
leans and which way, whose steps are short, whether the bed is tilted, whether the rods match. This
module reads those from a :class:`~deltacal.calibration.Calibration` of the complete model
(``printer``), each with its σ, and says which the measurements determine:

* a tower's **endstop** [mm]: ``endstop{i}``, positive when the carriage stops higher than the
  firmware's values say;
* its **travel** [%]: ``scale{i}`` per 100 mm, positive when the carriage travels more than
  commanded (its step distance, Klipper's ``rotation_distance``, is that much too small);
* its **lean** [deg]: the top's move per unit height, ``lean{i}t`` outwards along r_i and
  ``−lean{i}r`` sideways along t_i (anticlockwise seen from above: a rotation about r_i by ε moves
  the top by ε r_i × z = −ε t_i); the part all three towers share is the **bed's tilt** relative to
  the towers (a tilted bed and three towers leaning alike are one and the same to every
  measurement on the bed), the rest each tower's own lean;
* its **rods** [mm]: the mean of its two ``l{i}{j}`` and their difference.

A quantity is *determined* when the measurements bound it to less than half its build tolerance
(its σ before any measurement, :meth:`~deltacal.printer.identification.errormodels.PrinterModel.prior_sigma`
of the given tolerances); else only the tolerance bounds it, and the owner is told it was not
measured. Units: mm and deg on output, the model's mm and rad inside.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..calibration import Calibration
from ..geometry import DeltaGeometry, Tolerances
from ..identification.solver import solve_wls
from .firmware.owner_keys import OwnerKeys
from .identification.anchor import prior_factor_of
from .identification.errormodels import SCALE_TRAVEL_MM, PrinterModel
from .identification.fit import PrinterMeasurements, residuals_and_regressor

#: A quantity is determined when its σ is below this fraction of its σ before any measurement.
DETERMINED_FRACTION = 0.5
#: The towers' names when the firmware gives none.
TOWERS = ("A", "B", "C")


@dataclass(frozen=True)
class Estimate:
    """One quantity: its value, its σ and whether the measurements determine it.

    Attributes:
        value: In the quantity's unit (mm, deg or %).
        sigma: Its standard deviation, same unit.
        determined: Whether the measurements bound it to less than half its build tolerance.
    """

    value: float
    sigma: float
    determined: bool

    def words(self, unit: str, digits: int = 2) -> str:
        """``0.23 ± 0.01 mm``, or ``not measured (± 0.40 mm by the build tolerance)``."""
        if not self.determined:
            return f"not measured (± {self.sigma:.{digits}f} {unit} by the build tolerance)"
        return f"{self.value:+.{digits}f} ± {self.sigma:.{digits}f} {unit}"


@dataclass(frozen=True)
class TowerErrors:
    """One tower's errors in its owner's units.

    Attributes:
        name: The tower's name (``A``, or the firmware's, ``X``).
        endstop: Its carriage's stop above the firmware's value [mm].
        travel: Its carriage's travel beyond the commanded one [%].
        lean_out: Its own lean, the top outwards [deg] (the bed's tilt taken out).
        lean_side: Its own lean, the top anticlockwise seen from above [deg].
        rods: Its two rods' mean length beyond the firmware's [mm].
        rods_apart: Its second rod's length minus its first's [mm].
    """

    name: str
    endstop: Estimate
    travel: Estimate
    lean_out: Estimate
    lean_side: Estimate
    rods: Estimate
    rods_apart: Estimate


@dataclass(frozen=True)
class PrinterErrors:
    """What is wrong with a printer, tower by tower and the bed.

    Attributes:
        towers: Each tower's errors (A, B, C).
        bed_tilt: The bed's tilt relative to the towers [deg].
        bed_low_azimuth: The azimuth of the bed's low side [deg] (0: +x, anticlockwise).
    """

    towers: tuple[TowerErrors, TowerErrors, TowerErrors]
    bed_tilt: Estimate
    bed_low_azimuth: float

    def lines(self) -> list[str]:
        """The errors in words, one line per tower and one for the bed."""
        out = []
        for t in self.towers:
            out.append(f"tower {t.name}: endstop {t.endstop.words('mm')} ({_high(t.endstop)}); "
                       f"travel {t.travel.words('%')} ({_travel(t.travel)}); "
                       f"lean outwards {t.lean_out.words('deg', 3)}, sideways {t.lean_side.words('deg', 3)}; "
                       f"rods {t.rods.words('mm')} (the pair {t.rods_apart.words('mm')} apart)")
        if self.bed_tilt.determined and self.bed_tilt.value > 2.0 * self.bed_tilt.sigma:
            tilt = self.bed_tilt
            out.append(f"bed: tilted {tilt.value:.3f} ± {tilt.sigma:.3f} deg relative to the towers, "
                       f"low towards azimuth {self.bed_low_azimuth:.0f} deg")
        elif self.bed_tilt.determined:
            out.append(f"bed: level relative to the towers within {2.0 * self.bed_tilt.sigma:.3f} deg")
        else:
            out.append(f"bed: tilt {self.bed_tilt.words('deg', 3)}")
        return out


def _significant(e: Estimate) -> bool:
    """Determined, and more than twice its σ away from zero."""
    return e.determined and abs(e.value) > 2.0 * e.sigma


#: What the owner reads of a quantity whose σ is at least its value: its sign is not known.
UNDETERMINED = "not determined by these measurements"


def _high(e: Estimate) -> str:
    if not e.determined:
        return "unknown"
    if abs(e.value) <= e.sigma:
        return UNDETERMINED
    return "stops high" if e.value > 0 else "stops low"


def _travel(e: Estimate) -> str:
    if not e.determined:
        return "unknown"
    if abs(e.value) <= e.sigma:
        return UNDETERMINED
    if e.value > 0:
        return "travels long: its step distance is short"
    return "travels short: its step distance is long"


def measured_covariance(start: DeltaGeometry, data: PrinterMeasurements,
                        tolerances: Tolerances | None = None) -> np.ndarray:
    """The covariance of the 54 parameters the measurements leave with the build tolerances as priors.

    The reference for what the measurements determine (:func:`printer_errors`): the linearised fit
    at ``start`` with the tolerances as given (not scaled by the evidence, which may shrink them
    until an unmeasured parameter looks known), (54, 54) in mm and rad.
    """
    model = PrinterModel()
    _, W, _ = residuals_and_regressor(start, model, data)
    prior = model.prior_sigma(tolerances or Tolerances.printer_kit())
    _, _, Rinv = solve_wls(np.vstack([W * prior, np.eye(prior.size)]), np.zeros(W.shape[0] + prior.size))
    return (Rinv @ Rinv.T) * np.outer(prior, prior)


def printer_errors(calibration: Calibration, tolerances: Tolerances | None = None,
                   names: Sequence[str] = TOWERS, reference: np.ndarray | None = None) -> PrinterErrors:
    """A printer's errors in its owner's words, from a calibration of the complete model.

    Args:
        calibration: A printer's calibration with the model ``printer`` (every parameter kept).
        tolerances: The build tolerances that say what is determined (default: a kit's).
        names: The towers' names in the firmware's words.
        reference: What says whether the measurements determine a quantity: the parameters'
            covariance from the measurements with ``tolerances`` as priors
            (:func:`measured_covariance`); default: the calibration's own.

    Returns:
        The errors, each with its σ.

    Raises:
        ValueError: the calibration is not of the complete printer model.
    """
    quantities = owner_quantities(calibration, tolerances)
    rows, units, values, before = quantities.rows, quantities.units, quantities.values, quantities.before
    sigma = np.sqrt(np.maximum(np.diag(quantities.covariance), 0.0))
    known = sigma
    if reference is not None:
        known = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", rows, reference, rows), 0.0))
    est = [Estimate(float(v * u), float(s * u), bool(k < DETERMINED_FRACTION * b))
           for v, s, k, b, u in zip(values, sigma, known, before, units, strict=True)]
    towers = tuple(TowerErrors(names[i], *est[6 * i:6 * i + 6]) for i in range(3))
    tilt_xy = np.array([values[18], values[19]])  # the bed's rotation vector (x, y) [rad]
    tilt = float(np.hypot(*tilt_xy))
    # the bed's height at p is p·(z × β): its high side is along z × β, its low side opposite
    high = np.array([-tilt_xy[1], tilt_xy[0]])
    tilt_sigma = float(np.sqrt(np.mean(sigma[18:20] ** 2)))
    tilt_known = float(np.sqrt(np.mean(known[18:20] ** 2)))
    tilt_before = float(np.sqrt(np.mean(before[18:20] ** 2)))
    bed = Estimate(float(np.degrees(tilt)), float(np.degrees(tilt_sigma)),
                   bool(tilt_known < DETERMINED_FRACTION * tilt_before))
    low = float(np.degrees(np.arctan2(-high[1], -high[0])) % 360.0)
    return PrinterErrors(towers, bed, low)  # type: ignore[arg-type]


@dataclass(frozen=True)
class OwnerQuantities:
    """The owner's quantities of a calibration as linear combinations of its 54 parameters.

    Rows 6i..6i+5: tower i's endstop, travel, own lean outwards, own lean sideways, rods' mean, rods'
    difference; rows 18, 19: the bed's rotation vector (x, y). In the model's units (mm, rad; the
    travel in %): ``units`` turns each into the owner's (mm, deg, %).

    Attributes:
        rows: (20, 54) the linear map from the parameters (the model's order) to the quantities.
        units: (20,) each quantity's factor to the owner's unit.
        values: (20,) each quantity's value, the model's units.
        covariance: (20, 20) their covariance from the calibration's, the model's units.
        before: (20,) each one's σ before any measurement (the build tolerances).
        noise: (20, 20) the part of ``covariance`` the measurements' noise makes (the rest is the
            prior's, which two calibrations of one printer share): from ``Σ − Σ Σ₀⁻¹ Σ`` (Σ₀ the
            fit's prior, :func:`~.identification.anchor.prior_factor_of`) when the calibration records
            its measurements; else ``covariance``.
    """

    rows: np.ndarray
    units: np.ndarray
    values: np.ndarray
    covariance: np.ndarray
    before: np.ndarray
    noise: np.ndarray


def owner_quantities(calibration: Calibration, tolerances: Tolerances | None = None) -> OwnerQuantities:
    """The owner's quantities of a calibration of the complete model, their covariance and prior σ.

    Raises:
        ValueError: the calibration is not of the complete printer model.
    """
    model = PrinterModel()
    value, cov = model_parameters(calibration, model.names, "printer")
    prior = model.prior_sigma(tolerances or Tolerances.printer_kit())
    rows, units = _quantity_rows(calibration, model)
    noise = cov
    if calibration.measured is not None:  # Σ − Σ Σ₀⁻¹ Σ: what the measurements' noise leaves
        L = prior_factor_of(calibration)  # the model's order, as cov
        half = np.linalg.solve(L, cov)
        noise = cov - half.T @ half
    return OwnerQuantities(rows, units, rows @ value, rows @ cov @ rows.T,
                           np.sqrt(np.einsum("ij,j,ij->i", rows, prior**2, rows)), rows @ noise @ rows.T)


def model_parameters(calibration: Calibration, names: Sequence[str],
                     model: str) -> tuple[np.ndarray, np.ndarray]:
    """The calibration's values of the parameters ``names`` (model ``model``'s order) and their covariance.

    Raises:
        ValueError: a parameter the calibration does not hold (another model, or regrouped).
    """
    index = {p.name: k for k, p in enumerate(calibration.base)}
    missing = [n for n in names if n not in index]
    if missing:
        raise ValueError(f"a printer's errors need every parameter of the {model!r} model; {missing[0]} is "
                         f"not in the calibration (model {calibration.model.name!r})")
    order = [index[n] for n in names]
    where = {k: j for j, k in enumerate(calibration.robot_index)}
    picked = [where[k] for k in order]
    values = np.array([calibration.base[k].value for k in order])
    return values, calibration.covariance()[np.ix_(picked, picked)]


def _quantity_rows(calibration: Calibration, model: PrinterModel) -> tuple[np.ndarray, np.ndarray]:
    """Each owner's quantity as a linear combination of the 54 parameters, and its unit factor.

    Rows 6i..6i+5: tower i's endstop, travel, own lean outwards, own lean sideways, rods' mean,
    rods' difference; rows 18, 19: the bed's rotation vector (x, y) [rad].
    """
    col = {n: k for k, n in enumerate(model.names)}
    azimuth = np.asarray(calibration.nominal.limb_azimuth, dtype=float)
    r = np.stack([np.cos(azimuth), np.sin(azimuth)], axis=1)
    t = np.stack([-np.sin(azimuth), np.cos(azimuth)], axis=1)
    # the top's horizontal move per unit height of tower i: lean_it r_i − lean_ir t_i, as rows (2, 54)
    top = np.zeros((3, 2, model.size))
    for i in range(3):
        top[i, :, col[f"lean{i + 1}t"]] = r[i]
        top[i, :, col[f"lean{i + 1}r"]] = -t[i]
    shared = top.mean(axis=0)  # what the three share: the bed tilted the other way
    rows = np.zeros((20, model.size))
    units = np.ones(20)
    for i in range(3):
        rows[6 * i, col[f"endstop{i + 1}"]] = 1.0
        rows[6 * i + 1, col[f"scale{i + 1}"]] = 100.0 / SCALE_TRAVEL_MM
        own = top[i] - shared
        rows[6 * i + 2] = r[i] @ own
        rows[6 * i + 3] = t[i] @ own
        units[6 * i + 2:6 * i + 4] = np.degrees(1.0)
        rows[6 * i + 4, [col[f"l{i + 1}1"], col[f"l{i + 1}2"]]] = 0.5
        rows[6 * i + 5, col[f"l{i + 1}1"]], rows[6 * i + 5, col[f"l{i + 1}2"]] = -1.0, 1.0
    # towers leaning alike by the top's move m are the bed turned by β with β × z = −m: β = (m_y, −m_x)
    rows[18], rows[19] = shared[1], -shared[0]
    return rows, units


def owner_lines(errors: PrinterErrors, keys: OwnerKeys, firmware: str) -> list[str]:
    """The printer's errors in its owner's words, each with the firmware's value that holds it, or none.

    Args:
        errors: The printer's errors (:func:`printer_errors`, with ``keys.towers`` as names).
        keys: Where the firmware keeps each value (:attr:`~.firmware.base.Firmware.owner_keys`).
        firmware: The firmware's name users read (``Klipper``).

    Returns:
        One line per tower and per error class, then the bed, then what stays.
    """
    out = [f"What the measurements say of the printer, in {firmware}'s words (± one σ):"]
    stays = []
    for i, t in enumerate(errors.towers):
        out.append(f"  tower {t.name}: endstop {t.endstop.words('mm')} ({_high(t.endstop)}), held by "
                   f"{keys.key(keys.endstop, i)}")
        out.append(f"  tower {t.name}: travel {t.travel.words('%')} ({_travel(t.travel)}), held by "
                   f"{keys.key(keys.travel, i)}")
        if t.rods.determined or t.rods_apart.determined:
            out.append(f"  tower {t.name}: rods {t.rods.words('mm')}, the pair {t.rods_apart.words('mm')} "
                       f"apart; their mean held by {keys.key(keys.rods, i)}")
        else:
            out.append(f"  tower {t.name}: rods {t.rods.words('mm')}")
        out.append(f"  tower {t.name}: leans outwards {t.lean_out.words('deg', 3)}, sideways "
                   f"{t.lean_side.words('deg', 3)}")
        if _significant(t.lean_out) or _significant(t.lean_side):
            stays.append(f"tower {t.name}'s lean ({keys.key(keys.angle, i)} holds a sideways lean at the bed "
                         "only)")
    if errors.bed_tilt.determined and errors.bed_tilt.value > 2.0 * errors.bed_tilt.sigma:
        tilt = errors.bed_tilt
        holder = f"held by {keys.bed_tilt}" if keys.bed_tilt else f"no {firmware} value holds it"
        out.append(f"  bed: tilted {tilt.value:.3f} ± {tilt.sigma:.3f} deg relative to the towers, low "
                   f"towards azimuth {errors.bed_low_azimuth:.0f} deg; {holder}")
        if not keys.bed_tilt:
            stays.append("the bed's tilt")
    elif errors.bed_tilt.determined:
        out.append(f"  bed: level relative to the towers within {2.0 * errors.bed_tilt.sigma:.3f} deg")
    else:
        out.append(f"  bed: tilt {errors.bed_tilt.words('deg', 3)}")
    if stays:
        out.append(f"  {firmware}'s values cannot hold {', '.join(stays)}: the G-code route "
                   "(deltacal compensate) corrects them")
    return out
