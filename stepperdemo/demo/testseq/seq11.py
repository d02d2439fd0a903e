"""11 - the position never steps backwards (issue #68).

Must start at position 0.  43 us/step, a = 10 000, move to 1 000 000 and back to 0.
While moving, every loop pass reads the position 1001 times and fails on any step
against the direction of travel (printing the offending readings and stopping).

In the simulation a pass costs the CPU time of 1001 position reads; the position is
sampled at 11 evenly spaced instants of that time (any step backwards between two
samples would show as a backwards difference between them).
"""

from __future__ import annotations

from ... import messages as msg
from . import TEST_STATE_ERROR

READS_PER_PASS = 1001
SAMPLES_PER_PASS = 11


def _check(app, stepper, slot, going_up: bool) -> bool:
    backend = app.backend
    prev_pos = slot.s32_1
    # the reads' CPU time (DemoBuild.position_read_ticks; with the loop's sections
    # followed, DemoBuild.loop_sections, as measured on the AVR with the reads' own
    # critical sections, position_read_poll: one read per section)
    build = app.build
    poll = build.position_read_poll if build.loop_sections else None
    read_ticks = build.position_read_ticks if poll is None else poll[0] // len(poll[1])
    chunk = read_ticks * (READS_PER_PASS // (SAMPLES_PER_PASS - 1))
    for k in range(SAMPLES_PER_PASS):
        i = k * (READS_PER_PASS // (SAMPLES_PER_PASS - 1))
        pos = stepper.get_current_position()
        backwards = pos < slot.s32_1 if going_up else pos > slot.s32_1
        if backwards:
            app.print(msg.SEQ_I)
            app.print_number(i)
            if i != 0:
                app.print(msg.SEQ_PREV_POS)
                app.print_number(prev_pos)
            app.print(msg.SEQ_OLD_POS)
            app.print_number(slot.s32_1)
            app.print(msg.SEQ_CURR_POS)
            app.println_number(pos)
            stepper.stop_move()
            slot.state = TEST_STATE_ERROR
            return False
        prev_pos = slot.s32_1
        slot.s32_1 = pos
        if k < SAMPLES_PER_PASS - 1:
            if poll is None:
                backend.app_spend(chunk)
            else:
                backend.app_spend_in(chunk, poll)
    return True


def step(app, stepper, slot, time_ms: int) -> bool:
    state = slot.state
    slot.busy()
    if state == 0:
        slot.s32_1 = stepper.get_current_position()
        if slot.s32_1 != 0:
            slot.state = TEST_STATE_ERROR
            return True
        stepper.set_speed_in_us(43)
        stepper.set_acceleration(10_000)
        stepper.move_to(1_000_000)
        slot.state += 1
    elif state == 1:
        if not stepper.is_running():
            stepper.move_to(0)
            slot.state += 1
            return False
        if not _check(app, stepper, slot, True):
            return True
    elif state == 2:
        if not stepper.is_running():
            return True
        if not _check(app, stepper, slot, False):
            return True
    return False
