"""deltacal: geometric calibration of Delta parallel robots.

Units inside the library are millimetres and radians; files and the command
line use millimetres and degrees.
"""

from .exceptions import (
    AssemblyError,
    ConvergenceError,
    DeltacalError,
    GeometryError,
    IdentificationError,
    InputError,
    UnreachableError,
)
from .geometry import DeltaGeometry, NominalDelta, Tolerances, Workspace, error_names
from .kinematics.closed_form import VirtualDelta
from .kinematics.exact import PlatePose
from .kinematics.multibody import ClosureSolution, DeltaMultibody

__version__ = "0.1.0"

__all__ = [
    "AssemblyError",
    "ClosureSolution",
    "ConvergenceError",
    "DeltaGeometry",
    "DeltaMultibody",
    "DeltacalError",
    "GeometryError",
    "IdentificationError",
    "InputError",
    "NominalDelta",
    "PlatePose",
    "Tolerances",
    "UnreachableError",
    "VirtualDelta",
    "Workspace",
    "__version__",
    "error_names",
]
