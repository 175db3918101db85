"""The rotary Delta's wing: its robot file and its jobs (the engine's own robot, measured by a tracker).

Each job in a module of its own: :mod:`.plan` (Bai's poses or a D-optimal selection), :mod:`.simulate`
(a true robot seen by a tracker and a probe), :mod:`.identify` (one measurements CSV), :mod:`.export`
(a Cartesian controller's offsets or per-limb values). :data:`ROTARY` is the one wing object.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from ...calibration import Calibration
from ...chains import REVOLUTE, Chain
from ...controller import FIT_KINDS
from ...exceptions import UsageError
from ...geometry import NominalDelta
from ...io import load_nominal
from ...printer.firmware import firmware_named
from ...printer.firmware.base import Firmware
from ...printer.firmware.config_file import recorded_firmware
from ...printer.identification.errormodels import RotaryPrinterModel
from ..base import Done, Robot, Wing
from ..printer.compare import history_section
from ..requests import ExportRequest, IdentifyRequest, PlanRequest, ReportRequest, SimulateRequest
from .export import export_controller_values, export_firmware_rotary
from .identify import identify_rotary
from .plan import plan_poses
from .printed import plan_rotary_object
from .printer_simulate import simulate_rotary_prints
from .printing import identify_rotary_printer
from .simulate import simulate_rotary


class RotaryWing(Wing):
    """A rotary Delta (three revolute arms): a robot file without ``kind``, or ``kind = "rotary"``."""

    name: ClassVar[str] = "rotary"
    chain: ClassVar[Chain] = REVOLUTE

    def load(self, path: str | Path, data: dict | None = None) -> NominalDelta:
        """:func:`~deltacal.io.load_nominal`."""
        return load_nominal(path, data)

    def _robot(self, path: str | Path, robot: Robot | None) -> NominalDelta:
        robot = self.load(path) if robot is None else robot
        assert isinstance(robot, NominalDelta)
        return robot

    def plan(self, request: PlanRequest, robot: Robot | None = None,
             notify: Callable[[str], None] | None = None) -> Done:
        """Measurement poses (:func:`.plan.plan_poses`), or (``--object``) a rotary printer's object.

        The object through the firmware's configuration: :func:`.printed.plan_rotary_object`.
        """
        if request.object:
            return plan_rotary_object(request, self._robot(request.nominal, robot))
        return plan_poses(request, self._robot(request.nominal, robot), notify)

    def simulate(self, request: SimulateRequest, robot: Robot | None = None) -> Done:
        """A tracker's measurements (:func:`.simulate.simulate_rotary`), or a printer's (``--controller``).

        A firmware's configuration given: ``plan --object``'s templates filled through it
        (:func:`.printer_simulate.simulate_rotary_prints`).
        """
        if request.controller is not None:
            return simulate_rotary_prints(request, self._robot(request.nominal, robot))
        return simulate_rotary(request, self._robot(request.nominal, robot))

    def identify(self, request: IdentifyRequest, robot: Robot | None = None) -> Done:
        """The geometry from one measurements CSV (:func:`.identify.identify_rotary`), or a printer's.

        Given the firmware's configuration (``--controller``): a rotary printer's, from its probe heights
        and printed distances (:func:`.printing.identify_rotary_printer`).
        """
        if request.controller is not None:
            return identify_rotary_printer(request, self._robot(request.nominal, robot))
        return identify_rotary(request, self._robot(request.nominal, robot))

    def export_controller(self, request: ExportRequest, calibration: Calibration) -> Done:
        """A Cartesian controller's offsets or per-limb values, or a firmware's of a rotary Delta printer.

        ``offsets``, ``limbs``: :func:`.export.export_controller_values`; a firmware's name: its values
        of the rotary Delta printer its ``--config`` configures (:func:`.export.export_firmware_rotary`).
        """
        if request.controller in FIT_KINDS:
            return export_controller_values(request, calibration)
        firmware = firmware_named(str(request.controller))
        if firmware is None:
            raise UsageError(f"--controller {request.controller}: {request.calibration} is a rotary Delta's "
                             "calibration; a firmware's values are a printer's (--controller offsets|limbs "
                             "serve a rotary Delta)")
        return export_firmware_rotary(firmware, request, calibration)

    def report_firmware(self, request: ReportRequest,
                        calibration: Calibration) -> tuple[None, None, tuple[()], Calibration]:
        """None: a rotary Delta's controller is a Cartesian one (``--firmware``, ``--controller`` refused)."""
        if request.controller is not None:
            raise UsageError("--controller applies to a printer's calibration (its measurements' firmware)")
        if request.firmware is not None:
            raise UsageError(f"--firmware applies to a printer's calibration; {request.calibration} is a "
                             "rotary Delta's")
        return None, None, (), calibration

    def report_history(self, request: ReportRequest, calibration: Calibration, firmware: Firmware[Any] | None
                       ) -> tuple[str | None, tuple[str, ...]]:
        """``--history`` of a rotary printer's calibration: as a linear one's, arm by arm; else refused."""
        if not request.history or not isinstance(calibration.model, RotaryPrinterModel):
            return super().report_history(request, calibration, firmware)
        said = recorded_firmware(calibration, request.calibration) or firmware_named("klipper")
        assert said is not None
        return history_section(request, calibration, said)


#: The rotary Delta's wing.
ROTARY = RotaryWing()

__all__ = ["ROTARY", "RotaryWing"]
