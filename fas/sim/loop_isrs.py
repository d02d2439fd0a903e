"""The interrupts that take CPU time from the main loop, and how many fall in a span.

The main loop of an application (StepperDemo) loses CPU time to interrupt routines.
Those that run as events (a single step interrupt, the ramp task) add their time
themselves (:meth:`Machine.run_until`).  The others are counted per span of loop
time by :meth:`Machine.consume`:

* *trains*: interrupts at fixed periods, all known in advance until the next event
  (:meth:`Machine.loop_trains` states which: the step interrupts inside a block of
  pulses that a channel simulates as one - its last interrupt is an event of its
  own - and the ``millis()`` timer's overflows);
* the console UART's transmit interrupts, one per character it loads from its buffer
  (:attr:`Uart.loads`);
* timers that tick without events (``Machine.cpu_sources``: QuickStep's period
  interrupt), which count their own time.

A train is ``(first, period, last, cost)``: interrupts at ``first + j * period``
(``j >= 0``) up to the tick ``last``, each taking ``cost`` ticks.  The functions
here are the one place that counts a train: :func:`next_after`, :func:`count_from`
(:func:`count_between`) and :func:`running_end` - the machine uses them for every
span, and :class:`IsrClock` keeps a cursor per train over them.

:class:`IsrClock` answers spans between two events fast: a print hands the UART a
character at a time (:func:`fas.sim.printing.print_chars`), each a span of a few
hundred ticks, so a span must cost a few comparisons.  It holds until an event runs
or the machine's state changes (:meth:`Machine.isr_clock` makes a new one then): a
span in which an event falls due goes back to the machine.
(This runs for every character a program prints: written for speed.)
"""

from __future__ import annotations

from bisect import bisect_right
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from .machine import Machine

NEVER = 1 << 62  # a tick later than any run

Train = tuple[int, int, int, int]  # (first, period, last, cost)


def next_after(t: int, period: int, first: int, last: int) -> int:
    """The first tick of a train after tick ``t`` (:data:`NEVER` when it has ended)."""
    tick = first if t < first else first + ((t - first) // period + 1) * period
    return tick if tick <= last else NEVER


def count_from(nxt: int, period: int, last: int, end: int) -> int:
    """Interrupts of a train from its tick ``nxt`` on up to tick ``end`` (``nxt <= end``,
    ``nxt <= last``)."""
    k = (end - nxt) // period + 1
    if nxt + (k - 1) * period > last:
        k = (last - nxt) // period + 1
    return k


def count_between(train: Train, start: int, end: int) -> int:
    """Interrupts of ``train`` in the span ``(start, end]``."""
    first, period, last, _ = train
    nxt = next_after(start, period, first, last)
    return count_from(nxt, period, last, end) if nxt <= end else 0


def running_end(now: int, first: int, period: int, last: int, cost: int) -> int | None:
    """The tick at which the train's interrupt that runs at ``now`` ends (None: none
    runs)."""
    if now >= first:
        into = (now - first) % period
        if into < cost and now - into <= last:
            return now - into + cost
    return None


class IsrClock:
    """Cursors over the loop-stealing interrupts of a machine, from its ``now`` on.

    ``trains`` holds per train ``[next tick after the last span, period, first, last,
    cost]`` (:meth:`Machine.loop_trains`); the UART's loads are its list
    (:attr:`Uart.loads`), read from the cursor ``li`` on.  The Uart may cut that list
    meanwhile: at the back (loads that moved behind an interrupt-blocked window) and at
    the front (loads far behind).  A cursor past the end, or behind a load later than
    the tick looked for, is found again; otherwise every load it skipped lies before
    that tick (the list is in order), so going on from it counts right.  Timers without events
    (``cpu_sources``) are not followed: a machine with them counts every span itself.
    Made by :meth:`Machine.isr_clock`, which knows when it no longer holds."""

    __slots__ = ("m", "events", "trains", "loads", "li", "uart_cost", "quiet")

    def __init__(self, m: Machine) -> None:
        self.m = m
        self.events = m.events
        now = m.now
        self.trains = [[next_after(now, period, first, last), period, first, last, cost]
                       for first, period, last, cost in m.loop_trains()]
        self.uart_cost = m.timing.uart_isr_ticks
        self.loads = m.uart.loads  # (appended to while printing: in order)
        self.li = bisect_right(self.loads, now)  # the first load after now
        # no train's interrupt before this tick (the UART's loads are looked at apart:
        # they grow while printing); 'now' until a span has set the cursors
        self.quiet = now

    def spend(self, ticks: int) -> int:
        """:meth:`Machine.consume` of ``ticks`` as long as no event falls due; returns
        what is left to spend (0: done) from the first span in which one does."""
        m = self.m
        heap = self.events
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
                quiet = NEVER
                for tr in self.trains:
                    nxt = tr[0]
                    if nxt <= start:  # time jumped ahead (a wait): find the next one again
                        nxt = next_after(start, tr[1], tr[2], tr[3])
                    if nxt <= end:
                        period = tr[1]  # (count_from; its common case written out)
                        k = 1 if nxt + period > end else count_from(nxt, period, tr[3], end)
                        stolen += k * tr[4]
                        nxt += k * period
                        if nxt > tr[3]:
                            nxt = NEVER
                    tr[0] = nxt
                    if nxt < quiet:
                        quiet = nxt
            if uart_cost:
                li = self.li
                if li and (li > n_loads or loads[li - 1] > start):  # cut since (Uart)
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
        """:meth:`Machine.resume_wait`: forget what interrupts took while the loop
        waited, and return how long the routines running now still hold the CPU."""
        m = self.m
        m.stolen_ticks = 0
        now = m.now
        wait = m.busy_until - now
        for tr in self.trains:  # the interrupt of the period we are in, if it runs
            end = running_end(now, tr[2], tr[1], tr[3], tr[4])
            if end is not None and end - now > wait:
                wait = end - now
        cost = self.uart_cost
        if cost:
            loads = self.loads
            li = self.li
            n_loads = len(loads)
            if li and (li > n_loads or loads[li - 1] > now):  # cut since (Uart)
                li = bisect_right(loads, now)
            while li < n_loads and loads[li] <= now:
                li += 1
            self.li = li
            if li and loads[li - 1] > now - cost and loads[li - 1] + cost - now > wait:
                wait = loads[li - 1] + cost - now
        return wait
