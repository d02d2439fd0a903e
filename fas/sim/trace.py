"""Pin edges in global time order, and VCD files made from them.

The pin bank hands edges to its sinks per pin and in blocks: the pulses of one queue
entry arrive when the entry's block ends, so edges of different pins do not arrive
in global time order.  :class:`EdgeStream` puts them in order.  It buffers edges per
pin and hands on only those before a *watermark* - the earliest tick at which an
edge could still be reported: the machine's clock, or the first pulse of a block
that a channel has not reported yet.  Memory therefore stays bounded by a few blocks
per pin, however long the run.

Consumers of the ordered stream get runs of consecutive edges of one pin
(``edge_run(pin, times, levels)``).  :class:`VcdWriter` is such a consumer: it writes
a Value Change Dump with pyvcd, streaming, one variable per named pin plus the
interrupt-blocked windows of the application (StepperDemo's ``e``) as a signal.
"""

from __future__ import annotations

import heapq
import shutil
from bisect import bisect_right
from collections.abc import Mapping, Sequence
from math import gcd
from typing import IO, TYPE_CHECKING, Protocol

if TYPE_CHECKING:  # pragma: no cover
    from .backend import SimBackend

IRQ_BLOCKED = -1  # pseudo pin of the stream: HIGH while the application blocks interrupts
IRQ_BLOCKED_NAME = "IrqBlocked"
FLUSH_EDGES = 1 << 15  # hand edges on once this many are buffered

_UNITS = ((0, "s"), (3, "ms"), (6, "us"), (9, "ns"), (12, "ps"), (15, "fs"))


class OrderedEdgeSink(Protocol):
    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        """Consecutive edges of ``pin`` in global time order (levels 0/1)."""


