"""12 - like 10, towards position 10 000 000 with 20 ms switching (issue #103).

a = 10 000 while switching; endless in practice (stop it with `x`).
"""

from __future__ import annotations

from . import seq10


def step(app, stepper, slot, time_ms: int) -> bool:
    return seq10.run(app, stepper, slot, time_ms, period_ms=20, move_to=10_000_000,
                     accel_fast=10_000, d_end=10_000)
