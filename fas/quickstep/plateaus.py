"""Plateau acceleration: a move as a short list of orders at constant speeds.

With constant acceleration ``a`` the speed after ``s`` steps is ``sqrt(2·a·s)``.
QuickStep cuts that ramp into N segments of equal length (L steps each) and runs
each at the ramp's speed at its end: plateau k of N at ``VTOP·sqrt(k/N)``, one order
per plateau.  A move is N acceleration plateaus, one order at the top speed for the
rest of the distance, and N deceleration plateaus (N .. 1): A + D + 1 orders, as the
seed counts them (the last acceleration and first deceleration plateau run at the
top speed, too: they are the ramp's last segments).

``VTOP`` is the top speed asked for (V/H), or - when the move is too short to reach
it with acceleration ``a`` - the speed the ramp reaches at half the distance,
``sqrt(a·S)``, as FastAccelStepper's triangle ramp does; so ``a`` is the mean
acceleration of every move.  All arithmetic is on integers: periods in ticks.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import isqrt

ACCELERATE = "ACC"
COAST = "COAST"
DECELERATE = "DEC"

MAX_ORDER_STEPS = 32767  # an order's step count is an int16 (its sign is the direction)


@dataclass(frozen=True)
class Plateau:
    """One order of a plan: ``steps`` steps, ``period_ticks`` apart."""

    steps: int
    period_ticks: int
    phase: str  # ACCELERATE, COAST or DECELERATE
    level: int  # plateau k (1 .. n); n is the top speed


@dataclass(frozen=True)
class Plan:
    plateaus: tuple[Plateau, ...]
    top_period_ticks: int  # VTOP as a period
    plateau_steps: int  # L

    @property
    def steps(self) -> int:
        return sum(p.steps for p in self.plateaus)


def level_period(top_period_ticks: int, level: int, n: int) -> int:
    """Period (ticks) of plateau ``level`` of ``n``: the top period times sqrt(n/level)."""
    return isqrt(top_period_ticks * top_period_ticks * n // level)


def top_period(ticks_per_s: int, speed_period_ticks: int, accel: int, steps: int) -> int:
    """VTOP as a period: the asked-for one, or slower if ``steps`` cannot reach it."""
    if steps <= 0:
        return speed_period_ticks
    # tps / sqrt(a·S), rounded up
    reach = isqrt(ticks_per_s * ticks_per_s // (accel * steps))
    if reach * reach * accel * steps < ticks_per_s * ticks_per_s:
        reach += 1
    return max(speed_period_ticks, reach)


def plateau_steps(ticks_per_s: int, top_period_ticks: int, accel: int, n: int) -> int:
    """L = VTOP² / (2·a·n): the steps of one plateau (at least 1)."""
    return max(1, ticks_per_s * ticks_per_s // (2 * accel * n * top_period_ticks
                                                 * top_period_ticks))


def split(steps: int, period: int, phase: str, level: int) -> list[Plateau]:
    """One plateau as orders of at most MAX_ORDER_STEPS steps."""
    out = []
    while steps > 0:
        chunk = min(steps, MAX_ORDER_STEPS)
        out.append(Plateau(chunk, period, phase, level))
        steps -= chunk
    return out


def plan_move(ticks_per_s: int, steps: int, speed_period_ticks: int, accel: int,
              n: int) -> Plan:
    """The orders of a move of ``steps`` (> 0) steps from standstill to standstill."""
    top = top_period(ticks_per_s, speed_period_ticks, accel, steps)
    length = plateau_steps(ticks_per_s, top, accel, n)
    if 2 * n * length > steps:  # a move of a few steps: fewer plateaus, one step each
        m = min(n, (steps - 1) // 2)
        length = 1
    else:
        m = n
    out: list[Plateau] = []
    for k in range(1, m + 1):
        out.append(Plateau(length, level_period(top, k, n), ACCELERATE, k))
    cruise = steps - 2 * m * length
    top_level = n if m == n else m + 1
    out.extend(split(cruise, level_period(top, top_level, n), COAST, top_level))
    for k in range(m, 0, -1):
        out.append(Plateau(length, level_period(top, k, n), DECELERATE, k))
    return Plan(tuple(out), top, length)


def plan_run(ticks_per_s: int, speed_period_ticks: int, accel: int,
             n: int) -> tuple[list[Plateau], Plateau]:
    """Acceleration plateaus of an endless run, and the top-speed order that repeats."""
    length = plateau_steps(ticks_per_s, speed_period_ticks, accel, n)
    acc = [Plateau(length, level_period(speed_period_ticks, k, n), ACCELERATE, k)
           for k in range(1, n + 1)]
    return acc, Plateau(MAX_ORDER_STEPS, speed_period_ticks, COAST, n)


def plan_stop(ticks_per_s: int, top_period_ticks: int, accel: int, n: int,
              level: int) -> list[Plateau]:
    """Deceleration plateaus from ``level`` down to 1 (a stop with its ramp)."""
    length = plateau_steps(ticks_per_s, top_period_ticks, accel, n)
    return [Plateau(length, level_period(top_period_ticks, k, n), DECELERATE, k)
            for k in range(min(level, n), 0, -1)]
