"""Execution of one stepper's command queue by a simulated timer-compare channel.

This models FastAccelStepper's AVR step interrupt.  The timer's compare unit raises
the step pin at the compare tick (hardware, exact); the compare interrupt then clears
the pin, counts the step off the current entry and programs the next compare as
``previous compare + ticks``.  If the interrupt runs so late that this tick has
already passed (interrupts blocked by the application), the compare only matches
after the 16-bit timer wraps: a gap of 4.1 ms, no lost step - exactly what the
firmware shows under StepperDemo's `e`.

The interrupt is entered when the CPU is free (:meth:`Machine.cpu_free_at`): the pin
falls ``lat`` ticks after the entry and the next compare is written ``ocr`` ticks after
that, so other interrupts that hold the CPU when the compare matches (``millis()``'s
timer, the UART, the other channels' step interrupts, the ramp task's entry and exit,
StepperDemo's blocked sections) stretch the pulse and can make the next compare be
missed.  (``contention``: the AVR step channel; QuickStep's timer keeps its own rule.)

Runs of pulses inside one entry are executed as a block (one event for up to 255
steps; one channel of a machine at a time); the block is split only when interrupts
get blocked in its middle or when someone stops the channel.  The pulses of a block
whose compare falls while another routine holds the CPU are found when the block ends
(:meth:`Machine.held_requests`) and made as long as they were held - where someone
watches the pins' edges (a recorder, a trace): their timing does not depend on it, and
without such a sink the pin statistics count a block's pulses at their plain width.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable, Iterator
from functools import lru_cache
from heapq import heappush
from typing import TYPE_CHECKING

from ..channel import PulseCounter, QueueChannel
from ..codes import PIN_UNDEFINED
from .machine import LATE_ENTRY, PRIO_PLAIN, PRIO_STEP_ISR, Event, Machine
from .pins import EdgeRecorder
from .ramp_cost import conversion_ticks, start_pitch_ticks

if TYPE_CHECKING:  # pragma: no cover
    from ..queue import QueueEntry, StepperQueue

RESTART_TICKS = 10  # the step ISR's "do it immediately" delay after the queue ran dry

# kinds of entry notes (``SimChannel.entry_listeners``): which entry the channel works on
ENTRY_START = 0  # first entry after the channel was started (a new motion)
ENTRY_NEXT = 1  # the following entry of the queue
ENTRY_RESTART = 2  # an entry that arrived after the queue had run dry


@lru_cache(maxsize=8)
def _sections_in_order(sections: tuple[tuple[int, int], ...]
                       ) -> tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]] | None:
    """A command's mask sections ``(before, ticks)`` (before its write's end) as their
    starts' and ends' distances before it, and the ends' negated (ascending: to find the
    first that ends after a tick), if each begins at or after the one before it ends and
    none is empty (None: not so)."""
    if not sections or not all(t > 0 for _, t in sections) or not all(
            b1 <= b0 - t0 for (b0, t0), (b1, _) in zip(sections, sections[1:], strict=False)):
        return None
    return (tuple(b for b, _ in sections), tuple(b - t for b, t in sections),
            tuple(t - b for b, t in sections))


class SimChannel(QueueChannel):
    # (slots: the event loop and the ramp task read and write these for every pulse
    # and command)
    __slots__ = ("m", "q", "pins", "_made_plain", "_isr_plain", "step_pin", "lat", "wrap",
                 "start_ticks", "prio", "isr_ticks", "isr_next_ticks", "cost",
                 "irq_sensitive", "contention", "ocr", "ocr_next", "after_reti", "running",
                 "no_more", "mode_one", "event", "_spare", "_single_isr_fn",
                 "_batch_end_fn", "pending_compare", "pending_pulse", "batch", "b_entry",
                 "b_c0", "b_t", "b_n", "b_counted", "block_isrs_done", "entry_req",
                 "entry_tick", "precounted", "pulse_counter", "detached", "pulses",
                 "starts", "dry", "missed_compares", "entry_listeners", "maths_ticks",
                 "converted", "fast_acc_below", "_noted", "plan_pending", "_start_event",
                 "_start_tick", "entry_guard", "on_halt", "on_idle", "fill_charge",
                 "fill_read_tick", "ramp_continuous", "ramp_ended", "ramp_cubic_update",
                 "ramp_jump_maths", "ramp_path")

    def __init__(self, machine: Machine, queue: StepperQueue) -> None:
        p = machine.profile
        self.m = machine
        self.q = queue
        self.pins = machine.pins
        # _made is not extended by a subclass: a single pulse counts itself inline
        self._made_plain = type(self)._made is SimChannel._made  # noqa: SLF001
        # _isr is not replaced by a subclass: a single pulse goes on to the next inline
        self._isr_plain = type(self)._isr is SimChannel._isr  # noqa: SLF001
        self.step_pin = queue.step_pin
        timing = machine.timing
        self.lat = timing.isr_latency(queue.index)
        self.wrap = timing.timer_wrap_ticks
        self.start_ticks = p.queue_start_ticks
        self.prio = PRIO_STEP_ISR + queue.index
        self.isr_ticks = timing.isr_duration(queue.index)  # CPU of one step interrupt
        # ... one that takes up the next queue entry (the pending single one's: cost)
        self.isr_next_ticks = self.isr_ticks + timing.isr_next_entry_ticks
        self.cost = self.isr_next_ticks
        self.irq_sensitive = p.irq_block_delays_steps
        # the interrupt is requested at the compare and entered when the CPU is free;
        # it writes the next compare ``ocr`` ticks after it cleared the pin
        self.contention = bool(self.irq_sensitive and timing.isr_ocr_ticks)
        self.ocr = timing.isr_ocr_ticks if self.contention else 0
        # ... later where it takes up the next queue entry
        self.ocr_next = self.ocr + timing.isr_ocr_next(queue.index) if self.contention else 0
        self.after_reti = timing.reti_next_ticks if self.contention else 0
        self.running = False
        self.no_more = False
        self.mode_one = False
        self.event: Event | None = None
        # the event of the interrupt running now, free to carry the next one (_single_isr,
        # _batch_end: popped and run, no longer in the heap); taken by the next schedule
        self._spare: Event | None = None
        # the interrupt routines as bound methods, made once (an event's function)
        self._single_isr_fn = self._single_isr
        self._batch_end_fn = self._batch_end
        self.pending_compare = 0  # compare tick of the pending single ISR event
        self.pending_pulse = False
        # block of pulses of one entry: pulses at b_c0 + j*b_t, j < b_n (while batch;
        # b_entry: that entry - the ring's first slot until a block runs)
        self.batch = False
        self.b_entry: QueueEntry = queue.entries[0]
        self.b_c0 = 0
        self.b_t = 0
        self.b_n = 0
        self.b_counted = 0  # pulses of the block already given to the pulse counter
        # step interrupts of blocks that ran (each block's last one is an event of its
        # own and not counted here): the loop loses their CPU time (Machine.consume)
        self.block_isrs_done = 0
        self.entry_req = -1  # _entry_of: the request it answered last, and its entry
        self.entry_tick = 0
        self.precounted = 0  # the pending single pulse was already counted by sync()
        self.pulse_counter: PulseCounter | None = None
        self.detached = False
        # statistics
        self.pulses = 0
        self.starts = 0
        self.dry = 0  # times the queue ran empty under a running channel
        self.missed_compares = 0
        # observers (traces, timing reports): fn(kind, pulse_index, ticks, steps) when the
        # channel takes up an entry; pulse_index is the number of its first pulse
        self.entry_listeners: list[Callable[[int, int, int, int], None]] = []
        # the ramp's arithmetic for the command written next (fill_cmd_maths; -1: its
        # period was not computed from a ramp step), and the period below which an
        # accelerating ramp checks for too short commands
        self.maths_ticks = -1
        self.converted = False  # ... and whether the ramp computed it at all
        self.fast_acc_below = 2 * p.min_cmd_ticks
        self._noted: QueueEntry | None = None
        # the running ramp task's fill of this (running) stepper has not planned a
        # command yet: its first one costs SimTiming.fill_plan_ticks more
        self.plan_pending = False
        self._start_event: Event | None = None  # a timed start (start_at) waiting
        self._start_tick = 0  # ... and the tick of its first compare
        # limit switches: entry_guard(entry) True stops the channel before the entry's
        # first pulse; on_halt() is told afterwards (set by the backend)
        self.entry_guard: Callable[[QueueEntry], bool] | None = None
        self.on_halt: Callable[[], None] | None = None
        self.on_idle: Callable[[], None] | None = None  # the queue ran dry (fas.sync)
        # fill_charges_after_writes: this running stepper's fixed fill work, charged
        # after its writes (SimBackend._task sets it; flush_fills charges it)
        self.fill_charge = 0
        self.fill_read_tick = 0  # the tick of the fill's last live read of this queue
        # (fill_begins; bench tools)
        # the ramp's notes (QueueChannel's), as slots here
        self.ramp_continuous = False
        self.ramp_ended = False
        self.ramp_cubic_update = False
        self.ramp_jump_maths = 0
        self.ramp_path = 0
        if self.irq_sensitive:
            machine.block_listeners.append(self._on_block)

    # ----------------------------------------------------------- interface
    def is_running(self) -> bool:
        return self.running or self._start_event is not None

    def start(self) -> None:
        q = self.q
        if self.running or q.read_idx == q.next_write_idx:
            return
        if self._start_event is not None:  # started at once instead of at its time
            self.m.cancel(self._start_event)
            self._start_event = None
        self.running = True
        m = self.m
        m.activity += 1
        self.no_more = False
        self.starts += 1
        e = q.entries[q.read_idx % q.queue_len]
        if m.in_task:  # the ramp task starts the queue after its fill
            p = m.timing
            last = q.entries[(q.next_write_idx - 1) % q.queue_len]
            m.task_offset += (p.fill_start_after_cmd_ticks
                              if p.fill_start_after_cmd_ticks and last.total_steps > 1
                              else p.fill_start_ticks)
            if p.fill_start_ramp_end_ticks and self.ramp_ended:
                m.task_offset += p.fill_start_ramp_end_ticks  # the ramp ended in this fill
        t = m.cpu_now()
        if e.toggle_dir:
            self._toggle_dir(t)
        if e.steps and self.entry_guard is not None and self.entry_guard(e):
            self._halt()
            return
        self.mode_one = e.steps != 0
        if self.entry_listeners:
            self._note_entry(ENTRY_START, e)
        self._program(t + self.start_ticks, e)
        if m.in_task:  # the task goes on after the start (its compare is set)
            m.task_offset += m.timing.fill_start_tail_ticks

    def release(self) -> None:
        """The chip resets: stop at once and leave the machine (its interrupt-block
        listeners and the block sources)."""
        self.force_stop()
        m = self.m
        if self._on_block in m.block_listeners:
            m.block_listeners.remove(self._on_block)
        if self in m.block_sources:
            m.block_sources.remove(self)

    def force_stop(self) -> None:
        if self._start_event is not None:
            self.m.cancel(self._start_event)
            self._start_event = None
        if not self.running:
            return
        now = self.m.now
        if self.batch:
            self._close_batch_at(now)
        elif self.pending_pulse and self.pending_compare <= now:
            self._emit(self.pending_compare, max(now - self.pending_compare, 1), 1)
            q = self.q
            if self.precounted:
                self.precounted = 0
            elif q.read_idx != q.next_write_idx:
                self._count(1, q.entries[q.read_idx % q.queue_len].dir_level)
        self.m.cancel(self.event)
        self.event = None
        self.pending_pulse = False
        self.running = False
        self.m.activity += 1
        self.no_more = False
        self.mode_one = False

    def _halt(self) -> None:
        """A limit stops the channel before the entry at read_idx makes a pulse."""
        self.running = False
        self.m.activity += 1
        self.no_more = False
        self.mode_one = False
        self.pending_pulse = False
        self.event = None
        if self.on_halt is not None:
            self.on_halt()

    def stop_now(self) -> int:
        """Stop at once (as :meth:`force_stop`); the position where the pulses stopped."""
        q = self.q
        rp = q.read_idx
        if rp == q.next_write_idx:
            self.force_stop()
            return q.queue_end_pos
        e = q.entries[rp % q.queue_len]
        now = self.m.now
        if not self.running:
            remaining = e.steps
        elif self.batch:
            risen = 0 if now < self.b_c0 else min(self.b_n, (now - self.b_c0) // self.b_t + 1)
            remaining = self.b_n - risen
        elif self.pending_pulse and self.pending_compare <= now:
            remaining = e.steps - 1
        else:
            remaining = e.steps
        self.force_stop()
        pos = e.end_pos - remaining if e.count_up else e.end_pos + remaining
        return ((pos + 0x80000000) & 0xFFFFFFFF) - 0x80000000

    def moving_up(self) -> bool | None:
        """The direction of the pulses being made or next (None: none queued)."""
        self.sync()
        q = self.q
        rp = q.read_idx
        while rp != q.next_write_idx:
            e = q.entries[rp % q.queue_len]
            if e.steps:
                return e.count_up
            rp = (rp + 1) & 0xFF
        return None

    # ------------------------------------------------------- queue timing
    def end_tick(self) -> int | None:
        q = self.q
        rp, wp = q.read_idx, q.next_write_idx
        if rp == wp or self.no_more:
            return None
        if self._start_event is not None:
            end = self._start_tick
            first = rp
        elif not self.running:
            return None
        elif self.batch:
            end = self.b_c0 + self.b_n * self.b_t
            first = (rp + 1) & 0xFF
        else:  # the compare pending belongs to the entry at read_idx, steps left incl.
            e = q.entries[rp % q.queue_len]
            end = self.pending_compare + max(e.steps, 1) * e.ticks
            first = (rp + 1) & 0xFF
        while first != wp:
            e = q.entries[first % q.queue_len]
            end += e.ticks * max(e.total_steps, 1)
            first = (first + 1) & 0xFF
        return end

    def _running_segments(self) -> Iterator[tuple[int, int, int]]:
        """The compares still to come: ``(first, period, count)`` per queue entry, the
        running one first (none while the channel stands or waits for a timed start)."""
        q = self.q
        rp, wp = q.read_idx, q.next_write_idx
        if not self.running or self._start_event is not None or rp == wp or self.no_more:
            return
        n = q.queue_len
        if self.batch:
            yield self.b_c0, self.b_t, self.b_n
            end = self.b_c0 + self.b_n * self.b_t
        else:
            e = q.entries[rp % n]
            k = max(e.steps, 1)
            yield self.pending_compare, e.ticks, k
            end = self.pending_compare + k * e.ticks
        first = (rp + 1) & 0xFF
        while first != wp:
            e = q.entries[first % n]
            k = max(e.total_steps, 1)
            yield end, e.ticks, k
            end += e.ticks * k
            first = (first + 1) & 0xFF

    def isr_cpu_between(self, lo: int, hi: int) -> int:
        """CPU time of this channel's step interrupts whose compares fall in [lo, hi)."""
        count = 0
        for c0, t, k in self._running_segments():
            if c0 >= hi:
                break
            last = c0 + (k - 1) * t
            if last < lo:
                continue
            j0 = 0 if c0 >= lo else -(-(lo - c0) // t)
            j1 = min(k - 1, (hi - 1 - c0) // t)
            if j1 >= j0:
                count += j1 - j0 + 1
        return count * self.isr_ticks

    def fill_begins(self) -> int:
        m = self.m
        p = m.timing
        if m.in_task and p.fill_charges_after_writes:
            flush_fills(m)  # the fills before this one are over: their work comes now
            m.fills_done.append(self)
        if not (m.in_task and p.fill_reads_queue_live and self.running):
            return 0
        q = self.q
        m.task_offset += p.fill_stepper_ticks  # the fill's checks before it reads
        work = m.task_offset
        if p.fill_entry_after_reads:  # the task's fixed part comes after its fills' reads
            work = max(work - p.fill_entry_ticks, 0)
        t = m.now + (m.nested_stretched(work) if p.task_nested_isrs else m.stretched(work))
        self.fill_read_tick = t
        rp, wp = q.read_idx, q.next_write_idx
        n = q.queue_len
        # the channel takes up the entry after the running one in the step interrupt of
        # the running entry's last compare (a pause has one); the next entry's first
        # compare follows that one by the running entry's period
        skipped = 0
        if self._start_event is None and rp != wp:
            if self.batch:
                last, period = self.b_c0 + (self.b_n - 1) * self.b_t, self.b_t
            else:
                e = q.entries[rp % n]
                last = self.pending_compare + (max(e.steps, 1) - 1) * e.ticks
                period = e.ticks
            k = (rp + 1) & 0xFF
            while k != wp and last + self.lat <= t:
                e = q.entries[k % n]
                skipped += q.durations[k % n]
                last += period + (max(e.total_steps, 1) - 1) * e.ticks
                period = e.ticks
                rp = k
                k = (k + 1) & 0xFF
        # the library then sums the entries after the one running by then
        m.task_offset += self.queue_sum_ticks(rp)
        return skipped

    def queue_sum_ticks(self, rp: int) -> int:
        """The fill's CPU time summing the queue entries after entry ``rp`` (the one
        running): ``fill_queued_entry_ticks`` each, ``fill_queued_single_ticks`` for
        an entry of at most one step or a pause where that is set."""
        p = self.m.timing
        q = self.q
        wp = q.next_write_idx
        per_entry = p.fill_queued_entry_ticks
        per_single = p.fill_queued_single_ticks or per_entry
        queued = (wp - rp - 1) & 0xFF if wp != rp else 0
        if per_single == per_entry or not queued:
            return per_entry * queued
        n = q.queue_len
        first = (rp + 1) % n
        last = first + queued  # the queued entries from ``first``, the ring wrapping at n
        flags = q.singles  # (per slot: 1 where total_steps <= 1)
        singles = (sum(flags[first:last]) if last <= n
                   else sum(flags[first:]) + sum(flags[:last - n]))
        return per_single * singles + per_entry * (queued - singles)

    def earliest_start_tick(self) -> int:
        return self.m.cpu_now() + self.start_ticks

    def start_at(self, tick: int) -> int | None:
        """A timed start: an event ``start_ticks`` before ``tick`` starts the channel,
        whose first compare then falls on ``tick`` (as the device's timed Start)."""
        q = self.q
        if self.running or self._start_event is not None or q.read_idx == q.next_write_idx:
            return None
        fire = tick - self.start_ticks
        if fire <= self.m.cpu_now():
            begin = self.earliest_start_tick()
            self.start()
            return begin
        self._start_tick = tick
        self._start_event = self.m.schedule(fire, self._timed_start, PRIO_PLAIN)
        return tick

    def _timed_start(self) -> None:
        self._start_event = None
        self.start()

    def sync(self) -> None:
        if self.batch:
            now = self.m.now
            c0, t = self.b_c0, self.b_t
            if now >= c0 + self.lat:
                done = (now - c0 - self.lat) // t + 1
                if done > self.b_n - 1:
                    done = self.b_n - 1
                self.b_entry.steps = self.b_n - done
            if self.pulse_counter is not None and now >= c0:
                risen = min(self.b_n, (now - c0) // t + 1)
                if risen > self.b_counted:
                    self.pulse_counter.count(risen - self.b_counted, self.b_entry.dir_level)
                    self.b_counted = risen

    def ramp_converted(self, ramp_step: int, log2_ticks: int) -> None:
        self.converted = True
        if self.m.timing.fill_cmd_maths:
            self.maths_ticks = conversion_ticks(self.m.timing, ramp_step, log2_ticks)

    def entry_added(self) -> None:
        m = self.m
        maths, self.maths_ticks = self.maths_ticks, -1
        converted, self.converted = self.converted, False
        if m.in_task:  # planning one command costs the ramp task CPU time
            q = self.q
            wp = q.next_write_idx
            e = q.entries[(wp - 1) % q.queue_len]
            steps = e.total_steps
            p = m.timing
            if self.ramp_cubic_update:  # update()'s cubic figures before this command
                self.ramp_cubic_update = False
                m.task_offset += p.fill_cubic_update_ticks
            if self.ramp_jump_maths:  # a start's jump before this command
                jump, self.ramp_jump_maths = self.ramp_jump_maths, 0
                m.task_offset += sum(p.fill_jump_start_ticks[:jump])
            if self.plan_pending:
                self.plan_pending = False
                if p.fill_charges_after_writes:
                    self.fill_charge += p.fill_plan_ticks
                else:
                    m.task_offset += p.fill_plan_ticks
            if steps == 0:
                # a pause of auto enable's delay is a bare queue write (no ramp step)
                m.task_offset += (p.fill_bare_pause_ticks
                                  if e.bare and p.fill_bare_pause_ticks else p.fill_pause_ticks)
            elif steps == 1:
                m.task_offset += p.fill_single_ticks
            elif p.fill_unstarted_multi_cmd_ticks and not self.running:
                # a starting ramp's command of several steps: one figure, all in
                m.task_offset += p.fill_unstarted_multi_cmd_ticks
                if p.fill_start_pitch_ticks:  # ... and by the ramp's branches
                    m.task_offset += start_pitch_ticks(p.fill_start_pitch_ticks,
                                                       self.ramp_path)
            elif (p.fill_coast_cmd_ticks
                  and (not converted if p.fill_coast_unconverted
                       else (((wp - 1 - q.read_idx) & 0xFF)
                             and q.entries[(wp - 2) % q.queue_len].ticks == e.ticks))):
                m.task_offset += p.fill_coast_cmd_ticks  # at the speed of the one before
            elif (p.fill_dec_cmd_ticks and ((wp - 1 - q.read_idx) & 0xFF)
                  and q.entries[(wp - 2) % q.queue_len].ticks < e.ticks):
                # slower than the one before
                m.task_offset += p.fill_dec_cmd_ticks + (maths if maths > 0 else 0)
            elif maths < 0:
                m.task_offset += p.fill_cmd_ticks
            else:
                m.task_offset += p.fill_cmd_ticks + maths
                if (p.fill_fast_acc_ticks and ((wp - 1 - q.read_idx) & 0xFF)
                        and e.ticks < q.entries[(wp - 2) % q.queue_len].ticks
                        < self.fast_acc_below):
                    m.task_offset += p.fill_fast_acc_ticks  # accelerating at a high speed
            if (steps and p.fill_unstarted_cmd_extra_ticks and not self.running
                    and not (steps > 1 and p.fill_unstarted_multi_cmd_ticks)):
                m.task_offset += p.fill_unstarted_cmd_extra_ticks
            if p.fill_continuous_saved_ticks and self.ramp_continuous:
                first, other = p.fill_continuous_saved_ticks
                m.task_offset -= (first if not self.running
                                  and ((wp - 1 - q.read_idx) & 0xFF) == 0 else other)
            if (p.fill_first_write_enable_ticks and not self.running
                    and ((wp - 1 - q.read_idx) & 0xFF) == 0):
                # the first write's figure less its enableOutputs() (charged by the
                # backend where auto enable switches the outputs on)
                m.task_offset -= p.fill_first_write_enable_ticks
            if p.fill_no_dir_pin_saved_ticks and q.dir_pin == PIN_UNDEFINED:
                first, stopped, running = p.fill_no_dir_pin_saved_ticks
                # no direction checks (the first write also sets no pin)
                m.task_offset -= (running if self.running else
                                  first if ((wp - 1 - q.read_idx) & 0xFF) == 0 else stopped)
            if p.fill_cmd_mask_ticks and self.contention:
                # the command is written to the queue with interrupts off
                end = m.now + m.task_offset
                m.mask(end - p.fill_cmd_mask_ticks, end)
            elif p.fill_cmd_mask_sections and self.contention:
                end = m.now + m.task_offset
                # (Machine.mask of each, written out: 13 sections a command on build d)
                starts, ends = m.exit_starts, m.exit_ends
                last = ends[-1] if ends else 0
                sections = p.fill_cmd_mask_sections
                order = _sections_in_order(sections)
                # the first section that ends after the sections known: the ones before
                # it lie in them, it is cut to their end, the rest go in whole
                k = bisect_right(order[2], last - end) if order is not None else 0
                n = len(sections)
                if order is not None and k < n and len(starts) + n - k <= 1025:  # no list full
                    starts_before, ends_before, _ = order
                    start = end - starts_before[k]
                    starts.append(start if start > last else last)
                    ends.append(end - ends_before[k])
                    if k + 1 < n:
                        starts += map(end.__sub__, starts_before[k + 1:])
                        ends += map(end.__sub__, ends_before[k + 1:])
                    if ends[-1] > m._quiet_from:  # noqa: SLF001
                        m._quiet_from = ends[-1]  # noqa: SLF001
                elif order is None or k < n:  # (k == n: all within the sections known)
                    for before, ticks in sections:
                        # (a short command: not before the sections already known)
                        start = end - before
                        stop = start + ticks
                        if start < last:
                            start = last
                        if start < stop:
                            if len(starts) > 1024:
                                m._forget_isrs()  # noqa: SLF001
                            starts.append(start)
                            ends.append(stop)
                            last = stop
                            if stop > m._quiet_from:  # noqa: SLF001
                                m._quiet_from = stop  # noqa: SLF001

    def step_pin_high(self) -> bool:
        """Is a step pulse on the pin at this very tick?"""
        now = self.m.now
        if self.batch:
            if now < self.b_c0:
                return False
            j = (now - self.b_c0) // self.b_t
            return j < self.b_n and now - (self.b_c0 + j * self.b_t) < self.lat
        return self.pending_pulse and self.pending_compare <= now

    # ------------------------------------------------------------ internals
    def _toggle_dir(self, t: int) -> None:
        pin = self.q.dir_pin
        if pin & 0x80 == 0:
            self.pins.set(pin, 1 - self.pins.get(pin), t)

    def _made(self, count: int) -> None:
        """``count`` pulses of the entry at the read index were made (every emission
        passes here: a subclass that counts more, e.g. the device's position, hooks in)."""
        self.pulses += count

    def _emit(self, first: int, width: int, count: int, period: int = 1) -> None:
        self._made(count)
        if not self.detached:
            self.pins.pulses(self.step_pin, first, period, count, width)

    def _program(self, compare: int, e: QueueEntry) -> None:
        """Arm the compare at tick ``compare`` for entry ``e`` (the one at read_idx)."""
        m = self.m
        if self.mode_one and e.steps >= 2 and (not self.contention
                                               or m.batch_channel in (None, self)):
            self.batch = True
            self.b_entry = e
            self.b_c0 = compare
            self.b_t = e.ticks
            self.b_n = e.steps
            self.b_counted = 0
            last = compare + (e.steps - 1) * e.ticks
            if self.contention:
                m.batch_channel = self
                cost = self.cost = self.isr_next_ticks  # the last pulse's: the next entry
                # (Machine.schedule written out: this runs for every block of pulses)
                if last < m.now:
                    last = m.now
                ev = self._event(last, self._batch_end_fn, cost)
                self.event = ev
                m.seq += 1
                heappush(m.events, (last, self.prio, m.seq, ev))
            else:
                self.event = m.schedule(last + self.lat, self._batch_end, self.prio, isr=True)
        else:
            self.pending_compare = compare
            self.pending_pulse = self.mode_one
            self._schedule_single(compare)

    def _schedule_single(self, compare: int) -> None:
        q = self.q
        rp = q.read_idx
        cost = self.cost = (self.isr_ticks if rp != q.next_write_idx
                            and q.entries[rp % q.queue_len].steps > 1 else self.isr_next_ticks)
        m = self.m  # (Machine.schedule, written out)
        if self.contention:
            if compare < m.now:
                compare = m.now
            ev = self._spare  # (_event, written out: this runs for every single pulse)
            if ev is None:
                ev = Event(compare, self.prio, self._single_isr_fn, cost > 0, cost, self)
            else:
                self._spare = None
                ev.time = compare
                ev.fn = self._single_isr_fn
                ev.isr = cost > 0
                ev.enter = cost
                ev.owner = self
        else:
            compare += self.lat
            if compare < m.now:
                compare = m.now
            ev = Event(compare, self.prio, self._single_isr_fn, True, 0, None)
        self.event = ev
        m.seq += 1
        heappush(m.events, (compare, self.prio, m.seq, ev))

    def _leave_batch(self) -> None:
        self.batch = False
        self.entry_req = -1
        if self.m.batch_channel is self:
            self.m.batch_channel = None

    def _emit_block(self, j0: int, j1: int) -> None:
        """Make pulses ``j0 <= j < j1`` of the running block: ``lat`` wide, longer where
        the interrupt waited for the CPU."""
        if j1 <= j0:
            return
        c0, t, lat = self.b_c0, self.b_t, self.lat
        if self.contention and self.pins.sinks:
            waits = self._block_delays(j0, j1)
            if waits:
                self._made(j1 - j0)
                if not self.detached:
                    self.pins.pulses_waiting(self.step_pin, c0 + j0 * t, t, j1 - j0, lat,
                                             [(j - j0, d) for j, d in waits])
                return
        self._emit(c0 + j0 * t, lat, j1 - j0, t)

    def _block_delays(self, j0: int, j1: int) -> list[tuple[int, int]]:
        """``(j, ticks)`` for the pulses ``j0 <= j < j1`` of the running block whose
        interrupt entered late, in order."""
        m = self.m
        c0, t = self.b_c0, self.b_t
        out: list[tuple[int, int]] = []
        for j in m.held_requests(c0, t, j0, j1):
            c = c0 + j * t
            free = m.cpu_free_at(c, self)
            if free > c:  # behind a routine: after its reti, one instruction (not after
                # a blocked section's end: its sei's instruction is in sei_ticks)
                out.append((j, free - c + (self.after_reti if free != m.blocked_end
                                           else 0)))
        if m.loop_polls and m.loop_polls[-1][1] > c0 + j0 * t:
            loop = m.loop_holds(c0, t, j0, j1, self.isr_ticks, {j for j, _ in out})
            if loop:
                out = sorted(out + loop)
        return out

    def block_isr_running_at(self, t: int) -> int | None:
        """End of the step interrupt of the running block that holds the CPU at tick
        ``t`` (its interrupt j is requested at ``b_c0 + j * b_t``; entered when the
        CPU is free)."""
        if not self.batch:
            return None
        c0 = self.b_c0
        if t < c0:
            return None
        period = self.b_t
        j = (t - c0) // period
        if j > self.b_n - 2:
            j = self.b_n - 2
        if j < 0:
            return None
        cost = self.isr_ticks
        c = c0 + j * period
        while True:  # pulse j, then j - 1
            if t - c >= cost + LATE_ENTRY:  # its interrupt is over, however late it came
                return None
            if c != self.entry_req:  # (_entry_of, written out)
                self.entry_req = c
                self.entry_tick = self.m.cpu_free_at(c, self)
            entry = self.entry_tick
            if entry <= t < entry + cost:
                return entry + cost
            if not j:
                return None
            j = 0
            c -= period

    def _entry_of(self, c: int) -> int:
        """When the interrupt requested at ``c`` by the running block is entered (the
        last answer is kept: the machine asks about the same pulse again and again)."""
        if c != self.entry_req:
            self.entry_req = c
            self.entry_tick = self.m.cpu_free_at(c, self)
        return self.entry_tick

    def _count(self, n: int, dir_level: bool) -> None:
        if self.pulse_counter is not None and n > 0:
            self.pulse_counter.count(n, dir_level)

    def _close_batch_at(self, now: int) -> None:
        """Account the block's pulses up to ``now`` and leave block mode."""
        c0, t, n, lat = self.b_c0, self.b_t, self.b_n, self.lat
        risen = 0 if now < c0 else min(n, (now - c0) // t + 1)
        if risen:
            complete = risen
            last_rise = c0 + (risen - 1) * t
            if now - last_rise < lat:
                complete -= 1
            self._emit_block(0, complete)
            if complete < risen:
                self._emit(last_rise, max(now - last_rise, 1), 1)
            self._count(risen - self.b_counted, self.b_entry.dir_level)
        self.block_isrs_done += self._block_isrs_by(now)
        self._leave_batch()

    def _batch_end(self) -> None:
        """The interrupt after the block's last pulse: switch to the next entry."""
        ev = self.event  # (the event running now: free for the next interrupt's)
        self.event = None
        self.m.stolen_ticks += self.cost
        e = self.b_entry
        n, t, c0 = self.b_n, self.b_t, self.b_c0
        last_c = c0 + (n - 1) * t
        now = self.m.now
        lat = self.lat
        # entered now (contention: at or after its request): the pin falls lat later
        fall = now + lat if self.contention else now
        if fall - last_c == lat and not self.contention:  # on time: all n pulses alike
            self._emit(c0, lat, n, t)
        elif self.contention:  # pulses whose interrupt waited are longer
            # (found only where someone watches the pins' edges: their timing does not
            # depend on it, and it costs a look at every block)
            waits = self._block_delays(0, n - 1) if self.pins.sinks else []
            if fall - last_c > lat:  # the last one stays high until its interrupt clears it
                waits.append((n - 1, fall - last_c - lat))
            if self._made_plain:
                self.pulses += n
            else:
                self._made(n)
            if self.detached:
                pass
            elif waits:
                self.pins.pulses_waiting(self.step_pin, c0, t, n, lat, waits)
            else:
                self.pins.pulses(self.step_pin, c0, t, n, lat)
        else:  # held back: the last pulse stays high until the interrupt runs
            if n > 1:
                self._emit(c0, lat, n - 1, t)
            self._emit(last_c, now - last_c, 1)
        if self.pulse_counter is not None:
            self._count(n - self.b_counted, e.dir_level)
        self.block_isrs_done += n - 1
        self.batch = False  # (_leave_batch, written out: this runs for every block)
        self.entry_req = -1
        m = self.m
        if m.batch_channel is self:
            m.batch_channel = None
        e.steps = 1
        if ev is not None:
            self._spare = ev
        self._isr(last_c, fall)

    def _block_isrs_by(self, t: int) -> int:
        """Step interrupts of the running block that ran by tick ``t`` (interrupt j runs
        at ``b_c0 + lat + j * b_t``; its last one runs as an event of its own)."""
        first = self.b_c0 + self.lat
        if t < first:
            return 0
        k = (t - first) // self.b_t + 1
        return k if k < self.b_n else self.b_n - 1

    def block_isrs_until(self, t: int) -> int:
        """Step interrupts of blocks that ran by tick ``t``, since the start (``t`` not
        before the last event: the running block is the one at ``t``)."""
        if self.batch:
            return self.block_isrs_done + self._block_isrs_by(t)
        return self.block_isrs_done

    def _single_isr(self) -> None:
        ev = self.event  # the event running now (the channel's only one)
        self.event = None
        m = self.m
        m.stolen_ticks += self.cost
        c = self.pending_compare
        now = m.now  # entered now (at or after the compare)
        contention = self.contention
        if contention:  # entered now: the pin falls lat later
            if now > c:
                if now != m.irq_blocked_until + m.timing.sei_ticks:  # (m.blocked_end)
                    # held behind a routine: after its reti, one instruction
                    now += self.lat + self.after_reti
                else:
                    now += self.lat
            elif now == c and m.loop_polling:  # ... or at the end of the loop's cli
                q = self.q
                now += self.lat + m.loop_hold(c, q.entries[q.read_idx % q.queue_len].ticks
                                              or 1, self.isr_ticks)
            else:
                now += self.lat
        if self.pending_pulse:
            self.pending_pulse = False
            # (_emit and PinBank.pulses of one pulse, written out: this runs for every single pulse)
            if self._made_plain:
                self.pulses += 1
            else:
                self._made(1)
            if not self.detached:
                pins = self.pins
                pin = self.step_pin
                width = now - c
                # (one by one: four names at once build a tuple and unpack it)
                rise = pins.rise
                fall = pins.fall
                total = pins.high_total
                high_max = pins.high_max
                try:  # (the pin has had a pulse before: its figures are there)
                    r = rise[pin]
                    f = fall[pin]
                    h = total[pin]
                    longest = high_max[pin]
                except KeyError:
                    r, f, h, longest = (rise.get(pin, 0), fall.get(pin, 0), total.get(pin, 0),
                                        high_max.get(pin, 0))
                rise[pin] = r + 1
                fall[pin] = f + 1
                total[pin] = h + width
                if width > longest:
                    high_max[pin] = width
                pins.level[pin] = 0
                if pins.sinks:
                    times = [c, now]
                    for sink in pins.sinks:
                        sink.edges(pin, times, b"\x01\x00")
            if self.precounted:
                self.precounted -= 1
            elif self.pulse_counter is not None:
                q = self.q
                if q.read_idx != q.next_write_idx:
                    self.pulse_counter.count(1, q.entries[q.read_idx % q.queue_len].dir_level)
        if ev is not None and contention and self._isr_plain:
            # (_isr's common case beside another channel's block of pulses, written out:
            # the entry goes on with one more single pulse - its event is this one again)
            q = self.q
            rp = q.read_idx
            if rp != q.next_write_idx:
                e = q.entries[rp % q.queue_len]
                steps = e.steps
                compare = c + e.ticks
                if steps > 1 and compare > now + self.ocr:
                    if steps == 2:
                        cost = self.isr_next_ticks
                    else:
                        bc = m.batch_channel
                        # (None or this one: a block of pulses, _isr programs it)
                        cost = 0 if bc is None or bc is self else self.isr_ticks
                    if cost:
                        e.steps = steps - 1
                        self.mode_one = True
                        if self.entry_listeners and e is not self._noted:
                            self._note_entry(ENTRY_RESTART if self.no_more else ENTRY_NEXT, e)
                        self.pending_compare = compare
                        self.pending_pulse = True
                        self.cost = cost
                        # (compare > now >= m.now here)
                        ev.time = compare  # (its owner: this channel, _event)
                        ev.isr = True
                        ev.enter = cost
                        self.event = ev
                        seq = m.seq + 1
                        m.seq = seq
                        sinks = self.pins.sinks
                        if (compare <= m.run_limit and not self.precounted
                                and self.pulse_counter is None and self._made_plain
                                and not self.detached
                                and (not sinks or (len(sinks) == 1
                                                   and type(sinks[0]) is EdgeRecorder))):
                            self._go_on(ev, e, compare, cost)
                            return
                        heappush(m.events, (compare, self.prio, seq, ev))
                        return
        if ev is not None:
            self._spare = ev  # (run: free for the next interrupt's event)
        self._isr(c, now)

    def _go_on(self, ev: Event, e: QueueEntry, compare: int, cost: int) -> None:
        """The single pulses of entry ``e`` (the running one) from the request at
        ``compare`` on (its event ``ev``, set but not pushed), inside
        :meth:`Machine.run_until`, nobody counting pulses or watching the pins' edges
        but an :class:`EdgeRecorder` (it keeps each pin's edges in order, however they
        come in: they are handed on when the run ends):
        while the next request is the next event run_until would run and the CPU is
        free for it at once, its interrupt runs here - run_until's work between two
        events and :meth:`_single_isr`'s for the pulse, written out, the pin's figures
        kept until the run ends.  Then the event is pushed, or the entry's last pulse
        goes on as _single_isr's does (:meth:`_isr`).  (A channel beside another one's
        block of pulses makes every pulse an event: this is where that costs.)"""
        m = self.m
        heap = m.events
        act = m.run_activity
        limit = m.run_limit
        if ((act is not None and m.activity != act)  # run_until stops before it
                or compare > limit or (heap and heap[0][0] <= compare)):
            # (... or the loop below would stop at its first check: nothing to set up)
            heappush(heap, (compare, self.prio, m.seq, ev))
            return
        lat, ocr, ticks = self.lat, self.ocr, e.ticks
        isr_ticks, isr_next = self.isr_ticks, self.isr_next_ticks
        loads = m.uart.loads  # (changed in place only)
        uart_window = m._uart_window  # noqa: SLF001
        ms_first, ms_phase = m._millis_first, m._millis_phase  # noqa: SLF001
        ms_ov, ms_window = m.timing.millis_overflow_ticks, m._ms_window  # noqa: SLF001
        starts, ends = m.isr_starts, m.isr_ends  # (likewise)
        polling = m.loop_polling
        bc = m.batch_channel
        other = bc is not None and bc is not self
        block = other and bc.batch  # type: ignore[union-attr]
        if block:
            c0 = bc.b_c0  # type: ignore[union-attr]
            period = bc.b_t  # type: ignore[union-attr]
            bn2 = bc.b_n - 2  # type: ignore[union-attr]
            bcost = bc.isr_ticks  # type: ignore[union-attr]
        pins = self.pins
        pin = self.step_pin
        made = 0
        high = 0
        longest = pins.high_max.get(pin, 0)
        edges: list[int] | None = [] if pins.sinks else None  # (for the EdgeRecorder)
        while True:
            # the request at ``compare``: the next event, entered at once?
            if compare > limit or (heap and heap[0][0] <= compare):
                break
            if not (compare >= m._quiet_from or m._none_holds(compare)):  # noqa: SLF001
                break
            if loads and compare < loads[-1] + uart_window:
                break
            if compare >= ms_first and (compare - ms_phase) % ms_ov < ms_window:
                break
            if block and compare >= c0:  # (block_isr_running_at's quick answers first)
                j = (compare - c0) // period
                if j > bn2:
                    j = bn2
                cb = c0 + j * period
                if not (j < 0 or compare - cb >= bcost + LATE_ENTRY
                        or (cb == bc.entry_req  # type: ignore[union-attr]
                            and compare >= bc.entry_tick + bcost  # type: ignore[union-attr]
                            and (not j or compare - cb + period >= bcost + LATE_ENTRY))):
                    end = bc.block_isr_running_at(compare)  # type: ignore[union-attr]
                    if end is not None and end > compare:
                        break
            # run_until between the two events: the routine that ran holds the CPU
            stolen = m.stolen_ticks
            mark = m.stolen_mark
            if stolen != mark:
                busy = m.busy_until
                t0 = m.now
                m.busy_until = (busy if busy > t0 else t0) + stolen - mark
            m.now = compare
            if len(starts) > 4096:
                m._forget_isrs()  # noqa: SLF001
            end = compare + cost
            starts.append(compare)
            ends.append(end)
            if end > m._quiet_from:  # noqa: SLF001
                m._quiet_from = end  # noqa: SLF001
            m.events_run += 1
            m.stolen_mark = stolen
            # the interrupt, entered at its request: the pin falls lat later
            m.stolen_ticks = stolen + cost
            c = compare
            now = c + lat
            if polling:  # ... or at the end of the loop's cli
                now += m.loop_hold(c, ticks or 1, isr_ticks)
            made += 1
            if edges is not None:
                edges += (c, now)
            width = now - c
            high += width
            if width > longest:
                longest = width
            steps = e.steps
            compare = c + ticks
            if steps > 1 and compare > now + ocr:
                # (beside no other block: the next pulses make a block, _isr does it)
                cost = isr_next if steps == 2 else isr_ticks if other else 0
                if cost:
                    e.steps = steps - 1
                    self.pending_compare = compare
                    self.cost = cost
                    ev.time = compare
                    ev.isr = True
                    ev.enter = cost
                    m.seq += 1
                    continue
            # the entry's last pulse, or its next compare is missed: as _single_isr
            self._made_pulses(made, high, longest, edges)
            self.pending_pulse = False
            self.event = None
            self._spare = ev
            self._isr(c, now)
            return
        self._made_pulses(made, high, longest, edges)
        heappush(heap, (compare, self.prio, m.seq, ev))

    def _made_pulses(self, n: int, high: int, longest: int, edges: list[int] | None) -> None:
        """``n`` single pulses made by :meth:`_go_on`, ``high`` ticks high in all, the
        longest (of the pin's) ``longest``: the pin's figures (PinBank.pulses), and
        their ``edges`` (rise, fall, ...) for the pins' one sink, an EdgeRecorder."""
        if not n:
            return
        if edges is not None:
            self.pins.sinks[0].edges(self.step_pin, edges, b"\x01\x00" * n)
        self.pulses += n
        pins = self.pins
        pin = self.step_pin
        rise, fall, total = pins.rise, pins.fall, pins.high_total
        rise[pin] = rise.get(pin, 0) + n
        fall[pin] = fall.get(pin, 0) + n
        total[pin] = total.get(pin, 0) + high
        if longest > pins.high_max.get(pin, 0):
            pins.high_max[pin] = longest
        pins.level[pin] = 0

    def _isr(self, c: int, now: int) -> None:
        """FastAccelStepper's compare ISR, for the compare at ``c`` running at ``now``."""
        q = self.q
        rp, wp = q.read_idx, q.next_write_idx
        if rp == wp:
            self.running = False
            self.m.activity += 1
            self.no_more = False
            self.mode_one = False
            if self.on_idle is not None:
                self.on_idle()
            return
        e = q.entries[rp % q.queue_len]
        ticks = e.ticks
        was_dry = self.no_more
        steps = e.steps
        if steps > 1:
            # the entry goes on (_program and _schedule_single written out for a single
            # pulse: this runs for every pulse of a channel beside a block of pulses)
            steps -= 1
            e.steps = steps
            self.mode_one = True
            if self.entry_listeners and e is not self._noted:
                self._note_entry(ENTRY_RESTART if was_dry else ENTRY_NEXT, e)
            compare = c + ticks
            if compare <= now + self.ocr:
                compare = self._next_compare(compare, now)
            m = self.m
            contention = self.contention
            if steps > 1:
                if not contention:
                    self._program(compare, e)  # a block of pulses
                    return
                bc = m.batch_channel
                if bc is None or bc is self:
                    self._program(compare, e)
                    return
                cost = self.isr_ticks
            else:
                cost = self.isr_next_ticks
            self.pending_compare = compare
            self.pending_pulse = True
            self.cost = cost
            if contention:
                if compare < m.now:
                    compare = m.now
                ev = self._event(compare, self._single_isr_fn, cost)
            else:
                compare += self.lat
                if compare < m.now:
                    compare = m.now
                ev = Event(compare, self.prio, self._single_isr_fn, True, 0, None)
            self.event = ev
            m.seq += 1
            heappush(m.events, (compare, self.prio, m.seq, ev))
            return
        # the entry's last pulse (or a pause): take up the next entry
        if self.no_more:
            self.no_more = False
            if e.steps != 0:
                ticks = RESTART_TICKS
        else:
            rp = (rp + 1) & 0xFF
            q.read_idx = rp
            if rp == wp:
                self.no_more = True
                self.dry += 1
                self.mode_one = False
                self._arm_single(c + ticks, now, e)
                return
            e = q.entries[rp % q.queue_len]
        if e.toggle_dir:
            self._toggle_dir(now)
        if e.steps and self.entry_guard is not None and self.entry_guard(e):
            self._halt()
            return
        self.mode_one = e.steps != 0
        if self.entry_listeners and e is not self._noted:
            self._note_entry(ENTRY_RESTART if was_dry else ENTRY_NEXT, e)
        compare = c + ticks  # (_arm, written out: this runs once per queue entry)
        if compare <= now + self.ocr_next:
            compare = self._next_compare(compare, now, self.ocr_next)
        steps = e.steps
        if steps < 2:
            if self.contention:  # (_program's single pulse, written out: every entry)
                self.pending_compare = compare
                self.pending_pulse = self.mode_one
                self._schedule_single(compare)
                return
            self._program(compare, e)
            return
        if not self.contention:
            self._program(compare, e)
            return
        m = self.m
        bc = m.batch_channel
        if bc is not None and bc is not self:
            self.pending_compare = compare  # (_program's single pulse, written out)
            self.pending_pulse = True
            self._schedule_single(compare)
            return
        # (_program's block of pulses where interrupts contend, written out: this runs
        # for every block)
        self.batch = True
        self.b_entry = e
        self.b_c0 = compare
        self.b_t = ticks = e.ticks
        self.b_n = steps
        self.b_counted = 0
        last = compare + (steps - 1) * ticks
        m.batch_channel = self
        cost = self.cost = self.isr_next_ticks  # the last pulse's: the next entry
        if last < m.now:
            last = m.now
        bev = self._spare  # (_event, written out: this runs for every block of pulses)
        if bev is None:
            bev = Event(last, self.prio, self._batch_end_fn, cost > 0, cost, self)
        else:
            self._spare = None
            bev.time = last
            bev.fn = self._batch_end_fn
            bev.isr = cost > 0
            bev.enter = cost
            bev.owner = self
        self.event = bev
        m.seq += 1
        heappush(m.events, (last, self.prio, m.seq, bev))

    def _event(self, time: int, fn: Callable[[], None], cost: int) -> Event:
        """This channel's next interrupt event: the running interrupt's, reused when it
        is spare (no new object on the per-pulse path), else a new one."""
        ev = self._spare
        if ev is None:
            return Event(time, self.prio, fn, cost > 0, cost, self)
        self._spare = None
        ev.time = time
        ev.fn = fn
        ev.isr = cost > 0
        ev.enter = cost
        ev.owner = self
        return ev

    def _note_entry(self, kind: int, e: QueueEntry) -> None:
        self._noted = e
        for fn in self.entry_listeners:
            fn(kind, self.pulses, e.ticks, e.total_steps)

    def deliver_until(self, now: int) -> None:
        """Report the complete pulses of the running block up to ``now`` to the pins
        (a trace that ends wants them before the block does); timing is unchanged."""
        if not self.batch or now < self.b_c0 + self.lat:
            return
        c0, t, n = self.b_c0, self.b_t, self.b_n
        done = min(n - 1, (now - c0 - self.lat) // t + 1)  # the last stays for _batch_end
        if done <= 0:
            return
        self._emit_block(0, done)
        if done > self.b_counted:
            self._count(done - self.b_counted, self.b_entry.dir_level)
            self.b_counted = 0
        else:
            self.b_counted -= done
        self.block_isrs_done += done
        self.b_c0 = c0 + done * t
        self.b_n = n - done
        self.b_entry.steps = self.b_n  # as sync() keeps it: steps not yet done

    def undelivered_from(self) -> int | None:
        """Earliest tick of a step edge that was made (or is due) but is not yet reported
        to the pin sinks: pulses of a block are reported when the block ends."""
        if self.batch:
            return self.b_c0
        if self.pending_pulse:
            return self.pending_compare
        return None

    def _next_compare(self, compare: int, now: int, ocr: int | None = None) -> int:
        """The tick at which the compare written by the interrupt that cleared the pin at
        ``now`` matches: it writes it ``ocr`` ticks later (default: the channel's
        ``ocr``); a value the timer has passed by then matches only after the timer
        wraps."""
        written = now + (self.ocr if ocr is None else ocr)
        if compare <= written:
            if self.wrap:  # the timer matches the passed value only after it wraps
                self.missed_compares += 1
                compare += self.wrap * ((written - compare) // self.wrap + 1)
            else:  # no wrap modelled: it matches at once, when the interrupt writes it
                compare = now
        return compare

    def _arm(self, compare: int, now: int, e: QueueEntry) -> None:
        self._program(self._next_compare(compare, now), e)

    def _arm_single(self, compare: int, now: int, e: QueueEntry) -> None:
        compare = self._next_compare(compare, now)
        self.pending_compare = compare
        self.pending_pulse = False
        self._schedule_single(compare)

    def _on_block(self, start: int, end: int) -> None:
        """Interrupts are blocked from ``start`` (now) to ``end``: split a running block."""
        if not self.batch:
            return
        c0, t, n, lat = self.b_c0, self.b_t, self.b_n, self.lat
        # interrupts requested before the block entered before it (contention), or
        # (without) those due before it ran
        off = 1 if self.contention else lat
        last_isr = c0 + (n - 1) * t + off
        if last_isr < start:
            return
        done = 0 if start < c0 + off else min(n - 1, (start - c0 - off) // t + 1)
        if done >= n - 1:
            return  # only the switching interrupt is left; it is simply held back
        self.m.cancel(self.event)
        e = self.b_entry
        self._emit_block(0, done)
        if done > self.b_counted:
            self._count(done - self.b_counted, e.dir_level)
        self.precounted = max(0, self.b_counted - done)
        self.block_isrs_done += done
        self._leave_batch()
        e.steps = n - done
        compare = c0 + done * t
        self.pending_compare = compare
        self.pending_pulse = True
        self._schedule_single(compare)


def flush_fills(m: Machine) -> None:
    """Charge the fixed work of the fills that ran so far in this task
    (``fill_charges_after_writes``)."""
    for ch in m.fills_done:
        m.task_offset += ch.fill_charge
        ch.fill_charge = 0
    m.fills_done.clear()
