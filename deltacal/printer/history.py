"""What changed in a printer between its calibrations, in its owner's words, each with its σ.

Of two calibrations, :func:`compare_calibrations`; of several (oldest first), the printer's history
(:func:`calibration_history`): each quantity in each and each step between consecutive ones, all under
the newest's prior (:func:`under_one_prior`).

Each owner's quantity (:mod:`.owner`: a tower's endstop, travel, own leans and rods; the bed's slope)
is read from both calibrations through the same linear map of their 54 parameters
(:func:`~.owner.owner_quantities`). The change is NEW's value minus OLD's; the two calibrations are
independent measurements of one printer under one prior (OLD re-anchored to NEW's controller), so
what the prior leaves unknown is the same in both and cancels in the change: its σ is both
calibrations' noise parts (:attr:`~.owner.OwnerQuantities.noise`: ``Σ − Σ Σ₀⁻¹ Σ``) in quadrature
(their whole σ, prior's part included, when a calibration records no measurements). With the whole
σ, a 0.2 mm endstop move on a simulated Kossel read +0.20 ± 0.12 mm, though four noise seeds of
the same printer scatter its endstop by 0.03 mm. A change is **significant** when both calibrations
measure the quantity (:mod:`.owner`'s rule: σ below half its build tolerance) and
``|change| > 3 σ`` (:data:`SIGNIFICANT_SIGMAS`): by chance
alone, one quantity of the 20 crosses it about once in 19 comparisons of an unchanged printer.

Both calibrations' parameters are deviations from the nominal printer they were identified from,
under priors scaled by each one's evidence: the changes mean what they say only under one prior.
:func:`old_against_new_controller` identifies both again under NEW's
(:func:`~.identification.anchor.reanchored`) when their robot files or scales differ. A rotary printer's
readings are its arms' angles counted from its values' endstops: one identified through other rotary values
has its readings counted again as NEW's count the same steps (re-anchoring's count,
:func:`~.firmware.config_file.recounted_record`) before both are identified again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..calibration import Calibration
from ..controller_record import changes_in_words
from ..exceptions import AssemblyError, ConvergenceError, InputError
from ..geometry import DeltaGeometry, Tolerances
from .firmware.base import Firmware
from .firmware.config_file import check_printer_values, in_firmware_frame, recorded_firmware, recounted_record
from .firmware.controller import RotaryFirmwareController
from .identification.anchor import reanchored
from .identification.errormodels import PrinterModel, RotaryPrinterModel
from .owner import DETERMINED_FRACTION, TOWERS, Estimate, OwnerQuantities, owner_quantities
from .rotary_owner import rotary_owner_quantities

#: A change is significant when it exceeds this many of its σ (and both calibrations measure it).
SIGNIFICANT_SIGMAS = 3.0

#: Each tower's quantities, in :func:`~.owner.owner_quantities`'s order: (name, unit, digits).
_TOWER_QUANTITIES = (("endstop", "mm", 2), ("travel", "%", 3), ("lean outwards", "deg", 3),
                     ("lean sideways", "deg", 3), ("rods", "mm", 2), ("rods' difference", "mm", 2))


@dataclass(frozen=True)
class Change:
    """One owner's quantity in two calibrations, and its change.

    Attributes:
        what: The quantity in the owner's words (``tower B's endstop``).
        unit: Its unit (mm, deg, %).
        old: Its value in the older calibration.
        new: Its value in the newer one.
        sigma: The σ of ``new - old``: both calibrations' noise parts in quadrature.
        measured: Whether both calibrations measure it (σ below half its build tolerance in each).
        digits: Decimals to show.
    """

    what: str
    unit: str
    old: float
    new: float
    sigma: float
    measured: bool
    digits: int = 2

    @property
    def change(self) -> float:
        """``new - old``, in :attr:`unit`."""
        return self.new - self.old

    @property
    def significant(self) -> bool:
        """Both measured and ``|change| > 3 σ`` (:data:`SIGNIFICANT_SIGMAS`)."""
        return self.measured and abs(self.change) > SIGNIFICANT_SIGMAS * self.sigma

    def words(self) -> str:
        """``tower B's endstop moved +0.21 ± 0.03 mm: significant``."""
        d = self.digits
        moved = f"{self.what} moved {self.change:+.{d}f} ± {self.sigma:.{d}f} {self.unit}"
        if not self.measured:
            return f"{moved}: not measured by both calibrations"
        return f"{moved}: {'significant' if self.significant else 'not significant'}"