class EdgeStream:
    """Merges the per-pin edge blocks of a simulated machine into global time order.

    ``start()`` subscribes to the pin bank (and to interrupt-block windows), ``stop()``
    hands on everything still buffered and unsubscribes.  Consumers are added with
    :meth:`add` before or while the stream runs.
    """

    def __init__(self, backend: SimBackend, flush_edges: int = FLUSH_EDGES) -> None:
        self.backend = backend
        self.machine = backend.machine
        self.flush_edges = flush_edges
        self.consumers: list[OrderedEdgeSink] = []
        self._times: dict[int, list[int]] = {}
        self._levels: dict[int, bytearray] = {}
        self._buffered = 0
        self._irq_open: tuple[int, int] | None = None  # blocked window not yet ended
        self.start_tick = 0
        self.last_tick = 0  # time of the last edge handed on
        self.edges_out = 0
        self.peak_buffered = 0  # most edges held at once (memory stays flat in run length)
        self.late_edges = 0  # edges reported behind the watermark (clamped; should be 0)
        self.active = False
        self._flushing = False

    def add(self, consumer: OrderedEdgeSink) -> None:
        self.consumers.append(consumer)

    # ------------------------------------------------------------ lifecycle
    def start(self) -> int:
        """Subscribe; returns the tick from which the stream is complete."""
        if not self.active:
            self.active = True
            # PWM waves made so far are not part of the stream (nobody listened)
            self.machine.outputs.deliver_until(self.machine.now)
            self.start_tick = self.last_tick = self.watermark()
            self.machine.pins.sinks.append(self)
            self.machine.block_listeners.append(self._on_block)
        return self.start_tick

    def stop(self) -> int:
        """Hand on every buffered edge, unsubscribe; returns the end tick of the stream."""
        if self.active:
            self._settle()
            self.active = False
            self.machine.pins.sinks.remove(self)
            self.machine.block_listeners.remove(self._on_block)
            if self._irq_open is not None:
                self._push(IRQ_BLOCKED, [self._irq_open[1]], b"\x00")
                self._irq_open = None
            self._flush(None)
        return max(self.last_tick, self.machine.now)

    # ------------------------------------------------------------ input side
    def watermark(self) -> int:
        """No edge before this tick can still be reported."""
        w = self.machine.now
        for ch in self.backend.channels:
            t = ch.undelivered_from()
            if t is not None and t < w:
                w = t
        t = self.machine.outputs.undelivered_from()
        if t is not None and t < w:
            w = t
        return w

    def edges(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        self._push(pin, times, levels)
        if self._buffered >= self.flush_edges:
            self.flush()

    def _push(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        buf = self._times.get(pin)
        if buf is None:
            buf = self._times[pin] = []
            self._levels[pin] = bytearray()
        buf.extend(times)
        self._levels[pin].extend(levels)
        self._buffered += len(times)
        self.peak_buffered = max(self.peak_buffered, self._buffered)

    def _on_block(self, start: int, end: int) -> None:
        """Interrupts blocked from ``start`` to ``end``; windows that touch are joined."""
        if self._irq_open is not None:
            o_start, o_end = self._irq_open
            if start <= o_end:
                self._irq_open = (o_start, max(o_end, end))
                return
            self._push(IRQ_BLOCKED, [o_end], b"\x00")
        self._push(IRQ_BLOCKED, [start], b"\x01")
        self._irq_open = (start, end)

    # ----------------------------------------------------------- output side
    def _settle(self) -> None:
        """Have the channels report the pulses of their running blocks up to now."""
        now = self.machine.now
        for ch in self.backend.channels:
            ch.deliver_until(now)
        self._deliver_outputs()

    def _deliver_outputs(self) -> None:
        """PWM waves make their edges on demand: up to now, before the watermark passes."""
        if not self._flushing:
            self._flushing = True
            try:
                self.machine.outputs.deliver_until(self.machine.now, self._after_chunk)
            finally:
                self._flushing = False

    def _after_chunk(self) -> None:
        if self._buffered >= self.flush_edges:
            self._flush(self.watermark())

    def flush(self, settle: bool = False) -> None:
        """Hand on every buffered edge before the watermark.

        ``settle``: first have the channels report the complete pulses of blocks still
        running (for a report in the middle of a move; not from inside a sink call).
        """
        if self.active:
            if self._flushing:
                return  # edges arriving while PWM edges are handed over: flushed after
            if settle:
                self._settle()
            else:
                self._deliver_outputs()
            w = self.watermark()
            if self._irq_open is not None and self._irq_open[1] <= w:
                self._push(IRQ_BLOCKED, [self._irq_open[1]], b"\x00")
                self._irq_open = None
            self._flush(w)

    def _flush(self, limit: int | None) -> None:
        segs: list[tuple[int, list[int], bytearray]] = []
        for pin, times in self._times.items():
            if not times:
                continue
            levels = self._levels[pin]
            if limit is None or times[-1] <= limit:
                segs.append((pin, times, levels))
                self._times[pin] = []
                self._levels[pin] = bytearray()
            else:
                k = bisect_right(times, limit)
                if k:
                    segs.append((pin, times[:k], levels[:k]))
                    del times[:k]
                    del levels[:k]
        if not segs:
            return
        for _, times, _ in segs:
            self._buffered -= len(times)
            if times[0] < self.last_tick:
                self._clamp(times)
        self._merge(segs)

    def _clamp(self, times: list[int]) -> None:
        last = self.last_tick
        for i, t in enumerate(times):
            if t >= last:
                break
            times[i] = last
            self.late_edges += 1

    def _merge(self, segs: list[tuple[int, list[int], bytearray]]) -> None:
        """Hand on the segments (each in time order) as runs in global time order."""
        consumers = self.consumers
        if len(segs) == 1:
            pin, times, levels = segs[0]
            for c in consumers:
                c.edge_run(pin, times, bytes(levels))
            self.edges_out += len(times)
            self.last_tick = times[-1]
            return
        # galloping merge: emit from the earliest segment everything up to the next
        # segment's head; one step per switch between pins, not per edge
        heap = [(times[0], i) for i, (_, times, _) in enumerate(segs)]
        heapq.heapify(heap)
        pos = [0] * len(segs)
        while heap:
            _, i = heapq.heappop(heap)
            pin, times, levels = segs[i]
            p = pos[i]
            k = bisect_right(times, heap[0][0], p) if heap else len(times)
            if p == 0 and k == len(times):
                run_t, run_l = times, bytes(levels)
            else:
                run_t, run_l = times[p:k], bytes(levels[p:k])
            for c in consumers:
                c.edge_run(pin, run_t, run_l)
            self.edges_out += k - p
            self.last_tick = times[k - 1]
            if k < len(times):
                pos[i] = k
                heapq.heappush(heap, (times[k], i))


# ---------------------------------------------------------------------- VCD
def vcd_timescale(ticks_per_s: int) -> tuple[str, int, int]:
    """The coarsest standard VCD timescale (1/10/100 s..fs) in which a tick is whole.

    Returns ``(timescale, num, den)`` with VCD time = tick * num // den; ``den`` is 1
    when ticks are exact (16 MHz: "100 ps", 625 per tick).  A clock with no exact
    decimal period (21 MHz) gets "1 ps", each tick rounded down to the picosecond.
    """
    for k in range(16):
        if 10**k % ticks_per_s == 0:
            return _timescale_label(k), 10**k // ticks_per_s, 1
    return "1 ps", 10**12, ticks_per_s


def _timescale_label(k: int) -> str:
    """Timescale of 10**-k seconds as VCD text ("100 ps")."""
    for exp, unit in _UNITS:
        if exp >= k:
            return f"{10 ** (exp - k)} {unit}"
    raise ValueError(f"timescale 1e-{k} s is finer than 1 fs")


def timescale_fs(timescale: str) -> int:
    """A VCD timescale like "1 us" in femtoseconds (ValueError, KeyError if it is none)."""
    from vcd.common import Timescale

    ts = Timescale.from_str(timescale)
    exp: int = {u: e for e, u in _UNITS}[ts.unit.value]
    magnitude = int(getattr(ts.magnitude, "value", ts.magnitude))
    if magnitude not in (1, 10, 100):  # the standard's; viewers misread other magnitudes
        raise ValueError(f"timescale magnitude {magnitude}: use 1, 10 or 100")
    unit_fs: int = 10 ** (15 - exp)  # exp <= 15: a whole number
    return magnitude * unit_fs


def timescale_factor(timescale: str, ticks_per_s: int) -> tuple[int, int]:
    """``(num, den)`` with VCD time = tick * num // den for a timescale like "1 ns"."""
    num, den = 10**15, timescale_fs(timescale) * ticks_per_s
    g = gcd(num, den)
    return num // g, den // g


class VcdWriter:
    """Streams ordered edges into a VCD file (pyvcd), one scalar wire per named pin.

    ``signals`` maps a pin to one or more names (a pin shared by two steppers, like
    the ESP32 demo's direction pin, gets one variable and an alias).  Edges of pins
    without a name are counted in ``ignored`` and not written.

    ``timescale`` None is the coarsest unit in which every tick is exact
    (:func:`vcd_timescale`).  A coarser unit rounds each edge down to it: a pulse (or
    a gap) shorter than the unit can then start and end at the same time, a change
    that viewers such as PulseView drop; ``zero_width`` counts them.
    """

    def __init__(self, file: IO[str], signals: Mapping[int, str | Sequence[str]],
                 ticks_per_s: int, *, start_tick: int = 0,
                 initial: Mapping[int, int] | None = None, timescale: str | None = None,
                 scope: str = "stepperdemo", comment: str = "") -> None:
        from vcd import VCDWriter as _PyVcdWriter

        if timescale is None:
            timescale, self._num, self._den = vcd_timescale(ticks_per_s)
        else:
            self._num, self._den = timescale_factor(timescale, ticks_per_s)
        self.timescale = timescale
        self.ticks_per_s = ticks_per_s
        self.file = file
        initial = initial or {}
        self._writer = _PyVcdWriter(file, timescale=timescale, date="",
                                    version="stepperdemo (fas.sim)", comment=comment,
                                    init_timestamp=self.vcd_time(start_tick),
                                    check_values=False)
        self._vars = {}
        for pin, names in signals.items():
            names = [names] if isinstance(names, str) else list(names)
            var = self._writer.register_var(scope, names[0], "wire", size=1,
                                            init=initial.get(pin, 0))
            for alias in names[1:]:
                self._writer.register_alias(scope, alias, var)
            self._vars[pin] = var
        # header and initial values now: an edge at the very start tick is then written
        # as a change after $dumpvars instead of replacing the initial value
        self._writer.flush()
        self.changes = 0
        self.ignored = 0
        # changes that the unit puts at the time of the one before on their pin (a later
        # tick, the same VCD time); changes in one tick are not counted: no unit parts them
        self.zero_width = 0
        self._last: dict[int, tuple[int, int]] = {}  # pin -> (tick, VCD time) of its last
        self.closed = False

    def vcd_time(self, tick: int) -> int:
        return tick * self._num // self._den

    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        var = self._vars.get(pin)
        if var is None:
            self.ignored += len(times)
            return
        change = self._writer.change
        num, den = self._num, self._den
        if den == 1:
            for t, lv in zip(times, levels, strict=True):
                change(var, t * num, lv)
        else:  # rounded down to the unit: a change may fall on the one before
            last_t, last = self._last.get(pin, (-1, -1))
            zero = 0
            for t, lv in zip(times, levels, strict=True):
                vt = t * num // den
                if vt == last and t != last_t:
                    zero += 1
                last_t, last = t, vt
                change(var, vt, lv)
            self._last[pin] = (last_t, last)
            self.zero_width += zero
        self.changes += len(times)

    def flush(self, end_tick: int | None = None) -> None:
        self._writer.flush(None if end_tick is None else self.vcd_time(end_tick))

    def close(self, end_tick: int) -> None:
        """Write the end time (so that viewers show the whole run) and stop writing."""
        if not self.closed:
            self.closed = True
            self._writer.close(self.vcd_time(end_tick))

    def copy_to(self, path: str, end_tick: int, timescale: str | None = None) -> int:
        """Write what is recorded so far, ending at ``end_tick``, to another file - in
        another ``timescale`` if one is given.  Returns the changes of the copy that
        fall on the time of the one before on their signal (see ``zero_width``)."""
        if not self.closed:
            self._writer.flush()
        if not self.file.closed:
            self.file.flush()
        end = None if self.closed else self.vcd_time(end_tick)
        with open(self.file.name, encoding="ascii") as src, \
                open(path, "w", encoding="ascii", newline="\n") as dst:
            if timescale is None or timescale_fs(timescale) == timescale_fs(self.timescale):
                shutil.copyfileobj(src, dst, 1 << 20)
                if end is not None:
                    dst.write(f"#{end}\n")
                return self.zero_width
            return _rescale(src, dst, timescale, timescale_fs(self.timescale),
                            timescale_fs(timescale), end)


def _rescale(src: IO[str], dst: IO[str], timescale: str, src_fs: int, dst_fs: int,
             end: int | None) -> int:
    """Copy a VCD of scalar wires written by :class:`VcdWriter` into another unit: each
    time is rounded down to it (the same as writing it in that unit at once, as long
    as the source was exact or the new unit is a multiple of the old one).  Equal
    times are merged; returns the changes that the new unit puts on the time of the one
    before on their wire (``VcdWriter.zero_width``)."""
    zero, shown = 0, -1
    now = was = 0
    last: dict[str, tuple[int, int]] = {}  # identifier -> (old time, new time)
    header = True
    for line in src:
        if header:
            if line.startswith("$timescale"):
                line = f"$timescale {timescale} $end\n"
            elif line.startswith("$enddefinitions"):
                header = False
            dst.write(line)
            continue
        if line.startswith("#"):
            was = int(line[1:])
            now = was * src_fs // dst_fs
            if now != shown:
                dst.write(f"#{now}\n")
                shown = now
            continue
        if line[:1] in "01xzXZ" and len(line) > 2:
            ident = line[1:-1]
            before = last.get(ident)
            if before is not None and before[1] == now and before[0] != was:
                zero += 1
            last[ident] = (was, now)
        dst.write(line)
    if end is not None:
        end = end * src_fs // dst_fs
        if end != shown:
            dst.write(f"#{end}\n")
    return zero


class VcdTrace:
    """A VCD file of a simulated run: an :class:`EdgeStream` with a :class:`VcdWriter`.

    ``VcdTrace(backend, "run.vcd", {9: "StepA", 5: "DirA"}).start()``, run the
    machine, then ``close()``.
    """

    def __init__(self, backend: SimBackend, path: str,
                 signals: Mapping[int, str | Sequence[str]], *,
                 irq_signal: str | None = IRQ_BLOCKED_NAME, timescale: str | None = None,
                 comment: str = "") -> None:
        self.backend = backend
        self.path = path
        self.signals = dict(signals)
        if irq_signal:
            self.signals[IRQ_BLOCKED] = irq_signal
        self.timescale = timescale
        self.comment = comment
        self.stream = EdgeStream(backend)
        self.writer: VcdWriter | None = None
        self._file: IO[str] | None = None

    def start(self) -> VcdTrace:
        start = self.stream.start()
        # kept open for the whole run (streaming); closed by close()
        self._file = open(self.path, "w", encoding="ascii", newline="\n",  # noqa: SIM115 - written until close()
                          buffering=1 << 20)
        self.writer = VcdWriter(self._file, self.signals, self.backend.profile.ticks_per_s,
                                start_tick=start, initial=pin_levels(self.backend, self.signals),
                                timescale=self.timescale, comment=self.comment)
        self.stream.add(self.writer)
        return self

    def close(self) -> None:
        if self.writer is None or self.writer.closed:
            return
        self.writer.close(self.stream.stop())
        if self._file is not None:  # opened with the writer (start)
            self._file.close()


def pin_levels(backend: SimBackend, pins: Mapping[int, object] | Sequence[int]) -> dict[int, int]:
    """Current levels of real pins (pseudo pins such as :data:`IRQ_BLOCKED` are LOW)."""
    bank = backend.machine.pins
    return {pin: bank.get(pin) if pin >= 0 else 0 for pin in pins}
