"""Reading StepperDemo's console output: status lines, the stepper table, its answers.

A board running the original StepperDemo tells a host everything through its text
console.  This module turns that text back into facts:

* :func:`parse_status` / :func:`parse_table` read a status line (``M1: @120 => 3200
  QueueEnd=160 v=100us/1600ticks ACC  M2: ...``, one entry per running stepper) and a
  line of the stepper table (``>> M1: @3200 acceleration  [steps/s^2]=1000 speed
  [us/step]=100``);
* :class:`BoardState` follows the board from its answers, line by line: the input
  mode (``Enter test mode`` ...), the selected stepper, ``I``/``Q`` toggles, a
  ``W`` spinning, a ``w<ms>`` pause, a running test and its result, which steppers
  run, a restart (the start banner);
* :class:`StatusTrace` keeps the status lines as samples per stepper (bounded), for
  ``/plot``, ``/report`` and the twin check.

The texts come from :mod:`stepperdemo.messages`, the same table the simulated
firmware prints from, so parser and firmware cannot drift apart.
"""

from __future__ import annotations

import re
from collections import deque
from dataclasses import dataclass, field

from .. import messages as msg

#: ``v=`` of a stepper whose period is not defined yet (0x0fffffff us)
UNDEFINED_PERIOD_US = 0x0FFFFFFF
DEFAULT_TRACE_SAMPLES = 100_000  # per stepper: ~2.8 hours of status lines
STOP_STATE = "stop"  # the sample a stepper table adds when a stepper stands again


def _text(piece: str) -> str:
    """A message-table text as it appears in a received line (no line end)."""
    return piece.rstrip("\r\n")


_STATE_RE = "|".join(re.escape(v.strip()) for v in msg.RAMP_STATE_TEXT.values())
_POS = r"@(?P<pos>-?\d+)(?: \[-?\d+\])*"  # ESP32: pulse counter readings follow
_RUNNING = (
    r"(?:(?P<nonstop>" + re.escape(msg.STATUS_NONSTOP) + r")|"
    + re.escape(msg.STATUS_TARGET) + r"(?P<target>-?\d+))"
    + re.escape(msg.STATUS_QUEUE_END) + r"(?P<qend>-?\d+)"
    + re.escape(msg.STATUS_V)
    + r"(?:(?P<us>\d+)" + re.escape(msg.STATUS_US) + r"(?P<ticks>\d+)"
    + re.escape(msg.STATUS_TICKS) + r"|(?P<mhz>-?\d+)" + re.escape(msg.STATUS_MSTEPS) + r")"
    + r"(?: (?P<state>" + _STATE_RE + r") *|" + re.escape(msg.STATUS_MANUAL)
    + r" *|(?P<code>\d+) *)"
)
_ENTRY = re.compile(r"M(?P<n>\d+): " + _POS + _RUNNING)
_STATUS_LINE = re.compile(r"^M\d+: @")
_TABLE_LINE = re.compile(
    r"^(?P<sel>" + re.escape(msg.TABLE_SELECTED) + "|" + re.escape(msg.TABLE_OTHER)
    + r")M(?P<n>\d+): " + _POS
    + r"(?:" + _RUNNING + r"|" + re.escape(msg.ACCELERATION_STATUS) + r"(?P<acc>\d+)"
    + r"(?:" + re.escape(msg.SPEED_STATUS_TIME) + r"(?P<speed_us>\d+)|"
    + re.escape(msg.SPEED_STATUS_FREQ) + r"(?P<speed_mhz>\d+))"
    + r"|\s*$)")
_WAIT_MS = re.compile(r"^-?\d+" + re.escape(_text(msg.WAIT_MS)) + "$")
_BANNER_PREFIX = msg.BANNER_VERSION.split(msg.VERSION)[0]  # "StepperDemo Version "
# what StepperDemo answers to its commands: a line that is one of these (or begins
# with one that takes a value) is the firmware's; the usage text is not among them
_ANSWER_TEXTS = frozenset(_text(t).rstrip() for t in (
    msg.TOGGLE_MOTOR_INFO, msg.TOGGLE_USAGE_INFO, msg.ENTER_TEST_MODE,
    msg.ENTER_CONFIG_MODE, msg.EXIT_TO_MAIN_MENU, msg.OUTPUT_DRIVER_ON,
    msg.OUTPUT_DRIVER_OFF, msg.OUTPUT_DRIVER_AUTO, msg.STOP, msg.KEEP_RUNNING,
    msg.RUN_FORWARD, msg.RUN_BACKWARD, msg.IMMEDIATE_STOP, msg.UPDATE_SPEED_ACCELERATION,
    msg.BLOCKING_WAIT, msg.STOPPED, msg.TEST_DIRECT_DRIVE, msg.STEPPED_FORWARD,
    msg.STEPPED_BACKWARD, msg.WAIT_COMPLETE, msg.RUN_TESTS, msg.FAILED_STATUS,
    msg.PASS_STATUS, msg.TEST_COMPLETED, msg.ERROR_INVALID_VALUE, msg.ENTER_GCODE_MODE,
    *msg.MOVE_RESULT.values()))
