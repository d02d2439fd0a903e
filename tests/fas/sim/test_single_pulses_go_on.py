"""A channel's single pulses beside another channel's block of pulses go on inside their
step interrupt while the next request is the next event (SimChannel._go_on): the chip
must end exactly as it does when every one of them is an event of its own."""

from __future__ import annotations

from heapq import heappush

import pytest

from fas import Engine
from fas.sim import SimBackend
from fas.sim.channel import SimChannel
from stepperdemo.demo.build import demo_build


def _as_events(self, ev, e, compare, cost) -> None:
    """_go_on's fallback for every pulse: the request becomes an event."""
    m = self.m
    heappush(m.events, (compare, self.prio, m.seq, ev))


def _run(arch: str) -> tuple:
    backend = SimBackend(arch, record=False)  # nobody watches the edges: _go_on may run
    engine = Engine(backend)
    engine.init()
    build = demo_build(backend.profile)
    steppers = []
    for k, (speed_us, accel) in enumerate(((70, 40_000), (230, 9_000))):
        s = engine.stepper_connect_to_pin(build.steppers[k].step)
        assert s is not None
        s.set_direction_pin(build.steppers[k].direction)
        s.set_speed_in_us(speed_us)
        s.set_acceleration(accel)
        steppers.append(s)
    for s, move in zip(steppers, (30_000, -9_000), strict=True):
        s.move(move)
    m = backend.machine
    seen = []  # what the loop sees after each wait: the CPU busy until, its time taken
    for _ in range(100_000):  # an application's loop: a wait of 0.25 ms at a time
        if not any(s.is_running() for s in steppers):
            break
        m.run_until(m.now + 4_000)
        seen.append((m.busy_until, m.stolen_ticks, m.events_run))
    assert not any(s.is_running() for s in steppers)
    pins = m.pins
    return (m.now, m.events_run, m.seq, m.busy_until, m.stolen_ticks,
            tuple(m.isr_starts), tuple(m.isr_ends),
            sorted(pins.rise.items()), sorted(pins.fall.items()),
            sorted(pins.high_total.items()), sorted(pins.high_max.items()),
            sorted(pins.level.items()),
            [s.get_current_position() for s in steppers],
            [ch.pulses for ch in backend.channels], [ch.missed_compares for ch in backend.channels],
            seen)


@pytest.mark.parametrize("arch", ["atmega328p", "atmega2560"])
def test_single_pulses_that_go_on_end_as_events_do(monkeypatch, arch):
    calls = []
    go_on = SimChannel._go_on  # noqa: SLF001 (the path under test)

    def counting(self, ev, e, compare, cost):
        calls.append(compare)
        go_on(self, ev, e, compare, cost)

    monkeypatch.setattr(SimChannel, "_go_on", counting)
    fast = _run(arch)
    assert len(calls) > 100  # the path ran, and often
    monkeypatch.setattr(SimChannel, "_go_on", _as_events)
    slow = _run(arch)
    assert fast[1] == slow[1]  # every interrupt counted as an event
    assert fast == slow
    assert fast[12] == [30_000, -9_000]
