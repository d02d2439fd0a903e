"""The main loop's lost CPU time: one set of counting rules (fas.sim.loop_isrs).

The machine counts the interrupts of every span of loop time (``consume_counting``);
between events its ``IsrClock`` answers with cursors instead.  Both must end every
span at the same tick, whatever runs: blocks of step pulses, ``millis()``, the UART.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fas.sim.loop_isrs import NEVER, count_between, next_after, running_end
from rigs.sim import make

PROP = settings(max_examples=int(os.environ.get("FAS_PROP_EXAMPLES", "40")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow])

# (first, period, last, cost): an interrupt routine ends before the next one begins
train = st.tuples(st.integers(0, 500), st.integers(1, 60), st.integers(0, 40),
                  st.integers(1, 60)).map(
    lambda v: (v[0], v[1], v[0] + v[2] * v[1], min(v[3], v[1])))


@given(train, st.integers(-50, 3000), st.integers(0, 3000))
def test_a_train_counts_its_interrupts_in_a_span(tr, start, length):
    first, period, last, cost = tr
    ticks = range(first, last + 1, period)
    end = start + length
    assert count_between(tr, start, end) == sum(1 for t in ticks if start < t <= end)
    later = [t for t in ticks if t > start]
    assert next_after(start, period, first, last) == (later[0] if later else NEVER)
    running = [t + cost for t in ticks if t <= start < t + cost]
    assert running_end(start, *tr) == (running[-1] if running else None)


class _SilentTimer:
    """A timer without events that takes no CPU time.  A machine with one counts every
    span itself (``consume_counting``) instead of asking its IsrClock."""

    def block_cpu_between(self, begin: int, end: int) -> int:
        return 0


op = st.one_of(
    st.tuples(st.just("move"), st.integers(-40_000, 40_000), st.integers(16, 400)),
    st.tuples(st.just("print"), st.integers(1, 200), st.integers(0, 300)),
    st.tuples(st.just("spend"), st.integers(1, 20_000), st.just(0)),
    st.tuples(st.just("wait"), st.integers(0, 400_000), st.just(0)),
    st.tuples(st.just("block"), st.integers(1, 3_000), st.just(0)),
    st.tuples(st.just("stop"), st.just(0), st.just(0)),
)


def _run(ops, counting: bool) -> list[int]:
    backend, _, s = make(record=False)
    m = backend.machine
    backend.app_started()  # millis(): its timer-0 interrupts begin
    if counting:
        m.cpu_sources.append(_SilentTimer())
    s.set_acceleration(1_000_000)  # at speed soon: long blocks of pulses
    ticks = []
    for name, a, b in ops:
        if name == "move":
            s.set_speed_in_us(b)
            s.move(a)
        elif name == "print":
            backend.console_write(bytes(32 + i % 95 for i in range(a)), [b] * a if b else None)
        elif name == "spend":
            backend.app_spend(a)
        elif name == "wait":
            backend.app_wait_until(m.now + a)
        elif name == "block":
            backend.block_interrupts(a)
        else:
            s.force_stop()
        ticks.append(m.now)
    ticks.append(s.get_current_position())
    return ticks


@PROP
@given(st.lists(op, min_size=1, max_size=14))
def test_the_isr_clock_ends_every_span_where_the_machines_counting_does(ops):
    assert _run(ops, counting=False) == _run(ops, counting=True)


def test_the_isr_clock_is_what_answers_a_print_under_a_running_block():
    """The comparison above means something: prints during a fast move go through the
    clock's cursors (a train of step interrupts and millis()) - and agree."""
    backend, _, s = make(record=False)
    backend.app_started()
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(20_000)
    backend.run_for_ms(40)
    clock = backend.machine.isr_clock()
    assert len(clock.trains) == 2  # the block of pulses and millis()
    assert clock.trains[0][3] - clock.trains[0][2] > 20 * clock.trains[0][1]  # a long one
    ops = [("move", 20_000, 40), ("wait", 640_000, 0), ("print", 40, 0), ("spend", 5000, 0),
           ("print", 120, 0), ("wait", 3000, 0), ("print", 60, 40), ("block", 1600, 0),
           ("print", 80, 0)]
    assert _run(ops, counting=False) == _run(ops, counting=True)