@dataclass(frozen=True)
class Quantity:
    """One owner's quantity through a printer's calibrations, oldest first: its history.

    Attributes:
        what: The quantity in the owner's words (``tower B's endstop``).
        unit: Its unit (mm, deg, %).
        values: Its value in each calibration, with its whole σ and whether that one measures it
            (:class:`~.owner.Estimate`).
        steps: Its change between each two consecutive calibrations (one fewer than ``values``).
        digits: Decimals to show.
    """

    what: str
    unit: str
    values: tuple[Estimate, ...]
    steps: tuple[Change, ...]
    digits: int = 2


def significant_in_words(changes: Sequence[Change]) -> str:
    """``significant: tower B's endstop``, or ``no significant change between them``."""
    found = [c.what for c in changes if c.significant]
    return f"significant: {', '.join(found)}" if found else "no significant change between them"


def _labels(names: Sequence[str]) -> list[tuple[str, str, int]]:
    """The owner's quantities' (name, unit, digits), in :func:`~.owner.owner_quantities`'s order."""
    labels = [(f"tower {names[i]}'s {what}", unit, digits) for i in range(3)
              for what, unit, digits in _TOWER_QUANTITIES]
    return labels + [(f"the bed's slope rising towards +{axis}", "deg", 3) for axis in "xy"]


def _linear(calibration: Calibration, tolerances: Tolerances | None, names: Sequence[str]
            ) -> tuple[OwnerQuantities, np.ndarray, list[tuple[str, str, int]]]:
    """A linear printer's quantities (:func:`~.owner.owner_quantities`), the owner's map, their labels."""
    # the bed's rotation vector β (rows 18, 19): its height at p is p·(z × β) = −β_y x + β_x y
    slope = np.eye(20)
    slope[18, 18:20], slope[19, 18:20] = (0.0, -1.0), (1.0, 0.0)
    return owner_quantities(calibration, tolerances), slope, _labels(names)


def _rotary(calibration: Calibration, tolerances: Tolerances | None, names: Sequence[str]
            ) -> tuple[OwnerQuantities, np.ndarray, list[tuple[str, str, int]]]:
    """A rotary printer's quantities arm by arm (:func:`~.rotary_owner.rotary_owner_quantities`)."""
    quantities, labels = rotary_owner_quantities(calibration, tolerances, names)
    return quantities, np.eye(len(labels)), labels


#: Each printer model's owner's quantities, asked of the calibration's model.
_OWNERS = {PrinterModel: _linear, RotaryPrinterModel: _rotary}


def _read(calibration: Calibration, tolerances: Tolerances | None, names: Sequence[str]
          ) -> tuple[list[tuple[Estimate, float]], list[tuple[str, str, int]]]:
    """Each owner's quantity of one calibration in the owner's unit: its estimate and its noise part's σ.

    Raises:
        ValueError: a calibration of no printer's model.
    """
    owner = _OWNERS.get(type(calibration.model))
    if owner is None:
        raise ValueError(f"model {calibration.model.name!r} is not a printer's complete model")
    q, mix, labels = owner(calibration, tolerances, names)
    out = []
    for k in range(len(labels)):
        u, row = q.units[k], mix[k]
        sigma = float(np.sqrt(max(row @ q.covariance @ row, 0.0))) * u
        before = float(np.sqrt(row**2 @ q.before**2)) * u
        estimate = Estimate(float(row @ q.values) * u, sigma, bool(sigma < DETERMINED_FRACTION * before))
        out.append((estimate, float(np.sqrt(max(row @ q.noise @ row, 0.0))) * u))
    return out, labels


def calibration_history(calibrations: Sequence[Calibration], tolerances: Tolerances | None = None,
                        names: Sequence[str] = TOWERS) -> list[Quantity]:
    """Each owner's quantity in each of a printer's calibrations, and each step's change.

    Args:
        calibrations: Two or more, oldest first, all against one controller under one prior
            (:func:`under_one_prior`).
        tolerances: The build tolerances that say what is measured (default: a kit's).
        names: The towers' names in the firmware's words.

    Returns:
        Per tower its endstop, travel, leans outwards and sideways, rods' mean and difference; then
        the bed's slope rising towards +x and towards +y [deg]. A step's σ: both calibrations' noise
        parts in quadrature; measured when both calibrations measure the quantity.

    Raises:
        ValueError: fewer than two calibrations, or one not of the complete printer model.
    """
    if len(calibrations) < 2:
        raise ValueError(f"a history needs two calibrations or more, got {len(calibrations)}")
    if len({type(c.model) for c in calibrations}) > 1:
        raise ValueError("a history needs calibrations of one printer model")
    read_labelled = [_read(c, tolerances, names) for c in calibrations]
    read = [r for r, _ in read_labelled]
    out = []
    for k, (what, unit, digits) in enumerate(read_labelled[-1][1]):
        values = tuple(r[k][0] for r in read)
        steps = tuple(Change(what, unit, a[k][0].value, b[k][0].value, float(np.hypot(a[k][1], b[k][1])),
                             a[k][0].determined and b[k][0].determined, digits)
                      for a, b in zip(read, read[1:], strict=False))
        out.append(Quantity(what, unit, values, steps, digits))
    return out


