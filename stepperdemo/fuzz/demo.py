"""Fuzzing StepperDemo: random input lines and the invariants every run must keep.

:func:`grammar_line` makes StepperDemo lines from the command language (the normal,
test and config modes, extreme and malformed numbers, waits, mode switches);
:func:`gmode_line` enters the ``g`` mode and sends G-code lines
(:func:`stepperdemo.fuzz.gcode.gcode_line`, ``?`` among them), then mostly leaves it;
:func:`raw_line` makes noise (random bytes, control characters, long tokens,
non-ASCII).  :func:`check_line` runs one line on virtual time and returns the violated
invariants:

* the run ends (input consumed and all at rest, or ``max_time`` reached) without an
  exception;
* the position each stepper reports equals the position counted from its step and
  direction pins, up to exactly what ``@``, ``X`` (or a new position) declared;
* no step period is shorter than the profile allows; no step while the driver is
  disabled under auto enable; a configured direction-change delay is kept, and the
  direction never changes during a pulse; no queue holds more entries than its depth;
* every rejected command printed exactly one error line, every accepted one none
  beyond its own ``ERROR`` result;
* the session goes on: after the input (and a console Ctrl-C if it still ran) the
  mode it was left in is left with its own exit (``x``; ``x`` alone on a line in the
  ``g`` mode), and ``?`` prints the stepper table with every stepper at the library's
  position.
"""

from __future__ import annotations

import bisect
import random
import re
from itertools import pairwise

from fas.codes import PIN_UNDEFINED
from fas.sim import SimBackend

from ..demo.app import StepperDemo
from ..demo.build import demo_build
from ..demo.command_table import CommandTable, Mode
from ..gcode.demo_mode import EXIT_LINE
from ..scenarios.evaluate import position_from_pins, rising_edges
from .common import BYTES, LINE, MAX_COMMAND_STEPS, Case, FuzzResult
from .gcode import (
    CTRL_X,
    GRBL_REALTIME,
    REALTIME,
    SCENES,
    Sender,
    check_output,
    gcode_lines,
    grbl_stream,
    stream,
)

PROGRAM = "demo"

NUMBERS = [0, 1, -1, 2, 7, 40, 100, 255, 256, 999, 1000, 4095, 4096, 32767, 32768, 65535,
           65536, 100000, 1000000, 2147483647, -2147483648, 2147483648, 99999999999,
           -99999999999]
NORMAL_NUMERIC = "VHhAaJjPR@EDw"
NORMAL_PLAIN = "NFOSXIW+-fbKUuQ?tcre"
TEST_CMDS = ["R", "I", "W", "x", "Q", "?"] + [f"{i:02d}" for i in range(0, 15)]
CONFIG_FORMS = ["x", "?", "dc", "d{p}", "d{p},0", "d{p},1,500", "d{q},1", "d{p},1,1", "d255",
                "d{p},1,5000", "d{p},", "d,", "d{p},1,2,3", "d{u},0,40"]


def _number(rng: random.Random, fast: bool) -> str:
    r = rng.random()
    if r < 0.5:
        n = rng.choice(NUMBERS)
    elif r < 0.8:
        n = rng.randint(-5000, 50000)
    else:
        n = rng.randint(-(2**40), 2**40)
    if fast:
        n = abs(n) % 400 if rng.random() < 0.7 else n
    text = str(n)
    r = rng.random()
    if r < 0.05:
        text = "+" + text.lstrip("-")
    elif r < 0.10:
        text = text + rng.choice(["x", ".5", ",", "e3", " "])
    elif r < 0.12:
        text = ""
    return text


def _config_command(rng: random.Random, profile) -> str:
    """A config-mode command; direction pins are the profile's own (a pin that is also
    another stepper's step pin would make steps by itself - a wiring error, not a bug)."""
    dirs = sorted({c.direction for c in demo_build(profile).steppers})
    used = {c.step for c in demo_build(profile).steppers} | {
        c.enable_low_active for c in demo_build(profile).steppers}
    unused = next(p for p in range(2, 60) if p not in used and p not in dirs)
    return rng.choice(CONFIG_FORMS).format(p=rng.choice(dirs), q=rng.choice(dirs), u=unused)


