"""The firmware's step generator (firmware/stepgen.c) in simavr against the Python device's
step timer, fed the same queue entries and starts (no protocol: the rig firmware).

The firmware's rising edges are made by the compare unit, so they fall on the same
ticks as the model's - one tick later in simavr, which matches a compare one cycle
after the counter reaches it.  The falling edge comes from a second compare set by
the interrupt, so pulse widths are the interrupt latency plus a few ticks.
"""

from __future__ import annotations

import pytest

from rigs.firmware import need_firmware
from rigs.stepgen import (
    DETACH,
    HALT,
    LB_UP,
    PCNT,
    PCNT_DIR_HIGH_UP,
    PCNT_ON,
    START_NOW,
    STOP,
    Both,
    Rig,
    build_rig,
)

SIM_COMPARE_OFFSET = 1  # simavr: the compare matches one cycle after the counter value


@pytest.fixture(scope="module")
def rig_files():
    need_firmware()
    return build_rig()


@pytest.fixture
def both(rig_files, tmp_path):
    rig = Rig(rig_files, str(tmp_path / "trace.txt"))
    yield Both(rig)
    rig.dev.close()


def _compare(both: Both, pin: int) -> tuple[list[int], list[int]]:
    trace = both.rig.dev.trace()
    return trace.rising(pin), both.model.rising(pin)


def _widths(both: Both, pin: int) -> list[int]:
    times, levels = both.rig.dev.trace().edges(pin)
    assert list(levels[:2]) == [1, 0]
    return [times[i + 1] - times[i] for i in range(0, len(times) - 1, 2)]


def test_entries_with_pauses_and_a_reversal_give_the_models_edges(both):
    both.dir_pin(0, 5, 1)
    for steps, ticks in [(1, 3000), (3, 2000), (10, 1000), (0, 5000), (20, 640), (255, 700),
                         (5, 900)]:
        both.entry(0, steps, ticks)
    both.entry(0, 0, 4000, up=False, toggle=True)  # the direction change's pause
    both.entry(0, 7, 700, up=False)
    both.entry(0, 1, 3000, up=False)
    at = both.rig.tick() + 50_000
    both.start_at(0, at)
    both.run_to_tick(at + 400_000)
    snap = both.rig.snapshot(0)
    fw, py = _compare(both, 9)
    assert len(fw) == len(py) == 302
    assert {f - p for f, p in zip(fw, py, strict=True)} == {SIM_COMPARE_OFFSET}
    assert snap.pulses == 302 and snap.pulse_pos == 294 - 8 and snap.state == 0
    # the direction pin toggled once, after the last step up and before the first down
    trace = both.rig.dev.trace()
    dir_times, dir_levels = trace.edges(5)
    assert list(dir_levels) == [1, 0]
    assert fw[293] < dir_times[1] < fw[294]
    assert all(40 <= w <= 160 for w in _widths(both, 9))


def test_two_channels_at_25_khz_keep_every_compare(both):
    """640 ticks (25 kHz) on both channels, started on the same tick: every compare of
    both coincides, the worst case for the interrupts."""
    for ch in (0, 1):
        both.entry(ch, 200, 640)
        both.entry(ch, 100, 640 + 13 * ch)
    at = both.rig.tick() + 30_000
    both.start_at(0, at)
    both.start_at(1, at)
    both.run_to_tick(at + 200_000)
    for pin in (9, 10):
        fw, py = _compare(both, pin)
        assert len(fw) == len(py) == 300
        assert {f - p for f, p in zip(fw, py, strict=True)} == {SIM_COMPARE_OFFSET}
        assert max(_widths(both, pin)) < 640 - 200  # low again well before the next step


def test_one_channel_at_50_khz(both):
    both.entry(0, 250, 320)
    both.entry(0, 250, 320)
    at = both.rig.tick() + 20_000
    both.start_at(0, at)
    both.run_to_tick(at + 200_000)
    fw, py = _compare(both, 9)
    assert len(fw) == 500
    assert {f - p for f, p in zip(fw, py, strict=True)} == {SIM_COMPARE_OFFSET}


@pytest.mark.parametrize("lead", [3000, 40_000, 65_500, 65_700, 500_000, 3 * 65_536 + 17])
def test_timed_starts_begin_on_their_tick(both, lead):
    """Within a counter wrap, close to one, and several wraps ahead (the compare matches
    every wrap until the start)."""
    both.entry(0, 4, 1000)
    at = both.rig.tick() + lead
    both.start_at(0, at)
    assert both.rig.late() == 0
    both.run_to_tick(at + 10_000)
    fw, py = _compare(both, 9)
    assert py[0] == at + 10
    assert fw == [t + SIM_COMPARE_OFFSET for t in py]


def test_a_start_in_the_past_begins_at_once_and_says_late(both):
    both.entry(0, 3, 1000)
    now = both.rig.tick()
    both.start_at(0, now - 5000)
    assert both.rig.late() == 1
    both.run_to_tick(now + 20_000)
    fw = both.rig.dev.trace().rising(9)
    assert len(fw) == 3 and now < fw[0] < now + 600


