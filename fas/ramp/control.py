"""One planning step of the ramp: the next queue command from the ramp state.

This is pure computation: given the target, the ramp's running state and the
position/direction at the end of the command queue, decide whether to accelerate,
coast, decelerate or reverse, how many steps the next command carries and at what
period.  It mirrors FastAccelStepper's ``_getNextCommand`` decision for decision,
with C's unsigned 16/32-bit arithmetic, because the conformance data shows its
exact integer results (step counts, periods, the moment a ramp turns).
"""

from __future__ import annotations

from ..codes import (
    PATH_CHECK,
    PATH_COAST,
    PATH_DEC,
    PATH_NEAR,
    RAMP_DIRECTION_COUNT_DOWN,
    RAMP_DIRECTION_COUNT_UP,
    RAMP_STATE_ACCELERATING_FLAG,
    RAMP_STATE_DECELERATING_FLAG,
    TICKS_FOR_STOPPED_MOTOR,
    RampState,
)
from .calculator import RampConfig

_IDLE = int(RampState.IDLE)
_COAST = int(RampState.COAST)
_ACCELERATE = int(RampState.ACCELERATE)
_DECELERATE = int(RampState.DECELERATE)
_REVERSE = int(RampState.REVERSE)
_ACC_FLAG = RAMP_STATE_ACCELERATING_FLAG
_DEC_FLAG = RAMP_STATE_DECELERATING_FLAG


class RampRw:
    """The ramp task's running state (upstream ``ramp_rw_s``)."""

    __slots__ = ("ramp_state", "performed_ramp_up_steps", "pause_ticks_left", "curr_ticks")

    def __init__(self) -> None:
        self.init()

    def init(self) -> None:
        self.ramp_state = _IDLE
        self.performed_ramp_up_steps = 0
        self.pause_ticks_left = 0
        self.curr_ticks = TICKS_FOR_STOPPED_MOTOR

    def copy(self) -> "RampRw":
        other = RampRw.__new__(RampRw)
        other.ramp_state = self.ramp_state
        other.performed_ramp_up_steps = self.performed_ramp_up_steps
        other.pause_ticks_left = self.pause_ticks_left
        other.curr_ticks = self.curr_ticks
        return other

    def start_ramp_if_not_running(self) -> None:
        if self.ramp_state == _IDLE:
            self.curr_ticks = TICKS_FOR_STOPPED_MOTOR
            self.ramp_state = _ACCELERATE


class NextCommand:
    """A queue command plus the ramp state that holds once it is queued."""

    __slots__ = ("ticks", "steps", "count_up", "rw", "path")

    def __init__(self, ticks: int, steps: int, count_up: bool, rw: RampRw,
                 path: int = 0) -> None:
        self.ticks = ticks
        self.steps = steps
        self.count_up = count_up
        self.rw = rw
        #: the branches the planning took (fas.codes.PATH_* bits; a backend whose CPU time
        #: follows the library's arithmetic reads them)
        self.path = path

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"NextCommand(ticks={self.ticks}, steps={self.steps}, "
                f"count_up={self.count_up}, state={self.rw.ramp_state})")


def _complete(rw: RampRw) -> NextCommand:
    out = rw.copy()
    out.pause_ticks_left = 0
    out.ramp_state = _IDLE
    out.curr_ticks = TICKS_FOR_STOPPED_MOTOR
    return NextCommand(0, 0, True, out)


