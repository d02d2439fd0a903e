"""07 - timing of move_by_acceleration (start at position 0).

40 us/step, accelerate +30 000 steps/s^2: print the ms until COAST (pass if within
792 +- 40); accelerate -30 000 for 3 s; +40 000 for 1 s; move to 0 and print the ms
until standstill (pass if within 1495 +- 30) and the final position (pass if 0).
"""

from __future__ import annotations

from fas.codes import RAMP_STATE_MASK, RampState

from . import TEST_STATE_ERROR, elapsed

COAST_MS, COAST_TOL = 792, 40
HOME_MS, HOME_TOL = 1495, 30


def _signed(v: int) -> int:
    return v - 0x100000000 if v & 0x80000000 else v


def step(app, stepper, slot, time_ms: int) -> bool:
    state = slot.state
    if state == 0:
        stepper.set_speed_in_us(40)
        stepper.move_by_acceleration(30_000)
        slot.u32_1 = time_ms
        slot.state += 1
    elif state == 1:
        if (stepper.ramp_state() & RAMP_STATE_MASK) == RampState.COAST:
            dt = _signed(elapsed(time_ms, slot.u32_1))
            app.println_number(dt)
            if abs(dt - COAST_MS) > COAST_TOL:
                slot.state = TEST_STATE_ERROR
                return True
            stepper.move_by_acceleration(-30_000)
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 2:
        if elapsed(time_ms, slot.u32_1) >= 3000:
            stepper.move_by_acceleration(40_000)
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 3:
        if elapsed(time_ms, slot.u32_1) >= 1000:
            stepper.move_to(0)
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 4 and not stepper.is_running():
        dt = _signed(elapsed(time_ms, slot.u32_1))
        app.println_number(dt)
        if abs(dt - HOME_MS) > HOME_TOL:
            slot.state = TEST_STATE_ERROR
        pos = stepper.get_position_after_commands_completed()
        app.println_number(pos)
        if pos != 0:
            slot.state = TEST_STATE_ERROR
        return True
    if slot.state == 2:
        slot.wait_time(slot.u32_1, 3000)
    elif slot.state == 3:
        slot.wait_time(slot.u32_1, 1000)
    elif slot.state == 1:
        slot.wait_machine()  # the ramp reaching COAST
    elif slot.state == 4:
        slot.wait_stop()
    else:
        slot.busy()
    return False
