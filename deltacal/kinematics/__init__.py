"""Kinematics of the Delta robot.

* :mod:`.closed_form`: perfect parallelograms (virtual rods), vectorised.
* :mod:`.exact`: any DeltaGeometry, vectorised six-rod Newton solver.
* :mod:`.multibody`: any DeltaGeometry, Pinocchio closed-loop model (ground truth).
"""

from .closed_form import VirtualDelta
from .exact import PlatePose
from .multibody import ClosureSolution, DeltaMultibody

__all__ = ["ClosureSolution", "DeltaMultibody", "PlatePose", "VirtualDelta"]
