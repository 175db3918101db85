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
from ._moved import install as _install_moved_paths
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
    UnreachableError,
)

#: The job's public names -> module that defines them (loaded on first access).
_LAZY = {
    # the robot: its values and files
    "NominalDelta": "geometry",
    "NominalLinearDelta": "printer.robot",
    "DeltaGeometry": "geometry",
    "Tolerances": "geometry",
    "Workspace": "geometry",
    "load_robot": "robots",
    "load_geometry": "io",
    "save_geometry": "io",
    "forward": "kinematics.exact",
    "DeltaMultibody": "kinematics.multibody",
    # plan and simulate
    "PoseSet": "planning",
    "d_optimal": "planning",
    "Metrology": "simulation",
    "simulate_measurements": "simulation",
    # measure and identify
    "Measurements": "observations",
    "read_measurements": "io",
    "FitOptions": "identification",
    "IdentificationResult": "identification",
    "identify": "identification",
    "PrinterMeasurements": "printer.identification.fit",
    "identify_printer": "printer.identification.fit",
    "Calibration": "calibration",
    "load_calibration": "io",
    "save_calibration": "io",
    # compensate, validate, hand over, report
    "compensate": "compensation",
    "validate": "validation",
    "validation_poses": "validation",
    "Controller": "controller",
    "load_controller": "robots",
    "corrected_targets": "controller",
    "fit_controller": "controller",
    "write_mjcf": "export",
    "write_report": "report",
    # the whole job
    "run_demo": "demo",
}

#: Names the top level held before, now in their subpackage: still importable from here, with a
#: DeprecationWarning, for one release.
_FORMER = {
    "ResourceError": "exceptions",
    "UsageError": "exceptions",
    "ViewerError": "exceptions",
    "Masses": "geometry",
    "error_names": "geometry",
    "VirtualDelta": "kinematics.closed_form",
    "PlatePose": "kinematics.exact",
    "ClosureSolution": "kinematics.multibody",
    "gravity_torque": "kinematics.statics",
    "multibody_gravity_torque": "kinematics.statics",
    "compliant_readings": "kinematics.statics",
    "ErrorModel": "errormodels",
    "get_model": "errormodels",
    "MODEL_NAMES": "errormodels",
    "BaseParameters": "identifiability",
    "base_parameters": "identifiability",
    "measured_combinations": "printer.identification.fit",
    "posterior_sigma": "printer.identification.fit",
    "LinearCalibration": "compensation",
    "linear_calibration_from_result": "compensation",
    "bai_poses": "planning",
    "condition_curve": "planning",
    "compliant_forward": "simulation",
    "ValidationMetrics": "validation",
    "ControllerFit": "controller",
    "CorrectedTargets": "controller",
    "KlipperDelta": "printer.firmware.klipper.model",
    "KlipperController": "printer.firmware.klipper.model",
    "KlipperFit": "printer.firmware.klipper.fit",
    "fit_klipper": "printer.firmware.klipper.fit",
    "klipper_basic": "printer.firmware.klipper.calibrate",
    "klipper_enhanced": "printer.firmware.klipper.calibrate",
    "probe_heights": "printer.simulation",
    "printed_distances": "printer.simulation",
    "random_printer": "printer.simulation",
    "save_controller": "io",
    "load_nominal": "io",
    "inverse": "kinematics.exact",
    "write_measurements": "io",
    "load_printer": "printer.files.robot_file",
    "load_klipper": "printer.firmware.klipper.config",
    "klipper_config_text": "printer.firmware.klipper.config",
    "save_klipper_config": "printer.firmware.klipper.config",
    "calibration_from_result": "io",
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
    "UnreachableError",
    "__version__",
    *sorted(_LAZY),
]

_install_moved_paths()
__getattr__ = lazy_getattr(__name__, _LAZY, _FORMER)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
