"""deltacal: geometric calibration of Delta parallel robots.

Units inside the library are millimetres and radians; files and the command
line use millimetres and degrees.

deltacal's matrices are small (tens of columns, a few hundred rows), where BLAS
threads only contend: on a 2-core machine a linear identification took 16 ms
single-threaded and 111 ms with OpenBLAS's default threads. The ``deltacal``
command runs single-threaded (threadpoolctl); in your own programs, wrap the work
in ``threadpoolctl.threadpool_limits(1)`` or set ``OPENBLAS_NUM_THREADS=1``.
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
