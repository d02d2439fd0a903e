"""02 - out and back with growing distances.

40 us/step, a = 1000; n = 1; repeat: move +n, wait for standstill, move -n, wait;
finish when n >= 6400, else n += 1 and n += n >> 2.  03 and 04 are this sequence
with a = 10 000 and a = 100 000.
"""

from __future__ import annotations


def start(stepper, slot, acceleration: int) -> None:
    stepper.set_speed_in_us(40)
    stepper.set_acceleration(acceleration)
    slot.u32_1 = 1
    slot.state += 1


def step(app, stepper, slot, time_ms: int) -> bool:
    steps = slot.u32_1
    state = slot.state
    if state == 0:
        start(stepper, slot, 1000)
    elif state == 1:
        stepper.move(steps)
        slot.state += 1
    elif state == 3:
        stepper.move(-steps)
        slot.state += 1
    elif state in (2, 4):
        if not stepper.is_running():
            slot.state += 1
    elif state == 5:
        if slot.u32_1 >= 6400:
            return True
        slot.u32_1 += 1
        slot.u32_1 += slot.u32_1 >> 2
        slot.state = 1
    if slot.state in (2, 4):
        slot.wait_stop()
    else:
        slot.busy()
    return False