def grammar_line(rng: random.Random, length: int = 12, arch: str = "atmega328p") -> str:
    """A plausible StepperDemo line: mostly valid commands, some malformed ones."""
    from fas.arch import get_profile
    profile = get_profile(arch)
    tokens: list[str] = []
    mode = "normal"
    for _ in range(rng.randint(1, length)):
        if mode == "normal":
            r = rng.random()
            if r < 0.1:
                tokens.append(f"M{rng.choice([1, 2, 2, 0, 3, 9])}")
            elif r < 0.55:
                c = rng.choice(NORMAL_NUMERIC)
                num = _number(rng, fast=c in "w")
                if c == "w":
                    num = str(rng.choice([0, 1, 5, 20, 50, 150, 400]))
                if c in "VA" and rng.random() < 0.6:
                    num = str(rng.choice([40, 60, 100, 250, 1000] if c == "V"
                                         else [100, 1000, 10000, 100000, 1000000]))
                if c in "RP" and rng.random() < 0.6:
                    num = str(rng.randint(-3000, 3000))
                tokens.append(c + num)
            elif r < 0.9:
                c = rng.choice(NORMAL_PLAIN)
                tokens.append(c)
                if c == "t":
                    mode = "test"
                elif c == "c":
                    mode = "config"
            else:
                tokens.append(rng.choice(["Zzz", "R12x", "V-", "M1,2", "A1000000000000",
                                          "a", "ww", "W1", "T", "?x"]))
        elif mode == "test":
            c = rng.choice(TEST_CMDS + ["M1", "M2", "w200", "w500"])
            tokens.append(c)
            if c == "x":
                mode = "normal"
        else:
            c = rng.choice(["M1", "M2", "M3", "config"])
            if c == "config":
                c = _config_command(rng, profile)
            tokens.append(c)
            if c == "x":
                mode = "normal"
    if mode == "test":
        tokens.append("x")
    sep = rng.choice([" ", " ", " ", "\n", "\r", "\r\n", "  "])
    return sep.join(tokens)


def raw_line(rng: random.Random) -> bytes:
    """Noise: random bytes, control characters, very long tokens, non-ASCII."""
    kind = rng.random()
    if kind < 0.3:
        return bytes(rng.randrange(256) for _ in range(rng.randint(1, 80)))
    if kind < 0.5:
        return rng.choice([b"A", b"V", b"R", b"M", b"w"]) * rng.randint(250, 700)
    if kind < 0.7:
        ctrl = bytes([rng.choice([0, 1, 3, 4, 7, 8, 9, 11, 12, 13, 10, 27, 127])
                      for _ in range(rng.randint(1, 20))])
        return b"M1 A1000 V100 " + ctrl + b" R100 W"
    text = rng.choice(["µ", "é", "Ω", "→", "🙂", "\u200b", "Ａ"]) * rng.randint(1, 5)
    return ("M1 A1000 V100 R1" + text + " R20 " + text + " W").encode("utf-8")


def _normal_tokens(rng: random.Random, most: int) -> list[str]:
    """A few normal-mode commands without a mode switch (around a ``g`` mode visit)."""
    out = []
    for _ in range(rng.randint(0, most)):
        c = rng.choice(NORMAL_NUMERIC.replace("w", "") + "MNFOSXW+-U")
        if c == "M":
            out.append(f"M{rng.choice([1, 2, 3])}")
        elif c in NORMAL_NUMERIC:
            num = _number(rng, fast=False)
            if c in "VA" and rng.random() < 0.7:
                num = str(rng.choice([40, 100, 250, 1000] if c == "V" else [1000, 10000, 100000]))
            if c in "RP" and rng.random() < 0.7:
                num = str(rng.randint(-500, 500))
            out.append(c + num)
        else:
            out.append(c)
    return out