def compare_calibrations(old: Calibration, new: Calibration, tolerances: Tolerances | None = None,
                         names: Sequence[str] = TOWERS) -> list[Change]:
    """Each owner's quantity's change from ``old`` to ``new``, two calibrations against one controller.

    The one step of :func:`calibration_history` of the two.

    Args:
        old: The older calibration (complete ``printer`` model), already against ``new``'s controller
            (:func:`old_against_new_controller`).
        new: The newer one.
        tolerances: The build tolerances that say what is measured (default: a kit's).
        names: The towers' names in the firmware's words.

    Raises:
        ValueError: a calibration not of the complete printer model.
    """
    return [q.steps[0] for q in calibration_history((old, new), tolerances, names)]


def old_against_new_controller(
    old: Calibration, new: Calibration, old_source: str | Path, new_source: str | Path,
) -> tuple[Calibration, Calibration, Firmware[Any] | None, tuple[str, ...]]:
    """Both calibrations under one prior, NEW's (:func:`under_one_prior` of the two).

    Returns:
        OLD and NEW under one prior, the firmware (None: neither records one) and the lines to say.

    Raises:
        InputError: as :func:`under_one_prior`, one line.
    """
    (old, new), firmware, said = under_one_prior((old, new), (old_source, new_source))
    return old, new, firmware, said


