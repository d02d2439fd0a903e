"""What every fuzz target shares: a run's result, exceptions as findings, the positions
counted from the pins, and driving a program on virtual time through the program
interface (:mod:`stepperdemo.program`) only.

* :class:`Case` - one generated input: typed text (``kind`` ``"line"``: the program's
  scripted input) or bytes that arrive in timed chunks (``kind`` ``"bytes"``: fed as a
  serial line delivers them, with virtual time in between).
* :class:`FuzzResult` - what a run broke; an exception is named by its type and the
  innermost frame in the project (``fas/`` or ``stepperdemo/``), and whether it came
  through the G-code program (:attr:`FuzzResult.in_gcode`).
* :class:`PinTracker` - the library's position of each stepper against the one
  counted from its step and direction pins, up to exactly what the program declared
  (``set_current_position``, ``force_stop_and_new_position`` ...).
* :func:`drive` / :func:`settle` - feed chunks and run the clock until the program
  rests (``next_wake_tick`` None and no input pending) or the time limit.
"""

from __future__ import annotations

import bisect
import random
import re
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from fas.codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED

from ..program import make_program
from ..scenarios.evaluate import rising_edges

if TYPE_CHECKING:  # pragma: no cover
    from fas.backend import Backend

    from ..program import Program

ROOT = Path(__file__).resolve().parent.parent.parent  # the checkout: fas/ and stepperdemo/
GCODE_DIR = "stepperdemo/gcode/"

MAX_COMMAND_STEPS = 255  # steps of one queue command
LINE = "line"  # a Case typed as the program's scripted input
BYTES = "bytes"  # a Case of raw bytes arriving in timed chunks


@dataclass(frozen=True)
class Case:
    """One fuzz input: ``text`` for a ``line`` case; ``chunks`` of ``(wait_ms, data)``
    for a ``bytes`` case (each chunk is fed, then ``wait_ms`` of virtual time pass)."""

    kind: str
    text: bytes = b""
    chunks: tuple[tuple[int, bytes], ...] = ()
    #: how a ``bytes`` case is sent to the G-code program: "" (all at once per chunk),
    #: "count" (a sender that counts characters against Grbl's 128-byte buffer, at
    #: serial speed) or "blast" (at serial speed without counting)
    sender: str = ""

    @property
    def data(self) -> bytes:
        """Everything the case sends, in order (for reports)."""
        return self.text if self.kind == LINE else b"".join(c for _, c in self.chunks)

    def __str__(self) -> str:
        if self.kind == LINE:
            return repr(self.text)
        head = f"bytes ({self.sender} sender) " if self.sender else "bytes "
        return head + " ".join(f"{c!r}" + (f" +{w}ms" if w else "")
                                   for w, c in self.chunks)


@dataclass
class FuzzResult:
    line: bytes  # what was sent (all chunks of a bytes case)
    arch: str
    program: str = "demo"
    case: Case | None = None
    end: str = ""
    violations: list[str] = field(default_factory=list)
    exception: str | None = None  # "IndexError: ... [stepperdemo/gcode/machine.py:552 f]"
    in_gcode: bool = False  # the exception passed through stepperdemo/gcode/
    lines: int = 1  # input lines of the run (a G-code case: its lines)

    @property
    def ok(self) -> bool:
        return not self.violations

    @property
    def signature(self) -> str:
        """The finding without its input: the exception's type and innermost project
        frame, or the first violation with its numbers blanked (for grouping)."""
        if self.exception is not None:
            head, _, where = self.exception.rpartition(" [")
            return f"{head.split(':', 1)[0]} [{where}"
        return re.sub(r"-?\d+", "N", self.violations[0]) if self.violations else ""

    def describe(self) -> str:
        return f"[{self.program} {self.arch}] {self.case if self.case else repr(self.line)}"

    def record_exception(self, exc: BaseException) -> None:
        """An exception ended the run: the finding (never re-raised)."""
        frames = [f for f in traceback.extract_tb(exc.__traceback__) if _in_project(f.filename)]
        where = ""
        if frames:
            f = frames[-1]
            where = f" [{_relative(f.filename)}:{f.lineno} {f.name}]"
        text = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        self.exception = text.splitlines()[0] + where if text else type(exc).__name__ + where
        self.in_gcode = any(_relative(f.filename).startswith(GCODE_DIR) for f in frames)
        self.violations.append("exception: " + self.exception)
        self.violations.append("".join(traceback.format_exception(exc, limit=-6)).rstrip())


