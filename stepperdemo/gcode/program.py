"""``stepperdemo gcode``: the G-code machine as a console program (``Program``).

The program connects the first ``axes`` steppers of the profile's StepperDemo
wiring (X, Y, Z ... = steppers 1, 2, 3 ...), prints a Grbl-style banner and answers
every line.  Input arrives character by character (:meth:`GcodeProgram.feed`); a
line ends at LF or CR.  ``?`` and Ctrl-X are real-time characters, handled when
they arrive.  A scripted run (``stepperdemo gcode FILE``) takes the file's lines as
fast as the block queue accepts them - as a sender streaming with ``ok`` flow
control would - and ends when every line is taken and the machine is idle.
"""

from __future__ import annotations

from collections import deque
from typing import Callable

from fas import Engine
from fas.backend import Backend

from .. import messages as msg
from ..demo.build import demo_build
from ..program import EndReason, Program
from .machine import RESET, STATUS, GcodeMachine
from .parser import AXES
from .settings import GcodeSettings

DEFAULT_AXES = 3
CRLF = "\r\n"

COMPLETIONS = [
    ("G0", "rapid move: G0 X.. Y.."), ("G1", "line at feed F: G1 X.. F.."),
    ("G4", "dwell P seconds"), ("G90", "absolute"), ("G91", "incremental"),
    ("G92", "set position (offset)"), ("M62", "Dout P on, synchronized"),
    ("M63", "Dout P off, synchronized"), ("M64", "Dout P on, at once"),
    ("M65", "Dout P off, at once"), ("M67", "Aout E duty Q%, synchronized"),
    ("M68", "Aout E duty Q%, at once"), ("M2", "end of program"), ("$$", "settings"),
    ("$X", "unlock after an alarm"), ("?", "status"),
]


