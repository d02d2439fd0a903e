"""Ramp maths: speed as a function of ramp step, and back.

With constant acceleration ``a`` the speed after ``s`` steps from standstill is
``v = sqrt(2·a·s)``, so the step period is ``ticks = TICKS_PER_S / sqrt(2·a·s)``.
With linear acceleration over the first ``s_h`` steps the ramp starts with a cubic
segment ``ticks = cubic / s^(2/3)`` and continues as the constant-acceleration ramp
shifted by ``s_h/4`` steps.  All of it is evaluated in the log2 fixed-point domain
(:mod:`fas.log2`) exactly as the firmware does.
"""

from __future__ import annotations

from .. import log2
from ..motion import MotionSettings

RampParameters = MotionSettings  # upstream's ramp_parameters_s: the stepper's settings


class RampConfig:
    """Parameters as seen by the ramp task plus the figures derived from them."""

    __slots__ = ("parameters", "max_ramp_up_steps", "log2_ticks_h", "cubic",
                 "_l2_ticks", "_l2_ticks_div_sqrt2", "_l2_accel_factor", "converted")

    def __init__(self, log2_ticks_per_s: int, log2_ticks_div_sqrt2: int,
                 log2_accel_factor: int) -> None:
        self.parameters = MotionSettings()
        self.max_ramp_up_steps = 0
        self.log2_ticks_h = 0
        self.cubic = 0
        self._l2_ticks = log2_ticks_per_s
        self._l2_ticks_div_sqrt2 = log2_ticks_div_sqrt2
        self._l2_accel_factor = log2_accel_factor
        # calculate_ticks's last conversion: the ramp step it took to log2 and the log2
        # value it took back (what the firmware's arithmetic costs depends on; the
        # planner hands it to the backend, QueueChannel.ramp_converted)
        self.converted: tuple[int, int] | None = None

    def update(self) -> None:
        p = self.parameters
        if p.s_h > 0:
            log2_s_h = log2.from_u32(p.s_h)
            # cubic = TICKS_PER_S / sqrt(s_h^(1/3) / (3/2 * a))
            cubic = log2.wrap16(log2.const(1.5) + p.log2_accel)
            cubic = log2.sqrt(log2.wrap16(log2.pow_div_3(log2_s_h) - cubic))
            self.cubic = log2.wrap16(self._l2_ticks + cubic)
            self.log2_ticks_h = log2.wrap16(self.cubic - log2.pow_2_div_3(log2_s_h))
        else:
            self.log2_ticks_h = log2.MAX
        self.max_ramp_up_steps = self.calculate_ramp_steps(p.min_travel_ticks) or 1

    def take_converted(self) -> tuple[int, int] | None:
        """calculate_ticks's conversion since the last call (None: none)."""
        converted, self.converted = self.converted, None
        return converted

    def calculate_ticks(self, steps: int) -> int:
        """Step period (ticks) at ramp step ``steps``."""
        p = self.parameters
        if steps >= p.s_h:
            steps -= (p.s_h + 2) >> 2
            l2 = log2.wrap16(log2.from_u32(steps) + p.log2_accel)
            l2 = log2.wrap16(self._l2_ticks_div_sqrt2 - log2.sqrt(l2))
            self.converted = (steps, l2)
            return log2.to_u32(l2)
        l2_steps = log2.from_u32(steps)
        l2 = log2.wrap16(self.cubic - log2.pow_2_div_3(l2_steps))
        self.converted = (steps, l2)
        return log2.to_u32(l2)

    def calculate_ramp_steps(self, ticks: int) -> int:
        """Ramp step at which the step period equals ``ticks``."""
        p = self.parameters
        l2_ticks = log2.from_u32(ticks)
        if l2_ticks <= self.log2_ticks_h:
            inv_accel2 = log2.wrap16(self._l2_accel_factor - p.log2_accel)
            steps = log2.to_u32(log2.wrap16(inv_accel2 - log2.square(l2_ticks)))
            return (steps + ((p.s_h + 2) >> 2)) & 0xFFFFFFFF
        l2_res = log2.wrap16(self.cubic - l2_ticks)
        return log2.to_u32(log2.pow_3_div_2(l2_res))


def _i32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - 0x100000000 if v & 0x80000000 else v
