"""A discrete-event microcontroller on an integer tick clock.

One heap of events ordered by (tick, priority, insertion).  Virtual time jumps from
event to event.  Interrupt-driven events (step compare interrupts, the periodic ramp
task) can be held back while the application blocks interrupts (StepperDemo's `e`):
they run when the block ends, in hardware priority order.

On a chip whose step pulses are ended by an interrupt routine (AVR), interrupts contend
for the CPU: an event scheduled with ``enter=`` is the request of an interrupt (its flag
set); it is entered once no routine holds the CPU with interrupts off
(:meth:`Machine.cpu_free_at`: a blocked section of the loop, a routine entered before -
another step interrupt, the ramp task's entry and exit -, ``millis()``'s timer
interrupt, the UART's transmit interrupt, the step interrupts of a channel's block of
pulses).  Requests pending when the CPU frees enter one after another in priority
order (lowest vector first), each holding the CPU ``enter`` ticks.

The machine also keeps the pieces of the chip that the application sees: pin levels
(:class:`PinBank`), ``millis()`` (Arduino's timer-0 bookkeeping), the console UART
and CPU time taken away from the main loop by interrupt routines.
"""

from __future__ import annotations

import heapq
from bisect import bisect_left, bisect_right
from typing import TYPE_CHECKING, Callable, Protocol

from ..arch import Profile
from .builds import check_build
from .loop_isrs import NEVER, IsrClock, Train, count_between, count_from, next_after
from .outputs import SimOutputs
from .pins import PinBank
from .timing import sim_timing
from .uart import Uart

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .channel import SimChannel

#: the main loop's passes while it polls: a pass's ticks and its sections (offset, ticks)
#: with interrupts off (:meth:`Machine.poll_begin`)
Poll = tuple[int, tuple[tuple[int, int], ...]]

PRIO_STEP_ISR = 10  # + channel index: TIMER1_COMPA before COMPB ...
PRIO_TASK = 30  # timer overflow: after the compare interrupts
PRIO_PLAIN = 50  # not an interrupt (application timers, recorders)


class BlockSource(Protocol):
    """A step channel that simulates a run of pulses as one block
    (:class:`fas.sim.channel.SimChannel`): pulses at ``b_c0 + j * b_t``, ``j < b_n``,
    each with a step interrupt of ``isr_ticks`` that runs ``lat`` after it."""

    batch: bool  # a block runs
    b_c0: int
    b_t: int
    b_n: int
    lat: int
    isr_ticks: int

    def block_isrs_until(self, t: int) -> int:
        """Step interrupts of the running block that ran by tick ``t``."""
        ...


class CpuSource(Protocol):
    """A timer whose interrupts take CPU time without events (QuickStep's period
    interrupt, :class:`fas.sim.quickstep.TimerLoad`)."""

    def block_cpu_between(self, begin: int, end: int) -> int:
        """The CPU ticks its interrupts take in ``(begin, end]``."""
        ...


class BatchSource(Protocol):
    """The channel whose block of pulses runs as one event (one at a time per machine,
    :attr:`Machine.batch_channel`): its block as :class:`BlockSource` has it (the event
    loop answers the common case itself)."""

    batch: bool
    b_c0: int
    b_t: int
    b_n: int
    isr_ticks: int
    # the request of its block that it answered last and that interrupt's entry
    entry_req: int
    entry_tick: int

    def block_isr_running_at(self, t: int) -> int | None:
        """End of its step interrupt that holds the CPU at tick ``t`` (None: none)."""
        ...


LOOP_POLL_OPEN = 1 << 62  # the end of a poll still running (Machine.loop_polls)
# where timer 0 and the UART come before the step compares: how long after its request
# one of them may still begin (behind the routines running then; a blocked section is
# known on its own)
LATE_ISR_SLACK = 1024
# no routine keeps a step interrupt of a block of pulses waiting this long (the longest
# chain of other routines: timer 0, the UART, the ramp task's exit, another step interrupt)
LATE_ENTRY = 512


class Event:
    __slots__ = ("time", "prio", "fn", "cancelled", "isr", "enter", "owner")

    def __init__(self, time: int, prio: int, fn: Callable[[], None], isr: bool,
                 enter: int = 0, owner: object = None) -> None:
        self.time = time
        self.prio = prio
        self.fn = fn
        self.cancelled = False
        self.isr = isr
        # > 0: an interrupt request entered once the CPU is free (Machine.cpu_free_at);
        # the routine then holds the CPU this long with interrupts off
        self.enter = enter
        self.owner = owner  # the channel whose interrupt it is (its own block: no obstacle)


