"""A stepper's motion settings: what the application asked for (upstream's
``ramp_parameters_s``).

Speed, acceleration, linear acceleration and jump start belong to the stepper; it
lends them to its planner (:mod:`fas.planner`).  FastAccelStepper's ramp takes them
up with a request (a move, a run, ``apply_speed_acceleration``): the request fields
and the change flags below are the ramp's hand-over, copied to its task on
``apply`` (:mod:`fas.ramp.generator`).  QuickStep plans each move with the speed and
acceleration of its time.
"""

from __future__ import annotations

from . import log2
from .codes import TICKS_FOR_STOPPED_MOTOR


class MotionSettings:
    """Settings of one stepper's moves and the request waiting for its planner."""

    __slots__ = (
        "move_value", "min_travel_ticks", "s_h", "s_jump", "log2_accel", "apply",
        "any_change", "recalc_ramp_steps", "valid_acceleration", "valid_speed",
        "move_absolute", "keep_running", "keep_running_count_up", "acceleration",
        "forward_planning_ticks",
    )

    def __init__(self, forward_planning_ticks: int = 0) -> None:
        self.forward_planning_ticks = forward_planning_ticks  # how far ahead to plan
        self.move_value = 0
        self.min_travel_ticks = 0  # the speed: ticks between two steps at the top
        self.s_h = 0  # linear acceleration over the first s_h steps
        self.s_jump = 0  # jump start: begin at this ramp step
        self.log2_accel = 0
        self.acceleration = 0  # steps/s^2 as set
        self.apply = False
        self.any_change = False
        self.recalc_ramp_steps = False
        self.valid_acceleration = False
        self.valid_speed = False
        self.move_absolute = True
        self.keep_running = False
        self.keep_running_count_up = True

    def copy(self) -> MotionSettings:
        other = MotionSettings.__new__(MotionSettings)
        for name in MotionSettings.__slots__:
            setattr(other, name, getattr(self, name))
        return other

    # --- settings ---
    def set_speed_checked(self, min_step_ticks: int, fastest_ticks: int) -> int:
        """``FastAccelStepper::setSpeedInTicks()``: -1 (and nothing changes) for a
        period below the stepper's fastest or for ``TICKS_FOR_STOPPED_MOTOR``."""
        if min_step_ticks < fastest_ticks or min_step_ticks >= TICKS_FOR_STOPPED_MOTOR:
            return -1
        self.set_speed_in_ticks(min_step_ticks)
        return 0

    def set_speed_in_ticks(self, min_step_ticks: int) -> None:
        if not self.valid_speed or self.min_travel_ticks != min_step_ticks:
            self.min_travel_ticks = min_step_ticks
            self.valid_speed = True
            self.any_change = True

    def set_acceleration(self, accel: int) -> int:
        """``accel`` steps/s^2 (> 0; else -1 and nothing changes)."""
        if accel <= 0:
            return -1
        self.acceleration = accel
        new_log2_accel = log2.from_u32(accel)
        if not self.valid_acceleration or self.log2_accel != new_log2_accel:
            self.valid_acceleration = True
            self.any_change = True
            self.recalc_ramp_steps = True
            self.log2_accel = new_log2_accel
        return 0

    def set_cubic_acceleration_steps(self, s_cubic_steps: int) -> None:
        if self.s_h != s_cubic_steps:
            self.s_h = s_cubic_steps
            self.recalc_ramp_steps = True
            self.any_change = True

    def set_jump_start(self, jump_step: int) -> None:
        self.s_jump = jump_step

    # --- requests (upstream: ramp_parameters_s setters) ---
    def apply_parameters(self) -> None:
        if self.any_change:
            self.apply = True

    def set_running(self, count_up: bool) -> None:
        self.keep_running = True
        self.keep_running_count_up = count_up
        self.any_change = True
        self.apply = True

    def set_target_position(self, pos: int) -> None:
        self.move_value = pos
        self.move_absolute = True
        self.keep_running = False
        self.keep_running_count_up = True
        self.any_change = True
        self.apply = True

    def set_target_relative_position(self, move: int) -> None:
        if self.any_change and not self.move_absolute:
            self.move_value = _i32(self.move_value + move)
        else:
            self.move_value = move
        self.move_absolute = False
        self.keep_running = False
        self.keep_running_count_up = True
        self.any_change = True
        self.apply = True


def div_for_hz(ticks_per_s: int, f: int) -> int:
    """Ticks between steps at ``f`` Hz, rounded."""
    return (ticks_per_s + f // 2) // f


def div_for_milli_hz(ticks_per_s: int, f: int) -> int:
    """250·TICKS_PER_S·4 / f with upstream's 32-bit rounding (f: mHz or ticks)."""
    base = (250 * ticks_per_s) & 0xFFFFFFFF
    res = base // f
    base -= res * f
    base = (base << 2) & 0xFFFFFFFF
    res = (res << 2) & 0xFFFFFFFF
    base += f // 2
    return (res + base // f) & 0xFFFFFFFF


def milli_hz_of_ticks(ticks_per_s: int, ticks: int) -> int:
    """``((uint32_t)250 * TICKS_PER_S) / ticks * 4`` in uint32_t, as the C++ computes
    ``getMaxSpeedInMilliHz()`` and ``getCurrentSpeedInMilliHz()`` (no rounding; the
    product wraps where TICKS_PER_S > 17 179 869, e.g. the SAM Due's 21 MHz)."""
    return ((250 * ticks_per_s) & 0xFFFFFFFF) // ticks * 4 & 0xFFFFFFFF


def _i32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - 0x100000000 if v & 0x80000000 else v
