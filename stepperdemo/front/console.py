"""The interactive console: StepperDemo on a simulated chip that runs in real time.

A prompt-toolkit session takes lines; every character goes to the StepperDemo
program as if typed on its serial port.  A background task advances the simulated
chip to the wall clock (optionally scaled) and prints what the program prints above
the prompt.  Lines starting with ``/`` are console commands (``/help``).  Ctrl-C
force-stops every stepper and returns to the prompt; Ctrl-D leaves.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import time
from collections import deque
from pathlib import Path
from typing import Awaitable, Callable, Iterable

from prompt_toolkit import PromptSession
from prompt_toolkit.completion import Completer, Completion
from prompt_toolkit.filters import Condition
from prompt_toolkit.formatted_text import FormattedText
from prompt_toolkit.history import InMemoryHistory
from prompt_toolkit.key_binding import KeyBindings
from prompt_toolkit.patch_stdout import patch_stdout
from prompt_toolkit.shortcuts import print_formatted_text

from fas.arch import PROFILES, get_profile
from fas.sim import SimBackend

from .. import messages as msg
from ..program import Program, make_program
from ..watch.recent import MAX_EDGES
from . import serial_cli  # issue 7: --port, /reconnect /link /estop
from .mode_history import ModeHistory
from .trace_commands import META_COMMANDS as TRACE_META_COMMANDS
from .trace_commands import TraceCommands, help_lines

META_COMMANDS = {
    "/help": "console commands",
    "/quit": "leave the console",
    "/arch": "show or change the profile",
    "/stop": "force-stop all steppers",
    "/time": "simulated time",
    "/speed": "clock speed-up factor",
    **TRACE_META_COMMANDS,  # /trace /vcd /plot /report (issue 6)
    **serial_cli.META_COMMANDS,  # /reconnect /link /estop (issue 7)
}

TOOLBAR_REFRESH_S = 0.25  # the toolbar (time, running steppers, mode) redraws this often

Clock = Callable[[], float]
Sleep = Callable[[float], Awaitable[None]]


def default_history_path() -> Path:
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(Path.home(), ".local", "state")
    return Path(base) / "stepperdemo" / "history"


class RealTimeDriver:
    """Keeps the simulated chip at the wall clock: sim time = start + scale * elapsed."""

    def __init__(self, app: Program, scale: float = 1.0, clock: Clock = time.monotonic):
        self.app = app
        self.clock = clock
        self.scale = scale
        self._wall0 = clock()
        self._tick0 = app.backend.now()

    def set_scale(self, scale: float) -> None:
        self._tick0 = self.target_tick()
        self._wall0 = self.clock()
        self.scale = scale

    def target_tick(self) -> int:
        tps = self.app.profile.ticks_per_s
        return self._tick0 + int((self.clock() - self._wall0) * self.scale * tps)

    def advance(self) -> float | None:
        """Run the program up to now; seconds until it next needs the CPU (None: idle)."""
        app = self.app
        app.run_until(self.target_tick())
        wake = app.next_wake_tick()
        if wake is None:
            return None
        # the chip may be ahead of the wall clock (a long print): wait for the clock
        wake = max(wake, app.backend.now())
        tps = app.profile.ticks_per_s
        return max(0.0, (wake - self.target_tick()) / tps / self.scale)


TOOLBAR_COMMANDS = 12  # commands of the mode the toolbar lists


def toolbar_hints(completions: list[tuple[str, str]]) -> str:
    """The toolbar's list of the mode's commands: the first few, then ``?`` with what it
    does in this mode if it is not among them, then /help."""
    names = [k for k, _ in completions[:TOOLBAR_COMMANDS]]
    if "?" not in names:
        hint = next((h for k, h in completions if k == "?"), None)
        if hint is not None:
            names.append(f"? {hint.split()[0]}")
    return "  ".join([*names, "/help"])


class ProgramCompleter(Completer):
    def __init__(self, console: "Console") -> None:
        self.console = console

    def get_completions(self, document, complete_event) -> Iterable[Completion]:
        word = document.get_word_before_cursor(WORD=True)
        if word.startswith("/"):
            for name, hint in self.console.meta_commands.items():
                if name.startswith(word):
                    yield Completion(name, -len(word), display_meta=hint)
            return
        for letters, hint in self.console.app.completions():
            if not word or letters.startswith(word[:1]):
                yield Completion(letters.split("<")[0], -len(word), display=letters,
                                 display_meta=hint)


class Console:
    meta_commands = META_COMMANDS  # what Tab offers after "/"

    def __init__(self, arch: str = "atmega328p", *, scale: float = 1.0,
                 history: str | None = None, clock: Clock = time.monotonic,
                 sleep: Sleep | None = None, input=None, output=None,
                 port: str | None = None, baud: int = 115200, watchdog_ms: int = 500,
                 backend=None, program: str = "demo",
                 program_options: dict | None = None,
                 link_planning_ms: int | None = None,
                 redraw_postpone_s: float | None = 0.01,
                 recent_trace: bool = True, trace_edges: int = MAX_EDGES,
                 vcd_timescale: str | None = None) -> None:
        self.program = program  # which program the console hosts (stepperdemo.program)
        self.program_options = program_options or {}
        self.port, self.baud, self.watchdog_ms = port, baud, watchdog_ms  # issue 7
        self.link_planning_ms = link_planning_ms  # issue 18
        self._given_backend = backend  # issue 7: a connected serial backend (tests)
        self.clock = clock
        self.sleep = sleep or asyncio.sleep
        self.scale = scale
        self._pending = bytearray()
        self._wake = asyncio.Event()
        self._input = input
        self._output = output
        self.history = self._make_history(history)
        self.lines: list[str] = []  # everything shown, for tests
        self.quit = False
        self.prompt_session: PromptSession | None = None
        self._history_mode: str | None = None
        # prompt-toolkit postpones a redraw by up to this much *real* time while its loop
        # is busy (its default); on a virtual clock (tests) pass None: redraw at once
        self.redraw_postpone_s = redraw_postpone_s
        self._toolbar_at = -TOOLBAR_REFRESH_S  # wall time of the last toolbar redraw
        self._drawn_positions: list[int | None] = []  # stepper positions at that draw
        self.toolbar_shown: deque[str] = deque(maxlen=64)  # recent toolbar texts, for tests
        # /trace /vcd /plot /report (issue 6); the recent motion recorded from the start
        # on a simulated chip (issue 16; recent_trace=False starts with the trace off)
        self.trace = TraceCommands(lambda: self.app, recent=recent_trace, max_edges=trace_edges,
                                   timescale=vcd_timescale)  # /vcd's unit (issue 26)
        self._start(arch)
        self.trace.new_chip()

    # -------------------------------------------------------------- setup
    def _start(self, arch: str) -> None:
        if self.port or self._given_backend is not None:  # issue 7: a device does the work
            self.backend = self._given_backend or serial_cli.open_backend(
                self.port, self.baud, self.watchdog_ms, self.link_planning_ms)
            self.port = self.port or self.backend.port or "?"
            serial_cli.console_attach(self, self.backend)
            self.scale = self.backend.clock_hz / self.backend.profile.ticks_per_s
        else:
            self.backend = SimBackend(arch)
        self.app = make_program(self.program, self.backend, scripted=False,
                                output=self._collect, **self.program_options)
        self.driver = RealTimeDriver(self.app, self.scale, self.clock)
        if self.port:  # issue 7: the device's clock runs by itself
            self.driver = serial_cli.DeviceDriver(self.app, self.scale)

    def _make_history(self, path: str | None):
        target = Path(path) if path else default_history_path()
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.touch(exist_ok=True)
            return ModeHistory(str(target), lambda: self.app.mode_name())
        except OSError as exc:
            self.note(msg.REPL_HISTORY_FAILED.format(error=exc))
            return InMemoryHistory()

    # ------------------------------------------------------------- output
    def _collect(self, data: bytes) -> None:
        self._pending += data

    def output_pending(self) -> bool:
        """The program printed something not shown yet (a line not finished)."""
        return bool(self._pending)

    def flush(self, final: bool = False) -> None:
        """Show complete lines the program printed (and a partial line if ``final``)."""
        data = self._pending
        end = data.rfind(b"\n")
        if end < 0 and not final:
            return
        cut = len(data) if final else end + 1
        chunk = bytes(data[:cut])
        del data[:cut]
        text = chunk.decode("utf-8", "replace").replace("\r\n", "\n").replace("\r", "")
        for line in text.split("\n")[:-1] if text.endswith("\n") else text.split("\n"):
            self._show(line)

    def _show(self, line: str) -> None:
        self.lines.append(line)
        style = ""
        if line.startswith(("ERROR", "Unknown command", "Failed status", "error:", "ALARM")):
            style = "ansired bold"
        elif line.startswith("test passed"):
            style = "ansigreen bold"
        elif line.startswith(("M1: @", "M2: @", "M3: @", "M4: @", "M5: @", "M6: @")):
            style = "ansibrightblack"
        print_formatted_text(FormattedText([(style, line)]), output=self._output)

    def note(self, text: str) -> None:
        """A line of the console's own (not the program's), shown above the prompt."""
        self.lines.append(text)
        print_formatted_text(FormattedText([("ansicyan", text)]), output=self._output)

    # ------------------------------------------------------------ toolbar
    def toolbar(self):
        app = self.app
        t = self.backend.now() / self.backend.profile.ticks_per_s
        status = app.toolbar_status()
        state = (f" {app.mode_name()} mode | {status + ' | ' if status else ''}t={t:.3f}s"
                 f" | running {self._running_since_last_draw()} | ")
        self.toolbar_shown.append(state)
        return FormattedText([
            ("bold", f" {self.backend.profile.name} "),
            ("", state),
            ("italic", toolbar_hints(app.completions())),
        ])

    def _running_since_last_draw(self) -> int:
        """Steppers running now or moved since the toolbar was last drawn: a move of a
        few milliseconds (test sequence 01) falls between two draws."""
        positions = [None if s is None else s.get_current_position() for s in self.app.steppers]
        before = self._drawn_positions
        self._drawn_positions = positions
        return sum(1 for i, s in enumerate(self.app.steppers) if s is not None and (
            s.is_running() or (i < len(before) and before[i] != positions[i])))

    def refresh_toolbar(self) -> None:
        """Redraw the prompt (and its toolbar) every TOOLBAR_REFRESH_S of wall time, so
        that time, running steppers and mode move on while nobody types."""
        now = self.clock()
        if now - self._toolbar_at < TOOLBAR_REFRESH_S:
            return
        self._toolbar_at = now
        session = self.prompt_session
        if session is not None and session.app.is_running:
            session.app.invalidate()

    # ------------------------------------------------------- meta commands
    def meta(self, line: str) -> None:
        parts = line.split()
        cmd, args = parts[0], parts[1:]
        if cmd == "/help":
            for text in msg.REPL_HELP.splitlines() + help_lines(self.trace.max_edges):
                self.note(text)
            for text in msg.REPL_HELP_SERIAL.splitlines() if self.port else ():  # issue 7
                self.note(text)
        elif cmd in ("/quit", "/exit"):
            self.quit = True
        elif cmd == "/stop":
            self.app.force_stop_all()
            self.note(msg.REPL_STOPPED_ALL)
        elif cmd == "/time":
            sim_s = self.backend.now() / self.backend.profile.ticks_per_s
            self.note(msg.REPL_TIME.format(sim=sim_s,
                                            scale=self.driver.scale))
        elif self.port and (cmd in ("/speed", "/arch") and args or self.trace.handles(cmd)):
            self.note(msg.SERIAL_NOT_ON_DEVICE.format(cmd=cmd))  # issue 7
        elif cmd in serial_cli.META_COMMANDS:  # issue 7: /reconnect /link /estop
            for text in serial_cli.console_meta(self, cmd, args):
                self.note(text)
        elif cmd == "/speed":
            try:
                factor = float(args[0])
                if not 0 < factor <= 1000:
                    raise ValueError
            except (IndexError, ValueError):
                self.note(msg.REPL_BAD_ARG.format(cmd=cmd, problem="give a factor 0 < f <= 1000"))
                return
            self.scale = factor
            self.driver.set_scale(factor)
        elif cmd == "/arch":
            if not args:
                p = self.backend.profile
                self.note(msg.REPL_PROFILE.format(name=p.name, title=p.title,
                                                   steppers=p.max_steppers, ticks=p.ticks_per_s))
                return
            try:
                profile = get_profile(args[0])
                problem = getattr(type(self.app), "profile_problem", lambda _p: None)(profile)
                if problem:  # the program cannot run there (the winder: two dir pins)
                    raise ValueError(problem)
            except ValueError as exc:
                self.note(msg.REPL_BAD_ARG.format(cmd=cmd, problem=exc))
                return
            self.flush(final=True)
            kept = self.trace.stop()  # the recording belongs to the old chip (issue 6)
            self._start(args[0].lower())
            self.trace.new_chip()  # ... and the new one records as the mode says (issue 16)
            self.note(msg.REPL_SWITCHED.format(name=args[0].lower()))
            for text in kept:
                self.note(text)
        elif self.trace.handles(cmd):  # /trace /vcd /plot /report (issue 6)
            for text in self.trace.command(cmd, args):
                self.note(text)
        else:
            self.note(msg.REPL_UNKNOWN_META.format(cmd=cmd))

    def handle_line(self, line: str) -> None:
        stripped = line.strip()
        if stripped.startswith("/"):
            self.meta(stripped)
            return
        if self.port and not self.backend.connected:  # a lost device takes no input
            self.note(serial_cli.not_connected(self.backend))
            return
        self.app.feed(line + "\n")
        self._wake.set()

    def control_key(self, key: str) -> None:
        """A control key the program takes as a byte (Ctrl-X: Grbl's soft reset)."""
        data = self.app.control_keys().get(key)
        if data is not None:
            self.app.feed(data)
            self._wake.set()

    def key_bindings(self) -> KeyBindings:
        """The program's control keys, sent at once (eager: before Emacs's Ctrl-X
        prefix could wait for a second key)."""
        kb = KeyBindings()

        @kb.add("c-x", eager=True, filter=Condition(lambda: "c-x" in self.app.control_keys()))
        def _ctrl_x(event) -> None:
            self.control_key("c-x")

        return kb

    def interrupt(self) -> None:
        """Ctrl-C: stop all motion at once."""
        self.app.force_stop_all()
        self.note(msg.REPL_STOPPED_ALL)
        self._wake.set()

    # ---------------------------------------------------------- main loop
    def follow_mode(self) -> None:
        """The history offers the lines of the program's input mode: reload it when the
        mode changes (the line being typed stays)."""
        mode = self.app.mode_name()
        if mode != self._history_mode and self.prompt_session is not None:
            buf = self.prompt_session.default_buffer
            buf.reset(document=buf.document)
            self.prompt_session.app.invalidate()
        self._history_mode = mode

    async def ticker(self) -> None:
        while not self.quit:
            delay = self.driver.advance()
            self.flush()
            self.follow_mode()
            self.refresh_toolbar()
            if self.app.input_pending():
                delay = 0.0 if delay is None else min(delay, 0.001)
            # sleep until the program next needs the CPU or the toolbar is due; typed
            # input wakes us earlier
            due = max(0.0, self._toolbar_at + TOOLBAR_REFRESH_S - self.clock())
            timeout = min(due, 1.0 if delay is None else min(max(delay, 0.0), 1.0))
            self._wake.clear()
            with contextlib.suppress(asyncio.TimeoutError):  # a safety net
                await asyncio.wait_for(self._wake_or_sleep(timeout), timeout + 1)

    async def _wake_or_sleep(self, timeout: float) -> None:
        sleeper = asyncio.ensure_future(self.sleep(timeout))
        waiter = asyncio.ensure_future(self._wake.wait())
        done, pending = await asyncio.wait({sleeper, waiter},
                                           return_when=asyncio.FIRST_COMPLETED)
        for task in pending:
            task.cancel()

    def welcome(self) -> str:
        p = self.backend.profile
        if self.port:  # issue 7
            return msg.REPL_WELCOME_SERIAL.format(version=msg.VERSION, profile=p.name,
                                                  port=self.port, title=self.app.title)
        return msg.REPL_WELCOME.format(version=msg.VERSION, profile=p.name,
                                       mode=f"x{self.scale:g} real time", title=self.app.title)

    def close_session(self) -> None:
        """The console ends: release what the session holds."""
        if self.port:  # issue 7: end the device session
            self.backend.close()

    async def run(self) -> int:
        self.note(self.welcome())
        session = PromptSession(history=self.history, completer=ProgramCompleter(self),
                                bottom_toolbar=self.toolbar, input=self._input,
                                output=self._output, complete_while_typing=False,
                                key_bindings=self.key_bindings())
        session.app.max_render_postpone_time = self.redraw_postpone_s
        self.prompt_session = session
        with patch_stdout(raw=True):
            tick = asyncio.ensure_future(self.ticker())
            try:
                while not self.quit:
                    try:
                        line = await session.prompt_async("> ")
                    except KeyboardInterrupt:
                        self.interrupt()
                        continue
                    except EOFError:
                        break
                    self.handle_line(line)
            finally:
                self.quit = True
                self._wake.set()
                await tick
                self.flush(final=True)
                self.trace.close()  # issue 6: stop recording, remove the spool file
                self.close_session()
        self.note(msg.REPL_BYE)
        return 0


def run_console(args) -> int:
    port = getattr(args, "port", None)  # issue 7
    try:
        console = Console(args.arch, scale=args.speed, history=args.history, port=port,
                          baud=getattr(args, "baud", 115200),
                          watchdog_ms=getattr(args, "watchdog_ms", 500),
                          program=getattr(args, "program", "demo"),
                          program_options=getattr(args, "program_options", None),
                          link_planning_ms=getattr(args, "link_planning_ms", None),
                          vcd_timescale=getattr(args, "vcd_timescale", None))
    except ConnectionError as exc:  # issue 7: fas.serial.SerialError
        print(msg.CLI_SERIAL_CONNECT.format(port=port, error=exc), file=sys.stderr)
        return serial_cli.EXIT_USAGE
    except ValueError as exc:  # the profile cannot host the program
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return serial_cli.EXIT_USAGE
    return asyncio.run(console.run())


__all__ = ["Console", "RealTimeDriver", "run_console", "PROFILES"]
