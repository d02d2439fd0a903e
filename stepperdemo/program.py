"""What the front ends need from a program they host.

The console hosts programs - StepperDemo, and beside it the other systems that run on
the same library (the winder, G-code, ...).  Every front end - the REPL, ``-c``
scripted runs, scenario files, ``--port`` - drives a program only through this
interface, so a new program gets all of them by implementing it and registering its
factory as a subcommand of its name (:mod:`stepperdemo.subcommands`).

A program runs on a backend's clock: :meth:`Program.run_until` advances it,
:meth:`Program.next_wake_tick` says when it next needs the CPU, typed characters
arrive through :meth:`Program.feed`, and everything it prints goes to the ``output``
callback given at construction (bytes, the program's own line ends) and into
:attr:`Program.transcript`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from enum import IntEnum
from typing import TYPE_CHECKING, Any, Callable

from fas.backend import Backend

from .subcommands import SUBCOMMANDS, load

if TYPE_CHECKING:  # pragma: no cover
    from fas.arch import Profile

    from .watch.observe import Observers

Output = Callable[[bytes], None]


class EndReason(IntEnum):
    RUNNING = 0
    IDLE = 1  # input consumed, everything stopped
    FIRMWARE_END = 2  # firmware-style end: one second after the input was consumed
    MAX_TIME = 3


class Program(ABC):
    """A console program on a backend (see the module text)."""

    #: shown in the toolbar and the welcome line
    title: str = "program"
    backend: Backend
    #: everything printed so far
    transcript: bytearray
    #: the library's steppers (``None`` where a slot is unused), for plots and reports
    steppers: list

    @property
    def profile(self) -> Profile:
        return self.backend.profile

    # ------------------------------------------------------------ driving
    @abstractmethod
    def feed(self, text: str | bytes) -> None:
        """Characters typed at the console (interactive input)."""

    @abstractmethod
    def input_pending(self) -> bool:
        """Input received but not yet taken by the program."""

    @abstractmethod
    def run_until(self, tick: int) -> None:
        """Run the program until the backend's clock reaches ``tick``."""

    @abstractmethod
    def loop_pass(self) -> None:
        """One pass of the program's loop, now (a device driver runs it as ``loop()``)."""

    @abstractmethod
    def next_wake_tick(self) -> int | None:
        """When the program next has something to do (None: only input wakes it)."""

    @abstractmethod
    def run_script(self, line: str | bytes, *, firmware_end: bool = False,
                   max_ticks: int | None = None) -> EndReason:
        """Run one scripted line on virtual time to its end."""

    @abstractmethod
    def force_stop_all(self) -> None:
        """Console Ctrl-C: stop all motion at once and release any held input."""

    # -------------------------------------------------------- the console
    @abstractmethod
    def mode_name(self) -> str:
        """The input mode, for the toolbar (``normal``, ``test``, ...)."""

    @abstractmethod
    def completions(self) -> list[tuple[str, str]]:
        """``(command, hint)`` pairs of the current mode, for completion and toolbar."""

    def toolbar_status(self) -> str:
        """Program-specific toolbar text (selected stepper, inputs, ...)."""
        return ""

    def control_keys(self) -> dict[str, bytes]:
        """Control keys the console sends to the program as bytes when pressed (a key
        name of prompt-toolkit -> bytes; the G-code machine's Ctrl-X)."""
        return {}

    def exit_code(self) -> int:
        """0 when a scripted run succeeded; non-zero (1) when it reported a failure."""
        return 0

    def dropped_input(self) -> int:
        """Input bytes the program's firmware dropped unread (a full input buffer); the
        scripted console says so on stderr, the transcript stays the firmware's."""
        return 0

    # ----------------------------------------------------- watching a run
    def trace_signals(self) -> dict[int, list[str]]:
        """Pins of the program's own (inputs, outputs) to trace beside the steppers'."""
        return {}

    def watch(self, observers: Observers) -> None:  # noqa: B027 - optional: no-op by default
        """Recording of the pins starts (``stepperdemo.watch.observe.Observers``): the
        program may add consumers of its own to ``observers.stream``."""

    def watch_report(self) -> list[str]:
        """Lines the program adds to the timing report."""
        return []


class LoopProgram(Program):
    """A program written as an Arduino sketch: ``setup()`` once, then passes of
    ``loop()`` that read the serial input a character at a time.  It gives
    :meth:`run_until` and :meth:`run_script` from its own :meth:`_advance` (one pass,
    after skipping the time in which the pass would find nothing to do)."""

    _setup_done: bool
    #: tick at which the scripted input was consumed (None while some is left)
    input_consumed_at: int | None

    @abstractmethod
    def setup(self) -> None:
        """The sketch's ``setup()`` (at most once)."""

    @abstractmethod
    def load_script(self, line: str | bytes) -> None:
        """The scripted line becomes the serial input."""

    @abstractmethod
    def _advance(self, limit: int) -> None:
        """One loop pass, after skipping idle time (never beyond ``limit``)."""

    @abstractmethod
    def finished(self) -> bool:
        """Input consumed and everything at rest: the end of a scripted run."""

    def script_consumed(self) -> bool:
        """The scripted input is all taken (the firmware-style end counts from then)."""
        return self.input_consumed_at is not None

    def run_until(self, tick: int) -> None:
        """Run loop passes until the backend's clock reaches ``tick``."""
        if not self._setup_done:
            self.setup()
        b = self.backend
        while b.now() < tick:
            self._advance(tick)

    def run_script(self, line: str | bytes, *, firmware_end: bool = False,
                   max_ticks: int | None = None) -> EndReason:
        """Run a scripted line to its end.

        ``firmware_end``: stop one second after the input was consumed (as the
        conformance runs did).  Otherwise stop once the input is consumed and
        everything has come to rest (:meth:`finished`).
        """
        self.load_script(line)
        self.setup()
        b = self.backend
        limit = b.now() + (max_ticks if max_ticks is not None
                           else 3600 * self.profile.ticks_per_s)
        while True:
            if self.script_consumed():
                if firmware_end:
                    b.app_wait_until(self.input_consumed_at + self.profile.ticks_per_s)
                    return EndReason.FIRMWARE_END
                if self.finished():
                    return EndReason.IDLE
            if b.now() >= limit:
                return EndReason.MAX_TIME
            self._advance(limit)


#: the program the bare ``stepperdemo`` hosts; the others are hosted by a subcommand of
#: their name (:data:`stepperdemo.subcommands.SUBCOMMANDS`)
DEFAULT_PROGRAM = ("demo", "stepperdemo.demo.app:StepperDemo")


def programs() -> dict[str, str]:
    """Program name -> ``"module:factory"``; a factory takes (backend, *, scripted,
    output, **options) - options are the program's own (its command line gives them)."""
    found = dict([DEFAULT_PROGRAM])
    found.update((name, sub.program) for name, sub in SUBCOMMANDS.items()
                 if sub.program is not None)
    return found


def program_factory(name: str) -> Callable[..., Program]:
    return load(programs()[name])


def make_program(name: str, backend: Backend, *, scripted: bool,
                 output: Output | None = None, **options: Any) -> Program:
    return program_factory(name)(backend, scripted=scripted, output=output, **options)