_ANSWER_PREFIXES = tuple(_text(t) for t in (
    msg.SELECT_STEPPER, msg.SET_ACCELERATION_TO, msg.SET_SPEED_TO_US, msg.SET_SPEED_TO_HZ,
    msg.SET_SPEED_TO_MILLI_HZ, msg.MOVE_STEPS, msg.MOVE_TO_POSITION, msg.RETURN_CODE,
    msg.SET_POSITION, msg.SET_ENABLE_TIME, msg.SET_DISABLE_TIME, msg.LINEAR_ACCELERATION,
    msg.JUMP_START, msg.UNKNOWN_COMMAND, msg.SELECT_TEST_SEQUENCE, msg.PRESS_NUMBER_TO_SELECT,
    msg.BANNER_F_CPU, msg.BANNER_TICKS, msg.BANNER_STEPPERS))


def is_answer(line: str) -> bool:
    """Is ``line`` (without its line end) one StepperDemo prints in answer to a command?
    (Status lines, table rows and the banner are read on their own.)"""
    text = line.rstrip()
    return text in _ANSWER_TEXTS or text.startswith(_ANSWER_PREFIXES) or bool(
        _WAIT_MS.match(text))


@dataclass
class StatusEntry:
    """One running stepper in a status line (or in the table while it runs)."""

    number: int  # 1, 2, ... (M1, M2, ...)
    position: int
    target: int | None  # None: running without end ("nonstop")
    queue_end: int
    period_us: int | None  # v=<us>us/<ticks>ticks
    milli_hz: int | None  # v=<mHz>mSteps/s (after an H/h speed command)
    state: str  # ACC RED COAST REV IDLE, MANU, or the raw number

    @property
    def speed_known(self) -> bool:
        """False right after a move was given: the firmware prints an undefined period."""
        return self.milli_hz is not None or (self.period_us or 0) < UNDEFINED_PERIOD_US

    @property
    def speed_sps(self) -> float:
        """Planned speed in steps/s, signed by the direction of travel."""
        if self.milli_hz is not None:
            return self.milli_hz / 1000
        us = self.period_us or 0
        if us == 0 or us >= UNDEFINED_PERIOD_US:
            return 0.0
        ahead = self.queue_end - self.position
        if ahead == 0 and self.target is not None:
            ahead = self.target - self.position
        return -1e6 / us if ahead < 0 else 1e6 / us


@dataclass
class TableEntry:
    number: int
    selected: bool
    position: int
    running: StatusEntry | None  # the running form, or None when it stands
    acceleration: int | None = None
    speed_us: int | None = None
    speed_mhz: int | None = None


def _entry(m: re.Match) -> StatusEntry:
    state = m.group("state")
    if state is None:
        state = m.group("code") or _text(msg.STATUS_MANUAL).strip()
    return StatusEntry(
        number=int(m.group("n")), position=int(m.group("pos")),
        target=None if m.group("nonstop") else int(m.group("target")),
        queue_end=int(m.group("qend")),
        period_us=int(m.group("us")) if m.group("us") is not None else None,
        milli_hz=int(m.group("mhz")) if m.group("mhz") is not None else None,
        state=state)


def parse_status(line: str) -> list[StatusEntry] | None:
    """The entries of a status line, or None if ``line`` is not one."""
    if not _STATUS_LINE.match(line):
        return None
    entries = [_entry(m) for m in _ENTRY.finditer(line)]
    return entries or None


def parse_table(line: str) -> TableEntry | None:
    """A line of the stepper table, or None."""
    m = _TABLE_LINE.match(line)
    if m is None:
        return None
    running = _entry(m) if m.group("qend") is not None else None
    return TableEntry(
        number=int(m.group("n")), selected=m.group("sel") == msg.TABLE_SELECTED,
        position=int(m.group("pos")), running=running,
        acceleration=int(m.group("acc")) if m.group("acc") is not None else None,
        speed_us=int(m.group("speed_us")) if m.group("speed_us") is not None else None,
        speed_mhz=int(m.group("speed_mhz")) if m.group("speed_mhz") is not None else None)


# ------------------------------------------------------------------- samples
@dataclass
class Sample:
    t_s: float
    position: int
    speed_sps: float
    state: str
    speed_known: bool = True