def gmode_line(rng: random.Random, arch: str = "atmega328p") -> str:
    """A visit to the ``g`` mode: normal commands, ``g``, G-code lines (Grbl's
    real-time bytes and bytes >= 0x80 among them, as latin-1 characters), mostly
    ``x`` alone to leave, normal commands."""
    eol = rng.choice(["\n", "\n", "\r", "\r\n"])
    lines = gcode_lines(rng, 6)
    if rng.random() < 0.3:
        lines[1:1] = [item.format(m="G1 X20 Y-10 F3000") for item in rng.choice(SCENES)
                      if not item.startswith("RT:")]
    for _ in range(rng.choice([0, 0, 1, 2, 3])):
        k = rng.randrange(len(lines))
        at = rng.randint(0, len(lines[k]))
        extra = rng.choice([*REALTIME, bytes([rng.randrange(0x80, 0x100)])]).decode("latin-1")
        lines[k] = lines[k][:at] + extra + lines[k][at:]
    text = " ".join([*_normal_tokens(rng, 4), "g"]) + eol + eol.join(lines) + eol
    if rng.random() < 0.85:
        text += "x" + eol + " ".join(_normal_tokens(rng, 3))
    return text


def gmode_stream(rng: random.Random) -> Case:
    """A sender's stream into the ``g`` mode (StepperDemo on a serial line, as
    ``device --pty --console`` then ``g``): the G-code target's streams, without the
    line that leaves the mode (``x`` alone)."""
    case = grbl_stream(rng)
    chunks = []
    carry = b""  # what the chunks so far sent after their last line end or reset
    for wait, data in case.chunks:
        *pieces, rest = re.split(rb"[\r\n\x18]", carry + data)
        if any(_grbl_text(p) == EXIT_LINE for p in pieces):
            continue  # a line that leaves the g mode (a reset may have made it one)
        chunks.append((wait, data))
        carry = rest
    return Case(BYTES, chunks=tuple(chunks) or ((0, b"$$\n"),), sender=case.sender)


def _grbl_text(piece: bytes) -> str:
    """A line as Grbl's receive path hands it over: no real-time bytes, nothing >= 0x80,
    no spaces, control characters, '/' or comments, upper case."""
    kept = bytes(b for b in piece if 0x20 < b < 0x7F and b not in GRBL_REALTIME
                 and b != ord("/"))
    kept = re.sub(rb"\([^)]*\)?", b"", kept.split(b";")[0])
    return kept.decode("ascii").upper()


def demo_case(rng: random.Random, arch: str = "atmega328p") -> Case:
    """A StepperDemo input: noise, a ``g`` mode visit, a sender's stream into the ``g``
    mode, or a grammar line."""
    r = rng.random()
    if r < 0.2:
        return Case(LINE, raw_line(rng))
    if r < 0.35:
        return Case(LINE, gmode_line(rng, arch).encode("latin-1"))
    if r < 0.45:
        return gmode_stream(rng)
    return Case(LINE, grammar_line(rng, arch=arch).encode())


def check_demo(case: Case, arch: str = "atmega328p", max_time_s: float = 20.0) -> FuzzResult:
    if case.kind == BYTES:
        return check_gmode_stream(case, arch, max_time_s)
    res = check_line(case.text, arch, max_time_s)
    res.case = case
    return res


