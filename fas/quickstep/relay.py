"""QuickStep's orders on a backend that executes FastAccelStepper's command queue.

A device behind the serial link executes queue commands ``(ticks, steps)`` with its
step timer; it knows nothing of orders.  :class:`OrderRelay` is the channel of a
QuickStep FIFO on such a backend: it expands the orders, as the FIFO holds them,
into commands of the stepper's FastAccelStepper queue (at most 255 steps each;
periods over 65535 ticks as a step plus pauses; a few fast steps stretched to the
queue's shortest command), and maps the device's progress back onto the orders.
The step times are then the orders' intervals to one tick of the device's timer
instead of one count of QuickStep's timer; a stop can only shorten what has not
been sent yet (at most one queue of commands ahead).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..channel import OrderChannel
from ..codes import AqeResult
from ..queue import i32

if TYPE_CHECKING:  # pragma: no cover
    from ..queue import QueueEntry, StepperQueue
    from .clock import QuickStepClock
    from .orders import OrderQueue

MAX_CMD_STEPS = 255
MAX_CMD_TICKS = 65535


class OrderRelay(OrderChannel):
    def __init__(self, queue: OrderQueue, fas_queue: StepperQueue,
                 clock: QuickStepClock) -> None:
        self.q = queue
        self.fq = fas_queue
        self.clock = clock
        self.step_pin = queue.step_pin
        self.detached = False
        self.start_delay_ticks = 0
        self.cursor = queue.read_idx  # order being expanded
        self.left = -1  # its steps not yet sent (-1: not begun)
        # commands sent: (order index, fas write index after it, steps in it)
        self.sent: deque[tuple[int, int, int]] = deque()
        self.starts = 0
        self.pulses = 0
        self.dry = 0
        self.missed_compares = 0
        self.entry_listeners: list[Callable[[int, int, int, int], None]] = []
        self._busy = False

    # ------------------------------------------------------------ progress
    def is_running(self) -> bool:
        return self.fq.is_running() or not self.fq.is_queue_empty()

    def sync(self) -> None:
        if self._busy:
            return
        self._busy = True
        try:
            self._follow()
            self._expand()
        finally:
            self._busy = False

    def _follow(self) -> None:
        """Move the FIFO's read index and remaining steps after the device's progress."""
        fq, q = self.fq, self.q
        fq.channel.sync()
        done_before = fq.read_idx
        remaining: dict[int, int] = {}
        while self.sent:
            order, after, steps = self.sent[0]
            last = (after - 1) & 0xFF
            if ((last - done_before) & 0xFF) < ((fq.next_write_idx - done_before) & 0xFF):
                break  # this command is still in the device queue
            self.sent.popleft()
        for order, after, steps in self.sent:
            last = (after - 1) & 0xFF
            left = steps
            if last == done_before:
                left = fq.entries[last % fq.queue_len].steps
            remaining[order] = remaining.get(order, 0) + left
        while q.read_idx != q.next_write_idx:
            rp = q.read_idx
            e = q.entries[rp % q.queue_len]
            unsent = 0
            if rp == self.cursor:
                unsent = e.total_steps if self.left < 0 else self.left
            elif ((rp - self.cursor) & 0xFF) < ((q.next_write_idx - self.cursor) & 0xFF):
                unsent = e.total_steps
            left = remaining.get(rp, 0) + unsent
            e.steps = left
            in_device = rp in remaining
            if left > 0 or in_device or rp == self.cursor and self.left != 0:
                break
            q.read_idx = (rp + 1) & 0xFF

    def _expand(self) -> None:
        """Send commands for the FIFO's orders while the device queue has room."""
        fq, q = self.fq, self.q
        fq.dir_pin = q.dir_pin
        fq.dir_high_counts_up = q.dir_high_counts_up
        started = fq.is_running()
        added = False
        while not fq.is_queue_full():
            if self.cursor == q.next_write_idx:
                break
            e = q.entries[self.cursor % q.queue_len]
            if self.left < 0:
                self.left = e.total_steps
                if fq.is_queue_empty() and not fq.is_running():
                    fq.queue_end_pos = i32(e.end_pos - e.total_steps if e.count_up
                                           else e.end_pos + e.total_steps)
                    if self.start_delay_ticks:
                        self._pause(self.start_delay_ticks, e.count_up)
                        self.start_delay_ticks = 0
            if self.left == 0:
                if e.total_steps == 0:  # a pause order
                    self._pause(e.ticks, e.count_up)
                self.cursor = (self.cursor + 1) & 0xFF
                self.left = -1
                continue
            ticks = e.ticks
            if ticks > MAX_CMD_TICKS:
                res = self._command(MAX_CMD_TICKS, 1, e.count_up)
                if res != AqeResult.OK:
                    break
                self.left -= 1
                self._pause(ticks - MAX_CMD_TICKS, e.count_up)
            else:
                n = min(self.left, MAX_CMD_STEPS)
                min_cmd = fq.profile.min_cmd_ticks
                if ticks * n < min_cmd and n == self.left:
                    ticks = -(-min_cmd // n)  # a few fast steps: stretched to the minimum
                res = self._command(ticks, n, e.count_up)
                if res != AqeResult.OK:
                    break
                self.left -= n
            added = True
        if added and not started:
            self.starts += 1
            fq.start_queue()

    def _command(self, ticks: int, steps: int, count_up: bool) -> AqeResult:
        fq = self.fq
        res = fq.add_queue_entry(ticks, steps, count_up, start=False)
        if res == AqeResult.OK:
            self.sent.append((self.cursor, fq.next_write_idx, steps))
        return res

    def _pause(self, ticks: int, count_up: bool) -> None:
        fq = self.fq
        min_cmd = fq.profile.min_cmd_ticks
        while ticks > 0 and not fq.is_queue_full():
            chunk = min(ticks, MAX_CMD_TICKS)
            if ticks - chunk and ticks - chunk < min_cmd:
                chunk = ticks - min_cmd
            if fq.add_queue_entry(max(chunk, min_cmd), 0, count_up, start=False) != \
                    AqeResult.OK:
                break
            self.sent.append((self.cursor, fq.next_write_idx, 0))
            ticks -= chunk

    # ----------------------------------------------------------- interface
    def start(self) -> None:
        self.sync()

    def entry_added(self) -> None:
        """An order arrived; it is expanded at the next ``sync``."""

    def force_stop(self) -> None:
        fq = self.fq
        fq.channel.sync()
        pos = fq.current_position()
        fq.force_stop()
        fq.queue_end_pos = pos
        self.sent.clear()
        self.cursor = self.q.next_write_idx
        self.left = -1

    def keep_until(self) -> int:
        """Orders from this FIFO index on have not been sent and may be dropped."""
        q = self.q
        if self.cursor == q.next_write_idx:
            return q.next_write_idx
        first = self.cursor if self.left < 0 else (self.cursor + 1) & 0xFF
        if first == q.read_idx:
            first = (first + 1) & 0xFF
        return first

    def orders_dropped(self) -> None:
        q = self.q
        if ((self.cursor - q.read_idx) & 0xFF) > ((q.next_write_idx - q.read_idx) & 0xFF):
            self.cursor = q.next_write_idx
            self.left = -1

    def shorten(self, e: QueueEntry, keep: int) -> int:
        q = self.q
        cur = q.entries[self.cursor % q.queue_len] if self.cursor != q.next_write_idx else None
        if e is cur and self.left >= 0:
            sent_left = e.steps - self.left
            removed = max(0, min(self.left, e.steps - max(keep, sent_left)))
            self.left -= removed
            e.steps -= removed
            return removed
        if cur is not None and self.left < 0 and e is cur or self._unsent(e):
            removed = max(0, e.steps - keep)
            e.steps -= removed
            return removed
        return 0

    def _unsent(self, e: QueueEntry) -> bool:
        q = self.q
        i = self.cursor
        while i != q.next_write_idx:
            if q.entries[i % q.queue_len] is e:
                return i != self.cursor or self.left < 0
            i = (i + 1) & 0xFF
        return False

    def positions_shifted(self, delta: int) -> None:
        self.fq.shift_positions(delta)
