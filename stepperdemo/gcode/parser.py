"""G-code lines -> blocks of words (RS274/NGC as Grbl reads it).

A line is one block.  Letters are case-insensitive, spaces are ignored, ``(...)``
and ``;`` comments are dropped, a leading ``N<n>`` line number is ignored, ``%``
alone (a tape marker) is an empty line.  Every word is a letter and a real number.
:func:`parse_line` raises :class:`GcodeError` with a one-line reason; the program
answers it as ``error: <reason>`` (Grbl convention) and goes on.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from .. import messages as msg

MAX_LINE = 256  # characters of one block (Grbl: 80; longer lines are refused)
# the number after a letter: optional sign, digits with an optional point
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
AXES = "XYZABC"  # axis words, steppers 1..6
_VALUE_WORDS = "FPEQN" + AXES  # letters that carry a value (not a command)
_KNOWN = "GM" + _VALUE_WORDS


class GcodeError(ValueError):
    """A line that cannot be executed; ``str()`` is the reason for ``error: ...``."""


@dataclass
class Block:
    """The words of one line: commands (G/M codes, in order) and value words."""

    line: str
    g: list[float] = field(default_factory=list)
    m: list[float] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)

    @property
    def empty(self) -> bool:
        return not self.g and not self.m and not self.values


def strip_comments(line: str) -> str:
    """Drop ``(...)`` and ``;`` comments (an unclosed ``(`` is an error)."""
    out = []
    depth = False
    for ch in line:
        if depth:
            if ch == ")":
                depth = False
            continue
        if ch == "(":
            depth = True
            continue
        if ch == ";":
            break
        out.append(ch)
    if depth:
        raise GcodeError(msg.GCODE_ERR_COMMENT)
    return "".join(out)


def parse_line(line: str) -> Block:
    """The words of one G-code line (raises :class:`GcodeError`)."""
    if len(line) > MAX_LINE:
        raise GcodeError(msg.GCODE_ERR_LONG.format(n=MAX_LINE))
    text = strip_comments(line)
    text = "".join(text.split()).upper()
    block = Block(line)
    if text in ("", "%"):
        return block
    if text.startswith("/"):  # block delete: the line is skipped
        return block
    pos = 0
    first = True
    while pos < len(text):
        letter = text[pos]
        if not letter.isalpha():
            raise GcodeError(msg.GCODE_ERR_EXPECTED_LETTER.format(text=text[pos:pos + 8]))
        m = _NUMBER.match(text, pos + 1)
        if m is None:
            raise GcodeError(msg.GCODE_ERR_BAD_NUMBER.format(
                letter=letter, text=text[pos + 1:pos + 9] or msg.GCODE_NOTHING))
        value = float(m.group(0))
        if not math.isfinite(value):
            raise GcodeError(msg.GCODE_ERR_BAD_NUMBER.format(letter=letter, text=m.group(0)))
        pos = m.end()
        if letter not in _KNOWN:
            raise GcodeError(msg.GCODE_ERR_UNKNOWN_WORD.format(word=f"{letter}{m.group(0)}"))
        if letter == "N":
            if not first:
                raise GcodeError(msg.GCODE_ERR_LINE_NUMBER)
        elif letter == "G":
            block.g.append(value)
        elif letter == "M":
            block.m.append(value)
        else:
            if letter in block.values:
                raise GcodeError(msg.GCODE_ERR_REPEATED.format(letter=letter))
            block.values[letter] = value
        first = False
    return block


def code_name(letter: str, value: float) -> str:
    """``G1``, ``G92.1``, ``M62`` - a code as people write it."""
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return f"{letter}{text}"