def check_gmode_stream(case: Case, arch: str = "atmega328p",
                       max_time_s: float = 20.0) -> FuzzResult:
    """StepperDemo on a serial line: ``g``, then a sender's stream with the G-code
    target's checks (:func:`stepperdemo.fuzz.gcode.stream`), then ``x`` back to the
    normal mode, whose ``?`` lists every stepper at the library's position; the
    motion invariants of :func:`check_line` over the whole run."""
    res = FuzzResult(case.data, arch, PROGRAM, case)
    backend = SimBackend(arch, record=True)
    tps = backend.profile.ticks_per_s
    try:
        app = StepperDemo(backend, scripted=False, pin_config=0)
        tracker = _Tracker(app, backend)
        app.setup()
        tracker.attach()
        app.feed(b"g\n")
        app.run_until(backend.now() + tps // 20)
        if app.mode != Mode.GCODE:
            res.violations.append(f"'g' did not enter the g mode: {bytes(app.transcript)[-200:]!r}")
            return res
        limit = backend.now() + int(max_time_s * tps)
        sender = Sender(app, res, counting=case.sender == "count", limit=limit,
                        machine=app.gcode.machine)
        stream(sender, case)
        check_output(res, _grbl_part(bytes(app.transcript)))
        if app.mode != Mode.GCODE:
            res.violations.append("the g mode was left during the stream (no 'x' line sent)")
            return res
        # a line the sender left open (its end lost to a full buffer) ends before the x
        rest = Sender(app, res, counting=True, limit=backend.now() + int(max_time_s * tps),
                      machine=app.gcode.machine)
        rest.checking = False
        app.feed(b"\n")
        rest.come_to_rest(rest.limit)
        rest.detach()
        app.feed(b"x\n")
        end = backend.now() + 2 * tps
        while app.mode == Mode.GCODE and backend.now() < end:
            app.run_until(backend.now() + tps // 100)
        if app.mode != Mode.NORMAL:
            res.violations.append(f"probe: 'x' did not leave the g mode "
                                  f"(state {sender.machine.state_name()})")
            return res
        mark = len(app.transcript)
        app.feed(b"?\n")
        app.run_until(backend.now() + tps // 10)
        new = bytes(app.transcript[mark:])
        said = {int(n): int(p) for n, p in _TABLE_ROW.findall(new)}
        want = {i + 1: s.get_current_position() for i, s in enumerate(app.steppers)
                if s is not None}
        if said != want:
            res.violations.append(f"probe: '?' listed {said}, the library has {want}: "
                                  f"{new[-300:]!r}")
    except Exception as exc:  # the whole point: nothing may raise
        res.record_exception(exc)
        return res
    res.violations += tracker.drifts
    _check_motion(app, backend, tracker, res)
    return res


def _grbl_part(transcript: bytes) -> bytes:
    """What the g mode printed: from its banner on (StepperDemo's texts before it)."""
    at = transcript.find(b"Grbl ")
    return transcript[transcript.rfind(b"\n", 0, at) + 1:] if at >= 0 else b""


class _Tracker:
    """Follows the renumberings (@, X) and auto-enable settings of each stepper."""

    def __init__(self, app: StepperDemo, backend: SimBackend) -> None:
        self.app = app
        self.backend = backend
        self.offset: dict[int, int] = {}
        self.auto_enable: dict[int, list[tuple[int, bool]]] = {}
        self.dir_delay: dict[int, list[tuple[int, int, int]]] = {}
        self.detached: dict[int, bool] = {}
        self.since = 0  # the last restart of the chip (ESP32 `r`): pins count from here
        self.drifts: list[str] = []  # force stops that kept a position the pins deny

    def same_frame(self, i: int) -> bool:
        """Do stepper i's pins count in the library's frame (see _check_motion)?"""
        return not (_dir_frame_changed(self.app, self, i) or _step_pin_shared(self.app, i))

    def restarted(self) -> None:
        """The chip rebooted: new steppers, a new frame of reference for the pins."""
        self.since = self.backend.now()
        self.offset.clear()
        self.auto_enable.clear()
        self.dir_delay.clear()
        self.detached.clear()
        self.attach()

    def attach(self) -> None:
        app = self.app
        for i, s in enumerate(app.steppers):
            if s is None:
                continue
            self.offset[i] = 0
            self.auto_enable[i] = [(0, s.get_auto_enable())]
            self.dir_delay[i] = [(0, s.get_direction_pin(), s.get_dir_change_delay_ticks())]
            self.detached[i] = False
            self._wrap(i, s)

    def _wrap(self, i: int, s) -> None:
        tracker = self
        backend = self.backend
        orig_set = s.set_current_position
        orig_force = s.force_stop_and_new_position
        orig_after = s.set_position_after_commands_completed
        orig_auto = s.set_auto_enable
        orig_dir = s.set_direction_pin
        orig_detach = s.detach_from_pin

        def set_current_position(new_pos):
            before = s.get_current_position()
            orig_set(new_pos)
            tracker.offset[i] += s.get_current_position() - before

        def set_position_after(new_pos):
            before = s.get_current_position()
            orig_after(new_pos)
            tracker.offset[i] += s.get_current_position() - before

        def force_stop_and_new_position(new_pos):
            before = s.get_current_position()
            orig_force(new_pos)
            pins = tracker.app.demo_steppers[i]
            physical = position_from_pins(backend, pins.step, s.get_direction_pin(),
                                          s.direction_pin_high_counts_up(), tracker.since)
            if new_pos == before and tracker.same_frame(i):  # it claims to stop where it is
                drift = (before - physical - tracker.offset[i] + 2**31) % 2**32 - 2**31
                lag = 1 if s.queue.position_in_command else MAX_COMMAND_STEPS
                if abs(drift) > lag:
                    tracker.drifts.append(
                        f"M{i + 1}: force stop keeping position {before}, but the pins "
                        f"counted {physical} + declared {tracker.offset[i]}")
            tracker.offset[i] = s.get_current_position() - physical

        def set_auto_enable(value):
            orig_auto(value)
            tracker.auto_enable[i].append((backend.now(), bool(value)))

        def set_direction_pin(pin, high_counts_up=True, delay_us=0):
            orig_dir(pin, high_counts_up, delay_us)
            tracker.dir_delay[i].append((backend.now(), pin, s.get_dir_change_delay_ticks()))

        def detach_from_pin():
            tracker.detached[i] = True
            orig_detach()

        s.detach_from_pin = detach_from_pin
        s.set_current_position = set_current_position
        s.set_position_after_commands_completed = set_position_after
        s.force_stop_and_new_position = force_stop_and_new_position
        s.set_auto_enable = set_auto_enable
        s.set_direction_pin = set_direction_pin


def check_line(line: bytes | str, arch: str = "atmega328p", max_time_s: float = 20.0,
               probe_session: bool = True) -> FuzzResult:
    data = line.encode("utf-8") if isinstance(line, str) else bytes(line)
    res = FuzzResult(data, arch, PROGRAM, Case(LINE, data),
                     lines=len(re.split(rb"\r\n|\r|\n", data.rstrip(b"\r\n"))))
    backend = SimBackend(arch, record=True)
    max_ticks = int(max_time_s * backend.profile.ticks_per_s)
    try:
        # `w<ms>` in test mode is an extension (the firmware answers "Unknown command"):
        # switched on here so that test sequences get time to run between commands
        app = StepperDemo(backend, scripted=True, test_mode_wait=True)
        tracker = _Tracker(app, backend)
        app.setup()
        tracker.attach()
        orig_restart = app.restart

        def restart() -> None:
            orig_restart()
            tracker.restarted()

        app.restart = restart
        errors_seen: list[tuple[bytes, bool, int]] = []
        app.command_table = _CountingTable(app.command_table, app.transcript, errors_seen)
        reason = app.run_script(data, max_ticks=max_ticks)
        res.end = reason.name.lower()
        if reason.name != "IDLE":
            app.force_stop_all()  # the console's Ctrl-C
        if probe_session:
            _probe(app, max_ticks, res)
    except Exception as exc:  # the whole point: nothing may raise
        res.record_exception(exc)
        return res
    # an unknown command prints "Unknown command: <cmd>" once (after dispatch returns)
    unknown = app.transcript.count(b"Unknown command: ")
    if unknown != sum(1 for _, ok, _ in errors_seen if not ok):
        res.violations.append(f"{unknown} 'Unknown command' lines for "
                              f"{sum(1 for _, ok, _ in errors_seen if not ok)} rejected commands")
    for cmd, ok, n in errors_seen:
        if ok and n > 1:
            res.violations.append(f"command {cmd!r} printed {n} error lines")
    res.violations += tracker.drifts
    _check_motion(app, backend, tracker, res)
    return res


_TABLE_ROW = re.compile(rb"M(\d+): @(-?\d+)")
#: how each mode is left for the normal mode
_LEAVE = {Mode.TEST: b"x", Mode.CONFIG: b"x", Mode.GCODE: b"\nx\n"}


def _probe(app: StepperDemo, max_ticks: int, res: FuzzResult) -> None:
    """The session goes on: back to the normal mode, ``?`` lists every stepper at the
    library's position."""
    leave = _LEAVE.get(app.mode)
    if leave is not None:
        end = app.run_script(leave, max_ticks=max_ticks)
        if app.mode == Mode.GCODE:  # held or asleep: a sender's resume, then its reset
            for out in (b"~" + _LEAVE[Mode.GCODE], CTRL_X + _LEAVE[Mode.GCODE]):
                leave = out
                end = app.run_script(leave, max_ticks=max_ticks)
                if app.mode != Mode.GCODE:
                    break
        if app.mode != Mode.NORMAL:
            res.violations.append(f"probe: {leave!r} did not leave the {app.mode_name()} mode "
                                  f"(ended {end.name.lower()})")
            return
    mark = len(app.transcript)
    end = app.run_script(b"?", max_ticks=max_ticks)
    new = bytes(app.transcript[mark:])
    said = {int(n): int(p) for n, p in _TABLE_ROW.findall(new)}
    want = {i + 1: s.get_current_position() for i, s in enumerate(app.steppers)
            if s is not None}
    if end.name != "IDLE" or said != want:
        res.violations.append(f"probe: '?' listed {said}, the library has {want} "
                              f"(ended {end.name.lower()}): {new[-300:]!r}")


_ERROR_MARKS = (b"ERROR", b"Unknown command")


class _CountingTable(CommandTable):
    """The program's command table, noting per command whether it was accepted and how
    many error texts it printed: ``(command, accepted, errors)``."""

    def __init__(self, table: CommandTable, transcript: bytearray,
                 seen: list[tuple[bytes, bool, int]]) -> None:
        self.handlers, self.help = table.handlers, table.help  # the same commands
        self.transcript = transcript
        self.seen = seen

    def dispatch(self, app: StepperDemo, cmd: bytes) -> bool:
        mark = len(self.transcript)
        ok = super().dispatch(app, cmd)
        self.seen.append((cmd, ok, _errors_since(self.transcript, mark)))
        return ok


def _errors_since(transcript: bytearray, mark: int) -> int:
    """Error texts printed after ``transcript[:mark]`` (a text may have begun before
    the mark; counting the tail keeps a long run's checks cheap)."""
    start = max(0, mark - max(len(m) for m in _ERROR_MARKS) + 1)
    tail = transcript[start:]
    old = tail[:mark - start]
    return sum(tail.count(m) - old.count(m) for m in _ERROR_MARKS)


def _check_motion(app: StepperDemo, backend: SimBackend, tracker: _Tracker,
                  res: FuzzResult) -> None:
    prof = app.profile
    rec = backend.recorder
    n_steppers = sum(1 for s in app.steppers if s is not None)
    min_period = prof.max_speed_ticks(n_steppers)
    for i, s in enumerate(app.steppers):
        if s is None:
            continue
        pins = app.demo_steppers[i]
        name = f"M{i + 1}"
        if _step_pin_shared(app, i):
            continue  # the wiring drives this step pin from another stepper, too
        # position: library == pins + declared renumberings
        physical = position_from_pins(backend, pins.step, s.get_direction_pin(),
                                      s.direction_pin_high_counts_up(), tracker.since)
        pos = s.get_current_position()
        # a changed direction pin, or pins driven directly (T), count in another frame
        if (not _dir_frame_changed(app, tracker, i) and not s.is_running()
                and (pos - physical - tracker.offset[i]) & 0xFFFFFFFF):
            res.violations.append(f"{name}: position {pos} but pins counted {physical} "
                                  f"+ declared {tracker.offset[i]}")
        if s.queue.max_fill > prof.queue_len:
            res.violations.append(f"{name}: queue held {s.queue.max_fill} > {prof.queue_len}")
        times, levels = rec.pin_edges(pins.step)
        k0 = bisect.bisect_left(times, tracker.since)
        if k0:
            times, levels = times[k0:], levels[k0:]
        lv_bytes = bytes(levels)
        rises = rising_edges(times, lv_bytes)
        falls = (times[1::2] if len(rises) * 2 == len(times) and rises == times[0::2]
                 else [t for t, lv in zip(times, lv_bytes, strict=True) if not lv])
        if not s.queue.channel.detached:
            for a, b in pairwise(rises):
                if b - a < min_period:
                    res.violations.append(f"{name}: step period {b - a} ticks < {min_period}")
                    break
        # no step while disabled under auto enable
        en_pin = pins.enable_low_active
        if en_pin != PIN_UNDEFINED and rises and not tracker.detached[i]:
            etimes, elevels = rec.pin_edges(en_pin)
            history = tracker.auto_enable[i]
            history_times = [x for x, _ in history]
            for t in rises:
                k = bisect.bisect_right(etimes, t) - 1
                enabled = k >= 0 and elevels[k] == 0
                h = bisect.bisect_right(history_times, t) - 1
                auto = history[h][1]
                if auto and not enabled and not _shared_enable(app, en_pin):
                    res.violations.append(f"{name}: step at tick {t} with the driver disabled")
                    break
        # direction: never during a pulse; configured delay before the next step
        dir_changes = tracker.dir_delay[i]
        dpin = pins.direction
        if dpin != PIN_UNDEFINED and not _dir_frame_changed(app, tracker, i):
            dtimes, _ = rec.pin_edges(dpin)
            change_times = [x for x, _, _ in dir_changes]
            for t in dtimes[bisect.bisect_right(dtimes, tracker.since):]:
                k = bisect.bisect_right(rises, t) - 1
                if k >= 0 and k < len(falls) and falls[k] > t and rises[k] < t:
                    res.violations.append(f"{name}: direction changed during a pulse at {t}")
                    break
                h = bisect.bisect_right(change_times, t) - 1
                _, cfg_pin, delay = dir_changes[h]
                j = bisect.bisect_left(rises, t)
                if delay and cfg_pin == dpin and j < len(rises) and rises[j] - t < delay - 100:
                    res.violations.append(f"{name}: step {rises[j] - t} ticks after a "
                                          f"direction change (delay {delay})")
                    break


def _dir_frame_changed(app: StepperDemo, tracker: _Tracker, i: int) -> bool:
    """Did anything but stepper i's own queue drive its direction pin?  Its own new
    direction configuration, another stepper configured onto that pin, or a direct
    drive test (T) of a stepper sharing it: then the pins count in another frame."""
    pin = app.demo_steppers[i].direction
    if len(tracker.dir_delay[i]) > 1 or tracker.detached[i]:
        return True
    for j, changes in tracker.dir_delay.items():
        if j == i:
            continue
        if any(p == pin for _, p, _ in changes[1:]):
            return True
        if tracker.detached[j] and app.demo_steppers[j].direction == pin:
            return True
    return False


def _shared_enable(app: StepperDemo, pin: int) -> bool:
    return sum(1 for c in app.demo_steppers if c.enable_low_active == pin) > 1


def _step_pin_shared(app: StepperDemo, i: int) -> bool:
    """Is stepper i's step pin also another stepper's enable or direction pin?  The
    ESP32 test hardware's 14-stepper wiring (StepperPins_esp32.h) does that: those
    edges are not steps, so pins and position cannot agree."""
    step = app.demo_steppers[i].step
    return any(j != i and step in (c.enable_low_active, c.direction)
               for j, c in enumerate(app.demo_steppers))


def fuzz(lines: int, seed: int, *, arch_choice: tuple[str, ...] = ("atmega328p",),
         raw_share: float = 0.2, max_time_s: float = 20.0):
    """Yield a FuzzResult per generated line (deterministic for a seed)."""
    rng = random.Random(seed)
    for _ in range(lines):
        arch = rng.choice(arch_choice)
        line = (raw_line(rng) if rng.random() < raw_share
                else grammar_line(rng, arch=arch).encode())
        yield check_line(line, arch, max_time_s)
