"""08 - endless: random moves checked against an independent pulse counter.

Moves of random speed (40 us .. ~16 ms/step) and acceleration meant to take about a
second, alternating direction by the move's bit 1.  Whenever the stepper stands
still, the pulse counter (attached with limits -16384/16384) must agree with the
position modulo 2^14; a mismatch prints both and fails.  Runs until `x`.  On a chip
without a pulse counter the firmware compiles it empty: it ends at once
(:func:`stepperdemo.demo.testseq.sequences_for`).
"""

from __future__ import annotations

from ... import messages as msg
from . import TEST_STATE_ERROR, start_with_pulse_counter

VMIN, VMAX = 40, 16384
AMIN, AMAX = 10, 4 * 65536


def step(app, stepper, slot, time_ms: int) -> bool:
    if slot.state == 0:
        if start_with_pulse_counter(app, stepper, slot, time_ms):
            return True
    elif slot.state == 1 and not stepper.is_running():
        pcnt = stepper.read_pulse_counter()
        spos = stepper.get_position_after_commands_completed()
        slot.log.append({"t_ms": time_ms, "position": spos, "counter": pcnt})
        if (pcnt & 0x3FFF) != (spos & 0x3FFF):
            app.print(msg.STEPPER_POS)
            app.print_number(spos)
            app.print(msg.REAL_POS)
            app.println_number(pcnt)
            slot.state = TEST_STATE_ERROR
            return True
        rand = slot.rng.rand
        speed = rand() % (VMAX * 4) & 0xFFFF
        speed = (speed >> ((speed % 4) + 2)) + VMIN
        accel = rand() % (AMAX * 4)
        accel = (accel >> ((accel % 4) + 2)) + AMIN
        move = 1_000_000 // speed
        if move & 2:
            move = -move
        app.print(msg.SEQ_SPEED)
        app.print_number(speed)
        app.print(msg.SEQ_ACCEL)
        app.print_number(accel)
        app.print(msg.SEQ_MOVE)
        app.println_number(move)
        stepper.set_speed_in_us(speed)
        stepper.set_acceleration(accel)
        stepper.move(move)
        slot.u32_1 = time_ms
    slot.wait_stop()
    return False
