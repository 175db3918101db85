"""Where a firmware keeps each value a printer's owner adjusts, in the firmware's own words.

A printer's errors said to its owner (:mod:`deltacal.printer.owner`: each tower's endstop, travel,
lean and rods, the bed's tilt) name the setting of the owner's firmware that holds each one, or say
that none does (no firmware's delta model has a tower's lean). Each firmware gives its keys
(:attr:`~.base.Firmware.owner_keys`): ``{tower}`` in a key is the tower's name in the firmware's
words (Klipper's ``A``, Marlin's and RepRapFirmware's ``X``), ``{lower}`` the same in lower case
(``stepper_a``), ``{rod}`` the name of its rods' value.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class OwnerKeys:
    """A firmware's settings for what an owner adjusts, as templates over a tower.

    Attributes:
        towers: The towers' names in the firmware's words (A, B, C).
        rod_names: The names of each tower's rods' value (``{rod}`` in :attr:`rods`).
        endstop: The setting of a tower's endstop.
        travel: The setting of a tower's step distance (its travel per step).
        rods: The setting of a tower's rods' length.
        angle: The setting of a tower's position around the bed (a sideways lean holds at the bed
            as a turned tower).
        bed_tilt: The setting of the bed's tilt, or "" when the firmware has none.
        where: Where the owner puts the values (``printer.cfg``).
    """

    towers: tuple[str, str, str]
    rod_names: tuple[str, str, str]
    endstop: str
    travel: str
    rods: str
    angle: str
    bed_tilt: str
    where: str

    def key(self, template: str, tower: int) -> str:
        """A tower's setting (``[stepper_a] position_endstop``, ``M666 X``)."""
        name = self.towers[tower]
        return template.format(tower=name, lower=name.lower(), rod=self.rod_names[tower])