class GcodeProgram(Program):
    """The G-code program on a backend (see the module text)."""

    title = "G-code"

    def __init__(self, backend: Backend, *, scripted: bool = True,
                 output: Callable[[bytes], None] | None = None, axes: int | None = None,
                 settings: GcodeSettings | None = None,
                 setup_lines: list[str] | None = None) -> None:
        self.backend = backend
        self.scripted = scripted
        self.output = output
        self.transcript = bytearray()
        self.engine = Engine(backend)
        p = backend.profile
        self.axes = min(axes or DEFAULT_AXES, p.max_steppers, len(demo_build(p).steppers),
                        len(AXES))
        self.steppers: list = [None] * p.max_steppers
        self._settings = settings
        self._setup_lines = list(setup_lines or [])
        self.machine: GcodeMachine | None = None
        self.rx = bytearray()  # interactive input not yet taken
        self.lines_in: deque[str] = deque()  # complete lines waiting for the block queue
        self.script: deque[str] = deque()
        self.input_consumed_at: int | None = None
        self._partial = bytearray()
        self._setup_done = False

    # ------------------------------------------------------------- output
    def _write(self, line: str) -> None:
        data = (line + CRLF).encode("utf-8")
        self.transcript += data
        if self.output is not None:
            self.output(data)

    # -------------------------------------------------------------- setup
    def setup(self) -> None:
        if self._setup_done:
            return
        self._setup_done = True
        self.engine.init()
        for i, cfg in enumerate(demo_build(self.profile).steppers[:self.axes]):
            s = self.engine.stepper_connect_to_pin(cfg.step)
            if s is None:  # pragma: no cover - the profile table guarantees the pins
                break
            s.set_direction_pin(cfg.direction, cfg.direction_high_counts_up,
                                cfg.dir_change_delay_us)
            s.set_enable_pin(cfg.enable_low_active, True)
            s.set_enable_pin(cfg.enable_high_active, False)
            s.set_auto_enable(False)
            s.set_delay_to_enable(cfg.on_delay_us)
            self.steppers[i] = s
        axes = [s for s in self.steppers if s is not None]
        self.machine = GcodeMachine(self.engine, axes, self._write, self._settings)
        self._write(msg.GCODE_BANNER)
        for line in self._setup_lines:  # command-line settings (--set), answered as lines
            self.machine.line(line)

    # --------------------------------------------------------------- input
    def feed(self, text: str | bytes) -> None:
        data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
        self.rx += data

    def load_script(self, text: str) -> None:
        self.script = deque(text.splitlines())
        self.input_consumed_at = None

    def input_pending(self) -> bool:
        return bool(self.rx or self.lines_in or self.script)

    def _take_input(self) -> None:
        """Real-time characters at once; complete lines while the queue has room."""
        m = self.machine
        if self.rx:
            data, self.rx = bytes(self.rx), bytearray()
            for byte in data:
                ch = chr(byte)
                if ch == STATUS or byte == RESET:
                    m.realtime(ch)
                    if byte == RESET:
                        self.lines_in.clear()
                        self._partial.clear()
                elif ch in "\r\n":
                    self.lines_in.append(self._partial.decode("utf-8", "replace"))
                    self._partial.clear()
                else:
                    self._partial.append(byte)
        while m.can_take_line():
            if self.lines_in:
                line = self.lines_in.popleft()
            elif self.script:
                line = self._script_line(self.script.popleft())
                if not line.strip():
                    continue  # a blank line of a file: nothing to answer
            else:
                break
            m.line(line)
        if self.scripted and not self.script and self.input_consumed_at is None:
            self.input_consumed_at = self.backend.now()

    def _script_line(self, line: str) -> str:
        """A line of a file: its real-time characters act when the line is reached."""
        rest = []
        for ch in line:
            if ch == STATUS or ord(ch) == RESET:
                self.machine.realtime(ch)
            else:
                rest.append(ch)
        return "".join(rest)

    # ---------------------------------------------------------------- time
    def loop_pass(self) -> None:
        if not self._setup_done:
            self.setup()
        self._take_input()
        self.machine.poll()

    def next_wake_tick(self) -> int | None:
        b = self.backend
        if not self._setup_done:
            return b.now()
        m = self.machine
        if (self.rx or (self.lines_in or self.script) and m.can_take_line()):
            return b.now()
        return m.wake_tick()

    def run_until(self, tick: int) -> None:
        b = self.backend
        self.loop_pass()
        while b.now() < tick:
            wake = self.next_wake_tick()
            if wake is None or wake > tick:
                b.app_wait_until(tick)
            elif wake > b.now():
                b.app_wait_until(wake)
            else:
                b.app_wait_until(b.now() + 1)
            self.loop_pass()

    def finished(self) -> bool:
        return (self.input_consumed_at is not None and not self.lines_in and not self.rx
                and self.machine.idle())

    def run_script(self, line: str | bytes, *, firmware_end: bool = False,
                   max_ticks: int | None = None) -> EndReason:
        text = line.decode("utf-8", "replace") if isinstance(line, bytes) else line
        self.load_script(text)
        self.loop_pass()
        b = self.backend
        limit = b.now() + (max_ticks if max_ticks is not None
                           else 3600 * self.profile.ticks_per_s)
        while True:
            if self.finished():
                if firmware_end:
                    b.app_wait_until(max(b.now(), self.input_consumed_at
                                         + self.profile.ticks_per_s))
                    return EndReason.FIRMWARE_END
                return EndReason.IDLE
            if b.now() >= limit:
                return EndReason.MAX_TIME
            wake = self.next_wake_tick()
            if wake is None:
                return EndReason.IDLE  # pragma: no cover - finished() covers this
            target = min(max(wake, b.now() + 1), limit)
            b.app_wait_until(target)
            self.loop_pass()

    def force_stop_all(self) -> None:
        if self.machine is not None:
            self.machine.abort()
        self.lines_in.clear()
        self.rx.clear()
        self._partial.clear()

    # --------------------------------------------------- hosted by the console
    def mode_name(self) -> str:
        return "gcode" if self.machine is None else self.machine.state_name().lower()

    def completions(self) -> list[tuple[str, str]]:
        return COMPLETIONS

    def toolbar_status(self) -> str:
        if self.machine is None:
            return ""
        axes = " ".join(f"{AXES[i]}{s.get_current_position()}"
                        for i, s in enumerate(self.machine.steppers))
        return f"{axes} | queue {len(self.machine.queue)}"

    def exit_code(self) -> int:
        """1 when any line was answered with an error."""
        return 1 if self.machine is not None and self.machine.errors else 0
