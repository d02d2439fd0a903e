"""A print on the simulated UART, character by character, and the interrupt time in it.

A print hands its characters to the UART one by one: each costs the loop a few hundred
ticks and, once the buffer is full, a wait for room (:func:`print_chars`).
:meth:`Machine.consume` and :meth:`Machine.resume_wait` answer each such span; between
two events the machine's :class:`~fas.sim.loop_isrs.IsrClock` does, with a cursor per
interrupt, so that a span costs a few comparisons (its common case is written out
here).  (This runs for every character a program prints: written for speed.)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:  # pragma: no cover
    from .machine import Machine


def print_chars(m: Machine, data: bytes, cpu_after: Sequence[int] | None,
                char_ticks: int) -> None:
    """The loop hands ``data`` to the UART: per character ``char_ticks`` of CPU time
    (plus ``cpu_after[i]``, work done before the next one), after waiting for room in
    the buffer when it is full."""
    uart = m.uart
    chars = uart.records
    capacity = uart.capacity
    heap = m.events
    byte_ticks = uart.byte_ticks
    idle_start = uart.idle_start
    reg = uart.register_ticks
    loads = uart.loads
    # the interrupts that take time from the loop, followed between events by the
    # machine's IsrClock (asked again after events ran); QuickStep's timers are not
    # followed there: then the machine counts every span
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
                if clock is None:
                    clock = m.isr_clock()
                wait = clock.resume_wait()
                if wait > 0:
                    ticks += wait
        # Uart.put(now), written out
        t = m.now
        prev = uart.last_start
        load = t if t > prev + reg else prev + reg
        start = prev + byte_ticks
        if load > start:  # the line is idle (Uart.idle_start)
            start = load + idle_start
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
                    and (not clock.uart_cost or (li := clock.li) == (n := len(loads))
                         or (li < n and loads[li] > end))):
                m.now = end
                continue
            ticks = clock.spend(ticks)
            if not ticks:
                continue
        # the machine counts the span (an event falls due in it, or QuickStep's timers
        # run) and may run events: the clock is asked for again afterwards
        clock = None
        m.consume_counting(ticks)
