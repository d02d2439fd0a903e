"""01 - the clock: a second hand for one minute, then back home.

40 us/step, a = 1 000 000.  Once per second move +53, +53, +54 (3200 steps per
minute); after 60 moves switch to 1000 us/step, a = 10 000 and move -3200.  Done
when the stepper stands still again.
"""

from __future__ import annotations

from . import elapsed


def step(app, stepper, slot, time_ms: int) -> bool:
    phase = slot.state & 15
    if phase == 0:
        stepper.set_speed_in_us(40)
        stepper.set_acceleration(1_000_000)
        slot.u32_1 = time_ms
        slot.state += 1
    elif phase in (1, 3, 5):
        if elapsed(time_ms, slot.u32_1) >= 1000:
            slot.state += 1
            if (slot.state >> 4) == 60 // 3:
                slot.state = 7
    elif phase in (2, 4):
        slot.u32_1 = (slot.u32_1 + 1000) & 0xFFFFFFFF
        stepper.move(53)
        slot.state += 1
    elif phase == 6:
        slot.u32_1 = (slot.u32_1 + 1000) & 0xFFFFFFFF
        stepper.move(54)
        slot.state = (slot.state & 0xFFF0) + 17
    elif phase == 7:
        stepper.set_speed_in_us(1000)
        stepper.set_acceleration(10_000)
        stepper.move(-3200)
        slot.state += 1
    elif phase == 8 and not stepper.is_running():
        return True
    phase = slot.state & 15
    if phase in (1, 3, 5):
        slot.wait_time(slot.u32_1, 1000)
    elif phase == 8:
        slot.wait_stop()
    else:
        slot.busy()
    return False