def under_one_prior(
    calibrations: Sequence[Calibration], sources: Sequence[str | Path],
) -> tuple[list[Calibration], Firmware[Any] | None, tuple[str, ...]]:
    """A printer's calibrations (oldest first) under one prior, the newest's: each fit's measurements kept.

    Refuses a calibration of another firmware than the newest (naming both) or of another printer (a
    value beyond its build tolerance, naming the key). Each fit's prior is centred on the nominal
    printer it was identified from (its robot file: the controller values it was imported from) and
    scaled by the factor its evidence chose: a change of a quantity the measurements do not wholly
    determine would otherwise be the two priors' difference. When the nominals or the scales differ,
    all are identified again (:func:`~.identification.anchor.reanchored`) from the newest's nominal
    with one scale, the geometric mean of theirs (each data set's evidence weighing alike); said, with
    the controller values that differ. On a simulated Kossel whose tower B endstop moved 0.2 mm and
    whose printer.cfg was re-calibrated between two calibrations (tower A's arm 1 mm longer), OLD
    re-anchored with its own scale (0.57) against NEW's (1.17) read tower A's endstop moved
    -0.21 ± 0.07 mm; under one prior -0.02 ± 0.06 and tower B's +0.20 ± 0.05. Refused when a
    calibration that must be identified again records no measurements. A calibration that records no
    controller (written before they were recorded) is taken to be against the others', said.

    A rotary printer's calibrations are placed on the bed (the firmware's frame); one identified through
    other rotary values than the newest's (Klipper's DELTA_CALIBRATE run again between them) is re-anchored
    to the newest's values: placed by its own, its readings counted again as the newest's values count the
    same steps (:func:`_on_the_bed`), then all identified again under the newest's prior (not re-anchored
    first as ``compensate`` does, :func:`~.firmware.config_file.rotary_reanchored_to`: its start, moved to
    follow the newest's values, would be replaced by the newest's nominal here). Recorded values of
    another printer (a shoulder radius or an arm beyond a build's tolerance, a gear ratio) are refused
    naming the key. On a simulated printer of Klipper's example whose arm B endstop angle moved 0.3 deg
    and whose values Klipper's extended DELTA_CALIBRATE re-calibrated between two calibrations, arm B's
    endstop read +0.308 ± 0.038 deg, the only significant change (before: refused).

    Returns:
        The calibrations under one prior, the firmware (None: none records one) and the lines to say.

    Raises:
        InputError: as above, one line naming the file.
    """
    cals, new_source = list(calibrations), sources[-1]
    new = cals[-1]
    _one_kind(cals, sources)
    firmware = recorded_firmware(new, new_source)
    for old, old_source in zip(cals[:-1], sources, strict=False):
        firmware = _same_printer(old, new, old_source, new_source, firmware)
    said = tuple(f"{source} records no controller (written before calibrations recorded the one they were "
                 "identified with): taken to be the other's"
                 for source, cal in zip(sources, cals, strict=True) if cal.controller is None)
    changed, keys = _controller_changes(cals, sources)
    rotary = not new.geometry.chain.firmware  # a rotary printer's readings are angles its values count
    frame = _rotary_frame(new, new_source, firmware) if rotary else None
    recounted: list[str] = []
    if frame is not None:  # its measurements' heights are the bed's: each placed on it, as identified
        cals, recounted = _on_the_bed(cals, sources, frame)
        new = cals[-1]
    scales = [None if c.measured is None else c.measured.tolerance_scale for c in cals]
    if not recounted and all(_same_nominal(c.nominal, new.nominal) for c in cals) and len(set(scales)) == 1:
        if changed:  # the readings are the printer's own, whatever the values that commanded them
            said += (f"{_all(cals)} identified from the same nominal printer under one prior, through "
                     f"{keys}: compared as identified",)
        return cals, firmware, said
    for cal, source in zip(cals, sources, strict=True):
        if cal.measured is None:
            pair = " and ".join(str(s) for s in sources)
            raise InputError(f"{pair} were identified under different priors (another robot file or "
                             f"tolerances' scale; {keys}) and this one records no measurements to identify "
                             "again under one (written before they were recorded): identify "
                             f"{_all(cals)} from the same robot file", str(source))
    scale = float(np.prod([c.measured.tolerance_scale for c in cals if c.measured]) ** (1.0 / len(cals)))
    anchored = []
    for cal, source in zip(cals, sources, strict=True):
        assert cal.measured is not None
        try:
            anchored.append(_again(replace(cal, measured=replace(cal.measured, tolerance_scale=scale)),
                                   new.nominal, frame))
        except (ValueError, ConvergenceError, AssemblyError) as exc:
            raise InputError(f"identifying it again under {new_source}'s prior failed ({exc}): identify "
                             f"{_all(cals)} from the same robot file", str(source)) from None
    if recounted:  # the older readings counted as the newest's values count the same steps
        said += (f"{' and '.join(recounted)} re-anchored to {new_source}'s rotary values ({keys}: the arms' "
                 f"readings counted again from those values' endstops), then {_all(cals)} identified again "
                 f"under one prior ({new_source}'s robot file, the build tolerances scaled by {scale:.3g}): "
                 "what the measurements determine is kept",)
    else:
        said += (f"{_all(cals)} identified again under one prior ({new_source}'s robot file, the build "
                 f"tolerances scaled by {scale:.3g}; {keys}): what the measurements determine is kept",)
    return anchored, firmware, said


def _one_kind(cals: Sequence[Calibration], sources: Sequence[str | Path]) -> None:
    """Refuse a linear printer's calibration and a rotary one's together (one line naming both files)."""
    kinds = [c.geometry.chain for c in cals]
    for cal, source in zip(cals, sources, strict=True):
        if cal.geometry.chain != kinds[-1]:
            raise InputError(f"{cal.geometry.chain.words.a_robot}'s calibration but {sources[-1]} "
                             f"{kinds[-1].words.a_robot}'s: compare tells what changed in one printer",
                             str(source))


def _rotary_frame(new: Calibration, source: str | Path, firmware: Firmware[Any] | None
                  ) -> RotaryFirmwareController:
    """The rotary controller NEW was identified through (its recorded configuration, its values).

    A rotary printer's probe heights are in the firmware's frame (the bed's), its calibration in the
    robot file's {O}: its prior (the bed's place) and its identification again are the bed frame's, the
    controller placing it (:func:`~.firmware.config_file.in_firmware_frame`).

    Raises:
        InputError: no controller recorded, or its configuration not a rotary one that reads.
    """
    record = new.controller
    rotary = None
    if record is not None and firmware is not None:
        try:
            rotary = firmware.rotary_controller(record.source)
        except (InputError, OSError):
            rotary = None
    if rotary is None or record is None:
        where = ("records no controller" if record is None else
                 f"'s configuration {record.source} does not read")
        raise InputError("a rotary printer's calibrations are compared on the bed, placed through the "
                         f"configuration they were identified with, and this one {where}: give it where "
                         "it was", str(source))
    return rotary.with_values(record.values)


