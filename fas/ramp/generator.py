"""The ramp generator: application-side requests and the ramp task's view of them.

The application changes *parameters* (speed, acceleration, target).  They reach the
ramp task only when flagged ``apply`` (by ``move``/``move_to``/``run_*``/
``apply_speed_acceleration``); the periodic task then copies them, derives the
target position and plans commands with :func:`fas.ramp.control.next_command`.
This two-stage hand-over is why a new speed takes effect only after the commands
already queued (the forward-planning time) have run.
"""

from __future__ import annotations

from ..codes import (
    RAMP_DIRECTION_COUNT_DOWN,
    RAMP_DIRECTION_COUNT_UP,
    RAMP_DIRECTION_MASK,
    RAMP_STATE_ACCELERATING_FLAG,
    RAMP_STATE_DECELERATING_FLAG,
    TICKS_FOR_STOPPED_MOTOR,
    MoveResult,
    RampState,
)
from ..motion import MotionSettings, div_for_hz, div_for_milli_hz
from .calculator import RampConfig, _i32
from .control import NextCommand, RampRw, next_command

_IDLE = int(RampState.IDLE)  # (an Enum member read per call costs a metaclass lookup)


class RampGenerator:
    __slots__ = ("_parameters", "config", "target_pos", "force_stop", "force_immediate_stop",
                 "rw", "_ticks_per_s", "_ticks_per_us", "_min_cmd_ticks", "cubic_updated",
                 "jump_maths")

    def __init__(self, ticks_per_s: int, min_cmd_ticks: int, log2_ticks_per_s: int,
                 log2_ticks_div_sqrt2: int, log2_accel_factor: int,
                 parameters: MotionSettings | None = None) -> None:
        """``parameters``: the stepper's motion settings (default: settings of its own)."""
        self._ticks_per_s = ticks_per_s
        self._ticks_per_us = ticks_per_s // 1_000_000
        self._min_cmd_ticks = min_cmd_ticks
        self._parameters = MotionSettings() if parameters is None else parameters
        self.config = RampConfig(log2_ticks_per_s, log2_ticks_div_sqrt2, log2_accel_factor)
        self.target_pos = 0
        self.force_stop = False
        self.force_immediate_stop = False
        self.rw = RampRw()
        # what the last get_next_command computed beyond a command (a backend whose CPU
        # time follows the library's reads it): update() with linear acceleration
        # (s_h > 0: the cubic ramp's figures), and a start's jump (0: none, 1:
        # calculate_ticks(s_jump), 2: and calculate_ramp_steps where the jump is over
        # the maximum speed)
        self.cubic_updated = False
        self.jump_maths = 0

    @property
    def acceleration(self) -> int:
        return self._parameters.acceleration

    # ------------------------------------------------------------------ queries
    def ramp_state(self) -> int:
        return self.rw.ramp_state

    def is_ramp_generator_active(self) -> bool:
        return self.rw.ramp_state != _IDLE

    def is_stopping(self) -> bool:
        return self.force_stop and self.is_ramp_generator_active()

    def is_running_continuously(self) -> bool:
        return self.config.parameters.keep_running

    def steps_to_stop(self) -> int:
        return self.rw.performed_ramp_up_steps

    def has_valid_config(self) -> bool:
        p = self._parameters  # (check_valid_config() == OK, asked by every ramp task)
        return p.valid_speed and p.valid_acceleration

    def check_valid_config(self) -> MoveResult:
        if not self._parameters.valid_speed:
            return MoveResult.ERR_SPEED_IS_UNDEFINED
        if not self._parameters.valid_acceleration:
            return MoveResult.ERR_ACCELERATION_IS_UNDEFINED
        return MoveResult.OK

    def speed_in_ticks(self) -> int:
        return self._parameters.min_travel_ticks

    def speed_in_us(self) -> int:
        return self._parameters.min_travel_ticks // self._ticks_per_us

    def speed_in_milli_hz(self) -> int:
        ticks = self._parameters.min_travel_ticks
        return 0 if ticks == 0 else self.div_for_milli_hz(ticks)

    def div_for_milli_hz(self, f: int) -> int:
        """250·TICKS_PER_S·4 / f with upstream's 32-bit rounding (f: mHz or ticks)."""
        return div_for_milli_hz(self._ticks_per_s, f)

    def div_for_hz(self, f: int) -> int:
        return div_for_hz(self._ticks_per_s, f)

    def current_period_in_ticks(self) -> int:
        return self.rw.curr_ticks

    def current_period_in_us(self) -> int:
        return self.rw.curr_ticks // self._ticks_per_us

    def current_acceleration(self) -> int:
        state = self.rw.ramp_state & (RAMP_STATE_ACCELERATING_FLAG | RAMP_STATE_DECELERATING_FLAG
                                      | RAMP_DIRECTION_MASK)
        if state in (RAMP_STATE_ACCELERATING_FLAG | RAMP_DIRECTION_COUNT_UP,
                     RAMP_STATE_DECELERATING_FLAG | RAMP_DIRECTION_COUNT_DOWN):
            return self.acceleration
        if state in (RAMP_STATE_DECELERATING_FLAG | RAMP_DIRECTION_COUNT_UP,
                     RAMP_STATE_ACCELERATING_FLAG | RAMP_DIRECTION_COUNT_DOWN):
            return -self.acceleration
        return 0

    # ------------------------------------------------------------------ setters
    def set_speed_in_ticks(self, ticks: int) -> None:
        self._parameters.set_speed_in_ticks(ticks)

    def set_acceleration(self, accel: int) -> int:
        return self._parameters.set_acceleration(accel)

    def set_linear_acceleration(self, steps: int) -> None:
        self._parameters.set_cubic_acceleration_steps(steps)

    def set_jump_start(self, jump_step: int) -> None:
        self._parameters.set_jump_start(jump_step)

    def set_keep_running(self) -> None:
        self.config.parameters.keep_running = True

    def apply_speed_acceleration(self) -> None:
        if not self.force_immediate_stop:
            self._parameters.apply_parameters()

    def start_run(self, count_up: bool) -> MoveResult:
        res = self.check_valid_config()
        if res != MoveResult.OK:
            return res
        self.force_stop = False
        self._parameters.set_running(count_up)
        self.rw.start_ramp_if_not_running()
        return MoveResult.OK

    def move_to(self, position: int, queue_end_pos: int) -> MoveResult:
        res = self.check_valid_config()
        if res != MoveResult.OK:
            return res
        if self.is_ramp_generator_active() and not self.config.parameters.keep_running:
            curr_target = self.target_pos
        else:
            curr_target = queue_end_pos
        self._parameters.set_target_position(position)
        self._start_move(curr_target != position)
        return MoveResult.OK

    def move(self, delta: int) -> MoveResult:
        res = self.check_valid_config()
        if res != MoveResult.OK:
            return res
        self._parameters.set_target_relative_position(delta)
        self._start_move(delta != 0)
        return MoveResult.OK

    def _start_move(self, position_changed: bool) -> None:
        self.force_stop = False
        if position_changed:
            self.rw.start_ramp_if_not_running()

    def initiate_stop(self) -> None:
        self.force_stop = True

    def immediate_stop(self) -> None:
        self.force_immediate_stop = True

    def stop_ramp(self) -> None:
        self.rw.init()

    def set_target_position(self, pos: int) -> None:
        self.target_pos = _i32(pos)

    def advance_target_position(self, delta: int) -> None:
        self.target_pos = _i32(self.target_pos + delta)

    # --------------------------------------------------------------- ramp task
    def get_next_command(self, qe_pos: int, qe_count_up: bool) -> NextCommand:
        cfg = self.config
        was_keep_running = cfg.parameters.keep_running
        app = self._parameters
        self.cubic_updated = False
        self.jump_maths = 0
        if app.apply:
            cfg.parameters = app.copy()
            app.apply = False
            app.any_change = False
            app.move_value = 0
            app.move_absolute = False
            app.recalc_ramp_steps = False
            cfg.update()
            self.cubic_updated = cfg.parameters.s_h > 0
            # a new move command clears an immediate stop
            if self.force_immediate_stop:
                p = cfg.parameters
                if p.move_absolute:
                    if self.target_pos != p.move_value:
                        self.force_immediate_stop = False
                elif p.move_value != 0:
                    self.force_immediate_stop = False

        p = cfg.parameters
        rw = self.rw
        curr_ticks = rw.curr_ticks
        if curr_ticks == TICKS_FOR_STOPPED_MOTOR:
            s_jump = p.s_jump
            if s_jump != 0:
                self.jump_maths = 1
                if cfg.calculate_ticks(s_jump) < p.min_travel_ticks:
                    s_jump = cfg.calculate_ramp_steps(p.min_travel_ticks)
                    self.jump_maths = 2
            rw.performed_ramp_up_steps = s_jump
            p.recalc_ramp_steps = False

        # a changed acceleration moves the speed to another ramp step
        if p.recalc_ramp_steps:
            rw.performed_ramp_up_steps = cfg.calculate_ramp_steps(curr_ticks)

        if self.force_stop:
            p.keep_running = False
            prus = rw.performed_ramp_up_steps
            self.target_pos = _i32(qe_pos + prus if qe_count_up else qe_pos - prus)
        elif p.any_change:
            p.any_change = False
            if p.keep_running:
                pass
            elif p.move_absolute:
                self.target_pos = _i32(p.move_value)
            else:
                base = qe_pos if was_keep_running else self.target_pos
                self.target_pos = _i32(base + p.move_value)

        p.recalc_ramp_steps = False

        if self.force_immediate_stop:
            self.force_immediate_stop = False
            self.target_pos = qe_pos
            stopped = RampRw()
            return NextCommand(0, 0, True, stopped)
        return next_command(cfg, self.target_pos, rw, qe_pos, qe_count_up,
                            self._ticks_per_s, self._min_cmd_ticks)

    def after_command_enqueued(self, cmd: NextCommand) -> None:
        self.rw = cmd.rw

    # ------------------------------------------------------------------ cuts
    def apply_pending(self) -> bool:
        """A request (move, run, new parameters) waits for the ramp task."""
        return self._parameters.apply

    def snapshot(self) -> tuple[RampRw, int, MotionSettings]:
        """The planning state after the last command: ramp, target, parameters."""
        return self.rw.copy(), self.target_pos, self.config.parameters

    def restore(self, snapshot: tuple[RampRw, int, MotionSettings]) -> None:
        """Plan on from a :meth:`snapshot` (the queue was cut back to where it was
        taken).  Parameters applied since stay; the ramp step is then recomputed."""
        rw, target, parameters = snapshot
        self.rw = rw.copy()
        self.target_pos = target
        if parameters is not self.config.parameters:
            self.config.parameters.recalc_ramp_steps = True
            if self._parameters.apply:  # about to replace the ramp task's parameters
                self._parameters.recalc_ramp_steps = True
