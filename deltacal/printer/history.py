"""What changed in a printer between two of its calibrations, in its owner's words, each with its σ.

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
(:func:`~.identification.anchor.reanchored`) when their robot files or scales differ.
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
from .firmware.config_file import check_printer_values, recorded_firmware
from .identification.anchor import reanchored
from .owner import DETERMINED_FRACTION, TOWERS, owner_quantities

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


def compare_calibrations(old: Calibration, new: Calibration, tolerances: Tolerances | None = None,
                         names: Sequence[str] = TOWERS) -> list[Change]:
    """Each owner's quantity's change from ``old`` to ``new``, two calibrations against one controller.

    Args:
        old: The older calibration (complete ``printer`` model), already against ``new``'s controller
            (:func:`old_against_new_controller`).
        new: The newer one.
        tolerances: The build tolerances that say what is measured (default: a kit's).
        names: The towers' names in the firmware's words.

    Returns:
        Per tower its endstop, travel, leans outwards and sideways, rods' mean and difference; then
        the bed's slope rising towards +x and towards +y [deg].

    Raises:
        ValueError: a calibration not of the complete printer model.
    """
    a, b = owner_quantities(old, tolerances), owner_quantities(new, tolerances)
    # the bed's rotation vector β (rows 18, 19): its height at p is p·(z × β) = −β_y x + β_x y
    slope = np.eye(20)
    slope[18, 18:20], slope[19, 18:20] = (0.0, -1.0), (1.0, 0.0)
    labels = [(f"tower {names[i]}'s {what}", unit, digits) for i in range(3)
              for what, unit, digits in _TOWER_QUANTITIES]
    labels += [(f"the bed's slope rising towards +{axis}", "deg", 3) for axis in "xy"]
    out = []
    for k, (what, unit, digits) in enumerate(labels):
        u, row = a.units[k], slope[k]
        values = [float(row @ q.values) * u for q in (a, b)]
        sigmas = [float(np.sqrt(max(row @ q.covariance @ row, 0.0))) * u for q in (a, b)]
        noise = [float(np.sqrt(max(row @ q.noise @ row, 0.0))) * u for q in (a, b)]
        before = float(np.sqrt(row**2 @ a.before**2)) * u
        measured = all(s < DETERMINED_FRACTION * before for s in sigmas)
        out.append(Change(what, unit, values[0], values[1], float(np.hypot(*noise)), measured, digits))
    return out


def old_against_new_controller(
    old: Calibration, new: Calibration, old_source: str | Path, new_source: str | Path,
) -> tuple[Calibration, Calibration, Firmware[Any] | None, tuple[str, ...]]:
    """Both calibrations under one prior, NEW's: each fit's measurements kept; the firmware; what to say.

    Refuses two calibrations of different firmwares (naming both) or printers (a value beyond its build
    tolerance, naming the key). Each fit's prior is centred on the nominal printer it was identified
    from (its robot file: the controller values it was imported from) and scaled by the factor its
    evidence chose: a change of a quantity the measurements do not wholly determine would otherwise
    be the two priors' difference. When the nominals or the scales differ, both are identified again
    (:func:`~.identification.anchor.reanchored`) from NEW's nominal with one scale, the geometric
    mean of the two (each data set's evidence weighing alike); said, with the controller values that
    differ. On a simulated Kossel whose tower B endstop moved 0.2 mm and whose printer.cfg was
    re-calibrated between them (tower A's arm 1 mm longer), OLD re-anchored with its own scale (0.57)
    against NEW's (1.17) read tower A's endstop moved -0.21 ± 0.07 mm; under one prior -0.02 ± 0.06
    and tower B's +0.20 ± 0.05. Refused when a calibration that must be identified again records no
    measurements. A calibration that records no controller (written before they were recorded) is
    taken to be against the other's, said.

    Returns:
        OLD and NEW under one prior, the firmware (None: neither records one) and the lines to say.

    Raises:
        InputError: as above, one line.
    """
    firmware = recorded_firmware(new, new_source)
    theirs = recorded_firmware(old, old_source)
    if firmware is not None and theirs is not None and theirs is not firmware:
        assert old.controller is not None and new.controller is not None
        raise InputError(f"identified with {theirs.title} ({old.controller.source}) but {new_source} with "
                         f"{firmware.title} ({new.controller.source}): two calibrations compare only "
                         "through one firmware", str(old_source))
    firmware = firmware or theirs
    if firmware is not None:
        check_printer_values(firmware, old.geometry, firmware.start(new.geometry), old_source,
                             f"{new_source}'s geometry")
    said = tuple(f"{source} records no controller (written before calibrations recorded the one they were "
                 "identified with): taken to be the other's" for source, cal in ((old_source, old),
                                                                               (new_source, new))
                 if cal.controller is None)
    changes = [] if old.controller is None or new.controller is None else \
        old.controller.changes(new.controller.values)
    keys = f"controller values {changes_in_words(changes)}" if changes else "the same controller values"
    scales = [None if c.measured is None else c.measured.tolerance_scale for c in (old, new)]
    if _same_nominal(old.nominal, new.nominal) and scales[0] == scales[1]:
        if changes:  # the readings are the printer's own, whatever the values that commanded them
            said += (f"both identified from the same nominal printer under one prior, through {keys}: "
                     "compared as identified",)
        return old, new, firmware, said
    for cal, source in ((old, old_source), (new, new_source)):
        if cal.measured is None:
            raise InputError(f"{old_source} and {new_source} were identified under different priors (another "
                             f"robot file or tolerances' scale; {keys}) and this one records no measurements "
                             "to identify again under one (written before they were recorded): identify both "
                             "from the same robot file", str(source))
    assert old.measured is not None and new.measured is not None
    scale = float(np.sqrt(old.measured.tolerance_scale * new.measured.tolerance_scale))
    try:
        old, new = (reanchored(replace(c, measured=replace(c.measured, tolerance_scale=scale)), new.nominal)
                    for c in (old, new) if c.measured is not None)
    except (ValueError, ConvergenceError, AssemblyError) as exc:
        raise InputError(f"identifying it again under {new_source}'s prior failed ({exc}): identify both "
                         "from the same robot file", str(old_source)) from None
    said += (f"both identified again under one prior ({new_source}'s robot file, the build tolerances scaled "
             f"by {scale:.3g}; {keys}): what the measurements determine is kept",)
    return old, new, firmware, said


def _same_nominal(a: DeltaGeometry, b: DeltaGeometry) -> bool:
    """Two nominal printers alike in every number (the same robot file)."""
    return all(np.array_equal(np.asarray(getattr(a, name), dtype=float),
                              np.asarray(getattr(b, name), dtype=float)) for name in NOMINAL_FIELDS)


#: The fields of a nominal printer that place its nozzle.
NOMINAL_FIELDS = ("axis_point", "axis_direction", "encoder_offset", "arm_ball", "plate_ball", "rod_length",
                  "tool", "step_distance")


__all__ = ["SIGNIFICANT_SIGMAS", "Change", "compare_calibrations", "old_against_new_controller"]
