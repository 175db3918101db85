"""A rotary Delta printer's errors in its owner's words: each arm's endstop, gear ratio, lengths and shoulder.

A rotary printer's calibration holds the 54 parameters of :class:`~.identification.errormodels.
RotaryPrinterModel`; its owner asks which arm stops off, whose gear turns long, whether the upper and
lower arms are the lengths the firmware holds, and whether a shoulder's axis is crooked. Per arm i (the
firmware's stepper a, b, c: arm A, B, C):

* its **endstop** [deg]: ``beta{i}t``, the arm's frame turned about its shoulder axis: the angle at
  which the arm stops, off by that much (Klipper holds it as ``[stepper_a] position_endstop``);
* its **gear ratio** [%]: ``scale{i}`` (over 100 deg): positive when the arm turns more than commanded
  (``gear_ratio`` too small: a step angle too large in the firmware's count is a short one in truth);
* its **upper arm** [mm]: the mean of its two elbow balls' ``a{i}{j}x`` (along the arm), Klipper's
  ``upper_arm_length``; its **lower arms** [mm]: the mean of ``l{i}1``, ``l{i}2`` (``lower_arm_length``)
  and their difference;
* its **shoulder** [deg]: the axis tilted (``beta{i}r``: turned about the arm's zero direction, one end up)
  and turned (``beta{i}z``: about up), which no firmware value holds.

A quantity is determined when the calibration bounds it to less than half its σ before any measurement
(:meth:`~deltacal.geometry.Tolerances.rotary_printer_kit`, :data:`~.owner.DETERMINED_FRACTION`).
Units: deg, % and mm on output.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..calibration import Calibration
from ..geometry import Tolerances
from .identification.anchor import prior_factor_of
from .identification.errormodels import RotaryPrinterModel
from .owner import DETERMINED_FRACTION, UNDETERMINED, Estimate, OwnerQuantities, model_parameters

#: The arms' names (Klipper's steppers a, b, c).
ARMS = ("A", "B", "C")
#: Degrees per radian (the owner's unit of the model's angles).
_DEG = float(np.degrees(1.0))


def _rows(i: int) -> list[tuple[str, str, dict[str, float]]]:
    """Arm i's quantities as weighted sums of the model's parameters, in the owner's units."""
    n = i + 1
    return [("endstop", "deg", {f"beta{n}t": _DEG}),
            ("gear ratio", "%", {f"scale{n}": _DEG}),  # deg over 100 deg: a per cent
            ("upper arm", "mm", {f"a{n}1x": 0.5, f"a{n}2x": 0.5}),
            ("lower arms", "mm", {f"l{n}1": 0.5, f"l{n}2": 0.5}),
            ("lower arms apart", "mm", {f"l{n}1": -1.0, f"l{n}2": 1.0}),
            ("shoulder tilted", "deg", {f"beta{n}r": _DEG}),
            ("shoulder turned", "deg", {f"beta{n}z": _DEG})]


def rotary_owner_quantities(calibration: Calibration, tolerances: Tolerances | None = None,
                            names: Sequence[str] = ARMS, noise_part: bool = True
                            ) -> tuple[OwnerQuantities, list[tuple[str, str, int]]]:
    """The owner's quantities of a rotary printer's calibration, as :func:`~.owner.owner_quantities`'s.

    Arm by arm (:func:`_rows`: endstop, gear ratio, upper arm, lower arms, their difference, shoulder
    tilted and turned), already in the owner's units (``units`` all 1), with their noise part
    (``Σ − Σ Σ₀⁻¹ Σ`` when the calibration records its measurements and ``noise_part``: its prior is
    the bed frame's, the calibration must be on the firmware's bed); and each one's (what, unit,
    digits): ``arm B's endstop``, deg, 3.

    Raises:
        ValueError: the calibration is not of the whole ``rotary_printer`` model.
    """
    model = RotaryPrinterModel()
    values, cov = model_parameters(calibration, model.names, model.name)
    prior = model.prior_sigma(tolerances or model.kit_tolerances())
    col = {name: k for k, name in enumerate(model.names)}
    rows, labels = [], []
    for i, arm in enumerate(names):
        for what, unit, weights in _rows(i):
            row = np.zeros(model.size)
            for parameter, w in weights.items():
                row[col[parameter]] = w
            rows.append(row)
            labels.append((f"arm {arm}'s {what}", unit, 3 if unit == "deg" else 2))
    m = np.array(rows)
    noise = cov
    if noise_part and calibration.measured is not None:  # Σ − Σ Σ₀⁻¹ Σ: what the measurements' noise leaves
        half = np.linalg.solve(prior_factor_of(calibration), cov)
        noise = cov - half.T @ half
    quantities = OwnerQuantities(m, np.ones(len(m)), m @ values, m @ cov @ m.T,
                                 np.sqrt(np.einsum("ij,j,ij->i", m, prior**2, m)), m @ noise @ m.T)
    return quantities, labels


