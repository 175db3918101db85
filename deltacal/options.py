"""Options values: one frozen dataclass per job, checked once, with keyword overrides.

A job (a fit, a plan) takes its options as one value (:class:`~deltacal.identification.FitOptions`,
:class:`~deltacal.planning.PlanOptions`, ...) and keyword arguments naming some of its fields;
:func:`with_overrides` applies them once, with :func:`dataclasses.replace`, so that the value's
own ``__post_init__`` checks every field in one place. This module imports nothing of deltacal.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping
from dataclasses import fields, replace
from typing import Any, ClassVar, Protocol, TypeVar

import numpy as np


class _Dataclass(Protocol):
    """Any dataclass (what :func:`dataclasses.fields` and :func:`dataclasses.replace` take)."""

    __dataclass_fields__: ClassVar[dict[str, Any]]


Options = TypeVar("Options", bound=_Dataclass)


def with_overrides(cls: type[Options], options: Options | None, overrides: Mapping[str, Any]) -> Options:
    """``options`` (default: ``cls()``) with the fields named in ``overrides`` replaced.

    The result is built once, so ``cls.__post_init__`` checks it once; an override wins over
    the same field of ``options``.

    Args:
        cls: The options' class (a frozen dataclass).
        options: The options given, or None for the defaults.
        overrides: Field names and their values.

    Returns:
        The options to use (``options`` itself when there is nothing to override).

    Raises:
        TypeError: ``options`` is not a ``cls``, or an override names no field of ``cls``.
        ValueError: a value out of its range (from ``cls``'s checks).
    """
    if options is not None and not isinstance(options, cls):
        raise TypeError(f"options must be a {cls.__name__}, got {type(options).__name__} {options!r}")
    names = [f.name for f in fields(cls)]
    for name in overrides:
        if name not in names:
            close = difflib.get_close_matches(name, names, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(f"{name!r} is not an option of {cls.__name__}{hint}; its options are "
                            f"{', '.join(names)}")
    if options is None:
        return cls(**overrides)
    return replace(options, **overrides) if overrides else options


def require_bool(name: str, value: object) -> bool:
    """``value`` as a bool, or TypeError naming ``name`` (numpy's bools are bools)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def require_positive(name: str, value: object) -> None:
    """ValueError naming ``name`` unless ``value`` is a positive finite number."""
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


def require_count(name: str, value: object) -> None:
    """ValueError naming ``name`` unless ``value`` is a positive integer."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")


def require_names(name: str, value: object) -> tuple[str, ...]:
    """``value`` as a tuple of distinct strings (first occurrences kept), or TypeError naming ``name``."""
    items = tuple(value) if isinstance(value, Iterable) and not isinstance(value, str) else None
    if items is None or not all(isinstance(item, str) for item in items):
        raise TypeError(f"{name} must be a sequence of names, got {value!r}")
    return tuple(dict.fromkeys(items))
