"""A print on the simulated UART, character by character, and the interrupt time in it.

A print hands its characters to the UART one by one: each costs the loop a few hundred
ticks and, once the buffer is full, a wait for room (:func:`print_chars`).
:meth:`Machine.consume` and :meth:`Machine.resume_wait` answer each such span in
general (events may run, blocks of pulses start and end).  Between two events the
interrupts that take CPU time from the loop are all known in advance: the step
interrupts inside a running block of pulses and the ``millis()`` timer come at fixed
periods, the UART's loads are listed.  :class:`IsrClock` follows each with a cursor,
so that a span costs a few comparisons.  Its answers are those of the machine's
methods - the same counting rules, written for this case - and hold until an event
runs: a span in which an event falls due goes to the machine, and a new clock is made
afterwards.  (This runs for every character a program prints: written for speed.)
"""

from __future__ import annotations

from bisect import bisect_right
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:  # pragma: no cover
    from .machine import Machine

_NEVER = 1 << 62  # a tick later than any run


class IsrClock:
    """Cursors over the loop-stealing interrupts of a machine, from its ``now`` on.

    A *train* is a periodic interrupt: ticks ``first + j * period`` (``j >= 0``) up to
    the tick ``last``, each taking ``cost`` ticks; the list holds
    ``[next tick after the last span, period, first, last, cost]``.  The UART's loads
    are the machine's list, read from the cursor ``li`` on.
    Not for machines with ``cpu_sources`` (their timers are not followed here).

    ``key`` is what the trains depend on besides time (:meth:`Machine.isr_clock`):
    events run and scheduled, interrupt-blocked windows, and ``activity`` (a channel
    started or stopped from the main loop)."""

    __slots__ = ("m", "key", "trains", "loads", "li", "uart_cost", "quiet")

    def __init__(self, m: Machine) -> None:
        self.m = m
        self.key = (m.events_run, m._seq, m.irq_block_windows, m.activity)
        now = m.now
        trains = []
        for src in m.block_sources:  # as Machine.consume: interrupts j <= b_n - 2 of a
            if src.batch and src.isr_ticks:  # block (its last one is an event)
                first = src.b_c0 + src.lat
                trains.append(_train(first, src.b_t, first + (src.b_n - 2) * src.b_t,
                                     src.isr_ticks, now))
        p = m.timing
        if p.millis_isr_ticks and m._millis_started:  # overflows k >= 1 after phase
            ov = p.millis_overflow_ticks
            trains.append(_train(m._millis_phase + ov, ov, _NEVER, p.millis_isr_ticks,
                                 now))
        self.trains = trains
        self.uart_cost = p.uart_isr_ticks
        self.loads = m.uart._loads  # (appended to while printing: in order)
        self.li = bisect_right(self.loads, now)  # the first load after now
        # no train's interrupt before this tick (the UART's loads are looked at apart:
        # they grow while printing); 'now' until a span has set the cursors
        self.quiet = now

    def spend(self, ticks: int) -> int:
        """:meth:`Machine.consume` of ``ticks`` as long as no event falls due; returns
        what is left to spend (0: done) from the first span in which one does."""
        m = self.m
        heap = m._heap
        loads = self.loads
        n_loads = len(loads)
        uart_cost = self.uart_cost
        quiet = self.quiet
        while True:
            start = m.now
            end = start + ticks
            if heap and heap[0][0] <= end:
                self.quiet = quiet
                return ticks
            m.now = end
            stolen = m.stolen_ticks
            if end >= quiet:  # a train's interrupt may fall in the span: count them all
                quiet = _NEVER
                for tr in self.trains:
                    nxt = tr[0]
                    if nxt <= start:  # time jumped ahead (a wait): find the next one again
                        nxt = _next_after(start, tr[1], tr[2], tr[3])
                    if nxt <= end:
                        period, last = tr[1], tr[3]
                        k = (end - nxt) // period + 1
                        if nxt + (k - 1) * period > last:
                            k = (last - nxt) // period + 1
                        stolen += k * tr[4]
                        nxt += k * period
                        if nxt > last:
                            nxt = _NEVER
                    tr[0] = nxt
                    if nxt < quiet:
                        quiet = nxt
            if uart_cost:
                li = self.li
                if li and loads[li - 1] > start:  # the list was cut since (Uart)
                    li = bisect_right(loads, start)
                while li < n_loads and loads[li] <= start:
                    li += 1
                begin = li
                while li < n_loads and loads[li] <= end:
                    li += 1
                self.li = li
                if li > begin:
                    stolen += (li - begin) * uart_cost
            m.stolen_ticks = 0
            if not stolen:
                self.quiet = quiet
                return 0
            ticks = stolen

    def resume_wait(self) -> int:
        """:meth:`Machine.resume_wait` as far as its callers look: a positive answer is
        that one (no event ran since this clock was made)."""
        m = self.m
        m.stolen_ticks = 0
        now = m.now
        wait = m.busy_until - now
        for tr in self.trains:  # the interrupt of the period we are in, if it runs
            first = tr[2]
            if now >= first:
                into = (now - first) % tr[1]
                if into < tr[4] and now - into <= tr[3] and tr[4] - into > wait:
                    wait = tr[4] - into
        cost = self.uart_cost
        if cost:
            loads = self.loads
            li = self.li
            n_loads = len(loads)
            if li and loads[li - 1] > now:  # the list was cut since (Uart)
                li = bisect_right(loads, now)
            while li < n_loads and loads[li] <= now:
                li += 1
            self.li = li
            if li and loads[li - 1] > now - cost and loads[li - 1] + cost - now > wait:
                wait = loads[li - 1] + cost - now
        return wait


