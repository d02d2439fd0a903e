"""Plot samples in bounded memory, thinned without inventing lines.

A recording offers one sample per pulse (or per PWM period); a plot needs no more
points than it has pixels.  :class:`PlotSamples` keeps at most ``limit`` of them: the
time axis is cut into buckets of equal width, and of each bucket it keeps the first
and the last sample and those with the least and the greatest value (``key``).  When
the kept samples exceed the limit, the buckets double in width and are thinned again
the same way.

So what a plot draws between two kept samples stays true at its resolution: a
standstill longer than a bucket keeps the zero-speed sample at each of its ends (the
last of one bucket, the first of another), a peak keeps its height, and the number of
samples does not grow with the number of moves.  (Halving the list, as before, dropped
the ends of standstills: the plot then drew ramps across them.)
"""

from __future__ import annotations

Sample = tuple  # (tick, value, ...) - the tick first


class PlotSamples:
    """At most ``limit`` samples (see the module text); ``key``: the index of the value
    whose extremes each bucket keeps."""

    __slots__ = ("_end", "_first", "_hi", "_last", "_lo", "key", "kept", "limit", "origin",
                 "width")

    def __init__(self, limit: int, key: int = 1) -> None:
        if limit < 8:
            raise ValueError("a plot needs at least 8 samples")
        self.limit = limit
        self.key = key
        self.width = 1  # bucket width in ticks (doubles as the recording grows)
        self.origin: int | None = None  # tick of the first sample: buckets count from it
        self.kept: list[Sample] = []  # samples of the closed buckets, in time order
        self._end: int | None = None  # end (exclusive) of the open bucket
        self._first: Sample | None = None
        self._lo: Sample | None = None
        self._hi: Sample | None = None
        self._last: Sample | None = None

    def add(self, sample: Sample) -> None:
        """One sample, not earlier than the one before."""
        t = sample[0]
        end = self._end
        if end is None or t >= end:
            self._close()
            if self.origin is None:
                self.origin = t
            self._end = self.origin + ((t - self.origin) // self.width + 1) * self.width
            self._first = self._lo = self._hi = self._last = sample
            return
        self._last = sample
        v = sample[self.key]
        if v < self._lo[self.key]:  # type: ignore[index]
            self._lo = sample
        elif v > self._hi[self.key]:  # type: ignore[index]
            self._hi = sample

    def samples(self) -> list[Sample]:
        """Every kept sample in time order (those of the open bucket too)."""
        return self.kept + self._picks()

    def __len__(self) -> int:
        return len(self.kept) + len(self._picks())

    # ---------------------------------------------------------------- inner
    def _picks(self) -> list[Sample]:
        if self._first is None:
            return []
        return _ordered((self._first, self._lo, self._hi, self._last))

    def _close(self) -> None:
        if self._first is None:
            return
        self.kept.extend(self._picks())
        self._first = self._lo = self._hi = self._last = None
        if len(self.kept) > self.limit - 4:  # room for the open bucket's picks
            self._thin()

    def _thin(self) -> None:
        """Double the bucket width until the kept samples fit in 3/4 of the limit (room
        to grow before the next thinning)."""
        key, origin = self.key, self.origin or 0
        while len(self.kept) > self.limit * 3 // 4:
            self.width *= 2
            width = self.width
            out: list[Sample] = []
            group: list[Sample] = []
            bucket = None
            for s in self.kept:
                b = (s[0] - origin) // width
                if b != bucket and group:
                    out.extend(_extremes(group, key))
                    group = []
                bucket = b
                group.append(s)
            if group:
                out.extend(_extremes(group, key))
            self.kept = out


def _extremes(group: list[Sample], key: int) -> list[Sample]:
    if len(group) <= 4:
        return group
    lo = min(group, key=lambda s: s[key])
    hi = max(group, key=lambda s: s[key])
    return _ordered((group[0], lo, hi, group[-1]))


def _ordered(picks: tuple) -> list[Sample]:
    """The picks of a bucket once each, in time order (ties keep their order)."""
    out: list[Sample] = []
    for s in sorted(picks, key=lambda s: s[0]):
        if not any(s is o for o in out):
            out.append(s)
    return out
