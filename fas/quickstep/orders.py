"""QuickStep's FIFO of orders: one per motor, 1 .. 255 orders deep.

An order is ``steps`` steps (up to 32767; the sign of QuickStep's int16 is our
``count_up``) ``period_ticks`` apart, the period being the order's interval of
1.00 .. 255.00 base times.  The FIFO is a :class:`fas.queue.StepperQueue` with a
capacity of ``depth`` orders, so the library's position bookkeeping (current
position inside an order, position after all orders, direction changes) is the
same as for FastAccelStepper's command queue.  Unlike FastAccelStepper's queue an
order keeps its slot until its last interval has elapsed: with a FIFO of one order
the next order can only be pushed once the motor has come to rest.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

from ..codes import AqeResult
from ..queue import QueueEntry, StepperQueue, i32

if TYPE_CHECKING:  # pragma: no cover
    from ..arch import Profile
    from ..channel import OrderChannel
    from ..queue import QueueHost

RING = 256  # slots of the ring; ``depth`` of them may be in use
MIN_DEPTH = 1
MAX_DEPTH = 255


@dataclass(frozen=True)
class OrderInfo:
    """What the planner knows about an order beyond its steps and period."""

    interval_256: int  # the interval in 1/256 base times
    phase: str  # plateaus.ACCELERATE / COAST / DECELERATE, or "" (pause, single step)
    level: int  # plateau k
    plateaus: int  # of N
    top_period_ticks: int  # VTOP of the move the order belongs to
    accel: int  # acceleration of that move


class OrderQueue(StepperQueue):
    """The FIFO of one QuickStep motor (see the module text): a ring of 256 slots, of
    which ``depth`` may be in use, with what the planner knows of each order."""

    channel: OrderChannel

    def __init__(self, index: int, profile: Profile, backend: QueueHost, step_pin: int,
                 depth: int, make_channel: Callable[[OrderQueue], OrderChannel]) -> None:
        self.depth = depth
        self.info: list[OrderInfo | None] = [None] * RING
        super().__init__(index, profile, backend, step_pin, length=RING,
                         make_channel=make_channel)
        self.max_speed_in_ticks = 1
        self.last_command_ticks = 0

    def is_queue_full(self) -> bool:
        return self.queue_entries() >= self.depth

    def ticks_in_queue(self) -> int:
        """Ticks of all orders after the one being executed (orders are shortened in
        place, so they are summed as they stand, not as written)."""
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return 0
        ticks = 0
        rp = (rp + 1) & 0xFF
        while rp != wp:
            e = self.entries[rp % RING]
            ticks += e.ticks * e.steps if e.steps > 1 else e.ticks
            rp = (rp + 1) & 0xFF
        return ticks

    def free_slots(self) -> int:
        return self.depth - self.queue_entries()

    def add_order(self, period_ticks: int, steps: int, count_up: bool, info: OrderInfo,
                  start: bool = True) -> AqeResult:
        """Append one order (``steps == 0``: a pause of one period)."""
        if not self.channel.ready_for_commands():
            return AqeResult.DEVICE_NOT_READY
        if self.is_queue_full():
            return AqeResult.QUEUE_FULL
        wp = self.next_write_idx
        self.info[wp % RING] = info
        return self._append(wp, period_ticks, steps, count_up, start,
                            period_ticks * steps if steps > 1 else period_ticks)

    def running_order(self) -> tuple[QueueEntry, OrderInfo | None] | None:
        """The order being executed (the FIFO's head), if any."""
        self.channel.sync()
        rp = self.read_idx
        if rp == self.next_write_idx:
            return None
        info = self.info[rp % RING]
        return self.entries[rp % RING], info

    def last_order(self) -> tuple[QueueEntry, OrderInfo | None] | None:
        if self.read_idx == self.next_write_idx:
            return None
        w = (self.next_write_idx - 1) & 0xFF
        return self.entries[w % RING], self.info[w % RING]

    def drop_pending(self) -> None:
        """Forget the orders that have not started (a stop or a new plan); a channel
        may keep some that are already on their way (see ``keep_until``)."""
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return
        keep = self.channel.keep_until()
        if keep == wp:
            return
        self.truncate(keep)
        self.channel.orders_dropped()

    def shorten_last(self, keep_steps: int) -> None:
        """Let the last order in the FIFO make at most ``keep_steps`` more steps."""
        self.channel.sync()
        if self.read_idx == self.next_write_idx:
            return
        w = (self.next_write_idx - 1) & 0xFF
        e = self.entries[w % RING]
        removed = self.channel.shorten(e, keep_steps)
        if removed > 0:
            e.total_steps -= removed
            self.singles[w % RING] = 1 if e.total_steps <= 1 else 0  # (StepperQueue.singles)
            e.end_pos = i32(e.end_pos - removed if e.count_up else e.end_pos + removed)
            self.queue_end_pos = e.end_pos
