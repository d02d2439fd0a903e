"""Small helpers shared by the fas tests: a 328p stepper on a recording simulator."""

from __future__ import annotations

from bisect import bisect_right

from fas import Engine
from fas.sim import SimBackend
from stepperdemo.demo.build import demo_build


def make(profile: str = "atmega328p", *, record: bool = True, dir_pin: int = 5,
         enable_pin: int | None = 6, step_pin: int | None = None, auto_enable: bool = True):
    backend = SimBackend(profile, record=record)
    engine = Engine(backend)
    engine.init()
    pin = step_pin if step_pin is not None else demo_build(backend.profile).steppers[0].step
    stepper = engine.stepper_connect_to_pin(pin)
    assert stepper is not None
    if dir_pin is not None:
        stepper.set_direction_pin(dir_pin)
    if enable_pin is not None:
        stepper.set_enable_pin(enable_pin)
    stepper.set_auto_enable(auto_enable)
    return backend, engine, stepper


def run_until_idle(backend, stepper, limit_s: float = 600) -> None:
    ok = backend.wait_until(lambda: not stepper.is_running(),
                            int(limit_s * backend.profile.ticks_per_s))
    assert ok, "stepper did not come to rest"


def rising(backend, pin: int) -> list[int]:
    return backend.recorder.rising(pin)


def pin_position(backend, step_pin: int, dir_pin: int, high_counts_up: bool = True) -> int:
    """Position counted from the recorded step and direction edges."""
    times, levels = backend.recorder.pin_edges(step_pin)
    dtimes, dlevels = backend.recorder.pin_edges(dir_pin)
    pos = 0
    for t, lv in zip(times, levels):
        if not lv:
            continue
        i = bisect_right(dtimes, t) - 1
        level = dlevels[i] if i >= 0 else 0
        pos += 1 if (level == 1) == high_counts_up else -1
    return pos


def periods(times: list[int]) -> list[int]:
    return [b - a for a, b in zip(times, times[1:])]
