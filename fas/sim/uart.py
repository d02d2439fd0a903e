"""The console's serial transmitter: a buffered UART that makes long prints block.

StepperDemo prints at 115200 baud.  The Arduino serial driver holds 63 characters in
its buffer plus one in the UART's data register; the next ``print`` waits until a
slot frees.  So a long usage text shifts every later command by milliseconds, which
is visible in the firmware's timing (e.g. when the first move starts).  Character
``k`` starts on the wire at ``S[k] = max(write time, S[k-1] + byte time)`` and a write
of character ``k`` can complete only once character ``k-buffer`` has started.
"""

from __future__ import annotations

from collections import deque


class Uart:
    __slots__ = ("byte_ticks", "capacity", "_starts", "last_start", "chars")

    def __init__(self, byte_ticks: int, capacity: int) -> None:
        self.byte_ticks = byte_ticks
        self.capacity = capacity
        self._starts: deque[int] = deque(maxlen=capacity)
        self.last_start = -(1 << 62)
        self.chars = 0

    def room_at(self) -> int:
        """Earliest tick at which one more character can be handed over."""
        if len(self._starts) < self.capacity:
            return -(1 << 62)
        return self._starts[0]

    def put(self, t: int) -> None:
        """Hand over one character at tick ``t`` (``t >= room_at()``)."""
        start = max(t, self.last_start + self.byte_ticks)
        self.last_start = start
        self._starts.append(start)
        self.chars += 1

    def idle_at(self) -> int:
        """Tick at which the last character handed over has left the wire."""
        return self.last_start + self.byte_ticks
