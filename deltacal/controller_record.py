"""The controller a printer's calibration was measured against: its firmware, its values, its files.

A printer's measurements are of commanded positions: ``identify`` turns them into readings through
the firmware's configuration it is given (``printer.cfg``, an ``M503`` capture, ``config.g``), and
what they do not determine follows that configuration. :class:`ControllerRecord` keeps what it was:
the firmware's name, the file given, a digest of every file the configuration read, and each value
read in the firmware's own key (``"stepper_a.position_endstop"``, ``"M665.L"``), so that a later
route given a configuration can tell whether it is the same (:meth:`ControllerRecord.changes`).
The calibration file's ``[controller]`` and ``[controller.values]`` tables.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType


@dataclass(frozen=True)
class ControllerRecord:
    """The firmware configuration a printer's calibration was identified with.

    Attributes:
        firmware: The firmware's name (``"klipper"``, ``"marlin"``, ``"rrf"``).
        source: The configuration file's name, as given to ``identify``.
        digest: The sha256 (hex) of the bytes of every file the configuration read, itself first.
        values: Every value read, by the firmware's own key (``"M666.X"``), in the firmware's units.
    """

    firmware: str
    source: str
    digest: str
    values: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = {str(k): float(v) for k, v in self.values.items()}
        object.__setattr__(self, "values", MappingProxyType(values))

    def changes(self, values: Mapping[str, float]) -> list[tuple[str, float | None, float | None]]:
        """The keys whose value differs from ``values`` (another read of the firmware's configuration).

        Returns:
            ``(key, recorded, now)`` in the record's order, then the keys only ``values`` holds; None
            where a side has no such key.
        """
        out: list[tuple[str, float | None, float | None]] = []
        for key, old in self.values.items():
            new = values.get(key)
            if new is None or float(new) != old:
                out.append((key, old, None if new is None else float(new)))
        out += [(key, None, float(new)) for key, new in values.items() if key not in self.values]
        return out


def files_digest(paths: Iterable[str | Path]) -> str:
    """The sha256 (hex) of the bytes of the files, in order (a configuration and the files it read).

    A file named but missing (RepRapFirmware's ``M501`` with no ``config-override.g``) adds nothing.
    """
    digest = hashlib.sha256()
    for path in paths:
        if Path(path).is_file():
            digest.update(Path(path).read_bytes())
    return digest.hexdigest()


def changes_in_words(changes: Iterable[tuple[str, float | None, float | None]]) -> str:
    """``M666.X -0.5 -> -0.7, M665.L 215 -> 216`` (``none`` where a side has no such key)."""
    def shown(v: float | None) -> str:
        return "none" if v is None else f"{v:.10g}"

    return ", ".join(f"{key} {shown(old)} -> {shown(new)}" for key, old, new in changes)
