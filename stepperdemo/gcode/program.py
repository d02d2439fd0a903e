"""``stepperdemo gcode``: the G-code machine as a console program (``Program``).

The program connects the first ``axes`` steppers of the profile's StepperDemo
wiring (X, Y, Z ... = steppers 1, 2, 3 ...; at most six, at most the profile's
steppers), powers the Grbl machine on (banner) and answers as Grbl 1.1 does.

* Interactive input (the console, a pty or TCP host) arrives as bytes
  (:meth:`GcodeProgram.feed`): Grbl's receive path - real-time bytes act at once,
  the rest goes through the 128-byte ring; a block ends at a line end (LF or CR).
* A scripted run (``stepperdemo gcode FILE``) takes the file a line at a time, each
  when the machine is ready to read the next (as a sender waiting for ``ok``);
  comments are stripped first, as senders do, so a ``?`` or ``!`` in a comment does
  not act.  It ends when every line is answered and the machine is at rest.

:class:`RawGrbl` is the same program driven from Python on virtual time: bytes in,
time on, output out (tests and the fuzzer).
"""

from __future__ import annotations

from collections import deque
from typing import Callable

from fas import Engine
from fas.backend import Backend

from ..demo.build import demo_build
from ..messages import GCODE_OK
from ..program import EndReason, Program
from .machine import GcodeMachine
from .parser import AXES, strip_comments
from .settings import GcodeSettings

DEFAULT_AXES = 3
CRLF = "\r\n"
#: the answer to almost every line, encoded once
_OK_LINE = (GCODE_OK + CRLF).encode("utf-8")

COMPLETIONS = [
    ("G0", "rapid move: G0 X.. Y.."), ("G1", "line at feed F: G1 X.. F.."),
    ("G4", "dwell P seconds"), ("G90", "absolute"), ("G91", "incremental"),
    ("G92", "set position (offset)"), ("M62", "Dout P on, synchronized"),
    ("M63", "Dout P off, synchronized"), ("M64", "Dout P on, at once"),
    ("M65", "Dout P off, at once"), ("M67", "Aout E duty Q%, synchronized"),
    ("M68", "Aout E duty Q%, at once"),
    ("G2", "arc clockwise: G2 X.. Y.. I.. J.. (or R..)"), ("G3", "arc counter-clockwise"),
    ("G20", "inches"), ("G21", "millimetres"), ("G28", "to the stored position"),
    ("G10 L20 P1", "set G54 so that here is X.. Y.."), ("G54", "work coordinates 1"),
    ("G53", "this line in machine coordinates"), ("G43.1", "tool length offset Z.."),
    ("M3", "spindle on at S"), ("M4", "spindle CCW; laser mode: power follows speed"),
    ("M5", "spindle off"), ("M7", "mist coolant"), ("M8", "flood coolant"),
    ("M9", "coolant off"),
    ("M2", "end of program"), ("$$", "settings"),
    ("$J=", "jog: $J=G91 X10 F3000"), ("$X", "unlock after an alarm"),
    ("?", "status"), ("!", "feed hold"), ("~", "resume"),
]
#: control keys the console passes to the machine as real-time bytes
CONTROL_KEYS = {"c-x": b"\x18"}