@dataclass
class StepperTrace:
    number: int
    samples: deque[Sample]
    status_lines: int = 0
    final_position: int | None = None  # from the last stepper table


class StatusTrace:
    """Status lines as samples per stepper, at most ``max_samples`` each (oldest go)."""

    def __init__(self, max_samples: int = DEFAULT_TRACE_SAMPLES) -> None:
        self.max_samples = max_samples
        self.steppers: dict[int, StepperTrace] = {}
        self.lines = 0

    def _of(self, number: int) -> StepperTrace:
        st = self.steppers.get(number)
        if st is None:
            st = self.steppers[number] = StepperTrace(number, deque(maxlen=self.max_samples))
        return st

    def status(self, t_s: float, entries: list[StatusEntry]) -> None:
        self.lines += 1
        for e in entries:
            st = self._of(e.number)
            st.status_lines += 1
            st.samples.append(Sample(t_s, e.position, e.speed_sps, e.state, e.speed_known))

    def stood(self, t_s: float, number: int, position: int) -> None:
        """The table shows the stepper standing: close its last run at this position."""
        st = self.steppers.get(number)
        if st is None:
            return
        st.final_position = position
        if st.samples and st.samples[-1].speed_sps != 0:
            st.samples.append(Sample(t_s, position, 0.0, STOP_STATE))

    def clear(self) -> None:
        self.steppers.clear()
        self.lines = 0


# --------------------------------------------------------------------- state
@dataclass
class StepperView:
    """What the board last said about one stepper."""

    number: int
    position: int | None = None
    running: bool = False  # a status line (or the table) showed it running
    continuous: bool = False  # told to run without end (f, b, K, a; "nonstop")
    stopping: bool = False  # S was given
    acceleration: int | None = None
    speed_us: int | None = None
    speed_mhz: int | None = None


@dataclass
class Banner:
    version: str = ""
    f_cpu: int | None = None
    ticks_per_s: int | None = None
    steppers: int | None = None




