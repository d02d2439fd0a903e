"""A command that arrives while the channel waits out the last command's period.

The queue has run dry after a step; the channel still waits for that command's period
to end ("no more commands") and then takes up what arrived meanwhile, as the AVR's
step interrupt does.  That interrupt writes the next compare 10 ticks after the old
one, which has passed by then: the AVR timer matches it only after it wraps (4.1 ms);
a profile without a modelled wrap (SAM Due, ESP32, Pico) matches it at once.  Either
way the pulse comes after the interrupt that decided it, so after the direction
toggle that interrupt writes (found by fuzzing: `t 05 13 R 03 05 00 09 x` on the SAM
Due put the pulse 32 ticks before that interrupt and its direction edge inside the
pulse, and the pins counted the backward step forward).
"""

import pytest

from rigs.sim import make, pin_position, run_until_idle
from stepperdemo.demo.build import demo_build

PERIOD_TICKS = 50_000
DIR_PIN = 5


def _pulses(backend, step_pin: int) -> list[tuple[int, int]]:
    times, levels = backend.recorder.pin_edges(step_pin)
    rises = [t for t, lv in zip(times, levels, strict=True) if lv]
    falls = [t for t, lv in zip(times, levels, strict=True) if not lv]
    assert len(rises) == len(falls)
    return list(zip(rises, falls, strict=True))


@pytest.mark.parametrize("arch", ["sam_due", "esp32", "rp2040", "atmega328p"])
def test_reversal_queued_during_the_dry_wait_steps_after_its_direction_edge(arch):
    backend, _, s = make(arch, dir_pin=DIR_PIN, enable_pin=None, auto_enable=False)
    step_pin = demo_build(backend.profile).steppers[0].step
    assert s.add_queue_entry(PERIOD_TICKS, 1, True) == 0
    start = backend.now()
    backend.run_for(PERIOD_TICKS // 2)  # the step is done, its period still runs
    assert s.queue.queue_entries() == 0 and s.queue.is_running()
    assert s.add_queue_entry(PERIOD_TICKS, 1, False) == 0  # back: a direction toggle
    run_until_idle(backend, s)

    pulses = _pulses(backend, step_pin)
    assert len(pulses) == 2
    dtimes, _ = backend.recorder.pin_edges(DIR_PIN)
    toggles = [t for t in dtimes if t > start]
    assert len(toggles) == 1
    toggle = toggles[0]
    # the direction edge lies between the pulses, never inside one
    (rise1, fall1), (rise2, _) = pulses
    assert fall1 <= toggle <= rise2
    # the second step keeps the first command's period
    assert rise2 - rise1 >= PERIOD_TICKS
    # and the pins count what the library reports
    assert s.get_current_position() == 0
    assert pin_position(backend, step_pin, DIR_PIN) == 0