def axes_for(backend: Backend, axes: int | None) -> int:
    """Axes X Y Z ... on this profile: ``axes`` (default 3), at most the steppers of
    StepperDemo's wiring and six."""
    p = backend.profile
    return max(1, min(axes or DEFAULT_AXES, p.max_steppers, len(demo_build(p).steppers),
                      len(AXES)))


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
        self.axes = axes_for(backend, axes)
        self.steppers: list = [None] * p.max_steppers
        self._settings = settings
        self._setup_lines = list(setup_lines or [])
        self.machine: GcodeMachine | None = None
        self.script: deque[str] = deque()
        self._sending = bytearray()  # the rest of a file's line not yet in the ring
        self.input_consumed_at: int | None = None
        self._setup_done = False

    # ------------------------------------------------------------- output
    def _write(self, line: str) -> None:
        data = _OK_LINE if line == GCODE_OK else (line + CRLF).encode("utf-8")
        self.transcript += data
        if self.output is not None:
            self.output(data)

    # -------------------------------------------------------------- setup
    def setup(self) -> None:
        if self._setup_done:
            return
        self._setup_done = True
        self.engine.init()
        p = self.profile
        for i, cfg in enumerate(demo_build(p).steppers[:self.axes]):
            # as StepperDemo connects them (ESP32 with ESP-IDF 5: the driver it names)
            s = (self.engine.stepper_connect_to_pin(cfg.step, cfg.driver) if p.driver_select
                 else self.engine.stepper_connect_to_pin(cfg.step))
            if s is None:  # the profile has no more step generators for these pins
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
        self.machine.power_on()
        for line in self._setup_lines:  # command-line settings (--set), answered as lines
            self.machine.line(line)

    def host_opened(self) -> None:
        """A host opened the port: a reset, as an Arduino's DTR makes one."""
        self.setup()
        self.machine.power_on()

    # --------------------------------------------------------------- input
    def feed(self, text: str | bytes) -> None:
        """Bytes from the console or a host, arriving now."""
        self.setup()
        data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
        self.machine.receive(data)

    def load_script(self, text: str) -> None:
        self.script = deque(text.splitlines())
        self._sending.clear()
        self.input_consumed_at = None

    def input_pending(self) -> bool:
        """Input the machine would take now (not what a hold or sleep keeps waiting)."""
        m = self.machine
        if m is None:
            return bool(self.script)
        return bool(self.script or self._sending) and m.can_read() or (
            m.rx.pending > 0 and m.can_read())

    def _take_script(self) -> None:
        """The next line of a file, when the machine would read it (comments stripped
        first, as senders do), in pieces that fit Grbl's receive buffer."""
        m = self.machine
        while True:
            if self._sending:
                free = m.rx.free
                if not free or not m.can_read():
                    break
                if len(self._sending) <= free:  # (the common case: a line fits)
                    piece = bytes(self._sending)
                    self._sending.clear()
                else:
                    piece = bytes(self._sending[:free])
                    del self._sending[:free]
                m.receive(piece)
                m.poll()
                continue
            if not self.script or m.pending is not None or not m.can_take_line():
                break  # (a line in execution: can_take_line() is False)
            raw = self.script.popleft()
            if not raw.strip():
                continue  # a blank line of a file: nothing to answer
            data = strip_comments(raw).encode("utf-8", "replace") + b"\n"
            if len(data) <= m.rx.ring_size:  # (the common case: it fits the empty ring -
                m.receive(data)  # can_take_line() - and goes in at once, as above)
                m.poll()
                continue
            self._sending += data
        if (self.scripted and not self.script and not self._sending
                and self.input_consumed_at is None):
            self.input_consumed_at = self.backend.now()

    # ---------------------------------------------------------------- time
    def loop_pass(self) -> None:
        if not self._setup_done:
            self.setup()
        self.machine.poll()
        self._take_script()

    def next_wake_tick(self) -> int | None:
        b = self.backend
        if not self._setup_done:
            return b.now()
        m = self.machine
        if (self._sending and m.can_read() and m.rx.free) or (
                self.script and m.pending is None and m.can_take_line()):
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
        return self.input_consumed_at is not None and self.machine.idle()

    def run_script(self, line: str | bytes, *, firmware_end: bool = False,
                   max_ticks: int | None = None) -> EndReason:
        text = line.decode("utf-8", "replace") if isinstance(line, bytes) else line
        self.load_script(text)
        self.loop_pass()
        b = self.backend
        limit = b.now() + (max_ticks if max_ticks is not None
                           else 3600 * self.profile.ticks_per_s)
        while True:
            if self.input_consumed_at is not None and self.finished():
                if firmware_end:
                    b.app_wait_until(max(b.now(), self.input_consumed_at
                                         + self.profile.ticks_per_s))
                    return EndReason.FIRMWARE_END
                return EndReason.IDLE
            now = b.now()
            if now >= limit:
                return EndReason.MAX_TIME
            wake = self.next_wake_tick()
            if wake is None:
                return EndReason.IDLE  # held (a feed hold, M0) with nothing to wake it
            nxt = now + 1
            target = wake if wake >= nxt else nxt  # (min(max(wake, now + 1), limit))
            b.app_wait_until(limit if limit < target else target)
            self.loop_pass()

    def force_stop_all(self) -> None:
        if self.machine is not None:
            self.machine.abort()

    # --------------------------------------------------- hosted by the console
    def mode_name(self) -> str:
        return "gcode" if self.machine is None else self.machine.state_name().lower()

    def completions(self) -> list[tuple[str, str]]:
        return COMPLETIONS

    def control_keys(self) -> dict[str, bytes]:
        """Keys the console sends to the program as bytes (Ctrl-X: Grbl's soft reset)."""
        return CONTROL_KEYS

    def toolbar_status(self) -> str:
        if self.machine is None:
            return ""
        axes = " ".join(f"{AXES[i]}{s.get_current_position()}"
                        for i, s in enumerate(self.machine.steppers))
        return f"{axes} | queue {len(self.machine.blocks)}"

    def path_units(self) -> dict[int, float]:
        """Steps per unit of each axis by its stepper number (M1 = X ...): ``--plot``
        shows the feed along the path with it."""
        if self.machine is None:
            return {}
        st = self.machine.settings
        return {i + 1: st.steps_per_unit[i] for i in range(self.machine.axes)}

    def exit_code(self) -> int:
        """1 when any line was answered with an error."""
        return 1 if self.machine is not None and self.machine.errors else 0


