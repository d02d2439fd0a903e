"""The console's serial transmitter: a buffered UART that makes long prints block.

StepperDemo prints at 115200 baud.  The Arduino serial driver holds 63 characters in
its buffer plus one in the UART's data register; the next ``print`` waits until a
slot frees.  So a long usage text shifts every later command by milliseconds, which
is visible in the firmware's timing (e.g. when the first move starts).

Character ``k`` is moved from the buffer into the data register ("loaded") by the
transmit interrupt as soon as the register is free, which is when character ``k-1``
starts on the wire: ``L[k] = max(write time, S[k-1])``, and it starts at
``S[k] = max(L[k], S[k-1] + byte time)``.  While the main loop has interrupts
disabled (StepperDemo's ``e``) the interrupt cannot load, so a load that falls into
such a window waits for its end; the line goes idle meanwhile.  A write of character
``k`` can complete only once character ``k-buffer`` has started.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections import deque
from operator import itemgetter

_load = itemgetter(1)  # the load tick of a character record


class Uart:
    __slots__ = ("byte_ticks", "capacity", "records", "last_start", "chars", "loads", "_pos",
                 "idle_start", "register_ticks")

    def __init__(self, byte_ticks: int, capacity: int, idle_start: int = 0,
                 single_register: bool = False) -> None:
        self.byte_ticks = byte_ticks
        self.capacity = capacity
        # ``single_register`` (SimTiming.uart_tx_single_register): the data register
        # frees only when its character is done on the wire (simavr's transmitter: no
        # separate shift register), so a character is loaded when the one before it
        # ends, not when it starts
        self.register_ticks = byte_ticks if single_register else 0
        # a character the loop hands over while the line is idle goes onto the wire
        # this much later (SimTiming.uart_idle_start_ticks): the transmit interrupts
        # that follow keep that phase (a load held by a blocked section does not)
        self.idle_start = idle_start
        # the newest ``capacity`` characters as
        # [write tick, load tick, start tick, start tick of the one before]
        # (fas.sim.printing hands characters over written out, for speed)
        self.records: deque[list[int]] = deque(maxlen=capacity)
        self.last_start = -(1 << 62)
        self.chars = 0
        # load ticks of the characters the transmit interrupt loaded, in order, and the
        # number of them at or before the last window asked about (windows move forward)
        self.loads: list[int] = []
        self._pos = 0

    def room_at(self) -> int:
        """Earliest tick at which one more character can be handed over."""
        if len(self.records) < self.capacity:
            return -(1 << 62)
        return self.records[0][2]

    def put(self, t: int) -> None:
        """Hand over one character at tick ``t`` (``t >= room_at()``)."""
        prev = self.last_start
        load = max(t, prev + self.register_ticks)
        start = prev + self.byte_ticks
        if load > start:  # the line is idle
            start = load + self.idle_start
        self.last_start = start
        self.records.append([t, load, start, prev])
        self.chars += 1
        if load > t:
            self.loads.append(load)

    def interrupts_blocked(self, begin: int, end: int) -> None:
        """Interrupts are off in ``[begin, end)``: loads due in it wait for its end.

        Windows arrive in time order and never before a pending write, so only
        characters loaded at or after ``begin`` move (with all that follow them):
        loads are in order, so those are the last ones.
        """
        chars = self.records
        k = len(chars)
        while k and chars[k - 1][1] >= begin:
            k -= 1
        if k == len(chars):
            return  # every character was loaded before the window
        moved = [chars[i] for i in range(k, len(chars))]
        prev_start = moved[0][3]
        reg = self.register_ticks
        for ch in moved:
            load = max(ch[0], prev_start + reg)
            if begin <= load < end:
                load = end
            start = prev_start + self.byte_ticks
            if load > start:  # the line is idle: a hand-over's start lags, a held load's not
                start = load + (self.idle_start if load == ch[0] else 0)
            ch[1] = load
            ch[2] = start
            ch[3] = prev_start
            prev_start = start
        self.last_start = prev_start
        loads = self.loads  # (in order: the ones before the window stay)
        del loads[bisect_left(loads, begin):]
        loads.extend([ch[1] for ch in moved if ch[1] > ch[0]])
        self._pos = min(self._pos, bisect_right(loads, begin))

    def isr_loads_between(self, begin: int, end: int) -> int:
        """Characters the transmit interrupt loads in ``(begin, end]``.

        A character written while the data register is free goes there directly;
        only the ones that waited in the buffer are loaded by the interrupt.
        """
        loads = self.loads
        n = len(loads)
        i = self._pos
        if i and loads[i - 1] > begin:  # a window before the last one
            i = bisect_right(loads, begin)
        elif i < n and loads[i] <= begin:  # further on (prints follow the loads
            i = bisect_right(loads, begin, i + 1)  # themselves: fas.sim.loop_isrs)
        if i > 4096:  # forget what lies far behind
            del loads[:i - 256]
            n -= i - 256
            i = 256
        self._pos = i
        j = i
        while j < n and loads[j] <= end:
            j += 1
        return j - i

    def isr_running_at(self, t: int, cost: int) -> int | None:
        """End of the transmit interrupt (``cost`` long) that runs at tick ``t``."""
        loads = self.loads
        i = bisect_right(loads, t)
        if i and loads[i - 1] > t - cost:
            return loads[i - 1] + cost
        return None

    def idle_at(self) -> int:
        """Tick at which the last character handed over has left the wire."""
        return self.last_start + self.byte_ticks
