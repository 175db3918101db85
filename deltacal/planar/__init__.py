"""Savoure's planar 1-dof parallelogram mechanism (Savoure et al. 2006, Sec. III).

A small mechanism that has the property of the Delta robot's parallelograms that
matters for calibration: when the four joint centres do not form a true
parallelogram the travelling plate rotates, and a tool at a distance ``h`` from
the plate turns that rotation into a position error that the classical
(virtual bar) model cannot represent.

Frames and conventions (Savoure Fig. 3, Sec. III-A-2), units mm and rad:

* Base frame R_b (O_b, x_b, y_b): ``A1 = (-a1x, 0)`` and ``A2 = (a2x, a2y)``.
* Plate frame R_p (O_p, x_p, y_p), at angle ``alpha`` from R_b:
  ``O_p B1 = -b1x x_p``, ``O_p B2 = b2x x_p + b2y y_p`` and the tool centre point
  ``O_p C = -h y_p``.
* Rod i joins A_i to B_i, of length l_i. The actuated joint at A1 sets the
  angle ``theta = q + q0`` from ``-y_b`` to ``A1B1``: ``A1B1 = l1 u(theta)`` with
  ``u(theta) = (sin theta, -cos theta)`` (Eq. 61). ``phi`` is the same angle for
  rod 2. The nominal mechanism hangs down: ``q > 0`` moves C towards ``+x_b``.
* Parameter order (Eq. 39, 40, 69): ``k_C = [q0 | a1x a2x a2y | b1x b2x b2y | l1 l2]``.
  The tool length h is not identified (Savoure: it is a metrology problem).

The simplified model is a single bar of length l actuated at O_b (Fig. 3, right).
"""

from .compensation import command_classical, command_improved
from .geometry import (
    LOOP_TOLERANCE,
    PAPER_BASE_ORDER,
    PARAMETER_NAMES,
    SIMPLIFIED_NAMES,
    PlanarGeometry,
    SimplifiedModel,
    table2_errors,
)
from .identification import (
    CompleteIdentification,
    SimplifiedIdentification,
    identify_complete,
    identify_simplified,
)
from .kinematics import (
    PlanarConfiguration,
    calibration_jacobians,
    configuration,
    forward_position,
    sensitivity,
)
from .multibody import PlanarMultibody

__all__ = [
    "PARAMETER_NAMES",
    "SIMPLIFIED_NAMES",
    "PAPER_BASE_ORDER",
    "LOOP_TOLERANCE",
    "PlanarGeometry",
    "table2_errors",
    "SimplifiedModel",
    "PlanarConfiguration",
    "configuration",
    "forward_position",
    "calibration_jacobians",
    "sensitivity",
    "PlanarMultibody",
    "SimplifiedIdentification",
    "identify_simplified",
    "CompleteIdentification",
    "identify_complete",
    "command_classical",
    "command_improved",
]
