"""Names of points and stations: text that every file deltacal writes holds and reads back.

A point or station name is any Unicode text (``süd``, ``ταυ``, ``smr_ö``, ``a,b``, ``"x"``)
except what no file of deltacal can carry through: control characters (a line break would
split a CSV row; the others are invisible and unreadable in an XML or HTML file), lone
surrogates (not UTF-8 text), spaces at either end (the CSV reader strips them) and the empty
name (an empty CSV field means ``tcp`` or the default station). Every reader and writer of
names applies :func:`name_problem`, so a name is refused where it enters, never after a
file has been written.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Iterable

from ..exceptions import InputError


def control_character(text: str) -> str | None:
    """The first control character or lone surrogate of ``text``, described; None if it has none.

    The rule for any text deltacal writes into a file where a person or another program reads
    it as a name (a robot's name too, which ends up in an MJCF model's attributes).
    """
    for c in text:
        category = unicodedata.category(c)
        if category == "Cc":
            return f"holds the control character U+{ord(c):04X}"
        if category == "Cs":
            return f"holds the lone surrogate U+{ord(c):04X} (not UTF-8 text)"
    return None


def name_problem(name: str) -> str | None:
    """What keeps ``name`` from being a point or station name, or None if it is one."""
    if not name:
        return "is empty"
    problem = control_character(name)
    if problem is not None:
        return problem
    if name != name.strip():
        return "begins or ends with a space"
    return None


def check_names(names: Iterable[str], what: str, source: str = "", where: str = "") -> None:
    """Refuse the first name that :func:`name_problem` refuses.

    Args:
        names: The names.
        what: What they name, for the message (``"station"``, ``"point"``).
        source: The file (or option) they come from.
        where: Where in it (``"key points"``).

    Raises:
        InputError: naming the name (as Python writes it: control characters escaped).
    """
    for name in names:
        problem = name_problem(name)
        if problem is not None:
            raise InputError(f"{what} name {name!r} {problem}: names of points and stations are "
                             "text without control characters or spaces at either end", source, where)


def check_robot_name(name: str, source: str = "", where: str = "") -> None:
    """Refuse a robot name holding a control character (:func:`control_character`).

    Raises:
        InputError: naming the name, as Python writes it.
    """
    problem = control_character(name)
    if problem is not None:
        raise InputError(f"robot name {name!r} {problem}", source, where)

