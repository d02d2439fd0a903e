"""QuickStep's timer on the simulated chip: orders executed by a periodic timer.

The timer (timer 2 on AVR, 8 bit) runs in CTC mode with the base time as its period.
Its period interrupt counts each running order's whole base times down; in the
period where a step is due, the compare unit fires at the step's count and the
compare interrupt writes the step pin high, does its bookkeeping and writes it low
(``QuickStepFigures.pulse_ticks`` later).  So steps land on the order's interval exactly (to one
timer count), and the CPU pays ``period_isr_ticks`` (+ ``motor_isr_ticks`` per
running motor) every base time and ``step_isr_ticks`` per step
(:mod:`fas.quickstep.figures`).

What the 8-bit timer changes under blocked interrupts (StepperDemo's `e`):

* a compare whose count has passed when its interrupt finally runs matches again
  only one timer period later: the step waits whole base times (not a 16-bit wrap
  of 4.1 ms as on timer 1);
* the period interrupt's flag holds one pending interrupt: a block spanning k period
  boundaries loses k-1 of them, and every order that was counting base times down
  steps that many base times late.

An order keeps its FIFO slot until its last interval has passed; the next order
then follows without a break if it is already in the FIFO, else the motor stops and
the next order starts from rest on the timer's next period boundary.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..channel import OrderChannel
from .channel import ENTRY_NEXT, ENTRY_RESTART, ENTRY_START, SimChannel
from .machine import Machine

if TYPE_CHECKING:  # pragma: no cover
    from ..queue import QueueEntry
    from ..quickstep.clock import QuickStepClock
    from ..quickstep.orders import OrderQueue


class TimerLoad:
    """The period interrupt's CPU time, as a block source of the machine."""

    def __init__(self, machine: Machine, clock: QuickStepClock) -> None:
        self.m = machine
        self.clock = clock
        self.channels: list[QuickStepChannel] = []

    def block_cpu_between(self, begin: int, end: int) -> int:
        running = sum(1 for ch in self.channels if ch.running)
        if not running:
            return 0
        p = self.clock.figures
        n = self.clock.boundaries_between(begin, end)
        return n * (p.period_isr_ticks + running * p.motor_isr_ticks)


