"""A discrete-event microcontroller on an integer tick clock.

One heap of events ordered by (tick, priority, insertion).  Virtual time jumps from
event to event.  Interrupt-driven events (step compare interrupts, the periodic ramp
task) can be held back while the application blocks interrupts (StepperDemo's `e`):
they run when the block ends, in hardware priority order.

The machine also keeps the pieces of the chip that the application sees: pin levels
(:class:`PinBank`), ``millis()`` (Arduino's timer-0 bookkeeping), the console UART
and CPU time taken away from the main loop by interrupt routines.
"""

from __future__ import annotations

import heapq
from typing import Callable

from ..arch import Profile
from .outputs import SimOutputs
from .pins import PinBank
from .uart import Uart

PRIO_STEP_ISR = 10  # + channel index: TIMER1_COMPA before COMPB ...
PRIO_TASK = 30  # timer overflow: after the compare interrupts
PRIO_PLAIN = 50  # not an interrupt (application timers, recorders)


class Event:
    __slots__ = ("time", "prio", "fn", "cancelled", "isr")

    def __init__(self, time: int, prio: int, fn: Callable[[], None], isr: bool) -> None:
        self.time = time
        self.prio = prio
        self.fn = fn
        self.cancelled = False
        self.isr = isr


class Machine:
    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.now = 0
        self._heap: list[tuple[int, int, int, Event]] = []
        self._seq = 0
        self.pins = PinBank()
        self.outputs = SimOutputs(self.pins)  # user outputs: digital pins, PWM waves
        self.uart = Uart(profile.sim_uart_byte_ticks, profile.sim_uart_tx_buffer)
        self.irq_blocked_until = 0
        self.irq_block_windows = 0
        self.irq_blocked_ticks = 0
        self.block_listeners: list[Callable[[int, int], None]] = []
        self.stolen_ticks = 0  # CPU time of interrupt routines not yet charged to the loop
        self.block_sources: list = []  # step channels that simulate runs of pulses as one
        self.task_offset = 0  # CPU time used so far by the running periodic task
        self.in_task = False
        self.events_run = 0
        self._millis_phase = 0  # timer 0 starts counting (see start_millis)

    # ----------------------------------------------------------- scheduling
    def schedule(self, time: int, fn: Callable[[], None], prio: int = PRIO_PLAIN,
                 isr: bool = False) -> Event:
        if time < self.now:
            time = self.now
        ev = Event(time, prio, fn, isr)
        self._seq += 1
        heapq.heappush(self._heap, (time, prio, self._seq, ev))
        return ev

    @staticmethod
    def cancel(ev: Event | None) -> None:
        if ev is not None:
            ev.cancelled = True

    def next_event_time(self) -> int | None:
        heap = self._heap
        while heap and heap[0][3].cancelled:
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def run_until(self, t: int) -> None:
        """Process every event at or before tick ``t``; afterwards ``now == t``."""
        heap = self._heap
        pop = heapq.heappop
        while heap and heap[0][0] <= t:
            time, prio, _, ev = pop(heap)
            if ev.cancelled:
                continue
            if ev.isr and time < self.irq_blocked_until:
                # interrupt pending until the block ends; then in priority order
                ev.time = self.irq_blocked_until
                self._seq += 1
                heapq.heappush(heap, (ev.time, prio, self._seq, ev))
                continue
            if time > self.now:
                self.now = time
            self.events_run += 1
            ev.fn()
        if t > self.now:
            self.now = t

    def run_one(self) -> bool:
        """Process the next event (advancing time to it); False if none is left."""
        t = self.next_event_time()
        if t is None:
            return False
        self.run_until(t)
        return True

    # ------------------------------------------------------- CPU and time
    def cpu_now(self) -> int:
        """Tick at which code running right now takes effect (inside a task: later)."""
        if not self.task_offset:
            return self.now
        return self.now + self.stretched(self.task_offset)

    def stretched(self, work: int) -> int:
        """Ticks that ``work`` ticks of interruptible code take from now on.

        The console UART's transmit interrupt refills its data register once per
        character while text is queued; each time it takes its CPU time from the
        code that runs (the periodic task's work is interruptible).
        """
        cost = self.profile.sim_uart_isr_ticks
        if not cost:
            return work
        t = work
        while True:
            n = self.uart.isr_loads_between(self.now, self.now + t)
            if work + n * cost == t:
                return t
            t = work + n * cost

    def consume(self, ticks: int) -> None:
        """The main loop spends ``ticks`` of CPU time; interrupts steal some on top.

        Stolen are the periodic task's work and the CPU time of step interrupts (and
        of timers that tick without events, QuickStep's): those run as events add
        their time themselves, the others are counted here for the window by their
        ``block_cpu_between``."""
        while True:
            start = self.now
            self.run_until(start + ticks)
            for src in self.block_sources:
                self.stolen_ticks += src.block_cpu_between(start, self.now)
            ticks = self.stolen_ticks
            if not ticks:
                return
            self.stolen_ticks = 0

    def forget_stolen(self) -> None:
        """The loop only polled while interrupts ran: their time delayed nothing."""
        self.stolen_ticks = 0

    def block_interrupts(self, ticks: int) -> None:
        """The main loop runs ``ticks`` with interrupts disabled (busy wait)."""
        start, end = self.now, self.now + ticks
        if end > self.irq_blocked_until:
            self.irq_blocked_until = end
        self.irq_block_windows += 1
        self.irq_blocked_ticks += ticks
        self.uart.interrupts_blocked(start, end)
        for listener in self.block_listeners:
            listener(start, end)
        self.consume(ticks)

    def start_millis(self) -> None:
        """Arduino's start-up has just started timer 0, the source of ``millis()``."""
        self._millis_phase = self.now

    def millis(self) -> int:
        """Arduino ``millis()``: timer-0 overflows with the 1.024 ms fraction fix-up."""
        n = (self.now - self._millis_phase) // self.profile.sim_millis_overflow_ticks
        if n <= 0:
            return 0
        if self.profile.sim_millis_overflow_ticks == 16384:
            return n + (3 * n) // 125
        return n * self.profile.sim_millis_overflow_ticks * 1000 // self.profile.ticks_per_s

    def tick_at_millis(self, ms: int) -> int:
        """Earliest tick at which :meth:`millis` returns at least ``ms``."""
        ov = self.profile.sim_millis_overflow_ticks
        if ms <= 0:
            return self._millis_phase
        if ov == 16384:
            # smallest n with n + floor(3n/125) >= ms
            n = max(0, (ms * 125) // 128 - 2)
            while n + (3 * n) // 125 < ms:
                n += 1
        else:
            per_ms = self.profile.ticks_per_s // 1000
            n = -(-ms * per_ms // ov)
        return self._millis_phase + n * ov

    def micros(self) -> int:
        return self.now // self.profile.ticks_per_us
