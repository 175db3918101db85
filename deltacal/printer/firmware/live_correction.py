"""A firmware configuration that corrects every move itself: deltacal's live correction installed in it.

A printer whose firmware applies deltacal's correction to every move (Klipper with ``export --live``'s
module: :meth:`~.base.Firmware.live_correction`) is no longer the printer its configuration's values
describe to the routes that measure or correct it:

* a program corrected offline would be corrected twice: ``compensate`` refuses
  (:meth:`LiveCorrection.refuse_compensate`);
* probe heights and an object printed through the correction measure the corrected printer, and a
  calibration of them undoes the one applied: ``identify`` refuses, unless told that they were made
  with it off (:meth:`LiveCorrection.refuse_identify`);
* ``plan``'s probe program turns it off before probing and on again at its end
  (:attr:`LiveCorrection.off`, :attr:`LiveCorrection.on`; :meth:`LiveCorrection.plan_note`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ...exceptions import InputError

#: The ``identify`` option that states the measurements were made with the live correction off.
LIVE_OFF_OPTION = "--live-correction-off"


@dataclass(frozen=True)
class LiveCorrection:
    """Where a firmware's configuration includes deltacal's live correction, and how to turn it off.

    Attributes:
        config: The configuration file given (``printer.cfg``).
        where: Where it includes the correction, in the configuration's words
            (``[deltacal_geometry] from deltacal_geometry.cfg``).
        off: The command that turns the correction off (``DELTACAL_GEOMETRY ENABLE=0``).
        on: The command that turns it on again.
        remove: How to take it out of the configuration (``remove [include deltacal_geometry.cfg]``).
    """

    config: str
    where: str
    off: str
    on: str
    remove: str

    def words(self) -> str:
        """``includes deltacal's live correction (WHERE)``."""
        return f"includes deltacal's live correction ({self.where})"

    def refuse_compensate(self) -> InputError:
        """``compensate``'s refusal: every move is already corrected (an offline correction twice)."""
        return InputError(f"{self.words()}: every move is already corrected; print the program as sliced, "
                          f"or {self.remove} to correct offline; nothing written", self.config)

    def refuse_identify(self) -> InputError:
        """``identify``'s refusal: measurements made through the correction measure the corrected printer."""
        return InputError(f"{self.words()}: probe heights and an object printed through it measure the "
                          "corrected printer, and the new calibration would undo the old; measure with it "
                          f"off ({self.off} before probing and printing the object, or {self.remove}), then "
                          f"give {LIVE_OFF_OPTION}; nothing written", self.config)

    def taken_off(self) -> str:
        """``identify``'s line when told (:data:`LIVE_OFF_OPTION`) the measurements were made with it off."""
        return (f"{self.config} {self.words()}: the measurements are taken as made with it off "
                f"({LIVE_OFF_OPTION})")

    def plan_note(self, program: str) -> str:
        """``plan``'s line on its probe program ``program``: it turns the correction off while probing."""
        return (f"{self.config} {self.words()}: {program} turns it off first ({self.off}) and on again at "
                f"its end ({self.on}): the probe heights measure the printer itself")

    def manual_note(self) -> str:
        """``plan``'s line for heights measured by hand: turn the correction off first, on again after."""
        return (f"{self.config} {self.words()}: turn it off ({self.off}) before measuring the heights and "
                f"printing the object, and on again after ({self.on}): they measure the printer itself")
