"""10 - speed changes around 64 us/step (issue #44).

64 us, a = 1000, run forward.  Once at 64 us set a = 1e8 and every 200 ms switch
between 64 us and 64+d us, 11 times per d, for d = 0, 1, -1, 2, -2 ... +-24
(printing "Speed changes 64us <=> <64+d>us"); then a = 1000 and stop.
"""

from __future__ import annotations

from ... import messages as msg
from . import elapsed


def run(app, stepper, slot, time_ms: int, *, period_ms: int, move_to: int | None,
        accel_fast: int, d_end: int) -> bool:
    state = slot.state
    if state == 0:
        stepper.set_speed_in_us(64)
        stepper.set_acceleration(1000)
        if move_to is None:
            stepper.run_forward()
        else:
            stepper.move_to(move_to)
        slot.u32_1 = time_ms
        slot.state += 1
    elif state == 1:
        if stepper.get_period_in_us_after_commands_completed() == 64:
            stepper.set_acceleration(accel_fast)
            slot.s16_1 = 0
            slot.s16_2 = 0
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 2:
        if elapsed(time_ms, slot.u32_1) >= period_ms:
            stepper.set_speed_in_us((64 + slot.s16_1) & 0xFFFFFFFF)
            stepper.apply_speed_acceleration()
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 3:
        if elapsed(time_ms, slot.u32_1) >= period_ms:
            stepper.set_speed_in_us(64)
            stepper.apply_speed_acceleration()
            slot.u32_1 = time_ms
            if slot.s16_2 < 10:
                slot.s16_2 += 1
                slot.state = 2
            else:
                slot.s16_1 = -slot.s16_1
                slot.s16_2 = 0
                if slot.s16_1 >= 0:
                    slot.s16_1 += 1
                if slot.s16_1 >= d_end:
                    slot.state = 4
                    stepper.set_acceleration(1000)
                    stepper.apply_speed_acceleration()
                    stepper.stop_move()
                else:
                    app.print(msg.SPEED_CHANGES)
                    app.print_number((64 + slot.s16_1) & 0xFFFF)
                    app.println("us")
                    slot.state = 2
    elif state == 4 and not stepper.is_running():
        return True
    if slot.state in (2, 3):
        slot.wait_time(slot.u32_1, period_ms)
    elif slot.state == 1:
        slot.wait_machine()  # the planned period reaching 64 us
    elif slot.state == 4:
        slot.wait_stop()
    else:
        slot.busy()
    return False


def step(app, stepper, slot, time_ms: int) -> bool:
    return run(app, stepper, slot, time_ms, period_ms=200, move_to=None,
               accel_fast=100_000_000, d_end=25)
