"""Clocks for the serial link: the wall clock, or a virtual clock for tests and benches.

Both count integer nanoseconds and offer one blocking primitive, ``wait(deadline,
stream)``: return when ``stream`` has input or the deadline has come.

:class:`RealClock` is the wall clock (optionally running ``scale`` times faster: a
sped-up simulated device).  :class:`VirtualClock` is a co-simulation: the party that
calls ``wait`` (the host) drives it, and every other party on the same machine - a
simulated device, a relay - is a *peer* stepped by the clock.  Bytes still travel
through real file descriptors (ptys); each direction is a :class:`Wire` that counts
bytes written and read, so the clock knows when every byte sent at the current
instant has been taken by its reader and only then lets time move on.  Runs are
therefore deterministic and take no wall time beyond the computing.
"""

from __future__ import annotations

import contextlib
import select
import time
from collections.abc import Sequence
from typing import Protocol


class Waitable(Protocol):
    def fileno(self) -> int: ...


class Wire:
    """Byte counters of one direction of a link (virtual clock only)."""

    __slots__ = ("name", "reader", "received", "sent")

    def __init__(self, reader: object | None = None, name: str = "") -> None:
        self.sent = 0
        self.received = 0
        self.reader = reader  # the peer reading this wire; None: the driving party
        self.name = name

    @property
    def pending(self) -> bool:
        return self.sent > self.received

    def drain(self) -> None:
        """Forget bytes in flight (the line was cut)."""
        self.received = self.sent


class Peer(Protocol):
    in_wires: list[Wire]

    def poll(self) -> None: ...

    def flush(self) -> bool: ...

    def advance(self, now_ns: int) -> None: ...

    def next_ns(self) -> int | None: ...


class Clock(Protocol):
    """What the link and the backend need of a clock: integer ns, and a wait."""

    virtual: bool
    scale: float

    def now_ns(self) -> int: ...

    def wait(self, deadline_ns: int | None, stream: Waitable | None) -> None: ...


class RealClock:
    """Wall-clock nanoseconds since creation, times ``scale``."""

    virtual = False

    def __init__(self, scale: float = 1.0) -> None:
        if scale <= 0:
            raise ValueError("clock scale must be positive")
        self.scale = scale
        self._t0 = time.monotonic_ns()

    def now_ns(self) -> int:
        return int((time.monotonic_ns() - self._t0) * self.scale)

    def wait(self, deadline_ns: int | None, stream: Waitable | None) -> None:
        timeout = None
        if deadline_ns is not None:
            timeout = max(0.0, (deadline_ns - self.now_ns()) / 1e9 / self.scale)
        if stream is None:
            time.sleep(0.05 if timeout is None else min(timeout, 0.05))
            return
        with contextlib.suppress(OSError, ValueError):  # closed: let the reader find out
            select.select([stream], [], [], timeout)


class VirtualClock:
    """Event-driven time shared by a driving party and its peers (see module text)."""

    virtual = True
    scale = 1.0
    SETTLE_LIMIT = 100_000
    IO_TIMEOUT_S = 10.0

    def __init__(self) -> None:
        self._now = 0
        self.peers: list[Peer] = []

    def now_ns(self) -> int:
        return self._now

    def add_peer(self, peer: Peer) -> None:
        self.peers.append(peer)

    def remove_peer(self, peer: Peer) -> None:
        if peer in self.peers:
            self.peers.remove(peer)

    def settle(self) -> None:
        """Let peers take every byte in flight and answer, until nothing moves."""
        for _ in range(self.SETTLE_LIMIT):
            busy = False
            for p in list(self.peers):
                if any(w.pending for w in p.in_wires):
                    p.poll()
                    busy = True
            for p in list(self.peers):
                if p.flush():
                    busy = True
            if not busy:
                return
        raise RuntimeError("virtual link does not settle")

    def wait(self, deadline_ns: int | None, stream: object | None) -> None:
        wire = getattr(stream, "rx_wire", None)
        while True:
            self.settle()
            if wire is not None and wire.pending:
                return
            if deadline_ns is not None and self._now >= deadline_ns:
                return
            self._step(deadline_ns)

    def run_until(self, deadline_ns: int) -> None:
        """Advance the peers alone (the driving party is silent) up to ``deadline_ns``."""
        while True:
            self.settle()
            if self._now >= deadline_ns:
                return
            self._step(deadline_ns)

    def _step(self, deadline_ns: int | None) -> None:
        times = [t for t in (p.next_ns() for p in self.peers) if t is not None]
        if deadline_ns is not None:
            times.append(deadline_ns)
        if not times:
            raise RuntimeError("virtual clock would wait for ever")
        t = max(min(times), self._now)
        self._now = t
        for p in list(self.peers):
            p.advance(t)


def wait_readable(fds: Sequence[int], timeout_s: float) -> bool:
    """Block until one of ``fds`` is readable (True) or ``timeout_s`` passed (False)."""
    try:
        r, _, _ = select.select(list(fds), [], [], timeout_s)
    except (OSError, ValueError):
        return True
    return bool(r)