def _on_the_bed(cals: Sequence[Calibration], sources: Sequence[str | Path], frame: RotaryFirmwareController
                ) -> tuple[list[Calibration], list[str]]:
    """Rotary calibrations on the bed (the firmware's frame), each where the values it recorded place it.

    One identified through other rotary values than ``frame``'s (the newest's) is placed by its own
    (:func:`~.firmware.config_file.in_firmware_frame`, as re-anchoring places it) and its recorded readings
    counted again as ``frame``'s values count the same steps
    (:func:`~.firmware.config_file.recounted_record`), to be identified again under the newest's prior.

    Returns:
        The calibrations placed, and the files of those counted again.

    Raises:
        InputError: recorded values of another printer than the newest's (naming the key), or a
            calibration through other values that records no measurements to count again.
    """
    new = cals[-1].controller
    assert new is not None  # the newest's controller is the frame (:func:`_rotary_frame`)
    here = f"{sources[-1]}'s recorded controller {new.source}"
    placed: list[Calibration] = []
    recounted: list[str] = []
    for cal, source in zip(cals, sources, strict=True):
        record = cal.controller
        if record is None or not record.changes(new.values):
            placed.append(in_firmware_frame(cal, frame))
            continue
        recorded = frame.with_values(record.values)
        frame.check_same_values(recorded, f"{source}'s recorded controller {record.source}", here)
        if cal.measured is None:
            raise InputError(f"identified through other rotary values than {sources[-1]} "
                             f"({changes_in_words(record.changes(new.values))}) and records no measurements "
                             "to count again (written before they were recorded): identify "
                             f"{_all(cals)} through one configuration", str(source))
        placed.append(replace(in_firmware_frame(cal, recorded),
                              measured=recounted_record(cal.measured, recorded, frame)))
        recounted.append(str(source))
    return placed, recounted


def _again(cal: Calibration, nominal: DeltaGeometry, frame: RotaryFirmwareController | None) -> Calibration:
    """``cal``'s measurements identified again from ``nominal`` (a rotary printer's on ``frame``'s bed)."""
    return reanchored(cal, nominal, reach=None if frame is None else frame.reach_radius)


def _all(cals: Sequence[Calibration]) -> str:
    """``both`` of two calibrations, ``all 3`` of three."""
    return "both" if len(cals) == 2 else f"all {len(cals)}"


def _same_printer(old: Calibration, new: Calibration, old_source: str | Path, new_source: str | Path,
                  firmware: Firmware[Any] | None) -> Firmware[Any] | None:
    """OLD of NEW's firmware (``firmware``: NEW's, or an older one's) and printer; the firmware.

    Raises:
        InputError: another firmware (naming both) or another printer (naming the key).
    """
    theirs = recorded_firmware(old, old_source)
    if firmware is not None and theirs is not None and theirs is not firmware:
        assert old.controller is not None
        other = new.controller.source if new.controller is not None else new_source
        raise InputError(f"identified with {theirs.title} ({old.controller.source}) but {new_source} with "
                         f"{firmware.title} ({other}): two calibrations compare only through one firmware",
                         str(old_source))
    firmware = firmware or theirs
    if firmware is not None and new.geometry.chain.firmware:  # a rotary printer's: its values compared
        check_printer_values(firmware, old.geometry, firmware.start(new.geometry), old_source,
                             f"{new_source}'s geometry")
    return firmware


def _controller_changes(cals: Sequence[Calibration], sources: Sequence[str | Path]) -> tuple[bool, str]:
    """Whether an older calibration was identified with controller values other than the newest's; which."""
    new = cals[-1].controller
    found = []
    for cal, source in zip(cals[:-1], sources, strict=False):
        changes = [] if cal.controller is None or new is None else cal.controller.changes(new.values)
        if changes:
            found.append((source, changes_in_words(changes)))
    if not found:
        return False, "the same controller values"
    if len(cals) == 2:
        return True, f"controller values {found[0][1]}"
    return True, "controller values " + "; ".join(f"{source}'s {words}" for source, words in found)


def _same_nominal(a: DeltaGeometry, b: DeltaGeometry) -> bool:
    """Two nominal printers alike in every number (the same robot file)."""
    return all(np.array_equal(np.asarray(getattr(a, name), dtype=float),
                              np.asarray(getattr(b, name), dtype=float)) for name in NOMINAL_FIELDS)


#: The fields of a nominal printer that place its nozzle.
NOMINAL_FIELDS = ("axis_point", "axis_direction", "encoder_offset", "arm_ball", "plate_ball", "rod_length",
                  "tool", "step_distance")


__all__ = ["SIGNIFICANT_SIGMAS", "Change", "Quantity", "calibration_history", "compare_calibrations",
           "old_against_new_controller", "significant_in_words", "under_one_prior"]