class RawGrbl:
    """The G-code program as a Grbl controller on virtual time, driven from Python:
    :meth:`send` bytes as a host would, :meth:`advance` the clock, :meth:`take`
    what it answered.  The fuzzer's and the tests' entry point::

        g = RawGrbl("atmega2560")
        g.send(b"G1 X100 F6000\\n?")
        g.advance(0.5)
        out = g.take()          # b"...ok\\r\\n<Run|MPos:...>\\r\\n"
    """

    def __init__(self, arch: str = "atmega328p", axes: int | None = None, *,
                 record: bool = False, settings: GcodeSettings | None = None) -> None:
        from fas.sim import SimBackend

        self.backend = SimBackend(arch, record=record)
        self._out = bytearray()
        self.program = GcodeProgram(self.backend, scripted=False, output=self._out.extend,
                                    axes=axes, settings=settings)
        self.program.setup()
        self.machine: GcodeMachine = self.program.machine  # type: ignore[assignment]

    @property
    def ticks_per_s(self) -> int:
        return self.backend.profile.ticks_per_s

    def send(self, data: bytes) -> None:
        """Bytes from the host, arriving at the present tick."""
        self.program.feed(data)
        self.program.loop_pass()

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass."""
        self.program.run_until(self.backend.now() + int(seconds * self.ticks_per_s))

    def advance_ticks(self, ticks: int) -> None:
        self.program.run_until(self.backend.now() + ticks)

    def settle(self, max_seconds: float = 600.0) -> bool:
        """Run until the machine is at rest with nothing left to do (False: not within
        ``max_seconds``, e.g. held)."""
        limit = self.backend.now() + int(max_seconds * self.ticks_per_s)
        while not self.machine.idle():
            if self.backend.now() >= limit:
                return False
            wake = self.program.next_wake_tick()
            if wake is None:
                return False
            self.program.run_until(min(max(wake, self.backend.now() + 1), limit))
        return True

    def take(self) -> bytes:
        """What the controller printed since the last call."""
        data = bytes(self._out)
        self._out.clear()
        return data

    def open(self) -> None:
        """A host opens the port (a reset)."""
        self.program.host_opened()
