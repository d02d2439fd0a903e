"""A straight line of several axes as FastAccelStepper queue commands.

Pure computation (no library, no clock).  A G0/G1 block moves every axis by its
``steps``; all axes follow one speed profile along the path - a trapezoid (or a
triangle) in the path fraction ``s`` from 0 to 1 - so that they start together,
stay on the line and arrive together:

* path speed and acceleration are the largest that keep every axis within its own
  limits (``rate`` steps/s, ``accel`` steps/s²) and the feed rate;
* axis i makes step j (1 .. n_i) when the path reaches ``s = j / n_i``: at any time
  every axis is within one step of the line, and every axis's last step is at the
  end of the path (the same tick for all axes);
* the step times are turned into queue commands ``(ticks, steps, count_up)``:
  steps at a steady rate are grouped (at most 255, spanning at most ``horizon``
  ticks and at least the profile's minimum command time), a group ends exactly
  where its next step is due (so errors do not add up), waits longer than a command
  can hold are split into pauses, and the last step of every axis is a command of
  its own with the common ``tail`` (the queues run dry together).

Every timeline begins with a pause of ``lead`` ticks (at least the minimum command
time; the enable and direction-change delays when those apply): the direction pin
is set at its start, the first step comes after it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

MAX_TICKS = 65535  # a command's ticks field
MAX_STEPS = 255  # a command's steps field


@dataclass(frozen=True)
class Profile:
    """A speed profile along the path fraction s in [0, 1] (units: 1/s, 1/s²)."""

    v: float  # top speed
    a: float  # acceleration and deceleration
    s_acc: float  # fraction covered while accelerating (as much decelerating)
    t_acc: float  # time of the acceleration
    duration: float  # seconds from start to the end

    def time_at(self, s: float) -> float:
        """Seconds from the start until the path reaches fraction ``s``."""
        if s <= self.s_acc:
            return math.sqrt(2 * s / self.a)
        if s <= 1 - self.s_acc:
            return self.t_acc + (s - self.s_acc) / self.v
        return self.duration - math.sqrt(max(0.0, 2 * (1 - s) / self.a))


def speed_profile(v: float, a: float) -> Profile:
    """Trapezoid of top speed ``v`` and acceleration ``a`` over the whole path (s: 0..1)."""
    s_acc = v * v / (2 * a)
    if s_acc >= 0.5:  # triangle: the top speed is never reached
        s_acc = 0.5
        v = math.sqrt(a)
        t_acc = v / a
        return Profile(v, a, s_acc, t_acc, 2 * t_acc)
    t_acc = v / a
    return Profile(v, a, s_acc, t_acc, 2 * t_acc + (1 - 2 * s_acc) / v)


def line_profile(steps: Sequence[int], rate: Sequence[float], accel: Sequence[float],
                 path_speed: float | None) -> Profile:
    """The profile of a line: ``path_speed`` in path fractions per second (None: as
    fast as the axes allow, G0), each axis within ``rate[i]`` steps/s and
    ``accel[i]`` steps/s²."""
    v = math.inf if path_speed is None else path_speed
    a = math.inf
    for n, r, acc in zip(steps, rate, accel, strict=True):
        n = abs(n)
        if n:
            v = min(v, r / n)
            a = min(a, acc / n)
    if not (0 < v < math.inf and 0 < a < math.inf):
        raise ValueError("a line needs a moving axis, a positive speed and acceleration")
    return speed_profile(v, a)


@dataclass(frozen=True)
class Limits:
    """What one queue accepts (from the architecture profile and the stepper)."""

    ticks_per_s: int
    min_cmd_ticks: int  # ticks * steps of a command (ticks of a pause) at least this
    min_step_ticks: int  # the stepper's top speed: ticks between steps at least this
    horizon_ticks: int  # a group of steps spans at most this (steady-rate assumption)


class StepTimes(Sequence[int]):
    """Tick (from the block start) of each of an axis's ``n`` steps, computed when asked
    (a long move costs no memory)."""

    def __init__(self, profile: Profile, n: int, lead: int, ticks_per_s: int) -> None:
        self.profile = profile
        self.n = n
        self.lead = lead
        self.tps = ticks_per_s

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i):  # step i+1 of n
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(self.n))]
        if not 0 <= i < self.n:
            raise IndexError(i)
        return self.lead + round(self.profile.time_at((i + 1) / self.n) * self.tps)


def split_wait(ticks: int, limits: Limits) -> list[int]:
    """``ticks`` as command times each within min_cmd_ticks .. 65535 (sum exact)."""
    if ticks <= MAX_TICKS:
        return [ticks]
    parts = -(-ticks // MAX_TICKS)
    base, extra = divmod(ticks, parts)
    return [base + (1 if i < extra else 0) for i in range(parts)]


def axis_commands(times: Sequence[int], count_up: bool, tail: int,
                  limits: Limits) -> Iterator[tuple[int, int, bool]]:
    """Queue commands ``(ticks, steps, count_up)`` that step at ``times`` (ticks from the
    block start, rising) and end ``tail`` ticks after the last step."""
    n = len(times)
    cur = 0
    min_cmd = limits.min_cmd_ticks
    if n == 0:
        return
    for w in split_wait(times[0], limits):  # the lead: direction set, then wait
        yield w, 0, count_up
    cur = times[0]
    k = 0  # index of the next step, made at cur
    while k < n:
        if k == n - 1:
            yield max(tail, min_cmd, limits.min_step_ticks), 1, count_up
            return
        # a group of m steps (k .. k+m-1) ends where step k+m is due
        m = 1
        while (m < MAX_STEPS and k + m < n - 1
               and times[k + m + 1] - cur <= limits.horizon_ticks):
            m += 1
        while times[k + m] - cur < min_cmd and k + m < n - 1 and m < MAX_STEPS:
            m += 1  # too short for one command: take more steps
        span = times[k + m] - cur
        if span < min_cmd:  # only the last step is left after these: take it in too
            m = n - k
            t = max(-(-min_cmd // m), limits.min_step_ticks, tail)
            yield t, m, count_up
            return
        if m == 1:
            waits = split_wait(span, limits)
            yield waits[0], 1, count_up
            for w in waits[1:]:
                yield w, 0, count_up
            cur += span
        else:
            for cmd in group_commands(span, m, count_up, limits):
                cur += cmd[0] * cmd[1]  # what the queue really does: the next group
                yield cmd  # starts from there and makes up a rounding
        k += m


def group_commands(span: int, m: int, count_up: bool,
           limits: Limits) -> list[tuple[int, int, bool]]:
    """``m`` evenly spaced steps over ``span`` ticks: exactly as one command, or two whose
    periods differ by a tick (when both are long enough to be commands); else the
    nearest period."""
    t, r = divmod(span, m)
    if t < limits.min_step_ticks:
        return [(limits.min_step_ticks, m, count_up)]
    if r == 0:
        return [(t, m, count_up)]
    a, b = m - r, r
    if _valid(t, a, limits) and _valid(t + 1, b, limits):
        return [(t, a, count_up), (t + 1, b, count_up)]
    return [(t + (1 if 2 * r >= m else 0), m, count_up)]


def _valid(ticks: int, steps: int, limits: Limits) -> bool:
    rate = ticks * steps if steps > 1 else ticks
    return rate >= limits.min_cmd_ticks and ticks >= limits.min_step_ticks


def line_commands(steps: Sequence[int], profile: Profile, lead: int, tail: int,
                  limits: Limits) -> list[list[tuple[int, int, bool]]]:
    """Per axis the full command list of a line (tests, figures; the program streams
    :func:`axis_commands` instead)."""
    out = []
    for n in steps:
        times = StepTimes(profile, abs(n), lead, limits.ticks_per_s)
        out.append(list(axis_commands(times, n >= 0, tail, limits)) if n else [])
    return out
