"""The G-code program's settings, Grbl style: ``$$`` lists them, ``$N=value`` sets one.

=========  ==========================================================  ===========
 setting    meaning                                                     default
=========  ==========================================================  ===========
 $1         step idle delay, ms: drivers off this long after motion     25
            (255: keep them on)
 $100-105   steps per unit, axes X Y Z A B C                            1 (steps)
 $110-115   maximum rate, units/min (also the G0 rate)                  600000
 $120-125   acceleration, units/s² (per axis)                           10000
 $140-143   PWM frequency of Aout0-3, Hz (seed 003 default)             5000
 $150-153   pin of Dout0-3                                              profile
 $160-163   pin of Aout0-3 (a PWM pin of the profile)                   profile
=========  ==========================================================  ===========

With the default of one step per unit, axis words and F are in steps and steps per
minute (F600000 = 10 000 steps/s).  A rate above what the stepper can do is limited
to the stepper's top speed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .parser import AXES

AXIS_COUNT = len(AXES)
DEFAULT_STEPS_PER_UNIT = 1.0
DEFAULT_MAX_RATE = 600_000.0  # units/min: 10 000 steps/s at one step per unit
DEFAULT_ACCELERATION = 10_000.0  # units/s²
DEFAULT_IDLE_DELAY_MS = 25  # Grbl's $1
KEEP_ENABLED = 255

SETTING_HELP = {
    1: "step idle delay, ms (255: drivers stay on)",
    100: "steps per unit", 110: "maximum rate, units/min", 120: "acceleration, units/s^2",
    140: "PWM frequency, Hz", 150: "digital output pin", 160: "analog output pin",
}


@dataclass
class GcodeSettings:
    steps_per_unit: list[float] = field(
        default_factory=lambda: [DEFAULT_STEPS_PER_UNIT] * AXIS_COUNT)
    max_rate: list[float] = field(default_factory=lambda: [DEFAULT_MAX_RATE] * AXIS_COUNT)
    acceleration: list[float] = field(
        default_factory=lambda: [DEFAULT_ACCELERATION] * AXIS_COUNT)
    idle_delay_ms: int = DEFAULT_IDLE_DELAY_MS


def axis_setting(number: int) -> tuple[int, int] | None:
    """``(base, axis)`` of an axis setting number ($100..$125), else None."""
    for base in (100, 110, 120):
        if base <= number < base + AXIS_COUNT:
            return base, number - base
    return None


def output_setting(number: int) -> tuple[int, int] | None:
    """``(base, output)`` of an output setting number ($140..$163), else None."""
    for base in (140, 150, 160):
        if base <= number < base + 4:
            return base, number - base
    return None