class Machine:
    # (slots: the event loop reads and writes these for every event; __dict__: any
    # other attribute a tool sets)
    __slots__ = ("profile", "build", "timing", "now", "events", "seq", "pins", "outputs",
                 "uart", "irq_blocked_from", "irq_blocked_until", "irq_block_windows",
                 "irq_blocked_ticks", "block_listeners", "stolen_ticks", "busy_until",
                 "run_limit", "run_activity", "stolen_mark", "activity", "block_sources",
                 "cpu_sources", "task_offset", "in_task", "nest_timer0", "fills_done",
                 "step_isrs_between", "events_run", "_millis_phase", "_millis_started",
                 "_clock", "_clock_key", "_tick_at_ms", "_quiet_from", "_millis_first",
                 "isr_starts", "isr_ends", "exit_starts", "exit_ends", "batch_channel",
                 "_late_isrs", "_ms_window", "_uart_hold", "_uart_window", "loop_polls",
                 "loop_polling", "_ms_cost", "__dict__")

    def __init__(self, profile: Profile, build: str | None = None) -> None:
        self.profile = profile
        self.build = check_build(build)  # the firmware build (fas.sim.builds)
        self.timing = sim_timing(profile, build)
        self.now = 0
        # the pending events as a heap of (tick, priority, order, event), the earliest
        # first (cancelled ones stay until they come up); read it, never write it
        # (a print looks ahead for the next event's tick: fas.sim.printing)
        self.events: list[tuple[int, int, int, Event]] = []
        self.seq = 0  # insertion counter: the heap's tie-break (a channel pushes events too)
        self.pins = PinBank()
        self.outputs = SimOutputs(self.pins)  # user outputs: digital pins, PWM waves
        self.uart = Uart(self.timing.uart_byte_ticks, self.timing.uart_tx_buffer,
                         self.timing.uart_idle_start_ticks,
                         self.timing.uart_tx_single_register)
        # the last blocked section [from, until) (none yet: far in the past)
        self.irq_blocked_from = self.irq_blocked_until = -(1 << 62)
        self.irq_block_windows = 0
        self.irq_blocked_ticks = 0
        self.block_listeners: list[Callable[[int, int], None]] = []
        self.stolen_ticks = 0  # CPU time of interrupt routines not yet charged to the loop
        self.busy_until = 0  # interrupt routines run as events keep the CPU until here
        # inside run_until: its tick, the activity at its start where it stops on
        # activity (else None) and stolen_ticks before the event that runs (its CPU
        # time: busy_until) - a step interrupt whose next request is the next event goes
        # on with it itself, as run_until would (SimChannel._go_on); -1: outside
        self.run_limit = -1
        self.run_activity: int | None = None
        self.stolen_mark = 0
        # counts events after which a stepper may have started or stopped (a channel
        # started or stopped, or a ramp task ran while a channel stood): a program
        # waiting for that need not look after every other event
        self.activity = 0
        # step channels that simulate runs of pulses as one
        self.block_sources: list[BlockSource] = []
        # timers without events: block_cpu_between(begin, end)
        self.cpu_sources: list[CpuSource] = []
        self.task_offset = 0  # CPU time used so far by the running periodic task
        self.in_task = False
        # the running task nests timer 0 in its time line too (SimTiming.start_task_nested_isrs)
        self.nest_timer0 = False
        # fill_charges_after_writes: the channels whose fill ran in this task and whose
        # fixed work is still to charge (at the next fill's start or the task's end)
        self.fills_done: list[SimChannel] = []
        # the CPU time of the step interrupts entered in [lo, hi) (set by the backend:
        # SimTiming.task_nested_isrs)
        self.step_isrs_between: Callable[[int, int], int] | None = None
        self.events_run = 0
        self._millis_phase = 0  # timer 0 starts counting (see start_millis)
        self._millis_started = False
        self._clock: IsrClock | None = None  # see isr_clock()
        self._clock_key: tuple[int, int, int, int] | None = None  # the state it holds for
        # the last answer of tick_at_millis (ms, tick)
        self._tick_at_ms: tuple[int | None, int] = (None, 0)
        # interrupt contention (events with ``enter``): the routines entered as events,
        # as [start, end) with interrupts off, in order (step interrupts, the ramp task's
        # entry), and the ramp task's exits (known once the task ran)
        # no blocked section, routine entered as an event or ramp task's exit holds the
        # CPU from this tick on (cpu_free_at's quick answer); timer 0's first overflow
        self._quiet_from = -(1 << 62)
        self._millis_first = 1 << 62
        self.isr_starts: list[int] = []
        self.isr_ends: list[int] = []
        self.exit_starts: list[int] = []
        self.exit_ends: list[int] = []
        self.batch_channel: BatchSource | None = None  # its pulses' interrupts are no events
        # timer 0 and the UART come before the step compares in the vector table
        # (Profile.step_vectors_after_timer0): one requested while a routine runs enters
        # when it returns, before the step interrupts pending then - up to
        # LATE_ISR_SLACK ticks after its request (the quick answers look that far)
        self._late_isrs = profile.step_vectors_after_timer0
        slack = LATE_ISR_SLACK if self._late_isrs else 0
        self._ms_window = self.timing.millis_isr_ticks + slack
        # how long the UART's transmit interrupt holds a step interrupt (the CPU time it
        # takes from the loop and the ramp task is uart_isr_ticks)
        self._uart_hold = ((self.timing.uart_hold_ticks or self.timing.uart_isr_ticks)
                           if self.timing.uart_isr_ticks else 0)
        self._uart_window = self._uart_hold + slack
        # the main loop's own critical sections while it polls (:meth:`loop_hold`): the
        # polls as (start, end, period, sections), in order; the one running now has
        # end LOOP_POLL_OPEN (``loop_polling``: one runs)
        self.loop_polls: list[tuple[int, int, int, tuple[tuple[int, int], ...]]] = []
        self.loop_polling = False
        self._ms_cost = self.timing.millis_isr_ticks  # per 16 384 ticks (loop_hold)

    # ----------------------------------------------------------- scheduling
    def schedule(self, time: int, fn: Callable[[], None], prio: int = PRIO_PLAIN,
                 isr: bool = False, enter: int = 0, owner: object = None) -> Event:
        """An event at tick ``time``.  ``isr``: an interrupt, held back while the loop
        blocks interrupts.  ``enter`` > 0: an interrupt requested at ``time`` and entered
        when the CPU is free (it then holds it ``enter`` ticks; the event's function runs
        at the entry)."""
        if time < self.now:
            time = self.now
        ev = Event(time, prio, fn, isr or enter > 0, enter, owner)
        self.seq += 1
        heapq.heappush(self.events, (time, prio, self.seq, ev))
        return ev

    @staticmethod
    def cancel(ev: Event | None) -> None:
        if ev is not None:
            ev.cancelled = True

    def next_event_time(self) -> int | None:
        heap = self.events
        while heap and heap[0][3].cancelled:
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def run_until(self, t: int, stop_on_activity: bool = False) -> bool:
        """Process every event at or before tick ``t``; afterwards ``now == t``.

        ``stop_on_activity``: stop early, after the events of the first tick that
        changed :attr:`activity` (then ``now`` is that tick); True if it did."""
        heap = self.events
        pop = heapq.heappop
        activity = self.activity
        timing = self.timing
        uart_cost, ms_ov, ms_cost = (self._uart_window, timing.millis_overflow_ticks,
                                     self._ms_window)
        loads = self.uart.loads  # (changed in place only)
        # timer 0 (start_millis runs from the application, never inside an event)
        millis_first, millis_phase = self._millis_first, self._millis_phase
        starts, ends = self.isr_starts, self.isr_ends  # (likewise)
        # (a run inside an event's function gives the outer one its own back)
        outer = self.run_limit, self.run_activity, self.stolen_mark
        self.run_limit = t
        self.run_activity = activity if stop_on_activity else None
        while heap and heap[0][0] <= t:
            time, prio, _, ev = pop(heap)
            if ev.cancelled:
                continue
            enter = ev.enter
            if ev.isr:
                if enter:  # requested now: entered once the CPU is free
                    bc = self.batch_channel
                    if ((time >= self._quiet_from or self._none_holds(time))
                            and (not loads or time >= loads[-1] + uart_cost)
                            and (time < millis_first
                                 or (time - millis_phase) % ms_ov >= ms_cost)):
                        # (cpu_free_at's common case, written out)
                        if bc is None or bc is ev.owner or not bc.batch or time < bc.b_c0:
                            free = time
                        else:
                            # (block_isr_running_at's quick answer written out: the
                            # block's interrupt of this period is over, however late)
                            c0 = bc.b_c0
                            period = bc.b_t
                            j = (time - c0) // period
                            if j > bc.b_n - 2:
                                j = bc.b_n - 2
                            c = c0 + j * period
                            if j < 0 or time - c >= bc.isr_ticks + LATE_ENTRY:
                                free = time
                            elif (c == bc.entry_req and time >= bc.entry_tick + bc.isr_ticks
                                  and (not j or time - c + period
                                       >= bc.isr_ticks + LATE_ENTRY)):
                                # (block_isr_running_at's answer from the entry it keeps:
                                # interrupt j is over and j - 1's long ago)
                                free = time
                            else:
                                end = bc.block_isr_running_at(time)
                                free = (time if end is None or end <= time
                                        else self.cpu_free_at(time, ev.owner))
                    else:
                        free = self.cpu_free_at(time, ev.owner)
                    if free > time:  # pending; those pending then enter in priority order
                        ev.time = free
                        seq = self.seq + 1
                        self.seq = seq
                        if free > t or (heap and heap[0][0] <= free):
                            heapq.heappush(heap, (free, prio, seq, ev))
                            continue
                        # (no other event comes before it: it is the one popped next, and
                        # the CPU is free at ``free`` - cpu_free_at's answer holds there)
                        time = free
                        _ = seq
                elif time < self.irq_blocked_until:
                    # interrupt pending until the block ends; then in priority order
                    ev.time = self.irq_blocked_until
                    self.seq += 1
                    heapq.heappush(heap, (ev.time, prio, self.seq, ev))
                    continue
            if time > self.now:
                if stop_on_activity and self.activity != activity:
                    heapq.heappush(heap, (time, prio, _, ev))
                    self.run_limit, self.run_activity, self.stolen_mark = outer
                    return True
                self.now = time
            if enter:  # (enter_isr, written out: this runs for every step interrupt)
                if len(starts) > 4096:
                    self._forget_isrs()
                end = time + enter
                starts.append(time)
                ends.append(end)
                if end > self._quiet_from:
                    self._quiet_from = end
            run = self.events_run = self.events_run + 1
            self.stolen_mark = self.stolen_ticks
            ev.fn()
            stolen = self.stolen_mark
            if self.stolen_ticks != stolen:  # an interrupt routine: the CPU is busy
                busy = self.busy_until
                if self.events_run != run:  # it went on with later requests: the last's
                    time = self.now
                self.busy_until = (busy if busy > time else time) + self.stolen_ticks - stolen
        self.run_limit, self.run_activity, self.stolen_mark = outer
        if stop_on_activity and self.activity != activity:
            return True
        if t > self.now:
            self.now = t
        return False

    def run_until_changed(self, t: int, changed: Callable[[], bool]) -> bool:
        """Like :meth:`run_until`, but stop after the events of the first tick at which
        ``changed()`` holds (then ``now`` is that tick); True if it stopped that way.
        ``changed`` is asked only after ticks that changed :attr:`activity`."""
        while self.run_until(t, stop_on_activity=True):
            if changed():
                return True
        return False

    def run_one(self) -> bool:
        """Process the next event (advancing time to it); False if none is left."""
        t = self.next_event_time()
        if t is None:
            return False
        self.run_until(t)
        return True

    # ------------------------------------------------- interrupt contention
    def poll_begin(self, period: int, sections: tuple[tuple[int, int], ...]) -> None:
        """The main loop polls from now on in passes of ``period`` ticks, each with
        interrupts off in ``sections`` (offset in the pass, ticks), until
        :meth:`poll_end`."""
        polls = self.loop_polls
        if len(polls) > 4096:  # forget what no block of pulses can still ask about
            del polls[:len(polls) - 64]
        polls.append((self.now, LOOP_POLL_OPEN, period, sections))
        self.loop_polling = True

    def poll_end(self) -> None:
        """The loop takes up work (its poll ends now)."""
        polls = self.loop_polls
        start, _, period, sections = polls[-1]
        if self.now > start:
            polls[-1] = (start, self.now, period, sections)
        else:
            polls.pop()
        self.loop_polling = False

    def loop_hold(self, c: int, step_period: int, step_cost: int) -> int:
        """Ticks a step interrupt requested at ``c``, when no routine holds the CPU,
        waits for a critical section of the polling loop to end (0: none holds it).
        The passes run one after another from the poll's start in the loop's own CPU
        time: the step interrupts of the asking channel (``step_cost`` ticks every
        ``step_period``) and timer 0's overflows are taken from it."""
        holds = self.loop_holds(c, step_period, 0, 1, step_cost)
        return holds[0][1] if holds else 0

    def loop_holds(self, c0: int, period: int, j0: int, j1: int, step_cost: int,
                   skip: set[int] | frozenset[int] = frozenset()) -> list[tuple[int, int]]:
        """:meth:`loop_hold` of the requests ``c0 + j * period``, ``j0 <= j < j1`` (a
        channel's block of pulses, ``step_cost`` ticks each), but those in ``skip``:
        ``(j, ticks)`` for each that waits, in order.  The requests and the polls go
        forward together (the polls are in order and do not overlap).  The one place
        that reads a poll's passes (:meth:`loop_hold` asks it for one request)."""
        polls = self.loop_polls
        n = len(polls)
        out: list[tuple[int, int]] = []
        if not n:
            return out
        c = c0 + j0 * period
        lo, hi = 0, n  # the first poll that ends after c
        while lo < hi:
            mid = (lo + hi) // 2
            if polls[mid][1] <= c:
                lo = mid + 1
            else:
                hi = mid
        i = lo
        ms_cost = self._ms_cost
        j = j0
        while j < j1 and i < n:
            start, end, pass_ticks, sections = polls[i]
            i += 1
            first = c0 + j * period
            if first < start:  # the first request in this poll
                first = c0 + (-(-(start - c0) // period)) * period
                if first > c0 + (j1 - 1) * period:
                    break  # (the later polls begin later still)
            last = c0 + (j1 - 1) * period  # ... and the last
            if last >= end:
                last = c0 + ((end - 1 - c0) // period) * period
            for c in range(first, last + 1, period):
                if pass_ticks < 0:
                    phase = (c - start) % -pass_ticks
                else:
                    d = c - start
                    d -= step_cost * (d // period) + ms_cost * (d >> 14)
                    phase = d % pass_ticks
                for offset, ticks in sections:
                    if offset <= phase < offset + ticks:
                        k = (c - c0) // period
                        if k not in skip:
                            out.append((k, offset + ticks - phase))
                        break
            j = (last - c0) // period + 1 if last >= first else j
        return out

    @property
    def blocked_end(self) -> int:
        """The tick at which an interrupt held by the loop's last blocked section (`e`)
        enters: its end and the instruction after its sei."""
        return self.irq_blocked_until + self.timing.sei_ticks

    def enter_isr(self, t: int, cost: int) -> None:
        """A routine entered as an event at tick ``t`` holds the CPU ``cost`` ticks."""
        starts = self.isr_starts
        if len(starts) > 4096:  # forget what no block of pulses can still ask about
            self._forget_isrs()
        starts.append(t)
        self.isr_ends.append(t + cost)
        if t + cost > self._quiet_from:
            self._quiet_from = t + cost

    def mask(self, start: int, end: int) -> None:
        """Interrupts are off in ``[start, end)`` (the ramp task's exit), known ahead."""
        if len(self.exit_starts) > 1024:
            self._forget_isrs()
        self.exit_starts.append(start)
        self.exit_ends.append(end)
        if end > self._quiet_from:
            self._quiet_from = end

    def _forget_isrs(self) -> None:
        keep = self.now
        bc = self.batch_channel
        if bc is not None:
            keep = min(keep, getattr(bc, "b_c0", keep))
        for starts, ends in ((self.isr_starts, self.isr_ends),
                             (self.exit_starts, self.exit_ends)):
            i = bisect_left(ends, keep)
            if i > 64:
                del starts[:i - 64]
                del ends[:i - 64]

    def cpu_free_at(self, t: int, asker: object = None) -> int:
        """The first tick at or after ``t`` at which no routine holds the CPU with
        interrupts off: the loop's blocked section (`e`), a routine entered as an event
        or the ramp task's exit, ``millis()``'s timer interrupt, the UART's transmit
        interrupt, and the step interrupts of the block of pulses of a channel other
        than ``asker``.  (Also for ticks in the past: a block of pulses asks for its
        pulses when it ends.)"""
        timing = self.timing
        bc = self.batch_channel
        if bc is asker:
            bc = None
        # the common case first: nothing has interrupts off at t (but perhaps the step
        # interrupt of another channel's block of pulses)
        if t >= self._quiet_from or self._none_holds(t):
            loads = self.uart.loads
            if ((not loads or t >= loads[-1] + self._uart_window)
                    and (t < self._millis_first or (t - self._millis_phase)
                         % timing.millis_overflow_ticks >= self._ms_window)):
                if bc is None:
                    return t
                end = bc.block_isr_running_at(t)
                if end is None or end <= t:
                    return t
        ms_cost = timing.millis_isr_ticks if self._millis_started else 0
        ms_ov = timing.millis_overflow_ticks
        ms_phase = self._millis_phase
        ms_first = ms_phase + ms_ov
        # a step interrupt waits for the UART's routine to the end of its reti and one
        # instruction; the loop and the ramp task go on after the CPU time it takes
        uart_cost = self._uart_hold if asker is not None else timing.uart_isr_ticks
        loads = self.uart.loads
        bfrom, buntil = self.irq_blocked_from, self.irq_blocked_until
        blocked_end = buntil + timing.sei_ticks
        starts, ends = self.isr_starts, self.isr_ends
        xs, xe = self.exit_starts, self.exit_ends
        while True:
            t0 = t
            if bfrom <= t < blocked_end:
                t = blocked_end
            if starts and t < ends[-1]:
                i = bisect_right(starts, t) - 1
                if i >= 0 and t < ends[i]:
                    t = ends[i]
            if xs and t < xe[-1]:
                i = bisect_right(xs, t) - 1
                if i >= 0 and t < xe[i]:
                    t = xe[i]
            if self._late_isrs:
                t = self._after_late_isrs(t, bc, uart_cost)
            # timer 0 and the UART (lower priority than the step compares): they hold the
            # CPU when they began with interrupts on (one held back by a blocked section
            # runs after the step interrupts pending at its end)
            elif ms_cost and t >= ms_first:
                into = (t - ms_phase) % ms_ov
                if into < ms_cost and not bfrom <= t - into <= buntil:
                    t += ms_cost - into
            if uart_cost and loads and t < loads[-1] + uart_cost and not self._late_isrs:
                i = bisect_right(loads, t) - 1
                if i >= 0 and t < loads[i] + uart_cost and not bfrom <= loads[i] <= buntil:
                    t = loads[i] + uart_cost
            if bc is not None:
                end = bc.block_isr_running_at(t)
                if end is not None and end > t:
                    t = end
            if t == t0:
                return t

    def _none_holds(self, t: int) -> bool:
        """No blocked section, routine entered as an event or ramp task's exit holds the
        CPU at ``t`` (though one known ahead comes later: the ramp task's exit and its
        commands' masks; :meth:`cpu_free_at`'s loop would not move ``t`` for them)."""
        if self.irq_blocked_from <= t < self.irq_blocked_until + self.timing.sei_ticks:
            return False
        ends = self.isr_ends
        if ends and t < ends[-1]:
            i = bisect_right(self.isr_starts, t) - 1
            if i >= 0 and t < ends[i]:
                return False
        ends = self.exit_ends
        if ends and t < ends[-1]:
            i = bisect_right(self.exit_starts, t) - 1
            if i >= 0 and t < ends[i]:
                return False
        return True

    def _routines_end(self, t: int, bc: BatchSource | None) -> int:
        """The first tick at or after ``t`` at which no routine entered before holds the
        CPU: the loop's blocked section, a routine entered as an event, the ramp task's
        exit, a step interrupt of the block of pulses ``bc``."""
        bfrom, blocked_end = self.irq_blocked_from, self.irq_blocked_until + self.timing.sei_ticks
        starts, ends = self.isr_starts, self.isr_ends
        xs, xe = self.exit_starts, self.exit_ends
        while True:
            t0 = t
            if bfrom <= t < blocked_end:
                t = blocked_end
            if starts and t < ends[-1]:
                i = bisect_right(starts, t) - 1
                if i >= 0 and t < ends[i]:
                    t = ends[i]
            if xs and t < xe[-1]:
                i = bisect_right(xs, t) - 1
                if i >= 0 and t < xe[i]:
                    t = xe[i]
            if bc is not None:
                end = bc.block_isr_running_at(t)
                if end is not None and end > t:
                    t = end
            if t == t0:
                return t

    def _timer0_runs(self, req: int, bc: BatchSource | None, uart: int) -> int:
        """Where timer 0's interrupt requested at ``req`` begins when it comes before
        the step compares: once the routines running then have returned (a UART
        interrupt running then too, holding the CPU ``uart`` ticks; 0: not asked)."""
        cost = uart
        loads = self.uart.loads
        t = req
        while True:
            t = self._routines_end(t, bc)
            if not (uart and cost and loads and t < loads[-1] + cost):
                return t
            i = bisect_right(loads, t) - 1
            if i < 0 or t >= loads[i] + cost:
                return t
            t = loads[i] + cost

    def _after_late_isrs(self, t: int, bc: BatchSource | None, uart_cost: int) -> int:
        """``t``, or the end of timer 0's or the UART's interrupt running at ``t``, where
        both come before the step compares (``Profile.step_vectors_after_timer0``): each
        begins once the routines running at its request have returned, timer 0 before a
        UART interrupt pending with it."""
        timing = self.timing
        cost = timing.millis_isr_ticks
        if cost and self._millis_started and t >= self._millis_first:
            ov = timing.millis_overflow_ticks
            req = t - (t - self._millis_phase) % ov
            for r in (req, req - ov):
                if r >= self._millis_first and t - r < self._ms_window:
                    begin = self._timer0_runs(r, bc, uart_cost)
                    if begin <= t < begin + cost:
                        return begin + cost
        cost = uart_cost
        loads = self.uart.loads
        if cost and loads and t < loads[-1] + self._uart_window:
            i = bisect_right(loads, t) - 1
            while i >= 0 and t - loads[i] < self._uart_window:
                begin = loads[i]
                while True:  # after the routines running then and timer 0 pending then
                    b0 = begin
                    begin = self._routines_end(begin, bc)
                    ms = timing.millis_isr_ticks
                    if ms and self._millis_started and begin >= self._millis_first:
                        ov = timing.millis_overflow_ticks
                        r = begin - (begin - self._millis_phase) % ov
                        if r >= self._millis_first and begin - r < self._ms_window:
                            m0 = self._timer0_runs(r, bc, 0)
                            if m0 <= begin < m0 + ms:
                                begin = m0 + ms
                    if begin == b0:
                        break
                if begin <= t < begin + cost:
                    return begin + cost
                i -= 1
        return t

    def held_requests(self, c0: int, period: int, j0: int, j1: int) -> list[int]:
        """The requests ``c0 + j * period`` (``j0 <= j < j1``) of a block of pulses that
        fall in a section with interrupts off (timer 0, the UART, a routine entered as
        an event, the ramp task's exit): only these can have waited, and only for these
        :meth:`cpu_free_at` is asked.  In order, without repeats.
        (Written out for speed: this runs for every block of pulses.)"""
        lo, hi = c0 + j0 * period, c0 + (j1 - 1) * period
        found: list[int] = []
        timing = self.timing
        cost = self._ms_window if timing.millis_isr_ticks else 0
        if cost and self._millis_started:
            ov = timing.millis_overflow_ticks
            first = self._millis_phase + ov
            s = first + max(0, -(-(lo - cost + 1 - first) // ov)) * ov
            while s <= hi:
                j = j0 if s <= lo else -(-(s - c0) // period)
                if j < j1 and c0 + j * period < s + cost:
                    found.append(j)
                s += ov
        cost = self._uart_window if timing.uart_isr_ticks else 0
        loads = self.uart.loads
        if cost and loads and loads[-1] + cost > lo:
            i = bisect_right(loads, lo - cost)
            n = len(loads)
            while i < n and loads[i] <= hi:
                s = loads[i]
                j = j0 if s <= lo else -(-(s - c0) // period)
                if j < j1 and c0 + j * period < s + cost:
                    found.append(j)
                i += 1
        for starts, ends in ((self.isr_starts, self.isr_ends),
                             (self.exit_starts, self.exit_ends)):
            if ends and ends[-1] > lo:
                i = bisect_right(ends, lo)
                n = len(starts)
                while i < n and starts[i] <= hi:
                    s = starts[i]
                    j = j0 if s <= lo else -(-(s - c0) // period)
                    if j < j1 and c0 + j * period < ends[i]:
                        found.append(j)
                    i += 1
        if len(found) > 1:
            found = sorted(set(found))
        return found

    # ------------------------------------------------------- CPU and time
    def cpu_now(self) -> int:
        """Tick at which code running right now takes effect (inside a task: later)."""
        if not self.task_offset:
            return self.now
        if self.timing.task_nested_isrs >= 2 or self.nest_timer0:
            return self.now + self.nested_stretched(self.task_offset)
        return self.now + self.stretched(self.task_offset)

    def nested_stretched(self, work: int) -> int:
        """Ticks that ``work`` ticks of the ramp task's code take from now on with every
        interrupt nested in it: the UART's, timer 0's overflows and the step
        interrupts."""
        timing = self.timing
        ucost = timing.uart_isr_ticks
        mcost = timing.millis_isr_ticks if self._millis_started else 0
        ov = timing.millis_overflow_ticks
        steps = self.step_isrs_between
        now = self.now
        t = work
        for _ in range(50):
            extra = 0
            if ucost:
                extra += ucost * self.uart.isr_loads_between(now, now + t)
            if mcost:
                lo = max(now, self._millis_first)
                hi = now + t
                if hi > lo:
                    # overflows at phase + k * ov in [lo, hi)
                    first = lo + (-(lo - self._millis_phase)) % ov
                    if first < hi:
                        extra += mcost * ((hi - 1 - first) // ov + 1)
            if steps is not None:
                extra += steps(now, now + t)
            if work + extra == t:
                return t
            t = work + extra
        return t

    def stretched(self, work: int) -> int:
        """Ticks that ``work`` ticks of interruptible code take from now on.

        The console UART's transmit interrupt refills its data register once per
        character while text is queued; each time it takes its CPU time from the
        code that runs (the periodic task's work is interruptible).
        """
        cost = self.timing.uart_isr_ticks
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

        Stolen are the periodic task's work and the CPU time of step interrupts:
        those run as events add their time themselves; the others are counted here
        for the window (fas.sim.loop_isrs): the trains of :meth:`loop_trains` (the
        step interrupts of runs of pulses simulated as one block - every one that ran
        in the window, also of a block that ended in it, at the channel's
        ``isr_ticks`` - and the timer-0 overflow interrupts of ``millis()``), the
        UART's transmit interrupts and timers that tick without events
        (``cpu_sources``: QuickStep's period interrupt).  So spending ``a`` and then
        ``b`` ticks ends at the same tick as spending ``a + b``.
        (Written out for speed: this runs for every character a program prints.)"""
        if not self.cpu_sources:  # between events an IsrClock answers (fas.sim.loop_isrs)
            clock = self._clock  # (isr_clock(), written out)
            key = (self.events_run, self.seq, self.irq_block_windows, self.activity)
            if clock is None or self._clock_key != key:
                clock = self._clock = IsrClock(self)
                self._clock_key = key
            ticks = clock.spend(ticks)
            if not ticks:
                return
        self.consume_counting(ticks)

    def consume_passes(self, passes: Sequence[tuple[int, int, Poll | None]], before: int,
                       changed: Callable[[], bool]) -> int:
        """The main loop's passes, the same round of ``passes`` again and again: each
        pass ``(head, ticks, poll)`` spends ``head`` ticks, then makes its reads, then
        spends ``ticks`` (``poll``: its sections, as :meth:`poll_begin`'s; None: none),
        each span as :meth:`consume` would.  A pass is spent when no event falls due in
        its head and its reads come before tick ``before`` (else it is taken back and
        the call returns); events in its ``ticks`` run as in :meth:`consume`, and after
        a pass in which one ran the call returns once ``changed()`` holds.  Returns how
        many passes were spent, from the round's first.

        Rounds in which no interrupt takes time from the loop (before the next tick of
        a train, the UART's next load and the next event) follow each other at the
        round's length: they are spent at once, and the polls of one pass of each kept
        as one entry of :attr:`loop_polls` with the round's length negated as its period
        (its passes ``-period`` apart from its start, each exactly: :meth:`loop_hold`).
        A machine with ``cpu_sources`` counts every span itself: it spends none here."""
        if self.cpu_sources or not passes:
            return 0
        polls = self.loop_polls
        heap = self.events
        count = len(passes)
        length = sum(head + ticks for head, ticks, _ in passes)
        polled = [i for i, (_, ticks, poll) in enumerate(passes) if poll is not None and ticks]
        run: tuple[int, int, tuple[tuple[int, int], ...]] | None = None  # (offset, ticks, sections)
        bulk = length > 0 and not polled
        if len(polled) == 1:
            i = polled[0]
            head, ticks, poll = passes[i]
            if poll is not None and poll[0] == ticks:  # sections of the pass's own length
                bulk = True
                run = (sum(h + t for h, t, _ in passes[:i]) + head, ticks, poll[1])
        done = 0
        i = 0
        while True:
            clock = self.isr_clock()
            now = self.now
            if i == 0 and bulk and not self.stolen_ticks:  # the rounds nothing meets, at once
                trains = clock.trains
                horizon = before
                if heap and heap[0][0] < horizon:
                    horizon = heap[0][0]
                for tr in trains:
                    nxt = tr[0]
                    if nxt <= now:
                        nxt = tr[0] = next_after(now, tr[1], tr[2], tr[3])
                    if nxt < horizon:
                        horizon = nxt
                if clock.uart_cost:
                    loads = clock.loads
                    li = clock.li
                    n_loads = len(loads)
                    if li and (li > n_loads or loads[li - 1] > now):
                        li = bisect_right(loads, now)
                    while li < n_loads and loads[li] <= now:
                        li += 1
                    clock.li = li
                    if li < n_loads and loads[li] < horizon:
                        horizon = loads[li]
                k = (horizon - 1 - now) // length
                if k > 0:
                    self.now = now + k * length
                    done += k * count
                    if run is not None:
                        if len(polls) > 4096:  # (as poll_begin)
                            del polls[:len(polls) - 64]
                        offset, ticks, sections = run
                        polls.append((now + offset, now + (k - 1) * length + offset + ticks,
                                      -length, sections))
                    now = self.now
            head, ticks, poll = passes[i]
            if head:  # no event in it, the reads before ``before``: else taken back
                stolen0 = self.stolen_ticks
                trains = clock.trains
                cursors = [tr[0] for tr in trains]
                li0, quiet0 = clock.li, clock.quiet
                if clock.spend(head) or self.now >= before:
                    self.now, self.stolen_ticks = now, stolen0
                    for tr, nxt in zip(trains, cursors, strict=True):
                        tr[0] = nxt
                    clock.li, clock.quiet = li0, quiet0
                    return done
            elif now >= before:
                return done
            if poll is not None:
                self.poll_begin(*poll)
            left = clock.spend(ticks)
            if left:
                self.consume_counting(left)
            if poll is not None:
                self.poll_end()
            done += 1
            i += 1
            if i == count:
                i = 0
            if left and changed():
                return done

    def loop_trains(self) -> list[Train]:
        """The periodic interrupts that take CPU time from the loop until the next
        event, as ``(first, period, last, cost)`` (fas.sim.loop_isrs): the step
        interrupts ``j <= b_n - 2`` of each block of pulses (its last one is an event
        of its own), and the timer-0 overflows ``k >= 1`` after ``millis()`` started."""
        trains = []
        for src in self.block_sources:
            if src.batch and src.isr_ticks:
                first = src.b_c0 + src.lat
                trains.append((first, src.b_t, first + (src.b_n - 2) * src.b_t,
                               src.isr_ticks))
        millis = self._millis_train()
        if millis is not None:
            trains.append(millis)
        return trains

    def _millis_train(self) -> Train | None:
        timing = self.timing
        if not (timing.millis_isr_ticks and self._millis_started):
            return None
        ov = timing.millis_overflow_ticks
        return (self._millis_phase + ov, ov, NEVER, timing.millis_isr_ticks)

    def isr_clock(self) -> IsrClock:
        """The interrupts that take time from the loop, followed until the next event.
        A clock holds while no event ran or was scheduled, no interrupt-blocked window
        began and no channel started or stopped.  (With ``cpu_sources`` the machine
        counts every span itself: the clock answers only :meth:`resume_wait` then.)"""
        key = (self.events_run, self.seq, self.irq_block_windows, self.activity)
        clock = self._clock
        if clock is None or self._clock_key != key:
            clock = self._clock = IsrClock(self)
            self._clock_key = key
        return clock

    def consume_counting(self, ticks: int) -> None:
        """:meth:`consume`, each span counted here (for spans in which events fall due,
        and with ``cpu_sources``)."""
        uart_cost = self.timing.uart_isr_ticks
        uart = self.uart
        chars = uart.records
        heap = self.events
        sources = self.block_sources
        cpu_sources = self.cpu_sources
        while True:
            start = self.now
            end = start + ticks
            stolen_isr = 0
            if heap and heap[0][0] <= end:  # events in the window: blocks may change
                for src in sources:
                    if src.isr_ticks:
                        stolen_isr -= src.isr_ticks * src.block_isrs_until(start)
                self.run_until(end)
                stolen = self.stolen_ticks
                for src in sources:
                    if src.isr_ticks:
                        stolen_isr += src.isr_ticks * src.block_isrs_until(end)
                millis = self._millis_train()
                if millis is not None:
                    stolen_isr += millis[3] * count_between(millis, start, end)
            else:  # no event: the trains stay (SimChannel.block_isrs_until)
                self.now = end
                stolen = self.stolen_ticks
                for first, period, last, cost in self.loop_trains():
                    nxt = next_after(start, period, first, last)
                    if nxt <= end:
                        stolen_isr += cost * count_from(nxt, period, last, end)
            if stolen_isr:
                stolen += stolen_isr
            for cpu in cpu_sources:
                stolen += cpu.block_cpu_between(start, end)
            if uart_cost and chars and chars[-1][1] > start:
                stolen += uart_cost * uart.isr_loads_between(start, end)
            self.stolen_ticks = 0
            if not stolen:
                return
            ticks = stolen

    def resume(self) -> None:
        """The loop waited (polling) until now; it goes on once no interrupt routine
        holds the CPU.  What the routines took while it waited delayed nothing."""
        wait = self.resume_wait()
        if wait > 0:
            self.consume(wait)

    def resume_wait(self) -> int:
        """For :meth:`resume`: forget what interrupts took while the loop waited, and
        return how long the routines running now still hold the CPU (the step
        interrupt of a block, the timer-0 overflow, the UART's transmit interrupt:
        :meth:`IsrClock.resume_wait`)."""
        clock = self._clock
        if clock is not None and self._clock_key == (self.events_run, self.seq,
                                                     self.irq_block_windows, self.activity):
            return clock.resume_wait()
        # no clock holds (events ran while the loop waited): the same answer as a new
        # clock's, without making one - most waits need none after it
        self.stolen_ticks = 0
        now = self.now
        wait = self.busy_until - now
        # (loop_trains and running_end written out: this runs after every wait)
        for src in self.block_sources:
            if src.batch and src.isr_ticks:
                cost = src.isr_ticks
                first = src.b_c0 + src.lat
                if now >= first:
                    period = src.b_t
                    into = (now - first) % period
                    if into < cost and now - into <= first + (src.b_n - 2) * period:
                        end = now - into + cost
                        if end - now > wait:
                            wait = end - now
        timing = self.timing
        cost = timing.millis_isr_ticks
        if cost and self._millis_started:
            ov = timing.millis_overflow_ticks
            first = self._millis_phase + ov
            if now >= first:
                into = (now - first) % ov
                if into < cost and now - into <= NEVER:
                    end = now - into + cost
                    if end - now > wait:
                        wait = end - now
        cost = timing.uart_isr_ticks
        if cost:
            loads = self.uart.loads
            li = bisect_right(loads, now)
            if li and loads[li - 1] > now - cost and loads[li - 1] + cost - now > wait:
                wait = loads[li - 1] + cost - now
        return wait

    def block_interrupts(self, ticks: int) -> None:
        """The main loop runs ``ticks`` with interrupts disabled (busy wait).  Where
        interrupts contend, the loop gets to its ``cli`` only once no routine holds the
        CPU and none is pending (those requested before run first)."""
        if self.profile.irq_block_delays_steps:
            while True:
                free = self.cpu_free_at(self.now)
                if free == self.now:
                    break
                self.run_until(free)
        start, end = self.now, self.now + ticks
        if end > self.irq_blocked_until:
            self.irq_blocked_until = end
            self.irq_blocked_from = start
            self._quiet_from = max(self._quiet_from, end + self.timing.sei_ticks)
        self.irq_block_windows += 1
        self.irq_blocked_ticks += ticks
        self.uart.interrupts_blocked(start, end)
        for listener in self.block_listeners:
            listener(start, end)
        self.consume(ticks)

    def start_millis(self) -> None:
        """Arduino's start-up has just started timer 0, the source of ``millis()``."""
        self._millis_phase = self.now
        self._millis_started = True
        if self.timing.millis_isr_ticks:
            self._millis_first = self.now + self.timing.millis_overflow_ticks
        self._clock = None  # its interrupts begin
        self._tick_at_ms = (None, 0)

    def millis_isrs_between(self, begin: int, end: int) -> int:
        """Timer-0 overflow interrupts in ``(begin, end]``."""
        ov = self.timing.millis_overflow_ticks
        phase = self._millis_phase
        return max(0, (end - phase) // ov) - max(0, (begin - phase) // ov)

    def millis(self) -> int:
        """Arduino ``millis()``: timer-0 overflows with the 1.024 ms fraction fix-up."""
        n = (self.now - self._millis_phase) // self.timing.millis_overflow_ticks
        if n <= 0:
            return 0
        if self.timing.millis_overflow_ticks == 16384:
            return n + (3 * n) // 125
        return n * self.timing.millis_overflow_ticks * 1000 // self.profile.ticks_per_s

    def tick_at_millis(self, ms: int) -> int:
        """Earliest tick at which :meth:`millis` returns at least ``ms``."""
        if ms == self._tick_at_ms[0]:  # a waiting loop asks for the same deadline often
            return self._tick_at_ms[1]
        tick = self._tick_at_millis(ms)
        self._tick_at_ms = (ms, tick)
        return tick

    def _tick_at_millis(self, ms: int) -> int:
        ov = self.timing.millis_overflow_ticks
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
