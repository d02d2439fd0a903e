"""How far along its path a straight segment is at each moment: a *time law*.

Pure computation (no library, no clock).  ``s`` is the fraction of the segment's
path (0 at its start, 1 at its end; every axis makes its step ``j`` of ``n`` when
``s`` reaches ``j / n``); ``t`` is seconds from the law's origin.  A law is a list
of :class:`Phase` of constant acceleration, contiguous in ``t`` and ``s``, from one
state to rest.  It can be changed from any moment on (:meth:`TimeLaw.replace_from`):
a feed hold stops along the path (:func:`stop_from`), an override changes the speed
(:func:`ramp_to_rest`), and a resume starts again from rest where the hold stopped.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

EPS = 1e-12  # path fractions: a step this close to the end of a law is on it


@dataclass(frozen=True)
class Phase:
    """Constant acceleration ``a`` from ``(t0, s0, v0)`` until ``t1`` (units 1/s, 1/s²)."""

    t0: float
    s0: float
    v0: float
    a: float
    t1: float

    def s_at(self, t: float) -> float:
        dt = t - self.t0
        return self.s0 + self.v0 * dt + 0.5 * self.a * dt * dt

    def v_at(self, t: float) -> float:
        return max(0.0, self.v0 + self.a * (t - self.t0))

    @property
    def s1(self) -> float:
        return self.s_at(self.t1)

    def time_of(self, s: float) -> float:
        """When this phase reaches ``s`` (clamped to the phase)."""
        ds = s - self.s0
        if ds <= 0:
            return self.t0
        root = math.sqrt(max(0.0, self.v0 * self.v0 + 2 * self.a * ds))
        den = self.v0 + root
        dt = 2 * ds / den if den > 0 else self.t1 - self.t0
        return min(self.t0 + dt, self.t1)

    def cut(self, t: float) -> Phase:
        return Phase(self.t0, self.s0, self.v0, self.a, t)


class TimeLaw:
    """``s(t)`` as contiguous phases from ``(t_start, s_start)`` to rest."""

    def __init__(self, phases: list[Phase], t_start: float = 0.0, s_start: float = 0.0) -> None:
        self.phases = [p for p in phases if p.t1 > p.t0]
        self.t_start = self.phases[0].t0 if self.phases else t_start
        self.s_start = self.phases[0].s0 if self.phases else s_start
        self._ends = [p.s1 for p in self.phases]

    @property
    def end_t(self) -> float:
        return self.phases[-1].t1 if self.phases else self.t_start

    @property
    def end_s(self) -> float:
        return self._ends[-1] if self.phases else self.s_start

    def time_of(self, s: float) -> float | None:
        """When the path reaches ``s`` (None: this law stops before it)."""
        if s > self.end_s + EPS:
            return None
        if not self.phases or s <= self.s_start:
            return self.t_start
        i = bisect.bisect_left(self._ends, s - EPS)
        if i >= len(self.phases):
            return self.end_t
        return self.phases[i].time_of(s)

    def state_at(self, t: float) -> tuple[float, float]:
        """``(s, v)`` at time ``t`` (before the law: its start; after it: at rest)."""
        if not self.phases or t <= self.t_start:
            return (self.s_start, self.phases[0].v0 if self.phases else 0.0)
        if t >= self.end_t:
            return (self.end_s, 0.0)
        i = bisect.bisect_right([p.t1 for p in self.phases], t)
        p = self.phases[min(i, len(self.phases) - 1)]
        return (p.s_at(t), p.v_at(t))

    def replace_from(self, t: float, phases: list[Phase]) -> TimeLaw:
        """This law until ``t``, then ``phases`` (which begin at ``t``)."""
        kept = []
        for p in self.phases:
            if p.t1 <= t:
                kept.append(p)
            elif p.t0 < t:
                kept.append(p.cut(t))
        s_at_t = self.state_at(t)[0]
        return TimeLaw(kept + phases, t_start=min(t, self.t_start) if not kept else
                       self.t_start, s_start=self.s_start if kept else s_at_t)


def stop_from(t0: float, s0: float, v0: float, a: float) -> list[Phase]:
    """Decelerate with ``a`` from speed ``v0`` to rest (a feed hold)."""
    if v0 <= 0:
        return []
    return [Phase(t0, s0, v0, -a, t0 + v0 / a)]


def ramp_to_rest(t0: float, s0: float, v0: float, cruise: float, a: float,
                 s_end: float = 1.0) -> list[Phase]:
    """From ``(s0, v0)`` at ``t0``: towards the speed ``cruise`` with acceleration ``a``,
    then to rest exactly at ``s_end`` (a trapezoid, a triangle when the distance is too
    short for ``cruise``; slowing down first when ``v0`` is above it)."""
    dist = s_end - s0
    if dist <= EPS or cruise <= 0 or a <= 0:
        return stop_from(t0, s0, v0, a) if v0 > 0 else []
    phases: list[Phase] = []
    t, s, v = t0, s0, v0
    if v > cruise:
        if v * v / (2 * a) >= dist:  # can only stop (rounding): just in time
            a_stop = v * v / (2 * dist)
            return [Phase(t, s, v, -a_stop, t + v / a_stop)]
        dur = (v - cruise) / a
        phases.append(Phase(t, s, v, -a, t + dur))
        s += (v * v - cruise * cruise) / (2 * a)
        t += dur
        v = cruise
        peak = cruise
    else:
        peak = min(cruise, math.sqrt(a * dist + v * v / 2))
        if peak > v:
            dur = (peak - v) / a
            phases.append(Phase(t, s, v, a, t + dur))
            s += (peak * peak - v * v) / (2 * a)
            t += dur
            v = peak
    decel = peak * peak / (2 * a)
    cruise_dist = s_end - s - decel
    if cruise_dist > EPS and peak > 0:
        dur = cruise_dist / peak
        phases.append(Phase(t, s, peak, 0.0, t + dur))
        s += cruise_dist
        t += dur
    left = s_end - s
    if peak > 0 and left > 0:  # land exactly on s_end (a rounding's worth of acceleration)
        a_end = peak * peak / (2 * left)
        phases.append(Phase(t, s, peak, -a_end, t + peak / a_end))
    return phases
