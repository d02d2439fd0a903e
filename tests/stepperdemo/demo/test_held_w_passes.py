"""A held W's passes spent in rounds (StepperDemo._held_w_passes, the backend's
app_spend_passes, Machine.consume_passes) are the passes loop_pass runs one by one:
the same transcript, pin edges, final tick, pass and command counts, to the tick.

Build d's ATmega328P runs every pass of a held W (DemoBuild.w_every_pass, the
forty-second pass; its default since the fiftieth, docs/timing-model.md), with the
loop's sections in the pass that runs the W (w_pass_millis_before_end)."""

from __future__ import annotations

import pytest

from fas.arch import ATMEGA328P
from fas.sim import SimBackend
from fas.sim.machine import Machine
from stepperdemo.demo.app import StepperDemo
from stepperdemo.demo.build import demo_build

LINES = [
    "M1 A1000 V100 R3200 W",  # the README's move
    "M1 A10000 V100 R5000 M2 A5000 V200 R-3000 W M1 W",
    "M1 A20000 V40 R6000 M2 A20000 V60 R-6000 W",  # two fast steppers
    "M1 A1000 V100 R800 w50 R-800 W",
    "M1 A5000 V300 f w200 S W",  # a continuous run stopped: W ends at the stop
    "M1 A3000 V80 R1500 W M2 A3000 V90 R-100 W t",
]


def _run(line: str, *, rounds: bool, max_s: float = 20.0) -> tuple[object, ...]:
    b = SimBackend(ATMEGA328P, record=True)
    app = StepperDemo(b, scripted=True)
    spent = [0]
    if rounds:
        inner = b.app_spend_passes

        def counted(*args: object) -> int:
            n = inner(*args)  # type: ignore[arg-type]
            spent[0] += n
            return n

        b.app_spend_passes = counted  # type: ignore[method-assign]
    else:  # every pass by loop_pass, one by one
        app._held_w_passes = lambda limit: None  # type: ignore[method-assign]  # noqa: SLF001
    reason = app.run_script(line, max_ticks=int(max_s * b.profile.ticks_per_s))
    pins = b.pin_states
    rec = b.recorder
    assert rec is not None
    edges = {pin: (rec.times[pin].tobytes(), bytes(rec.levels[pin])) for pin in rec.times}
    return (reason, b.now(), bytes(app.transcript), app.passes, app.commands,
            sorted(pins.high_max.items()), sorted(pins.high_total.items()), edges,
            [None if s is None else s.get_current_position() for s in app.steppers],
            spent[0])


def test_build_d_runs_every_pass_of_a_held_w() -> None:
    build = demo_build(ATMEGA328P, "d")
    assert build.w_every_pass and build.loop_sections and build.w_pass_millis_before_end


@pytest.mark.parametrize("line", LINES)
def test_rounds_are_the_passes_one_by_one(line: str) -> None:
    one_by_one = _run(line, rounds=False)
    by_rounds = _run(line, rounds=True)
    assert by_rounds[:-1] == one_by_one[:-1]
    assert one_by_one[-1] == 0
    # most of the held W's passes went by rounds (not a test of nothing)
    assert by_rounds[-1] > by_rounds[3] // 2


def test_a_run_cut_by_its_time_limit_ends_on_the_same_tick() -> None:
    line = "M1 A1000 V100 R3200 W"
    for max_s in (0.25, 0.3337, 1.0):
        assert _run(line, rounds=True, max_s=max_s)[:-1] == _run(line, rounds=False,
                                                                  max_s=max_s)[:-1]


def _per_pass(m: Machine, passes, n: int) -> None:
    for j in range(n):
        head, ticks, poll = passes[j % len(passes)]
        m.consume(head)
        if poll is not None:
            m.poll_begin(*poll)
        m.consume(ticks)
        if poll is not None:
            m.poll_end()


