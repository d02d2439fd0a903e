"""One stepper on a recording simulated chip (a 328p unless told), and what its pins did."""

from __future__ import annotations

from fas import Engine
from fas.sim import SimBackend
from rigs.pins import periods, position_by_pins
from stepperdemo.demo.build import demo_build


def make(profile: str = "atmega328p", *, record: bool = True, dir_pin: int = 5,
         enable_pin: int | None = 6, step_pin: int | None = None, auto_enable: bool = True):
    """(backend, engine, stepper): one stepper on ``profile``'s simulated chip, on the
    step pin of StepperDemo's first stepper there unless ``step_pin`` is given."""
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
    """Run the chip until ``stepper`` stands; fail if it still runs after ``limit_s``."""
    ok = backend.wait_until(lambda: not stepper.is_running(),
                            int(limit_s * backend.profile.ticks_per_s))
    assert ok, "stepper did not come to rest"


def rising(backend, pin: int) -> list[int]:
    """The recorded rising edges of ``pin`` (ticks)."""
    return backend.recorder.rising(pin)


def pin_position(backend, step_pin: int, dir_pin: int, high_counts_up: bool = True) -> int:
    """Position counted from the recorded step and direction edges."""
    return position_by_pins(backend.recorder.pin_edges, step_pin, dir_pin, high_counts_up)


__all__ = ["make", "periods", "pin_position", "rising", "run_until_idle"]
