"""What a printer's calibration was identified from, kept in it so that it can be identified again.

A printer's measurements determine some combinations of its parameters; the others follow the
prior, centred on the printer its controller described. When a later route is given that
controller's values changed, the calibration is re-anchored: the same measurements identified
again with the prior centred on the controller now given
(:mod:`deltacal.printer.identification.anchor`): what they determine is kept, the rest follows.
:class:`MeasuredRecord` is what that needs: the readings the firmware commanded (physical: steps
below the endstops in the printer's nominal step distance, whatever the values that commanded
them), the distances measured, the σ given and the fit's choices. The calibration file's
``[measured]`` table. Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The fit's methods a record may name.
METHODS = ("linear", "iterated")


@dataclass(frozen=True)
class MeasuredRecord:
    """A printer's measurements as its identification took them, and how it fitted them.

    Attributes:
        probe: Readings at which the probe triggered on the bed [mm], (N, 3).
        trigger_height: The probe point's height above the bed at each trigger [mm], (N,).
        pairs: Readings at which the two features of each distance were printed [mm], (M, 2, 3).
        distance: The distances measured [mm], (M,).
        probe_offset: The probe's trigger point relative to the nozzle, effector frame [mm], (3,).
        height_sigma: σ given of a probe height [mm].
        distance_sigma: σ given of a distance [mm].
        tolerance_scale: The build tolerances' scale the fit took.
        calibrated_start: The start was the firmware's values fitted to these measurements.
        method: ``"linear"`` or ``"iterated"``.
        workspace: The printable cylinder ``(radius, height, top_z)`` where the σ was given [mm],
            or None (the measurements' own).
    """

    probe: np.ndarray
    trigger_height: np.ndarray
    pairs: np.ndarray
    distance: np.ndarray
    probe_offset: np.ndarray
    height_sigma: float
    distance_sigma: float
    tolerance_scale: float
    calibrated_start: bool
    method: str
    workspace: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        probe = np.asarray(self.probe, dtype=float).reshape(-1, 3)
        trigger = np.asarray(self.trigger_height, dtype=float).reshape(-1)
        pairs = np.asarray(self.pairs, dtype=float).reshape(-1, 2, 3)
        distance = np.asarray(self.distance, dtype=float).reshape(-1)
        if trigger.shape[0] != probe.shape[0]:
            raise ValueError(f"{trigger.shape[0]} trigger heights for {probe.shape[0]} probe readings")
        if distance.shape[0] != pairs.shape[0]:
            raise ValueError(f"{distance.shape[0]} distances for {pairs.shape[0]} pairs of readings")
        for name, value in (("probe", probe), ("trigger_height", trigger), ("pairs", pairs),
                            ("distance", distance)):
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be finite")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "probe_offset", np.asarray(self.probe_offset, dtype=float).reshape(3))
        for name in ("height_sigma", "distance_sigma", "tolerance_scale"):
            if not float(getattr(self, name)) > 0.0 or not np.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name} must be positive and finite, got {getattr(self, name)!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be 'linear' or 'iterated', got {self.method!r}")
        if self.workspace is not None:
            workspace = tuple(float(v) for v in self.workspace)
            if len(workspace) != 3 or not (workspace[0] > 0.0 and workspace[1] > 0.0):
                raise ValueError(f"workspace must be (radius > 0, height > 0, top_z), got {self.workspace!r}")
            object.__setattr__(self, "workspace", workspace)