def _in_project(filename: str) -> bool:
    try:
        rel = Path(filename).resolve().relative_to(ROOT)
    except ValueError:
        return False
    return rel.parts[:1] in (("fas",), ("stepperdemo",))


def _relative(filename: str) -> str:
    try:
        return Path(filename).resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return filename


# ------------------------------------------------------------------ noise
NOISE_CHARS = ("µ", "é", "Ω", "→", "🙂", "\u200b", "Ａ", "\u2028", "\x85")
CONTROL_BYTES = (0, 1, 3, 4, 7, 8, 9, 10, 11, 12, 13, 18, 24, 26, 27, 127)


def noise(rng: random.Random, words: list[bytes]) -> bytes:
    """Bytes that are no input language: random bytes (also >= 0x80), control bytes
    between known words, very long tokens, non-ASCII text around known words."""
    kind = rng.random()
    if kind < 0.3:
        return bytes(rng.randrange(256) for _ in range(rng.randint(1, 80)))
    if kind < 0.45:
        word = rng.choice(words)
        return word[:rng.randint(1, len(word))] * rng.randint(40, 300)
    if kind < 0.7:
        ctrl = bytes(rng.choice(CONTROL_BYTES) for _ in range(rng.randint(1, 20)))
        return rng.choice(words) + ctrl + rng.choice(words)
    if kind < 0.85:
        high = bytes(rng.randrange(0x80, 0x100) for _ in range(rng.randint(1, 6)))
        word = rng.choice(words)
        cut = rng.randint(0, len(word))
        return word[:cut] + high + word[cut:]
    text = rng.choice(NOISE_CHARS) * rng.randint(1, 5)
    return (rng.choice(words).decode("latin-1") + text + " "
            + rng.choice(words).decode("latin-1")).encode("utf-8")


# ------------------------------------------------------------ the clock
def settle(program: Program, limit: int, res: FuzzResult) -> bool:
    """Run ``program`` until it rests (only input could wake it, none is pending) or
    the clock reaches ``limit``; True if it rests.  A program that keeps asking for
    the CPU now without the clock moving is a violation (it would hang a console)."""
    b = program.backend
    stalled = 0
    while b.now() < limit:
        wake = program.next_wake_tick()
        if wake is None and not program.input_pending():
            return True
        before = b.now()
        target = before + 1 if wake is None else max(wake, before + 1)
        program.run_until(min(target, limit))
        stalled = stalled + 1 if b.now() - before <= 1 else 0
        if stalled > 100_000:
            res.violations.append(f"busy: next_wake_tick() answers 'now' at tick {b.now()} "
                                  "while nothing happens")
            return False
    return False


def drive(program: Program, chunks: tuple[tuple[int, bytes], ...], limit: int,
          res: FuzzResult) -> bool:
    """Feed each chunk, let its wait pass (never beyond ``limit``), then settle."""
    b = program.backend
    ticks_per_ms = b.profile.ticks_per_ms
    for wait_ms, data in chunks:
        program.feed(data)
        program.run_until(min(b.now() + max(1, wait_ms * ticks_per_ms), limit))
        if b.now() >= limit:
            return False
    return settle(program, limit, res)


# ----------------------------------------------------- positions by the pins
class StepTrack:
    """A step pin's rising edges and the position counted after each (the direction
    pin's level at the edge decides; an edge of it at the tick of a step counts
    before the step, as :func:`stepperdemo.scenarios.evaluate.position_from_pins`)."""

    def __init__(self, backend: Backend, step_pin: int, dir_pin: int,
                 high_counts_up: bool) -> None:
        rec = backend.recorder
        times, levels = rec.pin_edges(step_pin)
        self.rises = rising_edges(times, bytes(levels))
        self.pos: list[int] = []
        if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
            self.pos = list(range(1, len(self.rises) + 1))
            self.up = [True] * len(self.rises)
            return
        dtimes, dlevels = rec.pin_edges(dir_pin)
        up_level = 1 if high_counts_up else 0
        p = 0
        self.up = []
        for t in self.rises:
            k = bisect.bisect_right(dtimes, t) - 1
            up = (dlevels[k] if k >= 0 else 0) == up_level
            p += 1 if up else -1
            self.pos.append(p)
            self.up.append(up)

    def at(self, tick: int) -> int:
        """The position after every step up to and including ``tick``."""
        k = bisect.bisect_right(self.rises, tick)
        return self.pos[k - 1] if k else 0

    @property
    def final(self) -> int:
        return self.pos[-1] if self.pos else 0


