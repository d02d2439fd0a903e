"""``move_timed``: a given number of steps spread evenly over a given time.

The intermediate level between the ramp generator and the raw queue (upstream issue
#299): the application plans in small time slices - each call appends ``steps``
(signed, the direction) to be made within ``duration`` ticks, bypassing the ramp
generator.  Because the ticks per step are whole numbers, the queued time may fall
short of ``duration`` by a few ticks; the result says how long the queued commands
really last, so that the caller can carry the difference into its next slice.

The arithmetic follows upstream's, C integer types included, so that the same calls
give the same queue entries:

* ``steps == 0``: a pause, split into commands of at most 65535 ticks;
* slow steps (more than 65535 ticks apart): one step followed by pauses, per step;
* otherwise: commands of up to 255 steps at ``duration // steps`` ticks, the last
  ``duration % steps`` steps one tick slower (the remainder is spread once, over the
  tail), so that the slice lasts as long as asked.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from .codes import AqeResult, MoveTimedResult, tmr_from

if TYPE_CHECKING:  # pragma: no cover
    from .stepper import Stepper

MAX_TICKS = 65535


class TimedMove(NamedTuple):
    """What ``move_timed`` did: the result code and the ticks actually queued."""

    result: MoveTimedResult
    actual_duration: int


def _split_pause(ticks: int) -> int:
    """Ticks of the next command of a long pause (upstream's chunking)."""
    if ticks <= MAX_TICKS:
        return ticks
    if ticks >= 2 * (MAX_TICKS + 1):
        return MAX_TICKS
    return ticks >> 1  # the rest in two halves, both within 16 bits


def move_timed(stepper: Stepper, steps: int, duration: int, start: bool = True) -> TimedMove:
    if not -32767 <= steps <= 32767:
        raise ValueError(f"move_timed: steps must fit int16 (-32767..32767), got {steps}")
    if not 0 <= duration <= 0xFFFFFFFF:
        raise ValueError(f"move_timed: duration must be 0..2^32-1 ticks, got {duration}")
    queue_len = stepper.queue.queue_len
    ok = MoveTimedResult.MOVE_EMPTY if stepper.is_queue_empty() else MoveTimedResult.OK
    if steps == 0 and duration == 0:
        if start:
            stepper.add_queue_entry(None, start=True)
        return TimedMove(ok, 0)
    free_entries = queue_len - stepper.queue_entries()
    actual = 0

    if steps == 0:
        if (duration >> 16) >= queue_len:
            return TimedMove(MoveTimedResult.ERROR_MOVE_TOO_LARGE, 0)
        if (duration >> 16) >= free_entries:
            return TimedMove(MoveTimedResult.MOVE_BUSY, 0)
        while duration > 0:
            ticks = _split_pause(duration)
            res = stepper.add_queue_entry(ticks, 0, True, start=start)
            if res != AqeResult.OK:
                return TimedMove(tmr_from(res), actual)
            actual += ticks
            duration -= ticks
        return TimedMove(ok, actual)

    count_up = steps > 0
    steps = abs(steps)
    rate = duration // steps
    if rate > MAX_TICKS:
        # slow: every step is one command with a step, then pauses
        cmds_per_step = (rate >> 16) + 1
        if cmds_per_step >= queue_len or steps >= queue_len:
            return TimedMove(MoveTimedResult.ERROR_MOVE_TOO_LARGE, 0)
        cmds = (steps * cmds_per_step) & 0xFF  # upstream keeps this in a uint8_t
        if cmds >= queue_len:
            return TimedMove(MoveTimedResult.ERROR_MOVE_TOO_LARGE, 0)
        if cmds > free_entries:
            return TimedMove(MoveTimedResult.MOVE_BUSY, 0)
        for _ in range(steps):
            left = rate
            n_steps = 1
            while left:
                ticks = _split_pause(left)
                left -= ticks
                res = stepper.add_queue_entry(ticks, n_steps, count_up, start=start)
                if res != AqeResult.OK:
                    return TimedMove(tmr_from(res), actual)
                actual += ticks
                n_steps = 0
        return TimedMove(ok, actual)

    if steps > queue_len * 255:
        return TimedMove(MoveTimedResult.ERROR_MOVE_TOO_LARGE, 0)
    if steps > free_entries * 255:
        return TimedMove(MoveTimedResult.MOVE_BUSY, 0)
    ticks = rate
    missing = duration - rate * steps  # < steps: spread over the tail, one tick each
    while steps > 0:
        if steps > 510:
            n = 255
        elif steps > 255:
            n = steps // 2
        else:
            n = steps
        if steps <= missing:
            ticks += 1  # from here on one tick slower: the slice keeps its length
            missing = 0
        res = stepper.add_queue_entry(ticks, n, count_up, start=start)
        if res != AqeResult.OK:
            return TimedMove(tmr_from(res), actual)
        actual += ticks * n
        steps -= n
    return TimedMove(ok, actual)
