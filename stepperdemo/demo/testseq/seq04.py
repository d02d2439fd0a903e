"""04 - sequence 02 with acceleration 100 000 steps/s^2."""

from __future__ import annotations

from . import seq02


def step(app, stepper, slot, time_ms: int) -> bool:
    seq02.start(stepper, slot, 100_000)
    slot.test = seq02.step
    slot.busy()
    return False
