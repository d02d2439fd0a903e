"""A fault-injecting relay between a host side and a device side.

Each direction passes bytes through :class:`FaultyLine`: every byte is, with seeded
probabilities, dropped, corrupted (one bit flipped) or duplicated, then delayed by a
fixed latency; optionally the line is paced to a baud rate (10 bits per byte), so
that a pty behaves like a real 115200-baud wire, delivered in bursts (a USB
adapter's latency timer), and stalled for ``stall_ms`` every ``stall_every_ms`` (a
busy host or hub: nothing moves, then everything held comes at once).  The relay
serves ptys in real time (``stepperdemo relay``) or runs as a peer of a
:class:`~fas.serial.clock.VirtualClock` in tests and benchmarks.
"""

from __future__ import annotations

import random
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, fields

from ..serial.clock import Clock, RealClock
from ..serial.stream import ByteStream, LinkClosed

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class Faults:
    drop: float = 0.0
    corrupt: float = 0.0
    dup: float = 0.0
    latency_ms: float = 0.0
    baud: int = 0  # 0: no pacing
    seed: int = 1
    chunk_ms: float = 0.0  # deliver in bursts at this period (a USB adapter's latency timer)
    stall_ms: float = 0.0  # the line stands still this long ...
    stall_every_ms: float = 0.0  # ... at every multiple of this period (0: never)

    def __post_init__(self) -> None:
        for name in ("drop", "corrupt", "dup"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name} must be a probability, not {v}")
        if self.drop + self.corrupt + self.dup > 1.0:
            raise ValueError("fault probabilities add up to more than 1")
        if self.latency_ms < 0 or self.baud < 0 or self.chunk_ms < 0 or self.stall_ms < 0:
            raise ValueError("latency, baud, chunk and stall times must not be negative")
        if self.stall_ms and not self.stall_every_ms > self.stall_ms:
            raise ValueError("stalls need a period (stall_every_ms) longer than they are")


@dataclass
class LineStats:
    bytes_in: int = 0
    bytes_out: int = 0
    dropped: int = 0
    corrupted: int = 0
    duplicated: int = 0

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


class FaultyLine:
    """One direction: faults at the input, then latency and pacing to the output."""

    def __init__(self, faults: Faults, seed: int) -> None:
        self.f = faults
        self.rng = random.Random(seed)
        self.latency_ns = int(faults.latency_ms * 1_000_000)
        self.byte_ns = 10 * NS_PER_S // faults.baud if faults.baud else 0
        self.chunk_ns = int(faults.chunk_ms * 1_000_000)
        self.stall_ns = int(faults.stall_ms * 1_000_000)
        self.stall_every_ns = int(faults.stall_every_ms * 1_000_000)
        self.line_free_ns = 0
        self.queue: deque[tuple[int, int]] = deque()  # (release time, byte)
        self.stats = LineStats()

    def take(self, data: bytes, now_ns: int) -> None:
        f = self.f
        rng = self.rng
        st = self.stats
        p_drop = f.drop
        p_corrupt = p_drop + f.corrupt
        p_dup = p_corrupt + f.dup
        for b in data:
            st.bytes_in += 1
            r = rng.random()
            if r < p_drop:
                st.dropped += 1
                continue
            copies = 1
            if r < p_corrupt:
                b ^= 1 << rng.randrange(8)
                st.corrupted += 1
            elif r < p_dup:
                copies = 2
                st.duplicated += 1
            for _ in range(copies):
                self._schedule(b, now_ns)

    def _schedule(self, b: int, now_ns: int) -> None:
        if self.byte_ns:
            start = max(now_ns, self.line_free_ns)
            self.line_free_ns = start + self.byte_ns
            release = self.line_free_ns + self.latency_ns
        else:
            release = now_ns + self.latency_ns
        if self.chunk_ns:
            release = -(-release // self.chunk_ns) * self.chunk_ns
        if self.stall_ns:
            k, phase = divmod(release, self.stall_every_ns)
            if k and phase < self.stall_ns:
                release = k * self.stall_every_ns + self.stall_ns
        if self.queue and release < self.queue[-1][0]:
            release = self.queue[-1][0]  # a line keeps the order
        self.queue.append((release, b))

    def due(self, now_ns: int) -> bytes:
        q = self.queue
        out = bytearray()
        while q and q[0][0] <= now_ns:
            out.append(q.popleft()[1])
        self.stats.bytes_out += len(out)
        return bytes(out)

    def next_ns(self) -> int | None:
        return self.queue[0][0] if self.queue else None


class Relay:
    """Copies bytes host side <-> device side through two faulty lines."""

    def __init__(self, host_side: ByteStream, device_side: ByteStream, faults: Faults,
                 clock: Clock | None = None) -> None:
        self.host = host_side
        self.device = device_side
        self.faults = faults
        self.clock = clock or RealClock()
        self.to_device = FaultyLine(faults, faults.seed * 2 + 1)
        self.to_host = FaultyLine(faults, faults.seed * 2 + 2)
        self._out_device = bytearray()
        self._out_host = bytearray()
        self.closed: str | None = None
        self.in_wires = [w for w in (host_side.rx_wire, device_side.rx_wire) if w is not None]

    # --------------------------------------------------------- peer protocol
    def poll(self) -> None:
        now = self.clock.now_ns()
        for src, line in ((self.host, self.to_device), (self.device, self.to_host)):
            try:
                data = src.read_available()
            except LinkClosed as exc:
                if src is self.device:
                    self.closed = str(exc)
                continue
            if data:
                line.take(data, now)
        self._collect(now)

    def _collect(self, now: int) -> None:
        self._out_device += self.to_device.due(now)
        self._out_host += self.to_host.due(now)

    def flush(self) -> bool:
        wrote = False
        for dst, buf in ((self.device, self._out_device), (self.host, self._out_host)):
            if buf:
                try:
                    dst.write(bytes(buf))
                    wrote = True
                except LinkClosed as exc:
                    if dst is self.device:
                        self.closed = str(exc)
                buf.clear()
        return wrote

    def advance(self, now_ns: int) -> None:
        self._collect(now_ns)

    def next_ns(self) -> int | None:
        times = [t for t in (self.to_device.next_ns(), self.to_host.next_ns()) if t is not None]
        return min(times) if times else None

    # ---------------------------------------------------------- real time
    def serve(self, stop: Callable[[], bool] = lambda: False) -> None:
        """Relay in real time until ``stop()`` or the device side closes."""
        import select

        clock = self.clock
        while not stop() and self.closed is None:
            nxt = self.next_ns()
            timeout = 0.2 if nxt is None else max(0.0, (nxt - clock.now_ns()) / 1e9)
            try:
                select.select([self.host.fileno(), self.device.fileno()], [], [],
                              min(timeout, 0.2))
            except (OSError, ValueError):
                break
            self.poll()
            self.flush()

    def stats(self) -> dict[str, dict[str, int]]:
        return {"to_device": self.to_device.stats.as_dict(),
                "to_host": self.to_host.stats.as_dict()}
