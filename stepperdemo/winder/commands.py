"""The winder's command words: the table, and a line cut into commands.

Commands are words separated by spaces; a command takes a fixed number of argument
words after it, on the same line (``pot 1 1023 w2000 pot 1 512``).  ``w<ms>`` waits.
A line is cut into :class:`Item` s up front; a malformed one becomes an item that
carries its error, so that it is reported in its place, in order, and nothing else
changes.  The values are checked when the command runs (:mod:`.app`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .. import messages as msg


@dataclass(frozen=True)
class Spec:
    args: tuple[str, ...]
    help: str


COMMANDS: dict[str, Spec] = {
    "move": Spec(("<s>", "<count>"), msg.WINDER_HELP_MOVE),
    "period": Spec(("<s>", "<counts>"), msg.WINDER_HELP_PERIOD),
    "accel": Spec(("<s>", "<steps/s2>"), msg.WINDER_HELP_ACCEL),
    "interlock": Spec(("0|1",), msg.WINDER_HELP_INTERLOCK),
    "ratio": Spec(("<n>:<m>",), msg.WINDER_HELP_RATIO),
    "pots": Spec((), msg.WINDER_HELP_POTS),
    "traverse": Spec(("<from>", "<to>"), msg.WINDER_HELP_TRAVERSE),
    "status": Spec((), msg.WINDER_HELP_STATUS),
    "pot": Spec(("<s>", "<0-1023>"), msg.WINDER_HELP_POT),
    "switch": Spec(("<A2-A5>", "<0|1>"), msg.WINDER_HELP_SWITCH),
    "reset": Spec((), msg.WINDER_HELP_RESET),
    "help": Spec((), msg.WINDER_HELP_HELP),
    "?": Spec((), msg.WINDER_HELP_HELP),
}

WAIT = "w"
_WAIT_RE = re.compile(r"w(\d{1,9})")
_INT_RE = re.compile(r"[+-]?\d+")


@dataclass(frozen=True)
class Item:
    """One command of a line: its word, argument words, or the error it makes."""

    name: str
    args: tuple[str, ...] = ()
    error: str | None = None

    @property
    def text(self) -> str:
        return " ".join((self.name, *self.args))


def usage(name: str) -> str:
    return " ".join((name, *COMMANDS[name].args))


def is_command_word(word: str) -> bool:
    return word.lower() in COMMANDS or _WAIT_RE.fullmatch(word.lower()) is not None


def parse_line(line: str) -> list[Item]:
    """The commands of one input line, in order."""
    words = line.split()
    items: list[Item] = []
    i = 0
    while i < len(words):
        word = words[i]
        low = word.lower()
        i += 1
        wait = _WAIT_RE.fullmatch(low)
        if wait:
            items.append(Item(WAIT, (wait.group(1),)))
            continue
        spec = COMMANDS.get(low)
        if spec is None:
            # the words that follow up to the next command belong to this mistake
            junk = [word]
            while i < len(words) and not is_command_word(words[i]):
                junk.append(words[i])
                i += 1
            items.append(Item(low, tuple(junk[1:]),
                              msg.WINDER_UNKNOWN.format(text=" ".join(junk))))
            continue
        args: list[str] = []
        while len(args) < len(spec.args) and i < len(words) and not is_command_word(words[i]):
            args.append(words[i])
            i += 1
        if len(args) < len(spec.args):
            items.append(Item(low, tuple(args),
                              msg.WINDER_NEEDS.format(usage=usage(low))))
            continue
        items.append(Item(low, tuple(args)))
    return items


def parse_int(word: str) -> int | None:
    """A whole number (sign allowed, nothing else), else None."""
    return int(word) if _INT_RE.fullmatch(word) else None


def parse_ratio(word: str) -> tuple[int, int] | None:
    m = re.fullmatch(r"(\d+):(\d+)", word)
    return (int(m.group(1)), int(m.group(2))) if m else None


def completions() -> list[tuple[str, str]]:
    out = [(usage(name), spec.help) for name, spec in COMMANDS.items() if name != "?"]
    out.append(("w<ms>", msg.WINDER_HELP_WAIT))
    return out