def test_an_entry_after_the_queue_ran_dry_continues_as_the_model(both):
    """The interrupt waits out the last entry's period; an entry arriving then is taken
    up ("no more commands" restart, 10 ticks), as FastAccelStepper's interrupt does."""
    both.entry(0, 2, 1000)
    both.entry(0, 1, 40_000)  # a long last period
    at = both.rig.tick() + 20_000
    both.start_at(0, at)
    both.run_to_tick(at + 3000 + 10_000)  # inside the last period
    both.entry(0, 3, 800)
    both.entry(0, 2, 900)
    both.run_to_tick(at + 120_000)
    assert both.rig.snapshot(0).state == 0
    fw, py = _compare(both, 9)
    assert len(fw) == len(py) == 8
    assert {f - p for f, p in zip(fw, py, strict=True)} == {SIM_COMPARE_OFFSET}


def test_force_stop_counts_exactly_the_pulses_on_the_pin(both):
    both.entry(0, 255, 640)
    both.entry(0, 255, 640)
    both.rig.command(START_NOW, 0)
    for stop_after in (3 * 640 + 5, 57 * 640 + 320):  # during a pulse / between pulses
        both.rig.run_to_tick(both.rig.tick() + stop_after)
        both.rig.command(STOP, 0)
        snap = both.rig.snapshot(0)
        assert snap.state == 0
        edges = both.rig.dev.pins()[9]
        assert snap.pulses == edges.rising == edges.falling
        assert edges.level == 0
        both.rig.run_to_tick(both.rig.tick() + 50_000)
        assert both.rig.dev.pins()[9].rising == snap.pulses  # nothing after the stop
        both.rig.command(START_NOW, 0)  # the rest of the queue


def test_detached_step_pin_counts_without_pulses(both):
    both.rig.command(DETACH, 0, 1)
    both.entry(0, 20, 1000)
    both.rig.command(START_NOW, 0)
    both.rig.run_to_tick(both.rig.tick() + 40_000)
    snap = both.rig.snapshot(0)
    assert snap.pulses == 20 and snap.pulse_pos == 20
    assert both.rig.dev.pins()[9].rising == 0


def test_pulse_counter_wraps_at_its_limits(both):
    both.rig.command(PCNT, 0, PCNT_ON | PCNT_DIR_HIGH_UP, pcnt=(-7, 5))
    both.entry(0, 13, 800, up=True, level=True)  # 13 up: 13 % 5 = 3
    both.entry(0, 9, 800, up=False, level=False)  # 9 down: 3 - 9 = -6
    both.rig.command(START_NOW, 0)
    both.rig.run_to_tick(both.rig.tick() + 30_000)
    assert both.rig.snapshot(0).pcnt == -6
    both.entry(0, 1, 800, up=False, level=False)  # -7 is the low limit: back to 0
    both.rig.command(START_NOW, 0)
    both.rig.run_to_tick(both.rig.tick() + 5_000)
    assert both.rig.snapshot(0).pcnt == 0


# ------------------------------------------------------- limit switches (issue 13)
def test_an_entry_towards_a_closed_limit_makes_no_pulse_as_the_model(both):
    """While a switch is closed the compare interrupt checks every entry as it
    begins: the down entry runs, the up entry after it does not make one pulse."""
    both.dir_pin(0, 5, 0)
    both.block(0, LB_UP)
    both.entry(0, 10, 900, up=False, level=False)
    both.entry(0, 5, 900, up=True, toggle=True, level=True)
    both.start_at(0, both.rig.tick() + 2000)
    both.run_to_tick(both.rig.tick() + 40_000)
    fw, py = _compare(both, 9)
    assert len(fw) == len(py) == 10
    assert {f - p for f, p in zip(fw, py, strict=True)} == {SIM_COMPARE_OFFSET}
    count, ch, up, tick = both.rig.hits()
    assert (count, ch, up) == (1, 0, 1)
    assert fw[-1] < tick < fw[-1] + 900  # at the last pulse's interrupt, not later
    snap = both.rig.snapshot(0)
    assert snap.state == 0 and snap.pulses == 10 and snap.pulse_pos == -10
    # the entry that began toggled the direction pin (as the model's interrupt does)
    assert both.rig.dev.pins()[5].level == both.model.machine.pins.get(5) == 1


def test_a_start_towards_a_closed_limit_makes_no_pulse(both):
    both.block(0, LB_UP)
    both.entry(0, 5, 900, up=True)
    both.rig.command(START_NOW, 0)
    both.run_to_tick(both.rig.tick() + 20_000)
    assert both.rig.dev.pins()[9].rising == 0
    assert both.rig.hits()[:3] == (1, 0, 1)
    both.block(0, 0)  # the switch opens: the same entry runs
    both.rig.command(START_NOW, 0)
    both.run_to_tick(both.rig.tick() + 20_000)
    assert both.rig.dev.pins()[9].rising == 5


@pytest.mark.parametrize("phase", [0, 5, 20, 33, 100, 320, 600])
def test_a_limit_stop_takes_the_channel_off_before_its_next_pulse(both, phase):
    """The pin-change interrupt's stop at any moment of a step period: every pulse
    that began is finished and counted; none comes later than the stop's compare
    lead (HALT_LEAD, 32 ticks) after it."""
    both.entry(0, 255, 640)
    both.rig.command(START_NOW, 0)
    both.rig.run_to_tick(both.rig.tick() + 20 * 640 + phase)
    both.rig.command(HALT, 0, 1)
    count, _ch, _up, tick = both.rig.hits()
    assert count == 1
    snap = both.rig.snapshot(0)
    pins = both.rig.dev.pins()[9]
    assert snap.state == 0 and snap.pulses == pins.rising == pins.falling
    both.rig.run_to_tick(both.rig.tick() + 20_000)
    rising = both.rig.dev.trace().rising(9)
    assert len(rising) == snap.pulses and rising[-1] <= tick + 32