def arm_errors(calibration: Calibration, tolerances: Tolerances | None = None
               ) -> list[dict[str, tuple[Estimate, str]]]:
    """Each arm's quantities (its :class:`~.owner.Estimate` and unit), arms A, B, C.

    Raises:
        ValueError: the calibration is not of the whole ``rotary_printer`` model.
    """
    q, labels = rotary_owner_quantities(calibration, tolerances, noise_part=False)
    sigma = np.sqrt(np.maximum(np.diag(q.covariance), 0.0))
    arms: list[dict[str, tuple[Estimate, str]]] = [{}, {}, {}]
    for k, (value, s, before) in enumerate(zip(q.values, sigma, q.before, strict=True)):
        what, unit, _ = labels[k]
        arms[k // 7][what.split("'s ", 1)[1]] = (
            Estimate(float(value), float(s), bool(s < DETERMINED_FRACTION * before)), unit)
    return arms


def _sense(name: str, e: Estimate) -> str:
    """What a value's sign says, or that it is not known."""
    if not e.determined:
        return ""
    if abs(e.value) <= e.sigma:
        return f" ({UNDETERMINED})"
    if name != "gear ratio":
        return ""
    return (" (turns long: its gear_ratio is small)" if e.value > 0 else
            " (turns short: its gear_ratio is large)")


def rotary_owner_lines(calibration: Calibration, firmware: str = "Klipper",
                       names: Sequence[str] = ARMS) -> list[str]:
    """The rotary printer's errors in its owner's words, arm by arm, each with the firmware key that holds it.

    Raises:
        ValueError: the calibration is not of the whole ``rotary_printer`` model.
    """
    keys = {"endstop": "position_endstop", "gear ratio": "gear_ratio", "upper arm": "upper_arm_length",
            "lower arms": "lower_arm_length"}
    out = [f"What the measurements say of the printer, in {firmware}'s words (± one σ):"]
    crooked = []
    for name, arm in zip(names, arm_errors(calibration), strict=True):
        stepper = f"[stepper_{name.lower()}]"
        for quantity, (e, unit) in arm.items():
            if quantity in ("lower arms apart", "shoulder tilted", "shoulder turned"):
                continue
            digits = 3 if unit == "deg" else 2
            held = f", held by {stepper} {keys[quantity]}" if quantity in keys else ""
            out.append(f"  arm {name}: {quantity} {e.words(unit, digits)}{_sense(quantity, e)}{held}")
        apart, _ = arm["lower arms apart"]
        tilted, _ = arm["shoulder tilted"]
        turned, _ = arm["shoulder turned"]
        out.append(f"  arm {name}: its lower arms {apart.words('mm')} apart; its shoulder's axis tilted "
                   f"{tilted.words('deg', 3)}, turned {turned.words('deg', 3)} about up")
        crooked += [f"arm {name}'s {what}" for what, found in (("lower arms' difference", (apart,)),
                                                              ("shoulder axis", (tilted, turned)))
                    if any(e.determined and abs(e.value) > 2.0 * e.sigma for e in found)]
    if crooked:
        out.append(f"  {firmware}'s values cannot hold {', '.join(crooked)}: the G-code route (deltacal "
                   "compensate) corrects them")
    return out
