"""QuickStep's base time: the period of its timer, and intervals counted in it.

The timer runs in CTC mode: it counts ``top_counts`` counts of ``prescaler`` CPU
ticks, then starts again and raises its period interrupt.  That period is the base
time.  A motor's step interval is 1.00 .. 255.00 base times in 1/256 steps (an
8.8 fixed-point number, 256 .. 65280); the period interrupt counts whole base times
down and the timer's compare unit places the step inside the last one, so a step
lands on a timer count: the interval in CPU ticks is ``interval_256 * top_counts /
256`` counts, rounded to a whole count, times the prescaler.

The base time is chosen automatically - the shortest step interval any QuickStep
motor needs at its top speed, as the seed recommends - or set; it must lie between
``QuickStepFigures.min_base_ticks`` (12 us on AVR) and what the counter width allows with
the largest prescaler (16.384 ms on an 8-bit timer, 4.19 s on a 16-bit one).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..arch import Profile
from .figures import QsTimer, quickstep_figures

INTERVAL_MIN = 256  # 1.00 base time
INTERVAL_MAX = 255 * 256  # 255.00 base times


@dataclass(frozen=True)
class TimeBase:
    timer: QsTimer
    prescaler: int
    top_counts: int  # counts per base period (1 .. 2**bits)

    @property
    def base_ticks(self) -> int:
        return self.prescaler * self.top_counts

    def interval_256(self, period_ticks: int) -> int:
        """The interval (1/256 base times) nearest to ``period_ticks``, within 1.00..255.00."""
        value = (period_ticks * 256 + self.base_ticks // 2) // self.base_ticks
        return min(max(value, INTERVAL_MIN), INTERVAL_MAX)

    def period_ticks(self, interval_256: int) -> int:
        """CPU ticks between two steps of an order with this interval (whole counts)."""
        counts = (interval_256 * self.top_counts + 128) // 256
        return max(counts, 1) * self.prescaler

    def min_period_ticks(self) -> int:
        return self.period_ticks(INTERVAL_MIN)

    def max_period_ticks(self) -> int:
        return self.period_ticks(INTERVAL_MAX)


def base_range_ticks(profile: Profile, timer: QsTimer) -> tuple[int, int]:
    """Shortest and longest base time (ticks) of ``timer`` on ``profile``."""
    longest = max(timer.prescalers) * (1 << timer.bits)
    return quickstep_figures(profile).min_base_ticks, longest


def choose(profile: Profile, timer: QsTimer, base_ticks: int) -> TimeBase:
    """The timer setting nearest to ``base_ticks`` (clamped into the timer's range).

    The smallest prescaler whose counter still holds the period wins: it gives the
    finest count, so the most exact step intervals.
    """
    lo, hi = base_range_ticks(profile, timer)
    base_ticks = min(max(base_ticks, lo), hi)
    top_max = 1 << timer.bits
    for prescaler in sorted(timer.prescalers):
        top = (base_ticks + prescaler // 2) // prescaler
        if top <= top_max:
            tb = TimeBase(timer, prescaler, max(top, 1))
            if tb.base_ticks < lo:  # rounding went below the minimum
                tb = TimeBase(timer, prescaler, tb.top_counts + 1)
            return tb
    return TimeBase(timer, max(timer.prescalers), top_max)  # pragma: no cover
