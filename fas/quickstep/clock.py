"""The QuickStep timer of an engine: which timer, which base time, shared by all
QuickStep motors (one periodic interrupt serves them all, as in the seed).

The base time is fixed while any QuickStep motor has orders; a new setting or new
top speeds take effect when all of them are at rest.  Automatic (``base_us == 0``):
the shortest step period any QuickStep motor needs at its top speed (its V/H speed),
so that the fastest motor runs at interval 1.00.
"""

from __future__ import annotations

from enum import IntEnum
from typing import TYPE_CHECKING

from ..arch import Profile
from ..planner import PlannerChange
from .figures import QsTimer, quickstep_figures
from .timebase import TimeBase, base_range_ticks, choose

if TYPE_CHECKING:  # pragma: no cover
    from ..allocate import Allocator
    from .planner import QuickStepPlanner

DEFAULT_BASE_TICKS_US = 1000  # automatic base time before any speed is known
TIMER_USER = "quickstep"  # QuickStep's name in the allocator's book of timers


def timer_name(timer: QsTimer) -> str:
    """The timer as the profile's PWM table names it (AVR: "timer 2")."""
    return f"timer {timer.number}"


class QsConfigResult(IntEnum):
    """Why a QuickStep setting was refused (0: accepted)."""

    OK = 0
    NOT_AVAILABLE = 1  # the profile has no QuickStep timer
    NO_SUCH_TIMER = 2
    BASE_OUT_OF_RANGE = 3
    DEPTH_OUT_OF_RANGE = 4
    PLATEAUS_OUT_OF_RANGE = 5
    RAM = 6  # the FIFOs would not fit the RAM
    RUNNING = PlannerChange.RUNNING.value  # not while the motor(s) concerned run
    TIMER_IN_USE = 8  # a user PWM output runs on the timer (issue 12, fas.outputs)


class QuickStepClock:
    """The timer of every QuickStep motor of an engine (see the module text).  While
    any motor runs QuickStep the timer is booked for it in the engine's allocator."""

    def __init__(self, profile: Profile, allocator: Allocator | None = None) -> None:
        self.profile = profile
        self.allocator = allocator
        self.figures = quickstep_figures(profile)
        self.timer: QsTimer | None = self.figures.timer()
        self.base_us = 0  # 0: automatic
        self.planners: list[QuickStepPlanner] = []
        self._current: TimeBase | None = None
        self.origin_tick = 0  # the timer's period boundaries are origin + k * base

    # ------------------------------------------------------------ motors
    def add(self, planner: QuickStepPlanner) -> None:
        """A motor switched to QuickStep: the timer serves it (and is booked)."""
        if not self.planners:
            self._book(True)
        self.planners.append(planner)

    def remove(self, planner: QuickStepPlanner) -> None:
        self.planners.remove(planner)
        if not self.planners:
            self._book(False)

    def _book(self, hold: bool) -> None:
        if self.allocator is None or self.timer is None:
            return
        if hold:
            self.allocator.hold_timer(timer_name(self.timer), TIMER_USER, self)
        else:
            self.allocator.release_timer(timer_name(self.timer), TIMER_USER, self)

    def timer_taken(self) -> bool:
        """Does something else (a user PWM output, issue 12) run on the timer?"""
        return (self.allocator is not None and self.timer is not None
                and self.allocator.timer_used_by_other(timer_name(self.timer), TIMER_USER))

    # ------------------------------------------------------------- settings
    def _timer_or_fail(self, timer: QsTimer | None = None) -> QsTimer:
        """``timer``, else the clock's own; a profile without one has no QuickStep."""
        timer = timer or self.timer
        if timer is None:
            raise ValueError(f"{self.profile.name} has no QuickStep timer")
        return timer

    def range_us(self, timer: QsTimer | None = None) -> tuple[int, int]:
        lo, hi = base_range_ticks(self.profile, self._timer_or_fail(timer))
        tpu = self.profile.ticks_per_us
        return -(-lo // tpu), hi // tpu

    def check_base(self, base_us: int, timer_number: int | None = None) -> QsConfigResult:
        if self.timer is None:
            return QsConfigResult.NOT_AVAILABLE
        timer = self.figures.timer(timer_number) if timer_number is not None else self.timer
        if timer is None:
            return QsConfigResult.NO_SUCH_TIMER
        lo, hi = self.range_us(timer)
        if base_us != 0 and not lo <= base_us <= hi:
            return QsConfigResult.BASE_OUT_OF_RANGE
        if self.busy():
            return QsConfigResult.RUNNING
        return QsConfigResult.OK

    def set_base(self, base_us: int, timer_number: int | None = None) -> QsConfigResult:
        res = self.check_base(base_us, timer_number)
        if res == QsConfigResult.OK:
            if timer_number is not None:
                if self.planners:
                    self._book(False)
                self.timer = self.figures.timer(timer_number)
                if self.planners:
                    self._book(True)
            self.base_us = base_us
            self._current = None
        return res

    def ram_used(self, extra_depth: int = 0, without: QuickStepPlanner | None = None) -> int:
        depth = sum(p.depth for p in self.planners if p is not without) + extra_depth
        return depth * self.figures.order_bytes

    def fits(self, extra_depth: int, without: QuickStepPlanner | None = None) -> bool:
        return self.ram_used(extra_depth, without) <= self.figures.ram_bytes

    # ---------------------------------------------------------------- state
    def busy(self) -> bool:
        return any(p.has_orders() for p in self.planners)

    def wanted_base_ticks(self) -> int:
        if self.base_us:
            return self.base_us * self.profile.ticks_per_us
        speeds = [p.speed_period_ticks() for p in self.planners]
        speeds = [s for s in speeds if s > 0]
        if not speeds:
            return DEFAULT_BASE_TICKS_US * self.profile.ticks_per_us
        return min(speeds)

    def timebase(self, now: int) -> TimeBase:
        """The base time in force; re-chosen when every QuickStep motor is at rest."""
        if self._current is None or not self.busy():
            tb = choose(self.profile, self._timer_or_fail(), self.wanted_base_ticks())
            if tb != self._current:
                self._current = tb
                self.origin_tick = now  # the timer restarts with its new period
        return self._current

    @property
    def current(self) -> TimeBase | None:
        return self._current

    def next_boundary(self, tick: int) -> int:
        """First period boundary of the timer at or after ``tick``."""
        tb = self._current
        if tb is None:
            return tick
        base = tb.base_ticks
        k = -(-(tick - self.origin_tick) // base)
        return self.origin_tick + max(k, 0) * base

    def boundaries_between(self, begin: int, end: int) -> int:
        """Period boundaries in (begin, end]."""
        tb = self._current
        if tb is None or end <= begin:
            return 0
        base, o = tb.base_ticks, self.origin_tick
        return (end - o) // base - (begin - o) // base
