"""06 - 32 000 steps with the speed switched every 100 ms (issue #24).

100 us/step, a = 10 000, move +32 000; every 100 ms alternate 90 us and 100 us
with apply_speed_acceleration(); once stopped, move -32 000 at 100 us.  Fails if
the position after the queued commands ever exceeds 32 000.
"""

from __future__ import annotations

from . import TEST_STATE_ERROR, elapsed

SPEED_1_US = 100
SPEED_2_US = 90
SPEED_HOME_US = 100


def step(app, stepper, slot, time_ms: int) -> bool:
    if stepper.get_position_after_commands_completed() > 32000:
        slot.state = TEST_STATE_ERROR
        return True
    state = slot.state
    if state == 0:
        stepper.set_speed_in_us(SPEED_1_US)
        stepper.set_acceleration(10_000)
        stepper.move(32000)
        slot.u32_1 = time_ms
        slot.state += 1
    elif state == 1:
        if elapsed(time_ms, slot.u32_1) >= 100:
            stepper.set_speed_in_us(SPEED_2_US)
            stepper.apply_speed_acceleration()
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 2:
        if elapsed(time_ms, slot.u32_1) >= 100:
            stepper.set_speed_in_us(SPEED_1_US)
            stepper.apply_speed_acceleration()
            slot.u32_1 = time_ms
            slot.state -= 1
        if not stepper.is_running():
            slot.state = 3
    elif state == 3:
        stepper.set_speed_in_us(SPEED_HOME_US)
        stepper.move(-32000)
        slot.state += 1
    elif state == 4 and not stepper.is_running():
        return True
    if slot.state in (1, 2):
        slot.wait_time(slot.u32_1, 100)
    elif slot.state == 4:
        slot.wait_stop()
    else:
        slot.busy()
    return False
