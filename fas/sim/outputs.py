"""User outputs on the simulated chip: digital pins and PWM waveforms (issue 12).

A digital output is an ordinary pin.  An analog output is a pin driven by a PWM
timer: :class:`PwmWave` knows its period (an exact fraction of ticks: an 80 MHz LEDC
timer does not divide a 16 MHz tick clock), its counts per period and the duty count
of every period, and produces the edges on demand.

Periods start at ``origin + floor(k * period)``.  A period with count c rises at its
start and falls ``h_k`` ticks later, with ``h_k = floor((k+1)·H) - floor(k·H)`` and
``H = c/counts · period``: a high time that is not a whole number of ticks alternates
between the two nearest, so that the mean duty over n periods is exact to 1/n tick.
A count of 0 is a low pin, a count equal to ``counts`` a high one.

A duty change takes effect at the start of the next period (the compare register is
double-buffered on AVR; LEDC updates at the period's end); a new frequency restarts
the timer at once.

Edges are made only when something asks (:meth:`SimOutputs.deliver_until`: a trace
flushing, a report): with nobody listening to the pins a waveform costs nothing, and
its pin level is computed when read.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from collections.abc import Callable
    from fractions import Fraction  # (annotations only: it takes ms to import)

    from .pins import PinBank

CHUNK_EDGES = 1 << 14  # edges handed to the pin sinks in one call


class PwmWave:
    """The waveform of one PWM pin from ``origin`` on (see the module text)."""

    def __init__(self, pin: int, origin: int, period: Fraction, counts: int, count: int,
                 level_before: int) -> None:
        self.pin = pin
        self.origin = origin
        self.pn = period.numerator
        self.pd = period.denominator
        self.counts = counts
        self.segments: list[tuple[int, int]] = [(0, count)]  # (first period, count)
        self.k = 0  # first period whose start edge is not yet delivered
        self.level_before = level_before
        self.level = level_before  # pin level before period k starts (as delivered)
        self.pending: list[tuple[int, int]] = []  # edges of period k-1 after the last delivery

    # ------------------------------------------------------------- periods
    def start(self, k: int) -> int:
        return self.origin + (k * self.pn) // self.pd

    def count_at(self, k: int) -> int:
        c = self.segments[0][1]
        for first, count in self.segments:
            if first > k:
                break
            c = count
        return c

    def period_at(self, t: int) -> int:
        """The period that contains tick ``t`` (-1 before the origin)."""
        if t < self.origin:
            return -1
        k = ((t - self.origin) * self.pd) // self.pn
        while self.start(k + 1) <= t:
            k += 1
        while k > 0 and self.start(k) > t:
            k -= 1
        return k

    def _high(self, k: int, c: int) -> int:
        """High ticks of period k at count c (0 < c < counts), within 1 .. length-1."""
        den = self.pd * self.counts
        num = c * self.pn
        h = ((k + 1) * num) // den - (k * num) // den
        length = self.start(k + 1) - self.start(k)
        return min(max(h, 1), max(length - 1, 1))

    def _edges(self, k: int, level: int) -> tuple[list[tuple[int, int]], int]:
        """Edges of period k given the level before it; and the level after it."""
        c = self.count_at(k)
        s = self.start(k)
        if c <= 0:
            return ([(s, 0)] if level else []), 0
        if c >= self.counts or self.start(k + 1) - s < 2:
            return ([] if level else [(s, 1)]), 1
        out = [] if level else [(s, 1)]
        out.append((s + self._high(k, c), 0))
        return out, 0

    # ------------------------------------------------------------- changes
    def set_count(self, count: int, t: int) -> None:
        """Duty ``count`` from the first period that starts after tick ``t``."""
        k = max(self.period_at(t) + 1, self.k)
        self.segments = [seg for seg in self.segments if seg[0] < k] or [(k, count)]
        if self.segments[-1][0] != k:
            self.segments.append((k, count))
        else:
            self.segments[-1] = (k, count)

    def level_at(self, t: int) -> int:
        k = self.period_at(t)
        if k < 0:
            return self.level_before
        c = self.count_at(k)
        if c <= 0:
            return 0
        if c >= self.counts:
            return 1
        s = self.start(k)
        if self.start(k + 1) - s < 2:
            return 1
        return 1 if t < s + self._high(k, c) else 0

    # ------------------------------------------------------------ delivery
    def edges_until(self, t: int, limit: int = CHUNK_EDGES) -> tuple[list[int], bytearray]:
        """The next edges with time <= ``t`` (at most about ``limit``), marked delivered."""
        times: list[int] = []
        levels = bytearray()
        pending = self.pending
        while pending and pending[0][0] <= t:
            et, lv = pending.pop(0)
            times.append(et)
            levels.append(lv)
        if pending:
            return times, levels
        level = self.level
        k = self.k
        while len(times) < limit and self.start(k) <= t:
            edges, level = self._edges(k, level)
            k += 1
            for et, lv in edges:
                if et <= t:
                    times.append(et)
                    levels.append(lv)
                else:
                    pending.append((et, lv))
            if pending:
                break
        self.k = k
        self.level = level
        self._drop_old_segments()
        return times, levels

    def next_edge_bound(self) -> int:
        """The next edge not yet delivered is at or after this tick."""
        return self.pending[0][0] if self.pending else self.start(self.k)

    def skip_until(self, t: int) -> None:
        """Nobody listens: jump to the period of tick ``t`` without making the edges of
        the periods before it."""
        if self.pending or self.start(self.k) > t:
            return
        k = self.period_at(t)
        if k <= self.k:
            return
        self.level = self.level_at(self.start(k) - 1)
        self.k = k
        self._drop_old_segments()

    def _drop_old_segments(self) -> None:
        segs = self.segments
        while len(segs) > 1 and segs[1][0] <= self.k - 1:
            segs.pop(0)


class SimOutputs:
    """The user outputs of one simulated machine: digital pins and PWM waves."""

    def __init__(self, pins: PinBank) -> None:
        self.pins = pins
        self.waves: dict[int, PwmWave] = {}

    def set_digital(self, pin: int, level: int, t: int) -> None:
        if pin in self.waves:  # the pin was a PWM output: its timer lets go
            self.deliver_pin(pin, t)
            del self.waves[pin]
        self.pins.set(pin, level, t)

    def configure(self, pin: int, period: Fraction, counts: int, count: int, t: int) -> None:
        """(Re)start the PWM timer of ``pin`` at tick ``t``."""
        level = self.pins.get(pin)
        if pin in self.waves:
            self.deliver_pin(pin, t)
            level = self.waves[pin].level_at(t)
        wave = PwmWave(pin, t, period, counts, count, level)
        self.waves[pin] = wave

    def set_count(self, pin: int, count: int, t: int) -> None:
        wave = self.waves.get(pin)
        if wave is not None:
            self.deliver_pin(pin, t)
            wave.set_count(count, t)

    def level(self, pin: int, t: int) -> int:
        wave = self.waves.get(pin)
        return self.pins.get(pin) if wave is None else wave.level_at(t)

    def count(self, pin: int, t: int) -> int | None:
        """The duty count of the period running at ``t`` (None: no PWM on the pin)."""
        wave = self.waves.get(pin)
        if wave is None:
            return None
        return wave.count_at(max(wave.period_at(t), 0))

    # ------------------------------------------------------------ delivery
    def deliver_pin(self, pin: int, t: int) -> None:
        wave = self.waves[pin]
        if not self.pins.sinks:
            wave.skip_until(t)
        while True:
            times, levels = wave.edges_until(t)
            if not times:
                return
            self.pins.waveform(pin, times, bytes(levels))

    def deliver_until(self, t: int, after_chunk: Callable[[], None] | None = None) -> None:
        """Hand every PWM edge up to tick ``t`` to the pin bank (and its sinks).

        Long spans go in chunks, earliest wave first; ``after_chunk()`` runs after each
        (a trace hands on what it holds, so its memory stays flat)."""
        if not self.waves:
            return
        if not self.pins.sinks:
            for pin in self.waves:
                self.deliver_pin(pin, t)
            return
        while True:
            wave = min(self.waves.values(), key=lambda w: w.next_edge_bound())
            if wave.next_edge_bound() > t:
                return
            times, levels = wave.edges_until(t)
            if times:
                self.pins.waveform(wave.pin, times, bytes(levels))
                if after_chunk is not None:
                    after_chunk()

    def undelivered_from(self) -> int | None:
        """No PWM edge before this tick is still to be made (None: no PWM)."""
        if not self.waves:
            return None
        return min(w.next_edge_bound() for w in self.waves.values())