def _next_after(t: int, period: int, first: int, last: int) -> int:
    """The first tick of a train after tick ``t`` (``_NEVER`` when it has ended)."""
    tick = first if t < first else first + ((t - first) // period + 1) * period
    return tick if tick <= last else _NEVER


def _train(first: int, period: int, last: int, cost: int, now: int) -> list[int]:
    return [_next_after(now, period, first, last), period, first, last, cost]


def print_chars(m: Machine, data: bytes, cpu_after: Sequence[int] | None,
                char_ticks: int) -> None:
    """The loop hands ``data`` to the UART: per character ``char_ticks`` of CPU time
    (plus ``cpu_after[i]``, work done before the next one), after waiting for room in
    the buffer when it is full."""
    uart = m.uart
    chars = uart._chars
    capacity = uart.capacity
    heap = m._heap
    byte_ticks = uart.byte_ticks
    loads = uart._loads
    # the interrupts that take time from the loop, followed between events by the
    # machine's IsrClock (asked again after events ran); QuickStep's timers are not
    # followed there: then the machine answers every span
    clock = None
    plain = not m.cpu_sources
    for i in range(len(data)):
        ticks = char_ticks if cpu_after is None else char_ticks + cpu_after[i]
        if len(chars) >= capacity:  # Uart.room_at()
            room = chars[0][2]
            if room > m.now:  # the print waits for a free place in the buffer
                if heap and heap[0][0] <= room:
                    m.run_until(room)
                    clock = None
                else:
                    m.now = room
                # it goes on once the interrupts running now are done (Machine.resume)
                # and hands the character over: the buffer is full, so the character
                # goes onto the wire when the one before it is done, whatever the
                # exact moment of the hand-over; the CPU time adds up exactly
                if plain:
                    if clock is None:
                        clock = m.isr_clock()
                    wait = clock.resume_wait()
                else:
                    wait = m.resume_wait()
                if wait > 0:
                    ticks += wait
        # Uart.put(now), written out
        t = m.now
        prev = uart.last_start
        load = t if t > prev else prev
        start = prev + byte_ticks
        if load > start:
            start = load
        uart.last_start = start
        chars.append([t, load, start, prev])
        uart.chars += 1
        if load > t:
            loads.append(load)
        # handing the character over, then what follows it: one span of loop time
        # (Machine.consume counts every interrupt in it, so this is exact)
        if plain:
            if clock is None:
                clock = m.isr_clock()
            end = t + ticks  # IsrClock.spend's common case, written out: no interrupt
            if (end < clock.quiet and not m.stolen_ticks  # and no event in the span
                    and (not heap or heap[0][0] > end)
                    and (not clock.uart_cost or clock.li == len(loads)
                         or loads[clock.li] > end)):
                m.now = end
                continue
            ticks = clock.spend(ticks)
            if not ticks:
                continue
            clock = None  # an event falls due in the span: the machine runs it
        m.consume_counting(ticks)
