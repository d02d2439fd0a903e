"""StepperDemo's `T`: drive a stepper's pins directly, bypassing the library.

Enable the driver, set the direction, make 3200 steps (10 us high, 190 us low),
reverse the direction, 3200 steps back, disable.  Every pin write is read back; a
pin that does not follow prints an error line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fas.codes import PIN_UNDEFINED

from .. import messages as msg
from .build import DemoStepper

if TYPE_CHECKING:  # pragma: no cover
    from .app import StepperDemo

STEPS = 3200
HIGH_US = 10
LOW_US = 190


def _write_check(app: StepperDemo, pin: int, level: int, failure: str) -> None:
    b = app.backend
    b.write_pin(pin, level)
    b.app_spend(HIGH_US * app.profile.ticks_per_us)
    if b.read_pin(pin) != level:
        app.print(failure)


def _steps(app: StepperDemo, step_pin: int) -> None:
    b = app.backend
    low_ticks = LOW_US * app.profile.ticks_per_us
    for _ in range(STEPS):
        _write_check(app, step_pin, 1, msg.STEP_PIN_IS_NOT_HIGH)
        b.write_pin(step_pin, 0)
        b.app_spend(low_ticks)
        if b.read_pin(step_pin) != 0:
            app.print(msg.STEP_PIN_IS_NOT_LOW)


def _direction(app: StepperDemo, pin: int, level: int) -> None:
    b = app.backend
    b.write_pin(pin, level)
    b.app_spend(HIGH_US * app.profile.ticks_per_us)
    if b.read_pin(pin) != level:
        app.print(msg.CANNOT_SET_DIRECTION_PIN)
        app.println("HIGH" if level else "LOW")


def test_direct_drive(app: StepperDemo, cfg: DemoStepper) -> None:
    if cfg.enable_low_active != PIN_UNDEFINED:
        _write_check(app, cfg.enable_low_active, 0, msg.ENABLE_LOW_PIN_IS_NOT_LOW)
    if cfg.enable_high_active != PIN_UNDEFINED:
        _write_check(app, cfg.enable_high_active, 1, msg.ENABLE_HIGH_PIN_IS_NOT_HIGH)
    if cfg.direction != PIN_UNDEFINED:
        up = 1 if cfg.direction_high_counts_up else 0
        _direction(app, cfg.direction, up)
        _steps(app, cfg.step)
        _direction(app, cfg.direction, 1 - up)
    _steps(app, cfg.step)
    if cfg.enable_low_active != PIN_UNDEFINED:
        _write_check(app, cfg.enable_low_active, 1, msg.ENABLE_LOW_PIN_IS_NOT_HIGH)
    if cfg.enable_high_active != PIN_UNDEFINED:
        _write_check(app, cfg.enable_high_active, 0, msg.ENABLE_HIGH_PIN_IS_NOT_LOW)
