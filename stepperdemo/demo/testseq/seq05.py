"""05 - 800 single steps, one every 200 ms, then 800 steps back in one move.

40 us/step, a = 1 000 000 for the single steps; 1000 us/step, a = 10 000 back.
"""

from __future__ import annotations

from . import elapsed

DT_MS = 200


def step(app, stepper, slot, time_ms: int) -> bool:
    phase = slot.state & 15
    if phase == 0:
        stepper.set_speed_in_us(40)
        stepper.set_acceleration(1_000_000)
        slot.u32_1 = time_ms
        slot.state += 1
    elif phase == 1:
        if elapsed(time_ms, slot.u32_1) >= DT_MS:
            if (slot.state & 0xFFF0) == 16 * 800:
                slot.state = 7
                stepper.set_speed_in_us(1000)
                stepper.set_acceleration(10_000)
                stepper.move(-800)
            else:
                slot.state += 1
    elif phase == 2:
        slot.u32_1 = (slot.u32_1 + DT_MS) & 0xFFFFFFFF
        stepper.move(1)
        slot.state += 16 - 1
    elif phase == 7 and not stepper.is_running():
        return True
    phase = slot.state & 15
    if phase == 1:
        slot.wait_time(slot.u32_1, DT_MS)
    elif phase == 7:
        slot.wait_stop()
    else:
        slot.busy()
    return False