class QuickStepChannel(SimChannel, OrderChannel):
    def __init__(self, machine: Machine, queue: OrderQueue, clock: QuickStepClock,
                 load: TimerLoad) -> None:
        super().__init__(machine, queue)
        p = clock.figures
        self.clock = clock
        self.lat = p.pulse_ticks
        self.start_ticks = p.start_ticks
        self.isr_ticks = self.isr_next_ticks = self.cost = p.step_isr_ticks
        self.irq_sensitive = True
        self.contention = False  # its timer's own rule: events at the pulse's end
        self.ocr = self.ocr_next = 0
        if self._on_block not in machine.block_listeners:
            machine.block_listeners.append(self._on_block)
        self.trailing = False  # waiting for the end of the finished order's last interval
        self.start_delay_ticks = 0  # set by the planner (auto enable) before a start
        self.lost_periods = 0  # period interrupts lost to blocked interrupts
        self.load = load
        load.channels.append(self)

    # ----------------------------------------------------------- interface
    def start(self) -> None:
        q = self.q
        if self.running or q.read_idx == q.next_write_idx:
            return
        tb = self.clock.timebase(self.m.now)
        self.wrap = tb.base_ticks
        self.running = True
        self.m.activity += 1
        self.no_more = False
        self.trailing = False
        self.starts += 1
        e = q.entries[q.read_idx % q.queue_len]
        t = self.m.cpu_now()
        if e.toggle_dir:
            self._toggle_dir(t)
        self.mode_one = e.steps != 0
        if self.entry_listeners:
            self._note_entry(ENTRY_START, e)
        first = self.clock.next_boundary(t + self.start_ticks + self.start_delay_ticks)
        self.start_delay_ticks = 0
        self._program(first, e)

    def force_stop(self) -> None:
        super().force_stop()
        self.trailing = False

    def entry_added(self) -> None:
        """Orders are pushed by the application (no ramp-task cost as on timer 1)."""

    def keep_until(self) -> int:
        """Orders from this FIFO index on have not started and may be dropped."""
        q = self.q
        return (q.read_idx + 1) & 0xFF

    def orders_dropped(self) -> None:
        """Orders behind the running one were taken back (nothing is armed for them)."""

    def shorten(self, e: QueueEntry, keep: int) -> int:
        """Order ``e`` makes at most ``keep`` (>= 1) more steps; returns how many steps
        were taken off it."""
        q = self.q
        head = q.entries[q.read_idx % q.queue_len]
        if e is not head:
            removed = max(0, e.steps - keep)
            e.steps -= removed
            return removed
        if not self.running or self.trailing:
            return 0
        now = self.m.now
        if self.batch and self.b_entry is e:
            c0, t, n = self.b_c0, self.b_t, self.b_n
            risen = 0 if now < c0 else min(n, (now - c0) // t + 1)
            new_n = min(n, risen + keep)
            removed = n - new_n
            if removed <= 0:
                return 0
            self.m.cancel(self.event)
            self.b_n = new_n
            e.steps -= removed
            last = c0 + (new_n - 1) * t + self.lat
            self.event = self.m.schedule(last, self._batch_end, self.prio, isr=True)
            return removed
        if e.steps > keep:
            removed = e.steps - keep
            e.steps = keep
            return removed
        return 0

    # ------------------------------------------------------------ internals
    def _stop(self) -> None:
        self.running = False
        self.m.activity += 1
        self.no_more = False
        self.mode_one = False
        self.trailing = False
        if self.on_idle is not None:  # synchronized user outputs wait for this (issue 12)
            self.on_idle()

    def _isr(self, c: int, now: int) -> None:
        q = self.q
        rp, wp = q.read_idx, q.next_write_idx
        if rp == wp:
            self._stop()
            return
        e = q.entries[rp % q.queue_len]
        if self.trailing:  # the finished order's last interval is over: its slot frees
            self.trailing = False
            rp = (rp + 1) & 0xFF
            q.read_idx = rp
            if rp == wp:
                self.dry += 1
                self._stop()
                return
            e = q.entries[rp % q.queue_len]
            if e.toggle_dir:
                self._toggle_dir(now)
            self.mode_one = e.steps != 0
            if self.entry_listeners:
                self._note_entry(ENTRY_RESTART, e)
            # pushed during the last interval: its first step on the next period boundary
            self._program(self.clock.next_boundary(now + self.start_ticks), e)
            return
        if e.steps > 1:
            e.steps -= 1
            self.mode_one = True
            self._arm(c + e.ticks, now, e)
            return
        # the order's last step is made (or a pause order began)
        nxt = (rp + 1) & 0xFF
        if nxt != wp:  # the next order waits in the FIFO: it follows without a break
            q.read_idx = nxt
            e.steps = 0
            e2 = q.entries[nxt % q.queue_len]
            if e2.toggle_dir:
                self._toggle_dir(now)
            self.mode_one = e2.steps != 0
            if self.entry_listeners and e2 is not self._noted:
                self._note_entry(ENTRY_NEXT, e2)
            self._arm(c + e.ticks, now, e2)
            return
        e.steps = 0
        self.trailing = True
        self.mode_one = False
        self._arm_single(c + e.ticks, now, e)

    def _on_block(self, start: int, end: int) -> None:
        """Interrupts blocked from ``start`` to ``end``: split a block of pulses, and
        delay the orders by the period interrupts the block swallows."""
        super()._on_block(start, end)
        if not self.running or self.batch:
            return
        lost = self.clock.boundaries_between(start, end) - 1
        if lost <= 0 or self.pending_compare <= end:
            return
        tb = self.clock.current
        assert tb is not None  # chosen when the running orders were planned
        base = tb.base_ticks
        self.lost_periods += lost
        self.m.cancel(self.event)
        self.pending_compare += lost * base
        self.event = self.m.schedule(self.pending_compare + self.lat, self._single_isr,
                                     self.prio, isr=True)