def next_command(config: RampConfig, target_pos: int, rw: RampRw, qe_pos: int,
                 qe_count_up: bool, ticks_per_s: int, min_cmd_ticks: int) -> NextCommand:
    """Plan the next command.  ``ticks == 0`` in the result means the ramp is done."""
    # a pause left over from a slow step
    pause_ticks = rw.pause_ticks_left
    if pause_ticks > 0:
        if pause_ticks > 65535:
            pause_ticks = min(pause_ticks >> 1, 65535)
        out = rw.copy()
        out.pause_ticks_left -= pause_ticks
        return NextCommand(pause_ticks, 0, qe_count_up, out)

    params = config.parameters
    count_up = qe_count_up
    if params.keep_running:
        need_count_up = params.keep_running_count_up
        remaining_steps = 0xFFFFFFF
    else:
        delta = (target_pos - qe_pos) & 0xFFFFFFFF
        if delta & 0x80000000:
            delta -= 0x100000000
        # delta 0 is an overshoot: reverse the current direction
        need_count_up = not count_up if delta == 0 else delta > 0
        remaining_steps = abs(delta)

    prus = rw.performed_ramp_up_steps
    if prus == 0:
        count_up = need_count_up

    if remaining_steps == 0 and prus <= 1:
        return _complete(rw)

    curr_ticks = rw.curr_ticks
    min_travel_ticks = params.min_travel_ticks
    path = 0

    # forward planning of 2 ms or more at slow speed
    if curr_ticks < ticks_per_s // 1000:
        planning_steps = ((ticks_per_s // 500) & 0xFFFF) // ((curr_ticks & 0xFFFF) or 1)
    else:
        planning_steps = 1
    orig_planning_steps = planning_steps

    if count_up != need_count_up:
        this_state = _REVERSE
        remaining_steps = prus
    elif remaining_steps == prus:
        this_state = _DECELERATE
    elif remaining_steps < prus:
        this_state = _REVERSE  # we will overshoot
        remaining_steps = prus
    elif min_travel_ticks < curr_ticks:
        this_state = _ACCELERATE
        if curr_ticks < 2 * min_cmd_ticks:
            # avoid generating commands that are too short:
            # 1 part accelerate, 2 parts coast, 1 part decelerate
            path = PATH_NEAR
            possible_coast_steps = (remaining_steps - prus) >> 2
            if 0 < possible_coast_steps <= 510:
                path = PATH_NEAR | PATH_CHECK
                if possible_coast_steps * curr_ticks < 2 * min_cmd_ticks:
                    this_state = _COAST
            if planning_steps > remaining_steps - prus:
                this_state = _DECELERATE
        elif (remaining_steps - prus < 2 * planning_steps
              and curr_ticks != TICKS_FOR_STOPPED_MOTOR):
            this_state = _COAST
            planning_steps = remaining_steps - prus
    elif min_travel_ticks > curr_ticks:
        this_state = _DECELERATE
        if prus <= planning_steps:
            planning_steps = prus if prus > 0 else 1
    else:
        this_state = _COAST
        possible_coast_steps = remaining_steps - prus
        if possible_coast_steps < 2 * planning_steps:
            planning_steps = possible_coast_steps & 0xFFFF
            if curr_ticks < min_cmd_ticks and curr_ticks * planning_steps < min_cmd_ticks:
                this_state = _DECELERATE

    if remaining_steps == 0:  # implies prus == 0
        return _complete(rw)

    if this_state & _ACC_FLAG:
        dec_steps = remaining_steps - prus
        if dec_steps < 512:
            # only half: the steps accelerating need to decelerate, too
            dec_steps_u16 = (dec_steps & 0xFFFF) // 2
            if dec_steps_u16 < orig_planning_steps:
                planning_steps = dec_steps_u16 or 1
        d_ticks_new = config.calculate_ticks(prus + planning_steps)
        if d_ticks_new < min_travel_ticks:
            d_ticks_new = min_travel_ticks
    elif this_state & _DEC_FLAG:
        if prus == 1:
            d_ticks_new = min_travel_ticks
        else:
            path |= PATH_DEC
            rs = planning_steps if prus <= planning_steps else prus - planning_steps
            d_ticks_new = config.calculate_ticks(rs)
            # cannot decelerate further down the ramp: clip to the travel speed (#150)
            if rs == 1 and min_travel_ticks > d_ticks_new:
                d_ticks_new = min_travel_ticks
    else:
        path |= PATH_COAST
        d_ticks_new = curr_ticks
        coast_steps = remaining_steps - prus
        if coast_steps < 256 and coast_steps < 2 * orig_planning_steps:
            planning_steps = coast_steps

    if d_ticks_new == 0:  # only with absurd accelerations; keep the division defined
        d_ticks_new = 1
    # the planning above used curr_ticks; d_ticks_new may be shorter
    if d_ticks_new < min_cmd_ticks and d_ticks_new * planning_steps < min_cmd_ticks:
        steps = ((min_cmd_ticks + d_ticks_new - 1) & 0xFFFF) // (d_ticks_new & 0xFFFF)
        if steps >= remaining_steps:
            planning_steps = remaining_steps & 0xFFFF
            this_state = _DECELERATE
        steps = max(planning_steps, steps)
        if 2 * steps >= remaining_steps:
            # at the ramp end: reduce the speed so that the command is long enough
            d_ticks_new = (min_cmd_ticks + remaining_steps - 1) // remaining_steps
            planning_steps = remaining_steps & 0xFFFF
            this_state = _DECELERATE
        else:
            planning_steps = steps
            if remaining_steps < prus + planning_steps:
                this_state = _DECELERATE

    # clip with the current period
    next_ticks = d_ticks_new
    if curr_ticks != TICKS_FOR_STOPPED_MOTOR:
        if this_state & _ACC_FLAG:
            if curr_ticks < next_ticks:
                next_ticks = curr_ticks
        elif this_state & _DEC_FLAG and curr_ticks > next_ticks:
            next_ticks = curr_ticks

    steps = planning_steps
    if steps > remaining_steps:
        steps = remaining_steps
    if steps < 1:
        steps = 1
    if steps > 255:
        steps = 255

    if next_ticks > 65535:
        steps = 1
        pause_ticks_left = next_ticks
        next_ticks = min(next_ticks >> 1, 65535)
        pause_ticks_left -= next_ticks
    else:
        pause_ticks_left = 0

    if this_state & _ACC_FLAG:
        prus += steps
    elif this_state & _DEC_FLAG:
        if prus < steps:
            prus = 0
        else:
            max_ramp_up_steps = config.max_ramp_up_steps
            if prus > max_ramp_up_steps:
                prus -= steps
            elif (prus >= max_ramp_up_steps and max_ramp_up_steps + steps <= remaining_steps
                  and prus - steps < max_ramp_up_steps):
                # speed was too high: do not overshoot the deceleration
                prus = max_ramp_up_steps
                next_ticks = min_travel_ticks
                if next_ticks > 65535:
                    steps = 1
                    pause_ticks_left = next_ticks
                    next_ticks = min(next_ticks >> 1, 65535)
                    pause_ticks_left -= next_ticks
                else:
                    pause_ticks_left = 0
            elif remaining_steps > prus:
                if remaining_steps - prus < steps:
                    prus = remaining_steps - steps
            else:
                prus -= steps

    this_state |= RAMP_DIRECTION_COUNT_UP if count_up else RAMP_DIRECTION_COUNT_DOWN
    out = RampRw.__new__(RampRw)
    out.ramp_state = this_state
    out.performed_ramp_up_steps = prus
    out.pause_ticks_left = pause_ticks_left
    out.curr_ticks = pause_ticks_left + next_ticks
    return NextCommand(next_ticks, steps, count_up, out, path)
