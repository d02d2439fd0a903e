"""The device's queues as the protocol sees them (``firmware/device.c``).

Configuration, entries, starts, cuts, stops and the pins of the queues; each queue's
stop state (docs/serial-protocol.md, section 10); what the queues report (Progress,
Status).  The entries are executed by the step generator (:mod:`.stepgen`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

from ..arch import Profile
from ..channel import PulseCounter
from ..queue import StepperQueue, i32
from ..serial.protocol import (
    P_CUT_REFUSED,
    P_DETACHED,
    P_HALTED,
    P_HAS_ENTRY,
    P_HAS_PCNT,
    P_RUNNING,
    P_START_PENDING,
    Config,
    Detach,
    DirPin,
    Entry,
    ForceStop,
    Message,
    PcntAttach,
    PcntClear,
    Pin,
    Progress,
    SetEndPos,
    Start,
    Started,
    Status,
    Truncate,
    tick_diff32,
)
from ..sim.machine import PRIO_PLAIN, Event
from .board import Board
from .stepgen import DeviceChannel

Handler = Callable[[Any], None]  # acts on one message type
ProgressKey = tuple[int, int, int, int]  # flags, read index, steps left, pulse count


class StopState:
    """Per stepper: the stop and cut state of docs/serial-protocol.md, section 10."""

    __slots__ = ("halt_id", "halted", "refused")

    def __init__(self) -> None:
        self.halt_id = 0  # the id of the last Halt acted on or ForceStop processed
        self.halted = False  # a Halt stopped the queue; its ForceStop has not come yet
        self.refused = False  # a Truncate came too late; the next cut clears it

    @property
    def discarding(self) -> bool:
        return self.halted or self.refused


class DeviceQueues:
    """The queues of the device and the sequenced messages that act on them."""

    def __init__(self, board: Board, ring_profile: Profile) -> None:
        self.board = board
        self.ring_profile = ring_profile  # the profile with the device's ring depth
        self.queues: dict[int, StepperQueue] = {}
        self.stops: dict[int, StopState] = {}
        self.stop_ticks: dict[int, int] = {}  # when a stop last ended a queue's motion
        self.start_events: dict[int, Event] = {}  # timed starts waiting
        self.last_progress: dict[int, ProgressKey] = {}  # as last reported
        self.channels: dict[int, DeviceChannel] = {}  # each queue's step generator

    def handlers(self) -> dict[type[Message], Handler]:
        """The sequenced messages acted on here."""
        return {Entry: self.entry, Start: self.start, Pin: self.pin,
                ForceStop: self.force_stop, SetEndPos: self.set_end_pos, Config: self.config,
                DirPin: self.dir_pin, Detach: self.detach, PcntAttach: self.pcnt_attach,
                PcntClear: self.pcnt_clear, Truncate: self.truncate}

    # ------------------------------------------------------------ queues
    def allocate_channel(self, queue: StepperQueue) -> DeviceChannel:
        """The step generator of ``queue`` (StepperQueue calls this while it is built)."""
        ch = DeviceChannel(self.board.machine, queue)
        ch.on_idle = self.queues_idle  # synchronized outputs wait for this (issue 12)
        self.board.sim.channels.append(ch)
        self.channels[queue.index] = ch
        return ch

    def queues_idle(self) -> None:
        """A queue ran dry or was stopped: synchronized outputs may be due (section 16)."""
        self.board.sim.queue_ran_dry()  # the chip's own rule for them

    def find(self, stepper: int) -> StepperQueue | None:
        """The queue of ``stepper`` if it is configured (else counted as rejected)."""
        q = self.queues.get(stepper)
        if q is None:
            self.board.reject()
        return q

    def config(self, m: Config) -> None:
        board = self.board
        if m.stepper >= board.profile.max_steppers:
            board.reject()
            return
        q = self.queues.get(m.stepper)
        if q is not None and q.step_pin != m.step_pin:
            self._stop_queue(m.stepper, q)
            board.sim.channels.remove(self.channels[m.stepper])
            q = None
        if q is None:
            # the chip drives its pins; its channel is the device's step generator
            q = StepperQueue(m.stepper, self.ring_profile, board.sim, m.step_pin,
                             make_channel=self.allocate_channel)
            self.queues[m.stepper] = q
        else:
            self._stop_queue(m.stepper, q)
        self.stops[m.stepper] = StopState()
        ch = self.channels[m.stepper]
        q.dir_pin = m.dir_pin
        ch.pulses = 0
        ch.underruns = 0
        q.read_idx = q.next_write_idx = m.index & 0xFF
        q.queue_end_pos = m.end_pos
        ch.pulse_pos = m.end_pos
        self.last_progress.pop(m.stepper, None)

    def _stop_queue(self, stepper: int, q: StepperQueue) -> None:
        machine = self.board.machine
        ev = self.start_events.pop(stepper, None)
        if ev is not None:
            machine.cancel(ev)
        ch = self.channels[stepper]
        if ch.running or ev is not None:
            self.stop_ticks[stepper] = machine.now
        ch.force_stop()

    def _discarding(self, stepper: int) -> bool:
        """Halted or after a refused cut: this message for ``stepper`` is dropped."""
        if self.stops[stepper].discarding:
            self.board.counters["discarded"] += 1
            return True
        return False

    def reset_stops(self) -> None:
        """A new session: every queue's stop state is cleared."""
        self.stops.clear()
        for idx in self.queues:
            self.stops[idx] = StopState()

    # ---------------------------------------------------------- entries
    def entry(self, m: Entry) -> None:
        board = self.board
        counters = board.counters
        q = self.find(m.stepper)
        if q is None:
            return
        if board.locked:
            counters["rejected"] += 1
            return
        if self._discarding(m.stepper):
            return
        wp = q.next_write_idx
        gap = (m.index - wp) & 0x0F
        if gap >= 8:
            counters["entries_duplicated"] += 1
            return
        if gap:
            counters["entries_lost"] += gap
        if ((wp - q.read_idx) & 0xFF) >= q.queue_len:
            counters["overflows"] += 1
            return
        e = q.entries[wp % q.queue_len]
        e.steps = e.total_steps = m.steps
        e.ticks = m.ticks
        q.durations[wp % q.queue_len] = m.ticks * m.steps if m.steps > 1 else m.ticks
        q.singles[wp % q.queue_len] = 1 if m.steps <= 1 else 0
        e.count_up = m.count_up
        e.toggle_dir = m.toggle_dir
        e.dir_level = m.dir_level
        e.end_pos = i32(q.queue_end_pos + (m.steps if m.count_up else -m.steps))
        q.next_write_idx = (wp + 1) & 0xFF
        q.queue_end_pos = e.end_pos
        q.queue_end_count_up = m.count_up
        q.queue_end_dir = m.dir_level
        q.entries_added += 1
        counters["entries"] += 1
        ch = self.channels[m.stepper]
        if m.cont and not ch.running and m.stepper not in self.start_events:
            # the host meant this to follow a running queue, which already ran dry
            counters["underruns"] += 1
            ch.underruns += 1
            self.start_queue(m.stepper)

    def start(self, m: Start) -> None:
        board = self.board
        machine = board.machine
        delta = tick_diff32(m.at, machine.now & 0xFFFFFFFF)
        for idx in range(8):
            if not m.mask & (1 << idx):
                continue
            q = self.find(idx)
            if q is None:
                continue
            if board.locked:
                board.reject()
                continue
            if self._discarding(idx):
                continue
            old = self.start_events.pop(idx, None)
            if old is not None:
                machine.cancel(old)
            if delta <= 0:
                if delta < 0:
                    board.counters["late_starts"] += 1
                self.start_queue(idx)
            else:
                self.start_events[idx] = machine.schedule(
                    machine.now + delta, partial(self._timed_start, idx), PRIO_PLAIN)

    def _timed_start(self, idx: int) -> None:
        self.start_events.pop(idx, None)
        if idx in self.queues:
            self.start_queue(idx)

    def start_queue(self, idx: int) -> None:
        """Start the step timer on the queue and tell the host when its first entry
        begins (the host plans other queues on that timeline, section 18)."""
        ch = self.channels[idx]
        was = ch.is_running()
        begin = ch.earliest_start_tick()
        ch.start()
        if not was and ch.is_running():
            assert begin is not None
            self.board.send(Started(idx, begin & 0xFFFFFFFF))

    # ------------------------------------------------------------ stops
    def force_stop(self, m: ForceStop) -> None:
        q = self.find(m.stepper)
        if q is None:
            return
        self._stop_queue(m.stepper, q)
        # the position is where the pulses stopped; the host may rename it (SetEndPos)
        q.read_idx = q.next_write_idx = m.index & 0xFF
        q.queue_end_pos = self.channels[m.stepper].pulse_pos
        st = self.stops[m.stepper]
        st.halted = st.refused = False
        st.halt_id = m.stop_id
        self.queues_idle()  # synchronized outputs wait for idle queues (section 16)

    def halt(self, stepper: int, stop_id: int) -> None:
        """Halt (unsequenced, for this session): stop one queue now; drop its motion
        until the ForceStop."""
        st = self.stops[stepper]
        if stop_id == st.halt_id:
            return  # a copy of a Halt already acted on (or whose ForceStop came)
        board = self.board
        q = self.queues[stepper]
        st.halt_id = stop_id
        st.halted = True
        st.refused = False
        board.counters["halts"] += 1
        self.stop_ticks[stepper] = board.machine.now
        self._stop_queue(stepper, q)
        q.read_idx = q.next_write_idx
        q.queue_end_pos = self.channels[stepper].pulse_pos
        self.report(stepper)
        self.queues_idle()

    def halt_all(self) -> None:
        """Stop every queue at once; positions stay exact (where the pulses stopped)."""
        for idx, q in self.queues.items():
            self._stop_queue(idx, q)
            q.read_idx = q.next_write_idx
            q.queue_end_pos = self.channels[idx].pulse_pos

    def stop_at_limit(self, idx: int) -> None:
        """A limit stopped queue ``idx``: no entry is left, it is halted until the
        host's ForceStop (as after a Halt)."""
        q = self.queues[idx]
        ch = self.channels[idx]
        ch.on_halt = None
        self._stop_queue(idx, q)
        q.read_idx = q.next_write_idx
        q.queue_end_pos = ch.pulse_pos
        st = self.stops[idx]
        st.halted = True
        st.refused = False

    def truncate(self, m: Truncate) -> None:
        """Drop the entries from ``m.index`` on, if none of them has begun (a cut)."""
        q = self.find(m.stepper)
        if q is None:
            return
        counters = self.board.counters
        st = self.stops[m.stepper]
        if st.halted:
            counters["discarded"] += 1
            return
        ch = self.channels[m.stepper]
        ch.sync()
        rp, wp = q.read_idx, q.next_write_idx
        fill = (wp - rp) & 0xFF
        d = (m.index - rp) & 0xFF
        if d > fill or (d == 0 and fill and ch.running):
            # too late: the cut point has begun or passed; the queue runs on as it is
            st.refused = True
            counters["cuts_refused"] += 1
            self.report(m.stepper)
            return
        st.refused = False
        if d == fill:
            return  # a cut at the write index drops nothing
        counters["cuts"] += 1
        i = m.index
        while i != wp:
            e = q.entries[i % q.queue_len]
            q.queue_end_pos = i32(q.queue_end_pos - (e.total_steps if e.count_up
                                                     else -e.total_steps))
            i = (i + 1) & 0xFF
        q.next_write_idx = m.index & 0xFF

    def set_end_pos(self, m: SetEndPos) -> None:
        q = self.find(m.stepper)
        if q is None or self._discarding(m.stepper):
            return
        delta = i32(m.pos - q.queue_end_pos)
        if delta:
            q.shift_positions(delta)
            ch = self.channels[m.stepper]
            ch.pulse_pos = i32(ch.pulse_pos + delta)

    # ------------------------------------------------------------- pins
    def pin(self, m: Pin) -> None:
        machine = self.board.machine
        machine.pins.set(m.pin, m.level, machine.now)

    def dir_pin(self, m: DirPin) -> None:
        q = self.find(m.stepper)
        if q is not None:
            q.dir_pin = m.dir_pin

    def detach(self, m: Detach) -> None:
        if self.find(m.stepper) is not None:
            self.channels[m.stepper].detached = bool(m.detached)

    def pcnt_attach(self, m: PcntAttach) -> None:
        if self.find(m.stepper) is not None:
            ch = self.channels[m.stepper]
            ch.sync()
            counter = PulseCounter(m.low, m.high, bool(m.dir_high_counts_up))
            counter.value = m.value
            ch.pulse_counter = counter

    def pcnt_clear(self, m: PcntClear) -> None:
        if self.find(m.stepper) is not None:
            ch = self.channels[m.stepper]
            if ch.pulse_counter is not None:
                ch.sync()
                ch.pulse_counter.clear()

    # ---------------------------------------------------------- reports
    def progress_key(self, idx: int, q: StepperQueue) -> ProgressKey:
        ch = self.channels[idx]
        ch.sync()
        rp = q.read_idx
        flags = 0
        steps = 0
        if rp != q.next_write_idx:
            flags |= P_HAS_ENTRY
            steps = q.entries[rp % q.queue_len].steps
        if ch.running:
            flags |= P_RUNNING
        if idx in self.start_events:
            flags |= P_START_PENDING
        if ch.detached:
            flags |= P_DETACHED
        st = self.stops.get(idx)
        if st is not None:
            if st.halted:
                flags |= P_HALTED
            if st.refused:
                flags |= P_CUT_REFUSED
        pcnt = 0
        if ch.pulse_counter is not None:
            flags |= P_HAS_PCNT
            pcnt = ch.pulse_counter.read()
        return flags, rp, steps, pcnt

    def report(self, idx: int) -> None:
        """Progress of queue ``idx`` in the next frame (a stop or a refused cut)."""
        key = self.progress_key(idx, self.queues[idx])
        self.last_progress[idx] = key
        self.board.send(Progress(idx, *key))

    def report_all(self) -> None:
        """Progress of every queue (the slow refresh: a lost report heals)."""
        send = self.board.send
        for idx, q in self.queues.items():
            key = self.progress_key(idx, q)
            self.last_progress[idx] = key
            send(Progress(idx, *key))

    def report_changed(self, only_changed: bool) -> None:
        """Progress of the queues that changed since their last report (and, unless
        ``only_changed``, of those that move)."""
        send = self.board.send
        for idx, q in self.queues.items():
            key = self.progress_key(idx, q)
            moving = key[0] & (P_RUNNING | P_START_PENDING)
            if key != self.last_progress.get(idx) or (moving and not only_changed):
                self.last_progress[idx] = key
                send(Progress(idx, *key))

    def reporting(self) -> bool:
        """A queue runs, waits for its start or changed since its last report."""
        for idx, q in self.queues.items():
            if self.channels[idx].running or idx in self.start_events:
                return True
            if self.last_progress.get(idx) != self.progress_key(idx, q):
                return True
        return False

    def send_status(self) -> None:
        """Status of every queue, each in a frame of its own."""
        board = self.board
        for idx, q in self.queues.items():
            key = self.progress_key(idx, q)
            self.last_progress[idx] = key
            flags, rp, steps, pcnt = key
            ch = self.channels[idx]
            board.frame_break()
            board.send(Status(idx, flags, rp, steps, q.current_position(),
                              ch.pulses & 0xFFFFFFFF, ch.underruns & 0xFFFF, pcnt))

    # ------------------------------------------------------- inspection
    def running(self) -> bool:
        return any(self.channels[idx].running for idx in self.queues) \
            or bool(self.start_events)
