"""StepperDemo's command language: a table from (mode, letter) to a handler.

A handler gets the program and the characters after the letter and returns True if
it accepted the command; False makes the loop print ``Unknown command: <cmd>``.

Each module of commands declares its own :class:`CommandSet` (the firmware's in
:mod:`.commands`, QuickStep's in :mod:`.quickstep`); :mod:`.command_registry` puts
the sets into one :class:`CommandTable`, explicitly and in order.  Declaring a
command has no effect beyond its own set.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import IntEnum
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # pragma: no cover
    from .app import StepperDemo


class Mode(IntEnum):
    NORMAL = 0
    TEST = 1
    CONFIG = 2
    GCODE = 3  # issue 12: a line is a G-code block (stepperdemo.gcode.demo_mode)


Handler = Callable[["StepperDemo", bytes], bool]


class CommandSet:
    """The commands of one module, in the order they are declared: per command its
    letter, its modes, the handler and - for completion and help toolbars - the text
    shown (the letter and its argument) with a short description (none: not shown)."""

    def __init__(self) -> None:
        self.entries: list[tuple[str, tuple[Mode, ...], Handler, str, str]] = []

    def add(self, letter: str, modes: Iterable[Mode], handler: Handler, hint: str = "",
            shown: str | None = None) -> Handler:
        self.entries.append((letter, tuple(modes), handler,
                             letter if shown is None else shown, hint))
        return handler

    def command(self, letter: str, *modes: Mode, hint: str = "",
                arg: str = "") -> Callable[[Handler], Handler]:
        """Decorator: the function is the handler of ``letter`` in ``modes``; ``arg``
        names its argument in the help (``M<n>``)."""
        def declare(fn: Handler) -> Handler:
            return self.add(letter, modes, fn, hint, letter + arg)
        return declare


class CommandTable:
    """(mode, letter) -> handler, from command sets; a later set's command replaces an
    earlier one of the same mode and letter."""

    def __init__(self, *sets: CommandSet) -> None:
        self.handlers: dict[tuple[Mode, int], Handler] = {}
        self.help: dict[Mode, list[tuple[str, str]]] = {mode: [] for mode in Mode}
        for command_set in sets:
            for letter, modes, handler, shown, hint in command_set.entries:
                for mode in modes:
                    self.handlers[(mode, ord(letter))] = handler
                    if hint:
                        self.help[mode].append((shown, hint))

    def dispatch(self, app: StepperDemo, cmd: bytes) -> bool:
        """Run the command ``cmd`` (its letter first) in the program's mode; False if
        no command of that letter exists there or its handler refused it."""
        handler = self.handlers.get((app.mode, cmd[0]))
        if handler is None:
            return False
        return handler(app, cmd[1:])

    def hints(self, mode: Mode) -> list[tuple[str, str]]:
        """``(command, description)`` of the mode, for completion and help toolbars."""
        return self.help[mode]
