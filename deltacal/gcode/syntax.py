"""A G-code line's text as controllers read it: its comment and ending, and what they read differently.

The reader (:mod:`deltacal.gcode.rewriter`) splits a line into its code, comment and ending
(:func:`split_line`), and refuses, by the line, text that controllers read in different ways: a
block-delete line (:func:`block_delete_refusal`), a G word after an M code
(:func:`command_then_g_refusal`), words after a ``(...;...)`` comment (:func:`semicolon_refusal`),
a NUL or a blank a firmware reads otherwise than a host (:func:`bytes_refusal`). A line with text
before its command's first letter (:data:`JUNK`: a byte-order mark where two files were joined, a
NUL, a digit) is split into that text and the command (:func:`junk_split`). Each refusal is the
message's detail, or None where the line is read alike.
"""

from __future__ import annotations

import re

from .dialect import LineReading, Unread
from .source import line_ending

__all__ = ["JUNK", "M_LINE", "PARENS", "READ", "TEXT_M", "WORD", "block_delete_refusal", "bytes_refusal",
           "command_then_g_refusal", "junk_split", "line_params", "mark_refusal", "semicolon_refusal",
           "split_line"]

#: A word: its letter and the text of its number (which may not be one).
WORD = re.compile(r"([A-Za-z])\s*([-+]?[0-9.]*)")
#: A ``(...)`` comment.
PARENS = re.compile(r"\([^)]*\)")
#: An M code first (after a line number), its number without leading zeros.
M_LINE = re.compile(r"(?:[Nn]\s*[0-9]+\s*)?[Mm]\s*0*([0-9]+)?(?![0-9.])")
#: M codes whose parameter is text (a message, a file name): a G in it is not a command.
TEXT_M = frozenset(("23", "28", "30", "32", "117", "118"))
#: First letters of a line the filter reads (others are kept without reading them).
READ = frozenset("GgXxYyZzIiJjRrEeFfNnMm")
#: Text before a command's first letter (a byte-order mark, a NUL, a digit ...), then a G-code word.
JUNK = re.compile(r"[^A-Za-z_;(/%@][^A-Za-z;(]*[A-Za-z][ \t]*[-+]?\.?[0-9]")
_JUNK_PREFIX = re.compile(r"[^A-Za-z]*")
_PARAM = re.compile(r'([A-Za-z])[ \t]*("[^"]*"?|[^\sA-Za-z"]*)')


def line_params(s: str) -> dict[str, str]:
    """The parameters of a G or M command's line: upper-case letter -> the text of its value.

    The line's first word (the command; after a line number) is left out; a quoted value (RRF's
    ``P"config-override.g"``) keeps its quotes; the comment is not read.
    """
    code = PARENS.sub(" ", split_line(s)[0])
    words = _PARAM.findall(code[: code.find("*")] if "*" in code else code)
    first = 1 if words and words[0][0] in "Nn" else 0
    return {letter.upper(): value for letter, value in words[first + 1:]}


def split_line(line: str) -> tuple[str, str, str]:
    """(code, comment, ending) of a line: the comment from ';' on, the ending LF, CR LF, CR or ""."""
    ending = line_ending(line)
    body = line[: len(line) - len(ending)]
    cut = body.find(";")
    if cut > 0 and "(" in body[:cut]:  # a ';' within a '(...)' comment is the comment's
        inside, cut = False, -1
        for k, c in enumerate(body):
            if c == ";" and not inside:
                cut = k
                break
            inside = (inside or c == "(") and c != ")"
    return (body, "", ending) if cut < 0 else (body[:cut], body[cut:], ending)


def block_delete_refusal(s: str) -> str | None:
    """Why a block-delete line (``/G1 ...``, leading blanks stripped) the filter would read is refused.

    Whether it runs is the controller's switch: LinuxCNC runs it while the switch is off;
    Klipper and Marlin run none (an unknown command).
    """
    rest = s[1:].lstrip()
    m = M_LINE.match(rest)
    if rest[:1] in READ and (m is None or m.group(1) in ("82", "83")):
        return ("a block-delete line ('/'): whether it runs depends on the controller's block-delete "
                "switch: remove the '/' or the line")
    return None


def command_then_g_refusal(s: str) -> str | None:
    """Why a G word after an M code on its line (``M83 G1 X40``) is refused.

    Marlin and Klipper read the first command alone (the rest are its parameters: Klipper's
    ``gcode.py`` takes the first letter and number as the command); LinuxCNC and grbl run both.
    """
    code = PARENS.sub(" ", split_line(s)[0])
    words = WORD.findall(code[: code.find("*")] if "*" in code else code)
    if all(value for _, value in words) and any(letter in "Gg" for letter, _ in words):
        g, m = (next(f"{a.upper()}{v}" for a, v in words if a in c) for c in ("Gg", "Mm"))
        return f"{g} after {m} on one line: Marlin and Klipper read only the first command, LinuxCNC and " \
               f"grbl both: put {g} on a line of its own"
    return None


def semicolon_refusal(code: str) -> str | None:
    """Why words after a ``(...;...)`` comment are refused.

    Klipper ends the line at the ';'; Marlin (with its parenthesis comments) and LinuxCNC read on.
    """
    for found in PARENS.finditer(code):
        if ";" in found.group() and code[found.end():].strip():
            return f"words after the comment {found.group()!r}: Klipper ends the line at its ';', others " \
                   "read on: put the comment at the end"
    return None


def bytes_refusal(line: str, s: str, reading: LineReading, name: str) -> str | None:
    """Why a NUL where the controller ends a line, or a blank it does not skip before a command, is refused.

    Args:
        line: The line.
        s: The line without its leading whitespace.
        reading: How the controller finds a line's command.
        name: The controller's name, for the message.
    """
    if reading.nul_ends_line and "\0" in line:
        return (f"a NUL byte in the line: {name} ends a line there and runs what follows it as a line of "
                "its own: remove it")
    odd = line[:len(line) - len(s)].strip(reading.blanks) if reading.blanks is not None else ""
    if odd and s[:1].isalpha():
        return f"{odd[0]!r} before the command: {name} reads the line as an unknown command from its own " \
               "card, a host (OctoPrint) strips it and sends the command: remove it"
    return None


def mark_refusal(first: str, reading: LineReading, name: str) -> str | None:
    """Why a command right after the UTF-8 byte-order mark that opens a program is refused, or None.

    A firmware reading the file from its own card takes the mark for text before the command (it
    does not run the line: :attr:`LineReading.junk` ignored); a host (OctoPrint) strips it and sends
    the command. A controller whose reading is not known is taken to be sent the line by a host.
    """
    if reading.junk is not Unread.IGNORED or not first.lstrip()[:1].isalpha():
        return None
    return (f"a byte-order mark before the first command ({first.strip()!r}): {name} reading the file "
            f"from its own card answers '{reading.unknown}' and does not run the line, a host (OctoPrint) "
            "strips the mark and sends it: save the program without the mark, or begin it with a comment")


def junk_split(s: str) -> tuple[str, str]:
    """A :data:`JUNK` line (leading blanks stripped): the text before its command's first letter, the rest."""
    text = s.rstrip("\r\n")
    prefix = _JUNK_PREFIX.match(text).group()  # type: ignore[union-attr]
    return prefix, text[len(prefix):]
