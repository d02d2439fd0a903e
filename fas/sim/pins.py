"""Pin levels of the simulated chip, edge statistics, and optional per-edge recording.

Every pin starts LOW at tick 0 (as the AVR simulator's trace does).  Statistics are
always kept: rising/falling counts and the longest and summed HIGH phase per pin -
the figures FastAccelStepper's own simulator evaluation reports.  Per-edge recording
(needed for VCD files, plots and timing reports) is optional; a recorder receives
edges in blocks so that a run of 255 pulses costs one call, not 510.
"""

from __future__ import annotations

from array import array
from collections.abc import Sequence
from itertools import compress
from struct import pack
from typing import Protocol


class EdgeSink(Protocol):
    def edges(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        """Edges of one pin, in time order (levels 0/1)."""


# EdgeRecorder: from this many edges on, a list of them is packed into the array's
# bytes (struct) rather than appended item by item
PACKED_FROM = 16


class EdgeRecorder:
    """Keeps every edge in memory: per pin an array of times and one of levels."""

    def __init__(self) -> None:
        self.times: dict[int, array[int]] = {}
        self.levels: dict[int, bytearray] = {}

    def edges(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        t = self.times.get(pin)
        if t is None:
            t = self.times[pin] = array("q")
            self.levels[pin] = bytearray()
        if len(times) > PACKED_FROM and type(times) is list:
            # (a block's edges: packed at once - array.extend converts each item on its own)
            t.frombytes(pack(f"{len(times)}q", *times))
        else:
            t.extend(times)
        self.levels[pin].extend(levels)

    def pin_edges(self, pin: int) -> tuple[array[int], bytearray]:
        return self.times.get(pin, array("q")), self.levels.get(pin, bytearray())

    def rising(self, pin: int) -> list[int]:
        times, levels = self.pin_edges(pin)
        return list(compress(times, levels))  # (the times whose level is 1)


class PinBank:
    __slots__ = ("level", "rise", "fall", "high_since", "high_max", "high_total", "sinks",
                 "names", "first_write", "_writes")

    def __init__(self) -> None:
        self.level: dict[int, int] = {}
        self.rise: dict[int, int] = {}
        self.fall: dict[int, int] = {}
        self.high_since: dict[int, int] = {}
        self.high_max: dict[int, int] = {}
        self.high_total: dict[int, int] = {}
        self.sinks: list[EdgeSink] = []
        self.names: dict[int, str] = {}
        # per pin: (order of its first write among all writes, level written first)
        self.first_write: dict[int, tuple[int, int]] = {}
        self._writes = 0

    def get(self, pin: int) -> int:
        return self.level.get(pin, 0)

    def set(self, pin: int, level: int, t: int) -> bool:
        """Drive ``pin`` to ``level`` at tick ``t``; True if that was an edge."""
        level = 1 if level else 0
        if pin not in self.first_write:
            self.first_write[pin] = (self._writes, level)
        self._writes += 1
        if self.level.get(pin, 0) == level:
            return False
        self.level[pin] = level
        if level:
            self.rise[pin] = self.rise.get(pin, 0) + 1
            self.high_since[pin] = t
        else:
            self.fall[pin] = self.fall.get(pin, 0) + 1
            self._close_high(pin, t - self.high_since.get(pin, t))
        for sink in self.sinks:
            sink.edges(pin, (t,), b"\x01" if level else b"\x00")
        return True

    def _close_high(self, pin: int, duration: int) -> None:
        self.high_total[pin] = self.high_total.get(pin, 0) + duration
        if duration > self.high_max.get(pin, 0):
            self.high_max[pin] = duration

    def pulses(self, pin: int, first: int, period: int, count: int, width: int) -> None:
        """``count`` pulses of ``width`` ticks, rising edges ``period`` apart from ``first``.

        The pin must be LOW before and is LOW afterwards.
        """
        if count <= 0:
            return
        rise = self.rise
        rise[pin] = rise.get(pin, 0) + count
        fall = self.fall
        fall[pin] = fall.get(pin, 0) + count
        total = self.high_total
        total[pin] = total.get(pin, 0) + count * width
        high_max = self.high_max
        if width > high_max.get(pin, 0):
            high_max[pin] = width
        self.level[pin] = 0
        if self.sinks:
            times = [0] * (2 * count)
            end = first + count * period
            times[0::2] = range(first, end, period)
            times[1::2] = range(first + width, end + width, period)
            levels = b"\x01\x00" * count
            for sink in self.sinks:
                sink.edges(pin, times, levels)

    def pulses_waiting(self, pin: int, first: int, period: int, count: int, width: int,
                       longer: list[tuple[int, int]]) -> None:
        """:meth:`pulses`, where pulse ``j`` of each ``(j, extra)`` of ``longer`` (in
        order, ``j < count``) is ``extra`` ticks longer (its interrupt waited for the CPU)."""
        rise = self.rise
        rise[pin] = rise.get(pin, 0) + count
        fall = self.fall
        fall[pin] = fall.get(pin, 0) + count
        total = self.high_total
        total[pin] = total.get(pin, 0) + count * width + sum(extra for _, extra in longer)
        longest = width + max(extra for _, extra in longer)
        if longest > self.high_max.get(pin, 0):
            self.high_max[pin] = longest
        self.level[pin] = 0
        if self.sinks:
            times = [0] * (2 * count)
            end = first + count * period
            times[0::2] = range(first, end, period)
            times[1::2] = range(first + width, end + width, period)
            for j, extra in longer:
                times[2 * j + 1] += extra
            levels = b"\x01\x00" * count
            for sink in self.sinks:
                sink.edges(pin, times, levels)

    def waveform(self, pin: int, times: list[int], levels: bytes) -> None:
        """A run of edges of one pin (a PWM timer's), in time order, alternating levels."""
        level = self.level.get(pin, 0)
        for t, lv in zip(times, levels, strict=True):
            if lv == level:
                continue
            level = lv
            if lv:
                self.rise[pin] = self.rise.get(pin, 0) + 1
                self.high_since[pin] = t
            else:
                self.fall[pin] = self.fall.get(pin, 0) + 1
                self._close_high(pin, t - self.high_since.get(pin, t))
        self.level[pin] = level
        if pin not in self.first_write and times:
            self.first_write[pin] = (self._writes, levels[0])
            self._writes += 1
        for sink in self.sinks:
            sink.edges(pin, times, levels)

    def rising(self, pin: int) -> int:
        return self.rise.get(pin, 0)

    def falling(self, pin: int) -> int:
        return self.fall.get(pin, 0)
