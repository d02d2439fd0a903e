"""13 - raw queue entries (issue #113).

Auto enable off, outputs on, then four raw commands of one step at 50 000 ticks
(retrying while the queue asks for it); 20 ms after the last one the position must be
4, else "not all raw commands executed".
"""

from __future__ import annotations

from fas.codes import AqeResult

from ... import messages as msg
from . import TEST_STATE_ERROR, elapsed


def step(app, stepper, slot, time_ms: int) -> bool:
    state = slot.state
    if state in (0, 1, 2, 3):
        if state == 0:
            stepper.set_auto_enable(False)
            stepper.enable_outputs()
        res = stepper.add_queue_entry(50000, 1, True)
        if res.retry if isinstance(res, AqeResult) else res > 0:
            app.print_number(int(res) & 0xFF)
            app.print(" ")
        else:
            slot.u32_1 = time_ms
            slot.state += 1
    elif state == 4 and elapsed(time_ms, slot.u32_1) >= 20:
        if stepper.get_current_position() != 4:
            app.println(msg.NOT_ALL_RAW_EXECUTED)
            slot.state = TEST_STATE_ERROR
        return True
    if slot.state == 4:
        slot.wait_time(slot.u32_1, 20)
    else:
        slot.busy()
    return False
