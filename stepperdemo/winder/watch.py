"""The interlock as the pins show it: |S2 - (n/m)·S1| at every step edge.

A consumer of the ordered edge stream (:class:`fas.sim.trace.EdgeStream`): it counts
both steppers' positions from their step and direction pins and, while the gear
follows (its :class:`~fas.gear.GearSpan` s), measures the error after every tick
with an edge - edges of both steppers at one tick are one instant.
"""

from __future__ import annotations

from collections.abc import Sequence

from .. import messages as msg


class InterlockMeter:
    def __init__(self, source, wiring: Sequence, levels: dict[int, int],
                 positions: Sequence[int]) -> None:
        self.source = source  # has .spans (the gear's) and .gear.stats once set up
        self.step = [w.step for w in wiring]
        self.dir = [w.direction for w in wiring]
        self.up_level = [1 if w.high_counts_up else 0 for w in wiring]
        self.levels = dict(levels)
        self.pos = list(positions)
        self.tick: int | None = None  # the instant whose edges are being gathered
        self.max_error = 0.0
        self.max_at: int | None = None
        self.instants = 0  # instants measured while following
        self._span = 0
        self._stepped = False  # a rising step edge at the instant being gathered

    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        if pin in self.step:
            i = self.step.index(pin)
            d = self.dir[i]
            for t, lv in zip(times, levels, strict=True):
                if t != self.tick:
                    self._measure()
                    self.tick = t
                if lv:
                    up = d is None or self.levels.get(d, 0) == self.up_level[i]
                    self.pos[i] += 1 if up else -1
                    self._stepped = True
        elif pin in self.dir and times:
            last = times[-1]
            if self.tick is not None and last != self.tick:
                self._measure()
                self.tick = None
            self.levels[pin] = levels[-1]

    def _measure(self) -> None:
        t = self.tick
        if t is None or not self._stepped:
            return
        self._stepped = False
        spans = self.source.spans
        while self._span < len(spans) and spans[self._span].end is not None \
                and spans[self._span].end < t:
            self._span += 1
        if self._span >= len(spans):
            return
        sp = spans[self._span]
        if t < sp.start or (sp.end is not None and t > sp.end):
            return
        err = abs((self.pos[1] - sp.y0) - sp.n * (self.pos[0] - sp.x0) / sp.m)
        self.instants += 1
        if err > self.max_error:
            self.max_error = err
            self.max_at = t

    def finish(self) -> None:
        self._measure()
        self.tick = None

    def report_lines(self, ticks_per_s: int) -> list[str]:
        self.finish()
        spans = self.source.spans
        if not spans:
            return [msg.WINDER_REPORT_NO_INTERLOCK]
        stats = self.source.gear.stats
        ratios = sorted({f"{sp.n}:{sp.m}" for sp in spans})
        at = "-" if self.max_at is None else f"{self.max_at / ticks_per_s:.6f} s"
        return [msg.WINDER_REPORT_INTERLOCK.format(
            spans=len(spans), ratios=", ".join(ratios), instants=self.instants,
            error=self.max_error, at=at, late=stats.late, commands=stats.commands,
            pauses=stats.pauses)]