@dataclass
class BoardState:
    """The board's state as its answers tell it (see the module text)."""

    mode: str = "normal"
    selected: int = 1
    verbose: bool = True  # status lines (I toggles)
    usage_info: bool = True  # usage and table after a stop (Q toggles)
    spinning: bool = False  # "Blocking wait ..." seen, "STOPPED" not yet
    pausing: bool = False  # "<n> ms wait" seen, "Wait complete" not yet
    test_running: bool = False
    test_result: str | None = None  # "passed" / "failed" of the last test run
    tests_failed: int = 0
    tests_completed: int = 0
    motion_expected: bool = False  # a move was acknowledged; no stop table since
    resets: int = 0
    banner: Banner = field(default_factory=Banner)
    steppers: dict[int, StepperView] = field(default_factory=dict)
    trace: StatusTrace = field(default_factory=StatusTrace)
    last_line: str = ""
    answers: int = 0  # lines StepperDemo would print (a banner, a status line, an answer)

    # ------------------------------------------------------------ queries
    def stepper(self, number: int) -> StepperView:
        view = self.steppers.get(number)
        if view is None:
            view = self.steppers[number] = StepperView(number)
        return view

    @property
    def stepper_count(self) -> int | None:
        if self.banner.steppers:
            return self.banner.steppers
        return max(self.steppers) if self.steppers else None

    def running(self) -> list[int]:
        return sorted(n for n, v in self.steppers.items() if v.running)

    def busy(self) -> bool:
        """The board says it is still at work: a wait, a test, or a motion whose end it
        will announce (the usage and table printed when the last stepper stops)."""
        if self.spinning or self.pausing or self.test_running:
            return True
        if not self.usage_info:
            return False  # Q: the stop is not announced, only the quiet tells
        # a stepper seen running; or, with status lines off, a move acknowledged
        return bool(self.running()) or (self.motion_expected and not self.verbose)

    def selected_runs_for_ever(self) -> bool:
        """A W now would return at once: the selected stepper runs without end."""
        v = self.steppers.get(self.selected)
        return v is not None and v.continuous and not v.stopping

    def positions(self) -> dict[int, int]:
        return {n: v.position for n, v in sorted(self.steppers.items())
                if v.position is not None}

    # ------------------------------------------------------------ feeding
    def _restart(self, version: str) -> None:
        """The start banner: the board is back at power-on (the trace stays)."""
        fresh = BoardState(resets=self.resets + 1, trace=self.trace,
                           banner=Banner(version=version), answers=self.answers)
        self.__dict__.update(fresh.__dict__)

    def feed(self, line: str, t_s: float) -> str | None:
        """One received line (without its line end); returns what it was, for holds:
        ``reset``, ``status``, ``table``, ``spin``, ``stopped``, ``unknown``,
        ``test_done``, ``direct_drive`` or None."""
        prev, self.last_line = self.last_line, line
        kind = self._feed(line, prev, t_s)
        if kind is not None or is_answer(line):
            self.answers += 1
        return kind

    def _feed(self, line: str, prev: str, t_s: float) -> str | None:
        entries = parse_status(line)
        if entries is not None:
            self.trace.status(t_s, entries)
            seen = {e.number for e in entries}
            for n, v in self.steppers.items():
                if n not in seen:
                    v.running = False
            for e in entries:
                self._running(e)
            return "status"
        row = parse_table(line)
        if row is not None:
            return self._table(row, t_s)
        if line.startswith(_BANNER_PREFIX):
            self._restart(line[len(_BANNER_PREFIX):].strip())
            return "reset"
        return self._answer(line, prev)

    def _running(self, e: StatusEntry) -> None:
        v = self.stepper(e.number)
        v.position = e.position
        v.running = True
        v.continuous = e.target is None

    def _table(self, row: TableEntry, t_s: float) -> str:
        v = self.stepper(row.number)
        v.position = row.position
        if row.selected:
            self.selected = row.number
        if row.running is not None:
            self._running(row.running)
        else:
            v.running = v.continuous = v.stopping = False
            v.acceleration, v.speed_us, v.speed_mhz = (row.acceleration, row.speed_us,
                                                       row.speed_mhz)
            self.trace.stood(t_s, row.number, row.position)
            if not any(s.running for s in self.steppers.values()):
                self.motion_expected = False
        return "table"

    def _answer(self, line: str, prev: str) -> str | None:
        sel = self.stepper(self.selected)
        if line.startswith(msg.SELECT_STEPPER) and line[len(msg.SELECT_STEPPER):].isdigit():
            self.selected = int(line[len(msg.SELECT_STEPPER):])
        elif line == _text(msg.ENTER_TEST_MODE):
            self.mode = "test"
        elif line == _text(msg.ENTER_CONFIG_MODE):
            self.mode = "config"
        elif line == _text(msg.ENTER_GCODE_MODE):  # the simulation's `g` (issue 12)
            self.mode = "gcode"
        elif line == _text(msg.EXIT_TO_MAIN_MENU):
            self.mode = "normal"
            self.test_running = False
        elif line == _text(msg.TOGGLE_MOTOR_INFO):
            self.verbose = not self.verbose
        elif line == _text(msg.TOGGLE_USAGE_INFO):
            self.usage_info = not self.usage_info
        elif line == _text(msg.BLOCKING_WAIT):
            self.spinning = not self.selected_runs_for_ever()
            return "spin"
        elif line == msg.STOPPED:
            self.spinning = False
            sel.running = sel.continuous = sel.stopping = False
            return "stopped"
        elif _WAIT_MS.match(line):
            self.pausing = True
        elif line == _text(msg.WAIT_COMPLETE):
            self.pausing = False
        elif line == _text(msg.RUN_TESTS):
            self.test_running = True
            self.test_result = None
        elif line == _text(msg.PASS_STATUS):
            self.test_result = "passed"
        elif line == _text(msg.FAILED_STATUS):
            self.test_result = "failed"
            self.tests_failed += 1
        elif line == _text(msg.TEST_COMPLETED):
            self.test_running = False
            self.tests_completed += 1
            return "test_done"
        elif line == _text(msg.MOVE_RESULT[0]):
            if prev.startswith((msg.MOVE_STEPS, msg.MOVE_TO_POSITION, msg.SET_ACCELERATION_TO)):
                self.motion_expected = True
                sel.stopping = False
                sel.continuous = prev.startswith(msg.SET_ACCELERATION_TO)  # `a`
        elif line in (_text(msg.RUN_FORWARD), _text(msg.RUN_BACKWARD), _text(msg.KEEP_RUNNING)):
            self.motion_expected = True
            sel.continuous = True
            sel.stopping = False
        elif line == _text(msg.STOP):
            sel.stopping = True
        elif line == _text(msg.IMMEDIATE_STOP):
            sel.running = sel.continuous = sel.stopping = False
            sel.position = 0
        elif line.startswith(msg.UNKNOWN_COMMAND):
            return "unknown"
        elif line == _text(msg.TEST_DIRECT_DRIVE):
            return "direct_drive"
        else:
            for text, name in ((msg.BANNER_F_CPU, "f_cpu"), (msg.BANNER_TICKS, "ticks_per_s"),
                               (msg.BANNER_STEPPERS, "steppers")):
                if line.startswith(text) and line[len(text):].strip().isdigit():
                    setattr(self.banner, name, int(line[len(text):]))
        return None
