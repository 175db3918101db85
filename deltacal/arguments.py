"""The Python API's commonest arguments, checked where they come in: points and the robot's geometry.

A function of the engine takes points as an (N, 3) array (or one point, (3,)) and the identified
robot as a :class:`~deltacal.geometry.DeltaGeometry`. Anything else fails here in one
:class:`ValueError` (or :class:`TypeError`) naming the argument and what it must be, not deep inside
numpy ("operands could not be broadcast", an index out of bounds) or as an attribute a calibration
does not have. A value that holds its geometry (a :class:`~deltacal.calibration.Calibration`, an
identification's result: its ``geometry``) is taken as it.
"""

from __future__ import annotations

import numpy as np

from .geometry import DeltaGeometry


def points_array(values: object, name: str = "targets", one: str = "target") -> np.ndarray:
    """``values`` as an (N, 3) float array: given (N, 3), or (3,) for one row (a point, readings).

    Args:
        values: The rows (an array or nested sequences of numbers).
        name: The argument's name, for the message.
        one: What one row is, for the message (``"target"``, ``"reading"``).

    Raises:
        ValueError: naming the argument and the shape it has (or that it is not numbers).
    """
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers of shape (N, 3), or (3,) for one {one}; got "
                         f"{type(values).__name__} {_short(values)}") from None
    if array.shape == (3,):
        return array[None]
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), or (3,) for one {one}; got shape {array.shape}")
    return array


def geometry_of(value: object, name: str = "geometry") -> DeltaGeometry:
    """The robot's geometry: ``value`` itself, or the ``geometry`` it holds (a calibration's, a result's).

    Raises:
        TypeError: naming the argument and the type given.
    """
    if isinstance(value, DeltaGeometry):
        return value
    inner = getattr(value, "geometry", None)
    if isinstance(inner, DeltaGeometry):
        return inner
    raise TypeError(f"{name} must be a DeltaGeometry (or a Calibration: its geometry); got "
                    f"{type(value).__name__}")


def _short(value: object) -> str:
    """A value in at most 60 characters, for a message."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
