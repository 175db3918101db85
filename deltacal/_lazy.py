"""Names of a package loaded on first use (PEP 562), so that importing it stays cheap."""

from __future__ import annotations

import importlib
import sys
import warnings
from collections.abc import Callable
from typing import Any


def lazy_getattr(
    package: str, table: dict[str, str], former: dict[str, str] | None = None
) -> Callable[[str], Any]:
    """A module ``__getattr__`` that imports ``table[name]`` (a submodule of ``package``) on first use.

    Args:
        package: The package's ``__name__``.
        table: Attribute name -> name of the submodule that defines it.
        former: Names the package exported before, now only in their submodule: still found, with
            a :class:`DeprecationWarning` that names where they live now (not cached, so that
            every use warns).

    Returns:
        The function to assign to the package's ``__getattr__``; it caches what it loads in
        the package's namespace, so each name is imported once.
    """

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None and former is not None and name in former:
            home = f"{package}.{former[name]}"
            warnings.warn(f"{package}.{name} is now {home}.{name}; {package}.{name} goes in the next release",
                          DeprecationWarning, stacklevel=2)
            return getattr(importlib.import_module(home), name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{module}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__
