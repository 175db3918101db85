"""RepRapFirmware's meta commands (RRF 3.01 and later) where a configuration meets them.

``config.g`` may hold meta commands (RRF's "G-Code Meta Commands"): ``if``, ``elif``, ``else`` and
``while`` open a block of the lines indented below them; ``global NAME = EXPR``, ``var NAME = EXPR``,
``set global.NAME = EXPR`` and ``set var.NAME = EXPR`` set a variable that a command's parameter
reads as ``{global.NAME}`` or ``{var.NAME}`` (a ``var`` in the file that sets it, a ``global`` in every
file run after it). deltacal evaluates no expression; it reads:

* which block each line stands in (:class:`Blocks`): a delta setting inside a block is refused
  naming its line and the block's, its branch known only when RRF runs the file (RRF runs one
  branch of an ``if``, a ``while`` as often as its condition holds);
* a variable set to a plain number outside any block (``global rodLength = 280``): its value; set to
  anything else (an expression, a string, an object model value), or inside a block: unknown
  (:class:`Variables`);
* a parameter that is exactly a variable, or a list of them (``L{global.rodLength}``,
  ``L{var.a}:{var.b}:{var.c}``): the variables' values (:func:`substitute`); an unknown or unset
  variable is refused naming the line, any other expression where the value is read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from ....exceptions import InputError

#: A meta command that opens a block.
_BLOCK = re.compile(r"^(if|elif|else|while)\b", re.IGNORECASE)
#: A meta command that sets a variable: ``global x = ...``, ``var x = ...``, ``set global.x = ...``.
_SETS = re.compile(r"^(?:(?P<new>global|var)\s+|set\s+(?P<old>global|var)\.)(?P<name>[A-Za-z_]\w*)\s*=\s*"
                   r"(?P<value>.*)$", re.IGNORECASE)
#: A plain number, as an expression gives one.
_NUMBER = re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$")
#: A variable named in a parameter: ``{global.x}`` or ``{var.x}``.
_REFERENCE = re.compile(r"^\{\s*(global|var)\.([A-Za-z_]\w*)\s*\}$", re.IGNORECASE)


@dataclass(frozen=True)
class Block:
    """An open block: the meta command that opened it, its line and its indentation."""

    keyword: str
    line: int
    indent: int


@dataclass
class Blocks:
    """The blocks open at each line of one file, told by indentation as RRF tells them."""

    open: list[Block] = field(default_factory=list)

    def enter(self, text: str, number: int) -> Block | None:
        """The innermost block the line ``text`` (its comment stripped) stands in, or None.

        A blank line leaves the blocks as they are; a line indented no deeper than a block's
        opening line closes it. A line that opens a block stands outside it.
        """
        body = text.strip()
        if not body:
            return self.open[-1] if self.open else None
        indent = len(text) - len(text.lstrip(" \t"))
        while self.open and self.open[-1].indent >= indent:
            self.open.pop()
        inside = self.open[-1] if self.open else None
        opening = _BLOCK.match(body)
        if opening:
            self.open.append(Block(opening.group(1).lower(), number, indent))
        return inside


@dataclass(frozen=True)
class Variable:
    """A variable's value (None when unknown), where it was set and why it is unknown."""

    value: float | None
    source: str
    line: int
    why: str = ""


@dataclass
class Variables:
    """The variables a configuration has set so far: the globals of every file, the vars of one."""

    globals: dict[str, Variable] = field(default_factory=dict)
    local: dict[str, Variable] = field(default_factory=dict)

    def in_file(self) -> Variables:
        """The variables a file called from this one sees: the same globals, no vars."""
        return Variables(self.globals, {})

    def read(self, text: str, source: str, number: int, block: Block | None) -> bool:
        """Keep a variable the line sets (``text`` without its comment); whether it set one."""
        match = _SETS.match(text.strip())
        if match is None:
            return False
        kind = (match.group("new") or match.group("old")).lower()
        value = match.group("value").strip()
        if block is not None:
            known = Variable(None, source, number,
                             f"set inside the '{block.keyword}' block of line {block.line}")
        elif _NUMBER.match(value):
            known = Variable(float(value), source, number)
        else:
            known = Variable(None, source, number,
                             f"set to {value!r}, an expression RRF computes when it runs")
        (self.globals if kind == "global" else self.local)[match.group("name").lower()] = known
        return True

    def value(self, kind: str, name: str) -> Variable | None:
        """A variable (``kind`` "global" or "var"), or None when not set."""
        return (self.globals if kind.lower() == "global" else self.local).get(name.lower())


def substitute(params: dict[str, str], variables: Variables, source: str, number: int,
               code: str) -> dict[str, str]:
    """The parameters with each one that is exactly variables (``{global.x}``, ``a:b:c`` of them) as numbers.

    Raises:
        InputError: a variable named that is not set earlier, or whose value is unknown, naming the
            line, the key and where the variable was set.
    """
    out = dict(params)
    for key, text in params.items():
        parts = text.strip().split(":")
        references = [_REFERENCE.match(part.strip()) for part in parts]
        if "{" not in text or not all(references):
            continue
        numbers = []
        for match in references:
            assert match is not None
            kind, name = match.group(1).lower(), match.group(2)
            variable = variables.value(kind, name)
            where = f"line {number}, {code} {key}"
            if variable is None:
                raise InputError(f"value {text!r}: {kind}.{name} is not set earlier in the file (deltacal "
                                 "reads variables set to a number before they are used)", source, where)
            if variable.value is None:
                raise InputError(f"value {text!r}: {kind}.{name} ({variable.source} line {variable.line}) is "
                                 f"{variable.why}: write the number", source, where)
            numbers.append(repr(variable.value))
        out[key] = ":".join(numbers)
    return out
