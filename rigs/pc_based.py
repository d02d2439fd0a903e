"""Harness for the regression tests taken from FastAccelStepper's pc_based suite.

Upstream tests its ramp generator without any timer: the test calls the stepper
task's ``fill_queue()`` itself and then takes every queued command out again, feeding
each one to a checker that follows the step periods.  Here the same: a backend whose
channels never run (time does not pass), the ``pc_test`` profile (upstream's test
platform: 16 MHz ticks, MIN_CMD_TICKS 3200, a 16-entry queue), and
:class:`RampChecker`, which asserts what upstream's checker asserts:

* the speed only rises while accelerating is allowed and only falls after it rose;
* a direction change only where the test allows reversing;
* it sums time and position, and records the shortest step period, when the
  acceleration ended and when coasting ended.

:func:`run_ramp` is the common loop: fill, drain into the checker, and require that
every fill but the first planned more than 5 ms ahead.
"""

from __future__ import annotations

from typing import Callable

from fas import Engine
from fas.arch import PC_TEST
from fas.backend import Backend, QueueChannel

TPS = PC_TEST.ticks_per_s
NONE_U32 = 0xFFFFFFFF  # upstream's "~0": no period seen yet


class ManualChannel(QueueChannel):
    """A channel that never runs: the test takes the commands out by hand."""

    def __init__(self, queue) -> None:
        self.q = queue

    def is_running(self) -> bool:
        return False

    def start(self) -> None:
        pass  # nothing executes; drain() consumes the entries

    def force_stop(self) -> None:
        pass

    def sync(self) -> None:
        pass


class ManualBackend(Backend):
    def __init__(self, profile=PC_TEST) -> None:
        self.profile = profile
        self.pins: dict[int, int] = {}
        self.engine = None

    def now(self) -> int:
        return 0

    def attach_engine(self, engine) -> None:
        self.engine = engine

    def allocate_channel(self, queue) -> ManualChannel:
        return ManualChannel(queue)

    def write_pin(self, pin: int, level: int) -> None:
        self.pins[pin] = level

    def read_pin(self, pin: int) -> int:
        return self.pins.get(pin, 0)

    def wait_until(self, predicate, timeout_ticks: int) -> bool:
        raise AssertionError("the pc tests have no clock")

    def app_spend(self, ticks: int) -> None:
        raise AssertionError("the pc tests have no clock")

    def app_wait_until(self, tick: int) -> None:
        raise AssertionError("the pc tests have no clock")

    def next_event_time(self) -> int | None:
        return None


def make_stepper(dir_pin: int | None = None, *, profile=PC_TEST, external_call=None):
    """A stepper on the manual backend (upstream: ``s.init(NULL, 0, 0)``)."""
    engine = Engine(ManualBackend(profile))
    engine.init()
    if external_call is not None:
        engine.set_external_call_for_pin(external_call)
    s = engine.stepper_connect_to_pin(0)
    assert s is not None

    def abort(stepper, res, cmd):
        raise AssertionError(f"ramp aborted: {res!r} for {cmd!r}")

    engine.ramp_abort_listener = abort
    if dir_pin is not None:
        s.set_direction_pin(dir_pin)
    return s


class RampChecker:
    def __init__(self) -> None:
        self.total_ticks = 0
        self.pos = 0
        self.ticks_since_last_step = 0
        self.next_ramp()

    def next_ramp(self) -> None:
        self.increase_ok = True
        self.decrease_ok = False
        self.last_dt = NONE_U32
        self.min_dt = NONE_U32
        self.first = True
        self.dir_high = True
        self.coast_till = 0
        self.time_coasting = 0
        self.accelerate_till = 0
        self.reversing_allowed = False

    def check(self, e) -> None:
        steps = e.total_steps
        if steps == 0:  # a pause
            if self.ticks_since_last_step <= 0xFFFF0000:
                self.ticks_since_last_step += e.ticks
            self.total_ticks += e.ticks
            return
        if e.toggle_dir:
            assert self.reversing_allowed, "direction reversed"
            self.dir_high = not self.dir_high
            self.increase_ok = True
            self.last_dt = NONE_U32
            self.decrease_ok = False
        self.pos += steps if self.dir_high else -steps
        curr_dt = self.ticks_since_last_step
        self.total_ticks += steps * e.ticks
        if not self.first:
            self.min_dt = min(self.min_dt, curr_dt)
        assert self.first or steps * curr_dt > 0
        if self.last_dt > curr_dt:
            assert self.increase_ok, f"speed rose ({self.last_dt} -> {curr_dt} ticks)"
            self.accelerate_till = self.total_ticks
            self.decrease_ok = True
        elif self.last_dt < curr_dt:
            if self.increase_ok:
                self.coast_till = self.total_ticks - curr_dt
            assert self.decrease_ok, f"speed fell ({self.last_dt} -> {curr_dt} ticks)"
            self.increase_ok = False
        else:
            self.time_coasting += steps * curr_dt
        if not self.first:
            self.last_dt = curr_dt
        self.ticks_since_last_step = e.ticks
        self.first = False

    @property
    def seconds(self) -> float:
        return self.total_ticks / TPS


def drain(s, rc: RampChecker, *, free: bool = False) -> int:
    """Take every queued command out into the checker; ticks drained.  ``free``: the
    test allows any speed change (upstream sets increase_ok/decrease_ok each time)."""
    q = s.queue
    before = rc.total_ticks
    while q.read_idx != q.next_write_idx:
        if free:
            rc.increase_ok = True
            rc.decrease_ok = True
        rc.check(q.entries[q.read_idx % q.queue_len])
        q.read_idx = (q.read_idx + 1) & 0xFF
    return rc.total_ticks - before


def run_ramp(s, rc: RampChecker, loops: int, *, free: bool = False,
             each: Callable[[int], bool | None] | None = None,
             after_fill: Callable[[int], None] | None = None,
             stop_ticks: int | None = None) -> list[float]:
    """Upstream's loop: ``each(i)`` runs first (True ends the loop), then stop when the
    ramp is done, else fill, drain and check the planning time.  Returns the planned
    seconds per fill."""
    planned: list[float] = []
    old = 0.0
    for i in range(loops):
        if each is not None and each(i):
            break
        if not s.is_ramp_generator_active():
            break
        s.fill_queue()
        if after_fill is not None:
            after_fill(i)
        secs = drain(s, rc, free=free) / TPS
        assert i == 0 or old > 0.005, f"only {old * 1000:.2f} ms planned ahead at fill {i}"
        old = secs
        planned.append(secs)
        if stop_ticks is not None and rc.total_ticks > stop_ticks:
            break
    return planned
