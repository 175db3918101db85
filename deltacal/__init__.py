"""deltacal: geometric calibration of Delta parallel robots.

Units inside the library are millimetres and radians; files and the command
line use millimetres and degrees.

The public API is importable from here: ``from deltacal import identify,
compensate, d_optimal, ...``. Names are loaded on first use (PEP 562), so
``import deltacal`` stays light: Pinocchio and meshcat are imported only by
what needs them.

deltacal's matrices are small (tens of columns, a few hundred rows), where BLAS
threads only contend: on a 2-core machine a linear identification took 16 ms
single-threaded and 111 ms with OpenBLAS's default threads. The ``deltacal``
command runs single-threaded (threadpoolctl); in your own programs, wrap the work
in ``threadpoolctl.threadpool_limits(1)`` or set ``OPENBLAS_NUM_THREADS=1``.
"""

from __future__ import annotations

from ._lazy import lazy_getattr
from ._version import __version__
from .exceptions import (
    AssemblyError,
    ConvergenceError,
    DeltacalError,
    GeometryError,
    IdentificationError,
    InputError,
    InputWarning,
    PlanningError,
    PoorFitError,
    ResourceError,
    UnreachableError,
    UsageError,
    ViewerError,
)

#: Public name -> module that defines it (loaded on first access).
_LAZY = {
    # geometry and kinematics
    "DeltaGeometry": "geometry",
    "NominalDelta": "geometry",
    "Masses": "geometry",
    "NominalLinearDelta": "printer.robot",
    "Tolerances": "geometry",
    "Workspace": "geometry",
    "error_names": "geometry",
    "VirtualDelta": "kinematics.closed_form",
    "PlatePose": "kinematics.exact",
    "ClosureSolution": "kinematics.multibody",
    "DeltaMultibody": "kinematics.multibody",
    "forward": "kinematics.exact",
    "inverse": "kinematics.exact",
    "gravity_torque": "kinematics.statics",
    "multibody_gravity_torque": "kinematics.statics",
    "compliant_readings": "kinematics.statics",
    # models, measurements, identification
    "ErrorModel": "errormodels",
    "get_model": "errormodels",
    "MODEL_NAMES": "errormodels",
    "Measurements": "observations",
    "BaseParameters": "identifiability",
    "base_parameters": "identifiability",
    "FitOptions": "identification",
    "IdentificationResult": "identification",
    "identify": "identification",
    "PrinterMeasurements": "printer.identification",
    "identify_printer": "printer.identification",
    "measured_combinations": "printer.identification",
    "posterior_sigma": "printer.identification",
    "Calibration": "calibration",
    # compensation, planning, simulation, validation
    "LinearCalibration": "compensation",
    "compensate": "compensation",
    "linear_calibration_from_result": "compensation",
    "PoseSet": "planning",
    "bai_poses": "planning",
    "condition_curve": "planning",
    "d_optimal": "planning",
    "Metrology": "simulation",
    "simulate_measurements": "simulation",
    "compliant_forward": "simulation",
    "ValidationMetrics": "validation",
    "validate": "validation",
    "validation_poses": "validation",
    # controllers
    "Controller": "controller",
    "ControllerFit": "controller",
    "CorrectedTargets": "controller",
    "corrected_targets": "controller",
    "fit_controller": "controller",
    "KlipperDelta": "printer.firmware.klipper.model",
    "KlipperFit": "printer.firmware.klipper.fit",
    "fit_klipper": "printer.firmware.klipper.fit",
    "klipper_basic": "printer.firmware.klipper.calibrate",
    "klipper_enhanced": "printer.firmware.klipper.calibrate",
    "probe_heights": "printer.simulation",
    "printed_distances": "printer.simulation",
    "random_printer": "printer.simulation",
    "KlipperController": "printer.firmware.klipper.model",
    # files
    "load_controller": "robots",
    "save_controller": "io",
    "load_nominal": "io",
    "load_printer": "printer.robot_file",
    "load_robot": "robots",
    "load_klipper": "printer.firmware.klipper.config",
    "klipper_config_text": "printer.firmware.klipper.config",
    "save_klipper_config": "printer.firmware.klipper.config",
    "load_geometry": "io",
    "save_geometry": "io",
    "save_calibration": "io",
    "load_calibration": "io",
    "calibration_from_result": "io",
    "read_measurements": "io",
    "write_measurements": "io",
    # the whole job
    "run_demo": "demo",
    "run_printer_demo": "printer.demo",
}

__all__ = [
    "AssemblyError",
    "ConvergenceError",
    "DeltacalError",
    "GeometryError",
    "IdentificationError",
    "InputError",
    "InputWarning",
    "PlanningError",
    "PoorFitError",
    "ResourceError",
    "UnreachableError",
    "UsageError",
    "ViewerError",
    "__version__",
    *sorted(_LAZY),
]


__getattr__ = lazy_getattr(__name__, _LAZY)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

