"""The host's time in device ticks, and the device counter's offset to it.

docs/serial-protocol.md, section 7.  The host counts its own time in ticks at the rate
the device announces (``clock_hz``, Ident), from the first connection on.  Clock
samples - a SyncRequest with the host's tick, answered with the device's tick when it
took the request - give the device's 32-bit counter at any host tick: of the last
:data:`SYNC_SAMPLES` samples, the one with the shortest round trip is trusted; the
longest tells how slow the line can be (:meth:`ClockSync.high_round_trip`).
"""

from __future__ import annotations

from typing import Protocol

from .protocol import SyncReply, tick_diff32

NS_PER_S = 1_000_000_000
SYNC_SAMPLES = 8
MAX_SAMPLE_S = 5  # an answer later than this is not a clock sample


class WallClock(Protocol):
    """What the host's time is read from (:class:`~fas.serial.clock.RealClock`, or the
    virtual clock of a test)."""

    def now_ns(self) -> int: ...


class ClockSync:
    """Host ticks at the device's rate, and the device counter's offset (see module)."""

    __slots__ = ("_ns_base", "_tick_base", "clock", "clock_hz", "offset32", "rtt_ticks",
                 "samples")

    def __init__(self, clock: WallClock, clock_hz: int = 16_000_000) -> None:
        self.clock = clock
        self.clock_hz = clock_hz
        self._tick_base = 0
        self._ns_base = clock.now_ns()
        self.offset32 = 0  # device counter - host tick (mod 2^32)
        self.samples: list[tuple[int, int]] = []  # (rtt_ticks, offset32)
        self.rtt_ticks = 0  # the round trip of the trusted sample

    # ------------------------------------------------------------ host time
    def now(self) -> int:
        """The host's time in device ticks."""
        return self._tick_base + (self.clock.now_ns() - self._ns_base) * self.clock_hz // NS_PER_S

    def ns_at(self, tick: int) -> int:
        """The clock's ns at which host tick ``tick`` begins."""
        return self._ns_base + -(-(tick - self._tick_base) * NS_PER_S // self.clock_hz)

    def tick_at_ns(self, ns: int) -> int:
        """The first host tick at or after the clock's ``ns``."""
        return self._tick_base + -(-(ns - self._ns_base) * self.clock_hz // NS_PER_S)

    def ns_ticks(self, ns: int) -> int:
        """A duration in ns, in ticks."""
        return ns * self.clock_hz // NS_PER_S

    def set_rate(self, clock_hz: int) -> None:
        """The device counts at ``clock_hz`` (Ident): host ticks go on at that rate."""
        if clock_hz != self.clock_hz:
            now_ns = self.clock.now_ns()
            self._tick_base = self.now()
            self._ns_base = now_ns
            self.clock_hz = clock_hz

    # --------------------------------------------------------- the device
    def device_tick32(self, host_tick: int) -> int:
        """The device's 32-bit tick counter at host tick ``host_tick`` (estimated)."""
        return (host_tick + self.offset32) & 0xFFFFFFFF

    def host_tick(self, device_tick: int) -> int:
        """The host tick at which the device's counter showed ``device_tick`` (recent)."""
        now = self.now()
        return now + tick_diff32(device_tick, self.device_tick32(now))

    def clear(self) -> None:
        """A new session: the samples start again."""
        self.samples.clear()

    def sample(self, m: SyncReply) -> int | None:
        """Take the answer to a clock sample; its round trip in ticks (None: too late to
        count)."""
        t1 = self.now()
        rtt = (t1 - m.stamp) & 0xFFFFFFFF
        if rtt > self.clock_hz * MAX_SAMPLE_S:
            return None
        t0 = t1 - rtt
        offset = (m.device_tick - (t0 + rtt // 2)) & 0xFFFFFFFF
        samples = self.samples
        samples.append((rtt, offset))
        del samples[:-SYNC_SAMPLES]
        self.rtt_ticks, self.offset32 = min(samples)
        return rtt

    def high_round_trip(self, rank: int = 1) -> int | None:
        """The longest round trip of the recent samples (``rank=2``: the second longest,
        so that one sample that waited behind a burst does not count); None before any."""
        if not self.samples:
            return None
        rtts = sorted(rtt for rtt, _ in self.samples)
        return rtts[-min(rank, len(rtts))]
