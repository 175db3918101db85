"""Kinematics of the Delta robot.

* :mod:`.closed_form`: perfect parallelograms (virtual rods), vectorised.
* :mod:`.exact`: any DeltaGeometry, vectorised six-rod Newton solver.
* :mod:`.multibody`: any DeltaGeometry, Pinocchio closed-loop model (ground truth).

:mod:`.multibody`'s names are loaded on first use (PEP 562): Pinocchio is imported only
by what needs it, not by ``compensate`` or ``identify``.
"""

from __future__ import annotations

import importlib
from typing import Any

from .closed_form import VirtualDelta
from .exact import PlatePose

_LAZY = {"ClosureSolution": "multibody", "DeltaMultibody": "multibody"}

__all__ = ["ClosureSolution", "DeltaMultibody", "PlatePose", "VirtualDelta"]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