def test_the_machine_keeps_a_run_of_rounds_as_the_passes_polls() -> None:
    sections = ((0, 11), (207, 11))
    passes = [(0, 330, None), (137, 330, (330, sections))]
    a, b = Machine(ATMEGA328P, "d"), Machine(ATMEGA328P, "d")
    for m in (a, b):
        m.start_millis()  # timer 0's overflows take time from the loop every 16 384 ticks
    start = a.now
    n = b.consume_passes(passes, start + 200_000, lambda: False)
    assert n > 200  # nothing else runs: the passes up to the tick asked
    _per_pass(a, passes, n)
    assert a.now == b.now < start + 200_000
    assert len(b.loop_polls) < n // 8  # rounds nothing met: one entry per run
    big = 10**9  # no step interrupt of an asking channel in between
    for c in range(start, a.now + 400, 3):
        assert b.loop_hold(c, big, 0) == a.loop_hold(c, big, 0), c
    # the next pass would read at or after the tick asked: not spent
    assert b.consume_passes(passes[n % 2:] + passes[:n % 2], b.now + 1, lambda: False) == 0


def _hold(m: Machine, c: int, step_period: int, step_cost: int) -> int:
    """What a request at ``c`` waits for the loop's section, read off the poll that holds
    it, as docs/timing-model.md states it (fourteenth and fiftieth passes)."""
    for start, end, period, sections in reversed(m.loop_polls):
        if start <= c < end:
            if period < 0:  # a run of rounds: passes exactly -period apart
                phase = (c - start) % -period
            else:  # the loop's own CPU time: the asking channel's and timer 0's taken out
                d = c - start
                d -= step_cost * (d // step_period) + m.timing.millis_isr_ticks * (d >> 14)
                phase = d % period
            for offset, ticks in sections:
                if offset <= phase < offset + ticks:
                    return offset + ticks - phase
            return 0
    return 0


def test_the_holds_of_a_block_are_loop_hold_of_each_request() -> None:
    import random

    rng = random.Random(5)
    m = Machine(ATMEGA328P, "d")
    m.start_millis()
    for _ in range(300):  # polls of one pass or a run of rounds, with gaps between
        m.run_until(m.now + rng.randrange(0, 900))
        if rng.random() < 0.3:
            length = rng.randrange(300, 900)
            n = rng.randrange(1, 40)
            m.loop_polls.append((m.now, m.now + (n - 1) * length + 330, -length,
                                 ((0, 11), (207, 11))))
            m.run_until(m.now + (n - 1) * length + 330)
        else:
            m.poll_begin(797, ((0, 11), (207, 11), (330, 11), (674, 11)))
            m.run_until(m.now + rng.randrange(1, 3000))
            m.poll_end()
    first = m.loop_polls[0][0]
    for _ in range(400):
        c0 = rng.randrange(first - 2000, m.now)
        period = rng.randrange(40, 5000)
        j0 = rng.randrange(0, 5)
        j1 = j0 + rng.randrange(0, 200)
        cost = rng.randrange(0, 200)
        skip = {j for j in range(j0, j1) if rng.random() < 0.1}
        want = [(j, w) for j in range(j0, j1)
                if j not in skip and (w := _hold(m, c0 + j * period, period, cost))]
        assert m.loop_holds(c0, period, j0, j1, cost, skip) == want
        for j in range(j0, min(j1, j0 + 5)):
            c = c0 + j * period
            assert m.loop_hold(c, period, cost) == _hold(m, c, period, cost)


def test_beside_a_device_a_held_w_skips_its_passes() -> None:
    from fas.device.loopback import Loopback

    with Loopback() as lb:
        app = StepperDemo(lb.backend, scripted=True)
        # the host's loop is no chip's: its held W waits for the stop (no pass by pass)
        assert app.firmware_build is None and not app.build.w_every_pass
    assert StepperDemo(SimBackend(ATMEGA328P), scripted=True).build.w_every_pass