class PinTracker:
    """Each stepper of a program: the library's position against its pins.

    The program's declared renumberings (``set_current_position``,
    ``set_position_after_commands_completed``, ``force_stop_and_new_position``) move
    the library's frame against the pins' by exactly what they declare; a force stop
    that keeps the position must find the library where the pins are (within the
    pulse under way, or the command under way on a driver that counts whole
    commands)."""

    def __init__(self, backend: Backend, steppers: list, res: FuzzResult) -> None:
        self.backend = backend
        self.res = res
        self.steppers = [(i, s) for i, s in enumerate(steppers) if s is not None]
        # per stepper: (tick, offset library - pins) from that tick on
        self.offsets: dict[int, list[tuple[int, int]]] = {i: [(0, 0)] for i, _ in self.steppers}
        for i, s in self.steppers:
            self._wrap(i, s)

    def pins_position(self, s) -> int:
        return StepTrack(self.backend, s.get_step_pin(), s.get_direction_pin(),
                         s.direction_pin_high_counts_up()).final

    def offset_at(self, i: int, tick: int) -> int:
        hist = self.offsets[i]
        k = bisect.bisect_right(hist, (tick, float("inf"))) - 1
        return hist[max(k, 0)][1]

    def declare(self, i: int, offset: int) -> None:
        self.offsets[i].append((self.backend.now(), offset))

    def _wrap(self, i: int, s) -> None:
        tracker = self
        orig_set = s.set_current_position
        orig_after = s.set_position_after_commands_completed
        orig_force = s.force_stop_and_new_position

        def set_current_position(new_pos):
            before = s.get_current_position()
            orig_set(new_pos)
            tracker.declare(i, tracker.offsets[i][-1][1] + s.get_current_position() - before)

        def set_position_after(new_pos):
            before = s.get_current_position()
            orig_after(new_pos)
            tracker.declare(i, tracker.offsets[i][-1][1] + s.get_current_position() - before)

        def force_stop_and_new_position(new_pos):
            before = s.get_current_position()
            orig_force(new_pos)
            # the pins once stopped (the edges of a command under way are all made then)
            physical = tracker.pins_position(s)
            drift = (before - physical - tracker.offsets[i][-1][1] + 2**31) % 2**32 - 2**31
            # a pulse under way may count either way; a driver that moves the position by
            # whole commands (RMT, I2S: fas.arch.DriverPool) lags by the command under way
            lag = 1 if s.queue.position_in_command else MAX_COMMAND_STEPS
            # (a new position is a declaration; keeping the position claims the pins')
            if new_pos == before and abs(drift) > lag:
                tracker.res.violations.append(
                    f"stepper {i + 1}: force stop at position {before}, but the pins counted "
                    f"{physical} + declared {tracker.offsets[i][-1][1]}")
            tracker.declare(i, s.get_current_position() - physical)

        s.set_current_position = set_current_position
        s.set_position_after_commands_completed = set_position_after
        s.force_stop_and_new_position = force_stop_and_new_position

    def _wiring_conflict(self, s) -> bool:
        """A step pin that is also another stepper's direction or enable pin makes edges
        that are no steps (the ESP32 test wiring does that)."""
        step = s.get_step_pin()
        return any(o is not s and step in (o.get_direction_pin(), o.get_enable_pin_low_active(),
                                           o.get_enable_pin_high_active())
                   for _, o in self.steppers)

    def check(self) -> None:
        """Every stepper at rest: library position == pins + declared (mod 2^32)."""
        for i, s in self.steppers:
            if s.is_running() or self._wiring_conflict(s):
                continue
            physical = self.pins_position(s)
            offset = self.offsets[i][-1][1]
            pos = s.get_current_position()
            if (pos - physical - offset) & 0xFFFFFFFF:
                self.res.violations.append(f"stepper {i + 1}: position {pos} but the pins "
                                           f"counted {physical} + declared {offset}")


def start(name: str, backend: Backend, res: FuzzResult) -> tuple[Program, PinTracker]:
    """Make program ``name`` on ``backend`` as a script, run its set-up (its steppers
    exist from then on) and watch their pins against the library."""
    program = make_program(name, backend, scripted=True)
    program.run_until(backend.now())
    return program, PinTracker(backend, program.steppers, res)
