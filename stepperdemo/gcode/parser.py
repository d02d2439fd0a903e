"""G-code lines -> blocks of words (RS274/NGC as Grbl 1.1 reads it).

A line is one block.  Before it gets here Grbl's receive path has filtered it
(:mod:`.grbl_rx`): no spaces or control characters, no ``(...)``/``;`` comments,
no ``/``, letters upper case; :func:`parse_line` filters a raw line the same way
(tests, the console).  Every word is a letter and a real number (an optional
sign, digits, one decimal point: Grbl's ``read_float``; no exponent).

:func:`parse_line` raises :class:`GcodeError` with Grbl's ``error:N`` number
(:mod:`.codes`) and a one-line reason; the machine answers it as ``[MSG:reason]``
then ``error:N`` and the session goes on.  Checks made here, as Grbl makes them
while reading the words: letters (1, 20), numbers (2), negative F N P S T (4), a
word twice (25), line numbers (27), G/M codes that are not whole numbers (23).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from .. import messages as msg
from .codes import Err

MAX_LINE = 255  # characters of one block after filtering (Grbl_ESP32/FluidNC; Grbl AVR 79)
MAX_LINE_NUMBER = 9_999_999  # Grbl's N range
# the number after a letter: optional sign, digits with an optional point
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
#: a word (letter, number): a line of well-formed words only is the words ``findall``
#: finds, end to end (their lengths add up to the line's), and they are the words the
#: loop of :func:`parse_line` reads, one after the other, from such a line
_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
AXES = "XYZABC"  # axis words, steppers 1..6
# value words Grbl reads (A B C are axes when the machine has them); E and Q are
# Grbl_ESP32's for M67/M68
_VALUE_WORDS = "EFIJKLNPQRST" + AXES
_KNOWN = "GM" + _VALUE_WORDS
_NOT_NEGATIVE = "FNPST"
#: value words :func:`_take_word` checks only for a sign and a repetition
_PLAIN_WORDS = frozenset(_VALUE_WORDS) - {"N"}
#: what Grbl's line assembly drops: characters up to the space, '/' (block delete)
_DROPPED = re.compile(r"[\x00-\x20/]")
#: G codes with a decimal part that exist (G92.1 here; G28.1 G30.1 G38.x G43.1 later)
G_DECIMALS = {92.1, 28.1, 30.1, 38.2, 38.3, 38.4, 38.5, 43.1, 61.1}


class GcodeError(ValueError):
    """A line that cannot be executed: ``code`` is Grbl's error number, ``str()`` the
    reason (printed as ``[MSG:reason]`` before ``error:N``)."""

    def __init__(self, code: int, reason: str = "") -> None:
        super().__init__(reason)
        self.code = int(code)


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
    """Drop ``(...)`` and ``;`` comments; an unclosed ``(`` eats the rest of the line
    (Grbl reports nothing for it)."""
    if "(" not in line and ";" not in line:
        return line
    out = []
    inside = False
    for ch in line:
        if inside:
            if ch == ")":
                inside = False
            continue
        if ch == "(":
            inside = True
            continue
        if ch == ";":
            break
        out.append(ch)
    return "".join(out)


def filter_line(line: str) -> str:
    """What Grbl's line assembly keeps of a raw line: no comments, no characters up to
    the space, no ``/``, letters upper case."""
    return _DROPPED.sub("", strip_comments(line)).upper()


def parse_line(line: str, filtered: bool = False) -> Block:
    """The words of one G-code line (raises :class:`GcodeError`); ``filtered``: the
    line comes from the receive path, which has filtered it already (the same
    filter: :func:`filter_line` would leave it as it is)."""
    text = line if filtered else filter_line(line)
    if len(text) > MAX_LINE:
        raise GcodeError(Err.OVERFLOW, msg.GCODE_ERR_LONG.format(n=MAX_LINE))
    block = Block(line, [], [], {})
    words = _WORD.findall(text)
    size = len(words)  # (the letters)
    for _letter, number in words:
        size += len(number)
    if size == len(text):  # (the common case - nothing but words: the same checks)
        values = block.values
        for letter, number in words:
            value = float(number)
            # (_take_word's common cases written out: a value word read the first time,
            # a G or M code that is a whole number - round(value, 4) is the value)
            if letter in _PLAIN_WORDS:
                if letter not in values and (value >= 0 or letter not in _NOT_NEGATIVE):
                    values[letter] = value
                    continue
            elif letter == "G":
                if value.is_integer():
                    block.g.append(value)
                    continue
            elif letter == "M" and value.is_integer():
                block.m.append(value)
                continue
            _take_word(block, letter, number, value)
        return block
    match = _NUMBER.match
    pos = 0
    end = len(text)
    while pos < end:
        letter = text[pos]
        if not "A" <= letter <= "Z":
            raise GcodeError(Err.EXPECTED_COMMAND_LETTER,
                             msg.GCODE_ERR_EXPECTED_LETTER.format(text=text[pos:pos + 12]))
        m = match(text, pos + 1)
        if m is None:
            raise GcodeError(Err.BAD_NUMBER_FORMAT, msg.GCODE_ERR_BAD_NUMBER.format(
                letter=letter, text=text[pos:pos + 12]))
        number = m.group(0)
        value = float(number)
        if not math.isfinite(value):  # pragma: no cover - the pattern has no exponent
            raise GcodeError(Err.BAD_NUMBER_FORMAT, msg.GCODE_ERR_BAD_NUMBER.format(
                letter=letter, text=text[pos:pos + 12]))
        pos = m.end()
        _take_word(block, letter, number, value)
    return block


def _take_word(block: Block, letter: str, number: str, value: float) -> None:
    """One word read: checked (Grbl's errors) and added to ``block``."""
    if letter not in _KNOWN:
        raise GcodeError(Err.UNSUPPORTED_COMMAND,
                         msg.GCODE_ERR_UNKNOWN_WORD.format(word=letter + number))
    if letter == "G" or letter == "M":
        code = round(value, 4)
        if code != int(code) and not (letter == "G" and code in G_DECIMALS):
            raise GcodeError(Err.COMMAND_VALUE_NOT_INTEGER,
                             msg.GCODE_ERR_NOT_INTEGER.format(word=letter + number))
        (block.g if letter == "G" else block.m).append(code)
        return
    if value < 0 and letter in _NOT_NEGATIVE:
        raise GcodeError(Err.NEGATIVE_VALUE,
                         msg.GCODE_ERR_NEGATIVE.format(word=letter + number))
    values = block.values
    if letter in values:
        raise GcodeError(Err.WORD_REPEATED, msg.GCODE_ERR_REPEATED.format(letter=letter))
    if letter == "N" and value > MAX_LINE_NUMBER:
        raise GcodeError(Err.INVALID_LINE_NUMBER, msg.GCODE_ERR_LINE_NUMBER)
    values[letter] = value


def code_name(letter: str, value: float) -> str:
    """``G1``, ``G92.1``, ``M62`` - a code as people write it."""
    text = f"{value:.4f}".rstrip("0").rstrip(".")
    return f"{letter}{text}"
