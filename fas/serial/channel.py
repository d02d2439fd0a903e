"""The host's mirror of one device queue.

The library writes entries into its :class:`~fas.queue.StepperQueue` as on any
backend; this channel sends each one to the device and follows the device's
progress reports.  The mirror is *conservative*: an entry counts as executed only
once the device has said so, and a started queue counts as running until a report
that already reflects the start says it stopped.  So the host never believes the
device queue emptier or idler than it is - the free slots it sees are the device's
flow control, and a direction pin is never set while steps are still pending.

Stops do not wait for a deep queue (docs/serial-protocol.md, section 10):

* a force stop (StepperDemo's ``X``) goes out twice: as a :class:`Halt` that
  overtakes everything queued (repeated until the device confirms it) and as the
  sequenced :class:`ForceStop` that keeps the queue's order;
* a stop with deceleration (``S``) or a ``force_stop`` *cuts* the queue: the entries
  the device cannot have begun when the :class:`Truncate` arrives are dropped here
  and there, and the ramp is planned again from the cut.  A cut that arrives too
  late is refused by the device; the dropped entries then come back (they are still
  on the device) and the stop is planned from the end of the queue.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ..channel import PulseCounter, QueueChannel
from ..queue import i32
from .protocol import (
    P_CUT_REFUSED,
    P_HALTED,
    P_HAS_PCNT,
    Config,
    Detach,
    DirPin,
    Entry,
    ForceStop,
    PcntAttach,
    PcntClear,
    Progress,
    SetEndPos,
    Status,
    Truncate,
)

if TYPE_CHECKING:  # pragma: no cover
    from ..queue import StepperQueue
    from .backend import SerialBackend


class HaltState:
    """A Halt on its way: repeated until the device confirms it."""

    __slots__ = ("mid", "next_ns", "sent_ns", "stop_id")

    def __init__(self, stop_id: int, mid: int, sent_ns: int, next_ns: int) -> None:
        self.stop_id = stop_id
        self.mid = mid  # the ForceStop that follows it in sequence
        self.sent_ns = sent_ns
        self.next_ns = next_ns


class CutState:
    """A cut the device has not confirmed yet, with what it dropped (to restore)."""

    __slots__ = ("end", "entries", "index", "mid", "old_write", "on_refused", "shift")

    def __init__(self, index: int, old_write: int, entries: list[tuple[object, ...]],
                 end: tuple[int, bool, bool], on_refused: Callable[[], None]) -> None:
        self.index = index
        self.old_write = old_write
        self.entries = entries
        self.end = end
        self.on_refused = on_refused
        self.mid = 0
        self.shift = 0  # positions renamed meanwhile (set_current_position)


_ENTRY_FIELDS = ("steps", "total_steps", "ticks", "count_up", "toggle_dir", "dir_level",
                 "end_pos")


class SerialChannel(QueueChannel):
    supports_cut = True

    def __init__(self, backend: SerialBackend, queue: StepperQueue) -> None:
        self.b = backend
        self.q = queue
        self.index = queue.index
        self.step_pin = queue.step_pin
        self.dev_running = False  # as last reported
        self.pending_start_mid = 0  # a start the device has not reported on yet
        self.epoch_mid = 0  # reports from before this message (a stop) are stale
        self.sent_dir_pin = queue.dir_pin
        self.dev_end_pos: int | None = queue.queue_end_pos  # the device's queue end
        self.detached = False
        self.pulse_counter: PulseCounter | None = None
        self.pcnt_epoch_mid = 0
        self.bad_reports = 0
        # the last Status message (position, pulses, underruns)
        self.last_status: Status | None = None
        self.report_ns = backend.clock.now_ns()  # when the last report was taken
        self.halt: HaltState | None = None
        self.cut_state: CutState | None = None
        self._stop_id = 0
        self.cuts = 0
        self.cuts_refused = 0
        # timing of the device queue as the host planned it (fas.gear): the host tick at
        # which the queued entries end, while the device runs them without a gap
        self.start_ticks = backend.profile.queue_start_ticks
        self.t_end: int | None = None
        self.t_begin: int | None = None  # planned begin of a start not yet confirmed
        self.cuts_held = False  # a follower derives its steps from this queue: no cuts
        self.configure()

    # ------------------------------------------------------------ session
    def configure(self) -> None:
        """Tell the device this queue, as it stands (new channel or new session)."""
        q = self.q
        self.pending_start_mid = 0
        self.dev_running = False
        self.sent_dir_pin = q.dir_pin
        self.dev_end_pos = q.queue_end_pos
        self.halt = None
        self.cut_state = None
        mid = self.b.send(Config(self.index, self.step_pin, q.dir_pin & 0xFF,
                                 q.next_write_idx, q.queue_end_pos))
        self.epoch_mid = mid
        if self.detached:
            self.b.send(Detach(self.index, 1))
        if self.pulse_counter is not None:
            c = self.pulse_counter
            self.pcnt_epoch_mid = self.b.send(PcntAttach(self.index, c.low, c.high,
                                                         int(c.dir_high_counts_up), c.value))

    def connection_lost(self) -> None:
        self.pending_start_mid = 0
        self.dev_running = False
        self.t_end = None
        self.halt = None
        self.cut_state = None

    # ---------------------------------------------------------- interface
    def is_running(self) -> bool:
        return self.dev_running or self.pending_start_mid != 0

    def start(self) -> None:
        q = self.q
        if self.is_running() or q.read_idx == q.next_write_idx or not self.b.connected:
            return
        self.pending_start_mid = self.b.send_start(self.index)
        self._plan_from(self.b.last_start_at)

    # --- queue timing: a Start at host tick `at` begins the first entry at
    # `at + start_ticks`, the entries follow each other without a gap (section 18)
    def _plan_from(self, at: int) -> None:
        q = self.q
        t = at + self.start_ticks
        self.t_begin = t  # until the device's Started says when it really began
        rp = q.read_idx
        while rp != q.next_write_idx:
            e = q.entries[rp % q.queue_len]
            t += e.ticks * max(e.total_steps, 1)
            rp = (rp + 1) & 0xFF
        self.t_end = t

    def started(self, tick: int) -> None:
        """The device's Started: the queue's first entry began at host tick ``tick``."""
        if self.t_begin is not None and self.t_end is not None:
            self.t_end += tick - self.t_begin  # a late start shifts the whole timeline
            self.t_begin = None
        else:  # it restarted by itself after running dry: the timeline is lost
            self.t_end = None

    def end_tick(self) -> int | None:
        q = self.q
        if self.t_end is None or not self.is_running() or q.read_idx == q.next_write_idx:
            return None  # (a start not yet confirmed counts as planned: see started())
        if self.t_end <= self.b.now():
            return None  # by now the device has run dry: the timing is lost
        return self.t_end

    def earliest_start_tick(self) -> int | None:
        return self.b.earliest_start() + self.start_ticks

    def start_at(self, tick: int) -> int | None:
        q = self.q
        if self.is_running() or q.read_idx == q.next_write_idx or not self.b.connected:
            return None
        at = max(tick - self.start_ticks, self.b.earliest_start())
        self.pending_start_mid = self.b.send_start(self.index, at)
        self._plan_from(at)
        return at + self.start_ticks

    def hold_cuts(self, hold: bool) -> None:
        self.cuts_held = hold

    def halted(self) -> None:
        """The device stopped this queue at a limit (LimitHit): nothing runs there
        until the library force-stops the stepper (its ForceStop lets entries in)."""
        self.dev_running = False
        self.pending_start_mid = 0
        self.t_end = None

    def force_stop(self) -> None:
        was_running = self.is_running()
        self.pending_start_mid = 0
        self.dev_running = False
        self.cut_state = None
        self.t_end = None
        self.t_begin = None
        if self.b.connected:
            q = self.q
            moving = was_running or q.read_idx != q.next_write_idx
            self._stop_id = self._stop_id % 255 + 1  # never 0: a fresh queue's id
            now = self.b.clock.now_ns()
            if moving:
                self.b.send_halt(self.index, self._stop_id)  # overtakes the queue ...
            self.epoch_mid = self.b.send(ForceStop(self.index, q.next_write_idx,
                                                   self._stop_id))  # ... keeps its order
            if moving:
                self.halt = HaltState(self._stop_id, self.epoch_mid, now,
                                      now + self.b.repeat_ns())
        # the device calls its stop point by the pulses made; the host names it next
        self.dev_end_pos = None

    def resend_halt(self, now_ns: int) -> None:
        h = self.halt
        if h is None:
            return
        if self.b.link is None or self.b.link.acked_mid >= h.mid:
            self.halt = None  # the ForceStop is through: the queue is stopped anyway
            return
        self.b.send_halt(self.index, h.stop_id)
        h.next_ns = now_ns + self.b.repeat_ns()

    def sync(self) -> None:
        q = self.q
        if (q.read_idx == q.next_write_idx and q.queue_end_pos != self.dev_end_pos
                and self.b.connected):
            self.b.send(SetEndPos(self.index, q.queue_end_pos))
            self.dev_end_pos = q.queue_end_pos

    def ready_for_commands(self) -> bool:
        return self.b.connected

    def entry_added(self) -> None:
        q = self.q
        if not self.b.connected:
            return
        w = (q.next_write_idx - 1) & 0xFF
        e = q.entries[w % q.queue_len]
        if q.dir_pin != self.sent_dir_pin:
            self.b.send(DirPin(self.index, q.dir_pin & 0xFF))
            self.sent_dir_pin = q.dir_pin
        before = i32(e.end_pos - e.total_steps if e.count_up else e.end_pos + e.total_steps)
        if before != self.dev_end_pos:
            self.b.send(SetEndPos(self.index, before))
        running = self.is_running()
        self.b.send(Entry(self.index, w, e.total_steps, e.ticks, e.toggle_dir, e.dir_level,
                          e.count_up, running))
        self.dev_end_pos = e.end_pos
        if self.t_end is not None:
            if running and self.t_end > self.b.now():
                self.t_end += e.ticks * max(e.total_steps, 1)
            else:
                self.t_end = None  # a continuation after the device ran dry: untimed

    def positions_shifted(self, delta: int) -> None:
        if self.cut_state is not None:
            self.cut_state.shift = i32(self.cut_state.shift + delta)
        if self.b.connected:
            self.b.send(SetEndPos(self.index, self.q.queue_end_pos))
            self.dev_end_pos = self.q.queue_end_pos

    # --------------------------------------------------------------- cuts
    @property
    def cut_pending(self) -> bool:
        return self.cut_state is not None

    def cut_index(self) -> int | None:
        """The first entry the device will not have begun when a Truncate sent now
        arrives: the mirror's entries from the reported read point on, summed up to
        the backend's cut margin."""
        if (not self.b.connected or self.cut_state is not None or self.halt is not None
                or not self.is_running() or self.cuts_held):
            return None
        q = self.q
        rp, wp = q.read_idx, q.next_write_idx
        if rp == wp:
            return None
        margin = self.b.cut_margin_ticks(self.report_ns)
        n = q.queue_len
        e = q.entries[rp % n]
        ahead = e.ticks * max(e.steps, 1)  # what is left of the entry being executed
        i = (rp + 1) & 0xFF
        while i != wp:
            if ahead >= margin:
                return i
            e = q.entries[i % n]
            ahead += e.ticks * max(e.total_steps, 1)
            i = (i + 1) & 0xFF
        return None

    def cut(self, index: int, on_refused: Callable[[], None]) -> None:
        q = self.q
        n = q.queue_len
        w = q.next_write_idx
        saved = []
        i = index
        while i != w:
            e = q.entries[i % n]
            saved.append(tuple(getattr(e, f) for f in _ENTRY_FIELDS))
            i = (i + 1) & 0xFF
        state = CutState(index, w, saved,
                         (q.queue_end_pos, q.queue_end_count_up, q.queue_end_dir), on_refused)
        in_step = self.dev_end_pos == q.queue_end_pos
        self.t_end = None  # the timeline is no longer what was planned
        q.truncate(index)
        state.mid = self.b.send(Truncate(self.index, index))
        self.dev_end_pos = q.queue_end_pos if in_step else None
        self.cut_state = state
        self.cuts += 1

    def _cut_refused(self, c: CutState) -> None:
        """The device ran past the cut: it executes the queue as it was - so does the
        mirror again; a cut at the old end clears the device's refusal."""
        q = self.q
        n = q.queue_len
        for k, values in enumerate(c.entries):
            e = q.entries[(c.index + k) % n]
            for f, v in zip(_ENTRY_FIELDS, values, strict=True):
                setattr(e, f, v)
            if c.shift:
                e.end_pos = i32(e.end_pos + c.shift)
        q.next_write_idx = c.old_write
        q.queue_end_pos, q.queue_end_count_up, q.queue_end_dir = c.end
        q.queue_end_pos = i32(q.queue_end_pos + c.shift)
        self.cut_state = None
        self.cuts_refused += 1
        self.b.send(Truncate(self.index, c.old_write))
        self.b.send(SetEndPos(self.index, q.queue_end_pos))
        self.dev_end_pos = q.queue_end_pos
        c.on_refused()

    # --------------------------------------------------------- extras
    def set_detached(self, detached: bool) -> None:
        self.detached = detached
        if self.b.connected:
            self.b.send(Detach(self.index, int(detached)))

    def attach_counter(self, counter: PulseCounter) -> None:
        self.pulse_counter = counter
        counter.on_clear = self._counter_cleared  # the device's counter must be cleared, too
        if self.b.connected:
            self.pcnt_epoch_mid = self.b.send(PcntAttach(
                self.index, counter.low, counter.high, int(counter.dir_high_counts_up),
                counter.value))

    def _counter_cleared(self) -> None:
        if self.b.connected:
            self.pcnt_epoch_mid = self.b.send(PcntClear(self.index))

    # --------------------------------------------------------- reports
    def apply(self, rep: Progress, acked_mid: int) -> None:
        """A progress report that reflects every message up to ``acked_mid``."""
        if self.halt is not None and rep.flags & P_HALTED:
            self.halt = None  # the Halt arrived: no need to repeat it
        if acked_mid < self.epoch_mid:
            return  # from before a stop or a new configuration
        q = self.q
        c = self.cut_state
        if c is not None:
            if acked_mid < c.mid:
                # from before the cut: only entries ahead of the cut are the same here
                if ((rep.index - q.read_idx) & 0xFF) >= ((c.index - q.read_idx) & 0xFF):
                    return
            elif rep.flags & P_CUT_REFUSED:
                self._cut_refused(c)
            else:
                self.cut_state = None  # the cut is done
        self.report_ns = self.b.clock.now_ns()
        fill = (q.next_write_idx - q.read_idx) & 0xFF
        advance = (rep.index - q.read_idx) & 0xFF
        if advance > fill:
            self.bad_reports += 1
            return
        q.read_idx = rep.index
        if rep.has_entry and rep.index != q.next_write_idx:
            e = q.entries[rep.index % q.queue_len]
            if rep.steps_left <= e.total_steps:
                e.steps = rep.steps_left
        self.dev_running = rep.running
        if self.pending_start_mid and acked_mid >= self.pending_start_mid:
            self.pending_start_mid = 0
        if not self.is_running():
            self.t_end = None
        if (self.pulse_counter is not None and rep.flags & P_HAS_PCNT
                and acked_mid >= self.pcnt_epoch_mid):
            self.pulse_counter.value = rep.pcnt
