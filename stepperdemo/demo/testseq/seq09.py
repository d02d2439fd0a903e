"""09 - endless: random runs ended by a forced stop with a new position.

Random speed/acceleration, run forward or backward for 1 s, then
force_stop_and_new_position(0).  Once stopped, print the steps the pulse counter saw
after the stop command ("Steps needed for stop="); 100 ms later any further pulse
prints "Step AFTER stop".  Runs until `x`.  As compiled for a chip without a pulse
counter (AVR, SAM, Pico, some ESP32 builds) it only runs and stops, printing no
counter lines.
"""

from __future__ import annotations

from ... import messages as msg
from . import elapsed, start_with_pulse_counter

VMIN, VMAX = 40, 16384
AMIN, AMAX = 10, 4 * 65536


def _i16(v: int) -> int:
    v &= 0xFFFF
    return v - 0x10000 if v & 0x8000 else v


def step(app, stepper, slot, time_ms: int) -> bool:
    counter = app.profile.has_pulse_counter  # without one, no counter lines
    state = slot.state
    if state == 0:
        if start_with_pulse_counter(app, stepper, slot, time_ms):
            return True
    elif state == 1:
        if not stepper.is_running():
            rand = slot.rng.rand
            speed = rand() % (VMAX * 4)
            speed = (speed >> ((speed % 4) + 2)) + VMIN
            accel = rand() % (AMAX * 4)
            accel = (accel >> ((accel % 4) + 2)) + AMIN
            app.print(msg.SEQ_SPEED)
            app.print_number(speed)
            app.print(msg.SEQ_ACCEL)
            app.println_number(accel)
            stepper.set_speed_in_us(speed)
            stepper.set_acceleration(accel)
            if rand() & 1:
                stepper.run_forward()
            else:
                stepper.run_backward()
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 2:
        if elapsed(time_ms, slot.u32_1) >= 1000:
            if counter:
                slot.s16_1 = stepper.read_pulse_counter()
            stepper.force_stop_and_new_position(0)
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 3:
        if not stepper.is_running():
            if counter:
                old = slot.s16_1
                slot.s16_1 = stepper.read_pulse_counter()
                needed = _i16(old - slot.s16_1) & 0xFFFF
                app.print(msg.STEPS_NEEDED_FOR_STOP)
                app.println_number(needed)
                slot.log.append({"t_ms": time_ms, "steps_for_stop": needed, "after_stop": 0})
            slot.state += 1
    elif state == 4 and elapsed(time_ms, slot.u32_1) >= 100:
        if counter and slot.s16_1 != stepper.read_pulse_counter():
            app.println(msg.STEP_AFTER_STOP)
            if slot.log:
                slot.log[-1]["after_stop"] = 1
        slot.u32_1 = time_ms
        slot.state = 1
    if slot.state == 2:
        slot.wait_time(slot.u32_1, 1000)
    elif slot.state == 4:
        slot.wait_time(slot.u32_1, 100)
    elif slot.state in (1, 3):
        slot.wait_stop()
    else:
        slot.busy()
    return False
