"""Reading and writing deltacal's files: robot TOML, geometry TOML, atomic writes.

Files are in millimetres and degrees; the library works in millimetres and
radians. Every reader validates what it reads and raises
:class:`~deltacal.exceptions.InputError` naming the file and the key (or row
and column). Every writer writes a temporary file in the destination folder and
renames it, so a failure never leaves a half-written output.
"""

import importlib
import warnings

from .atomic import atomic_output, atomic_write_bytes, atomic_write_text
from .calibration import (
    calibration_from_result,
    calibration_to_dict,
    check_calibration,
    instrument_tables,
    load_calibration,
    load_instrument,
    load_linear_calibration,
    save_calibration,
)
from .controller_file import CONTROLLER_FORMAT, controller_to_dict, load_controller_file, save_controller
from .geometry_file import (
    CALIBRATION_FORMAT,
    GEOMETRY_FORMAT,
    check_format,
    geometry_from_dict,
    geometry_to_dict,
    load_geometry,
    save_geometry,
)
from .measurements import MeasurementFile, read_measurement_file, read_measurements, write_measurements
from .names import check_names, check_robot_name, control_character, name_problem
from .poses import POSES_COLUMNS, POSES_TOLERANCE, PosesFile, read_poses, read_poses_file, write_poses
from .robot import load_nominal
from .stl import write_stl
from .tables import (
    JOINT_COLUMNS,
    MEASUREMENT_COLUMNS,
    ORIENTATION_COLUMNS,
    TARGET_COLUMNS,
    CsvTable,
    data_row,
    lines_text,
    read_csv_table,
    unassembled_rows,
)
from .targets import (
    COMMAND_COLUMNS,
    CommandsWriter,
    JointsWriter,
    TargetChunk,
    TargetFile,
    joint_rows,
    read_target_table,
    write_joints,
)
from .toml import RawToml, exact_degrees, radians_from_text, read_toml, toml_dumps

__all__ = [
    "write_stl",
    "CALIBRATION_FORMAT",
    "CONTROLLER_FORMAT",
    "controller_to_dict",
    "load_controller_file",
    "save_controller",
    "CsvTable",
    "GEOMETRY_FORMAT",
    "JOINT_COLUMNS",
    "MEASUREMENT_COLUMNS",
    "ORIENTATION_COLUMNS",
    "POSES_COLUMNS",
    "POSES_TOLERANCE",
    "RawToml",
    "TARGET_COLUMNS",
    "atomic_output",
    "atomic_write_bytes",
    "atomic_write_text",
    "calibration_from_result",
    "check_names",
    "check_robot_name",
    "control_character",
    "calibration_to_dict",
    "check_calibration",
    "check_format",
    "data_row",
    "lines_text",
    "unassembled_rows",
    "exact_degrees",
    "geometry_from_dict",
    "geometry_to_dict",
    "load_geometry",
    "instrument_tables",
    "load_calibration",
    "load_instrument",
    "load_linear_calibration",
    "load_nominal",
    "name_problem",
    "radians_from_text",
    "read_csv_table",
    "read_measurements",
    "read_measurement_file",
    "MeasurementFile",
    "read_poses",
    "read_poses_file",
    "PosesFile",
    "read_target_table",
    "JointsWriter",
    "CommandsWriter",
    "COMMAND_COLUMNS",
    "TargetChunk",
    "TargetFile",
    "joint_rows",
    "read_toml",
    "save_calibration",
    "save_geometry",
    "toml_dumps",
    "write_joints",
    "write_measurements",
    "write_poses",
]

#: Readers io held before that now stand above both robot kinds (a robot file or controller of
#: either kind) or in the printer's wing: still found here, with a DeprecationWarning, for one
#: release. Loaded by name, so io imports nothing above it.
_FORMER = {
    "load_robot": "deltacal.robots",
    "load_controller": "deltacal.robots",
    "load_printer": "deltacal.printer.files.robot_file",
}


def __getattr__(name: str) -> object:
    home = _FORMER.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(f"{__name__}.{name} is now {home}.{name}; {__name__}.{name} goes in the next release",
                  DeprecationWarning, stacklevel=2)
    return getattr(importlib.import_module(home), name)
