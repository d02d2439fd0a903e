"""Every subcommand of ``stepperdemo``, in one registry.

``stepperdemo NAME ...`` runs the entry ``NAME`` of :data:`SUBCOMMANDS`: either a tool
with its own command line (``main``: a function of the arguments after the name,
returning the exit code) or a console program (``program``: a
:class:`stepperdemo.program.Program` factory) that the console hosts with its own
options (``-c``, ``--port``, ``--vcd``, the REPL ...).  A program's entry also makes it
known by that name to scenario files and :func:`stepperdemo.program.make_program`.
Both are named as ``"module:attribute"`` and imported only when used.

A new console program plugs in with one entry here (and its texts in
:mod:`stepperdemo.messages`); ``stepperdemo --help`` lists it.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from . import messages as msg


@dataclass(frozen=True)
class Subcommand:
    help: tuple[str, str]  # how ``stepperdemo --help`` lists it: (usage, what it does)
    main: str | None = None  # "module:function(argv) -> exit code": its own command line
    program: str | None = None  # "module:factory": a console program of that name

    def __post_init__(self) -> None:
        if self.main is None and self.program is None:
            raise ValueError("a subcommand runs a main function or hosts a program")


#: name -> subcommand, in the order ``stepperdemo --help`` lists them
SUBCOMMANDS: dict[str, Subcommand] = {
    "winder": Subcommand(msg.SUBCOMMAND_WINDER,  # issue 13: the helix winder (seed 002)
                         program="stepperdemo.winder.app:Winder"),
    "run": Subcommand(msg.SUBCOMMAND_RUN, main="stepperdemo.scenarios.runner:main"),
    "device": Subcommand(msg.SUBCOMMAND_DEVICE,  # issue 7
                         main="stepperdemo.front.serial_cli:run_device"),
    "relay": Subcommand(msg.SUBCOMMAND_RELAY, main="stepperdemo.front.serial_cli:run_relay"),
    "gcode": Subcommand(msg.SUBCOMMAND_GCODE, main="stepperdemo.gcode.cli:main",  # issue 12
                        program="stepperdemo.gcode.program:GcodeProgram"),
}


def load(target: str) -> Any:
    """The attribute a ``"module:attribute"`` names (imported now)."""
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def main_of(name: str) -> Callable[[Sequence[str]], int] | None:
    """The main function of subcommand ``name`` (None: it hosts a program with the
    console's own command line)."""
    target = SUBCOMMANDS[name].main
    return None if target is None else load(target)


def help_lines() -> list[str]:
    """The subcommands as ``stepperdemo --help`` lists them."""
    lines = []
    for sub in SUBCOMMANDS.values():
        usage, text = sub.help
        first, *more = text.split("\n")
        lines.append(msg.SUBCOMMAND_LINE.format(usage=usage, text=first))
        lines += [msg.SUBCOMMAND_LINE.format(usage="", text=t) for t in more]
    return lines
