"""Kinematics of the Delta robot.

* :mod:`.closed_form`: perfect parallelograms (virtual rods), vectorised.
* :mod:`.exact`: any DeltaGeometry, vectorised six-rod Newton solver.
* :mod:`.multibody`: any DeltaGeometry, Pinocchio closed-loop model (ground truth).

:mod:`.multibody`'s names are loaded on first use (PEP 562): Pinocchio is imported only
by what needs it, not by ``compensate`` or ``identify``.
"""

from __future__ import annotations

from .._lazy import lazy_getattr
from .closed_form import VirtualDelta
from .exact import PlatePose

_LAZY = {"ClosureSolution": "multibody", "DeltaMultibody": "multibody"}

__all__ = ["ClosureSolution", "DeltaMultibody", "PlatePose", "VirtualDelta"]


__getattr__ = lazy_getattr(__name__, _LAZY)
