"""The serial backend: the library on this computer, its queue commands on a device.

:class:`SerialBackend` implements :class:`fas.backend.Backend`.  The engine's ramp
task runs here every ``fill_period_ticks`` of host time; the entries it writes go to
the device through one :class:`~fas.serial.channel.SerialChannel` per stepper and a
:class:`~fas.serial.link.HostLink`.  Host time is counted in device ticks (the rate
the device announces), from the first connection on; a clock offset measured with
round trips converts it to the device's own counter for synchronized starts.

Losing the device (port error, silence, a device reset or watchdog stop) is reported
to ``listeners`` once; every stepper is then force-stopped at its last known
position, time goes on, and :meth:`reconnect` opens a new session.  Reconnected to
the same device (same boot id), the host takes over the positions the device
reports, so the axes keep their coordinates.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from ..arch import SERIAL_QUEUE_MAX, SERIAL_QUEUE_MIN, Profile, get_profile
from ..backend import Backend, PulseCounter
from ..queue import StepperQueue
from ..schedule import TaskSchedule
from .channel import SerialChannel
from .clock import RealClock
from .link import LOSSY, HostLink, LinkStats
from .protocol import (
    D_ESTOP,
    D_SESSION,
    D_WATCHDOG,
    F_INPUTS,
    F_SIM_INPUTS,
    L_CLEAR,
    L_UP,
    MAX_FRAME,
    MAX_PAYLOAD,
    MAX_RX_SLOTS,
    O_ANALOG,
    O_SYNCHRONIZED,
    PROTOCOL_VERSION,
    S_ANALOG,
    W_ANALOG,
    W_DIGITAL,
    W_PULLUP,
    Bye,
    DeviceStatus,
    EmergencyStop,
    Halt,
    Hello,
    Ident,
    Input,
    Limit,
    LimitHit,
    Message,
    OutputCancel,
    OutputPwm,
    OutputSet,
    Pin,
    Progress,
    SetInput,
    Start,
    Started,
    Status,
    StatusRequest,
    SyncReply,
    WatchInput,
    tick_diff32,
)
from .stream import ByteStream, LinkClosed, open_serial

NS_PER_S = 1_000_000_000
MS = 1_000_000
DEFAULT_WAIT_LIMIT_S = 3600
SYNC_SAMPLES = 8
HOST_MARGIN_MS = 50  # planned beyond the link's delays: host stalls (scheduling, GC)
LOSS_TARGET = 0.001  # retransmission rounds allowed for: more are needed this rarely
MAX_ROUNDS = 8
REPORT_BYTES = 17  # a report frame: two Progress messages and a Nak
CUT_BYTES = 48  # a Truncate (3) and a frame of entries after it (up to 40 + 5)


class SerialError(ConnectionError):
    """The device could not be reached or does not fit."""


Listener = Callable[[str, str], None]  # (event, text): "lost", "connected"


class SerialBackend(Backend):
    """Drives a device that speaks docs/serial-protocol.md (see module text)."""

    def __init__(self, port: str | ByteStream, *, baud: int = 115200, clock=None,
                 watchdog_ms: int = 500, report_ms: int | None = None,
                 connect_timeout_ms: int = 3000,
                 start_lead_us: int = 1000, window: int = 16, max_payload: int = MAX_PAYLOAD,
                 sync_interval_ms: int = 1000, link_planning_ms: int | None = None,
                 host_margin_ms: int = HOST_MARGIN_MS,
                 opener: Callable[[str, int], ByteStream] = open_serial) -> None:
        self.clock = clock or RealClock()
        self.opener = opener
        self.port = port if isinstance(port, str) else None
        self.baud = baud
        self.watchdog_ms = watchdog_ms
        # the device's report period: reports of two running queues (17 bytes) take at
        # most a quarter of the line back, and come at least every 2 ms
        self.report_ms = report_ms or max(2, -(-REPORT_BYTES * 10 * 4 * 1000 // baud))
        self.connect_timeout_ns = connect_timeout_ms * MS
        self.start_lead_us = start_lead_us
        self.window = window
        self.max_payload = max_payload
        self.sync_interval_ns = sync_interval_ms * MS
        self.link_planning_ms = link_planning_ms  # None: derived from the link
        self.host_margin_ms = host_margin_ms
        self.planning_extra_ticks = 0
        self.profile: Profile | None = None
        self.link: HostLink | None = None
        self.ident: Ident | None = None
        self.connected = False
        self.lost_reason: str | None = None
        self.listeners: list[Listener] = []
        self.channels: list[SerialChannel] = []
        self._by_index: dict[int, SerialChannel] = {}
        self.pins: dict[int, int] = {}  # levels the host wrote (replayed on reconnect)
        # inputs on the device's pins (issue 13): watched (replayed), last values
        self.input_listeners = []
        self.watches: dict[int, WatchInput] = {}
        self.inputs: dict[int, int] = {}
        self.input_ticks: dict[int, int] = {}  # host tick at which the device read it
        self.limit_listeners = []
        self.limits: dict[tuple[int, bool], Limit] = {}  # limit switches (replayed)
        self.last_start_at = 0  # host tick of the last Start sent
        # user outputs (issue 12): PWM configurations and states, replayed on reconnect
        self._pwm: dict[int, OutputPwm] = {}
        self._outputs: dict[tuple[bool, int], OutputSet] = {}
        self.device_status: DeviceStatus | None = None
        self.statuses: dict[int, Status] = {}
        self._status_seen: set[int] = set()
        self._status_count = 0
        self._ident_wanted: int | None = None
        self._nonce = 0
        self._boot_id: int | None = None
        self._estopping = False
        self._problem: str | None = None
        self.sessions = 0
        self._closed_stats = LinkStats()
        # host clock: ticks at the device's rate, counted from the first connection
        self.clock_hz = 16_000_000
        self._tick_base = 0
        self._ns_base = self.clock.now_ns()
        self._offset32 = 0
        self._sync_samples: list[tuple[int, int]] = []  # (rtt_ticks, offset32)
        self.rtt_ticks = 0
        self._next_sync_ns = 0
        # the periodic ramp task
        self._engine = None
        self.tasks = TaskSchedule()  # the ramp task's runs (attach_engine)
        self._task_tick: int | None = None
        self.task_runs = 0
        self.estop_ns: int | None = None  # when the last emergency stop was asked for
        self.connect(port if not isinstance(port, str) else None)

    # ------------------------------------------------------------------ time
    def now(self) -> int:
        return self._tick_base + (self.clock.now_ns() - self._ns_base) * self.clock_hz // NS_PER_S

    def _ns_at(self, tick: int) -> int:
        return self._ns_base + -(-(tick - self._tick_base) * NS_PER_S // self.clock_hz)

    def _set_rate(self, clock_hz: int) -> None:
        if clock_hz != self.clock_hz:
            now_ns = self.clock.now_ns()
            self._tick_base = self.now()
            self._ns_base = now_ns
            self.clock_hz = clock_hz

    def device_tick32(self, host_tick: int) -> int:
        """The device's 32-bit tick counter at host tick ``host_tick`` (estimated)."""
        return (host_tick + self._offset32) & 0xFFFFFFFF

    # ------------------------------------------------------------- sessions
    def connect(self, stream: ByteStream | None = None) -> None:
        """Open the port (unless ``stream`` is given) and start a session."""
        if stream is None:
            if self.port is None:
                raise SerialError("no port to open")
            try:
                stream = self.opener(self.port, self.baud)
            except LinkClosed as exc:
                raise SerialError(str(exc)) from exc
        self._open_session(stream)

    def reconnect(self, port: str | None = None) -> None:
        """Close what is left of the old line, open ``port`` (default: the same) again."""
        if port:
            self.port = port
        self._drop_link("reconnect")
        self.connect()

    def _drop_link(self, reason: str) -> None:
        if self.link is not None:
            self._account(self.link)
            self.link.close(reason)
            self.link = None
        self.connected = False

    def _account(self, link: HostLink) -> None:
        total = self._closed_stats
        for name, value in link.stats.as_dict().items():
            if name != "rtt_us":
                setattr(total, name, getattr(total, name) + value)

    def _open_session(self, stream: ByteStream) -> None:
        link = HostLink(stream, self.clock, window=self.window, max_payload=self.max_payload,
                        min_rto_ms=10.0, baud=self.baud)
        link.handler = self._on_messages
        link.probe = lambda: link.sync_request(self.now())
        self.link = link
        self.connected = False
        self._nonce = (self._nonce + 1 + random.getrandbits(15)) & 0xFFFF or 1
        self._ident_wanted = self._nonce
        self.ident = None
        statuses_before = self._status_count
        self.statuses = {}
        hello = Hello(PROTOCOL_VERSION, self._nonce, self.watchdog_ms, self.report_ms)
        ok = self._await(lambda: self.ident is not None and self._status_count > statuses_before,
                         self.connect_timeout_ns, lambda: link.send_unsequenced(hello),
                         50 * MS)
        if not ok:
            problem = link.closed or "no answer from the device"
            self._drop_link(problem)
            raise SerialError(problem)
        ident = self.ident
        try:
            profile = self._check_ident(ident)
        except SerialError:
            self._drop_link("unsuitable device")
            raise
        link.set_limits(min(self.window, ident.rx_slots + 1),
                        min(self.max_payload, ident.slot_payload))
        self._set_rate(ident.clock_hz)
        self._sync_samples.clear()
        for _ in range(3):
            self._sync_once(link)
        adopt = self._boot_id == ident.boot_id and self.profile is not None
        self.profile = profile
        self._update_planning()
        self._boot_id = ident.boot_id
        self.connected = True
        self.lost_reason = None
        self._problem = None
        self.sessions += 1
        self._next_sync_ns = self.clock.now_ns() + self._sync_interval()
        for pin, level in self.pins.items():
            link.send(Pin(pin, level))
        for message in (*self._pwm.values(), *self._outputs.values()):  # issue 12
            link.send(message)
        for ch in self.channels:
            ch.configure()
        if ident.features & F_INPUTS:  # issue 13
            for message in (*self.watches.values(), *self.limits.values()):
                link.send(message)
        if adopt and self._engine is not None:
            for s in self._engine.steppers:
                st = self.statuses.get(s.queue.index)
                if st is not None:
                    s.force_stop_and_new_position(st.position)
        link.flush()
        self._notify("connected", f"{profile.name} boot {ident.boot_id:04x}")

    def _check_ident(self, ident: Ident) -> Profile:
        """The profile the device names, with its queue ring as deep as it says."""
        if ident.version != PROTOCOL_VERSION:
            raise SerialError(f"device speaks protocol {ident.version}, "
                              f"host {PROTOCOL_VERSION}")
        try:
            p = get_profile(ident.name)
        except ValueError as exc:
            raise SerialError(f"device profile {ident.name!r} unknown") from exc
        if (p.ticks_per_s != ident.ticks_per_s or p.max_steppers != ident.max_steppers
                or p.ticks_per_s // p.min_cmd_ticks != ident.min_cmd_ticks_div):
            raise SerialError(f"device figures differ from profile {p.name}")
        n = ident.queue_len
        if not SERIAL_QUEUE_MIN <= n <= SERIAL_QUEUE_MAX or n & (n - 1):
            raise SerialError(f"device queue of {n} entries (a power of two "
                              f"{SERIAL_QUEUE_MIN}..{SERIAL_QUEUE_MAX} is needed)")
        if ident.rx_slots > MAX_RX_SLOTS or not 12 <= ident.slot_payload <= MAX_PAYLOAD:
            raise SerialError(f"device receive figures out of range ({ident.rx_slots} "
                              f"slots of {ident.slot_payload} bytes)")
        if self.profile is not None:
            if p.name != self.profile.name:
                raise SerialError(f"device is {p.name}, this session runs "
                                  f"{self.profile.name}")
            if n != self.profile.queue_len:
                raise SerialError(f"device queue of {n} entries, this session has "
                                  f"{self.profile.queue_len}")
        return p.with_queue_len(n)

    def _sync_interval(self) -> int:
        """Host-clock ns between clock samples; they are the heartbeat, too, so at least
        four fall in the device's watchdog time (device ms; a sped-up device's are short)."""
        watchdog_ns = self.watchdog_ms * MS * (self.profile.ticks_per_s if self.profile
                                               else self.clock_hz) // self.clock_hz
        return min(self.sync_interval_ns, watchdog_ns // 4 or self.sync_interval_ns)

    def _sync_once(self, link: HostLink) -> None:
        count = len(self._sync_samples)
        self._await(lambda: len(self._sync_samples) > count, 200 * MS,
                    lambda: link.sync_request(self.now()), resend_ns=50 * MS)

    def _await(self, cond: Callable[[], bool], timeout_ns: int,
               resend: Callable[[], None] | None = None, resend_ns: int = 200 * MS) -> bool:
        link = self.link
        clock = self.clock
        end = clock.now_ns() + timeout_ns
        next_resend = clock.now_ns()
        while True:
            if cond():
                return True
            now = clock.now_ns()
            if now >= end or link is None or link.closed:
                return False
            if resend is not None and now >= next_resend:
                resend()
                next_resend = now + resend_ns
            link.service()
            if cond():
                return True
            link.wait(min(end, next_resend) if resend is not None else end)

    def close(self) -> None:
        """End the session politely (the device stops without a watchdog trip)."""
        if self.link is not None and self.connected:
            self.link.flush()
            for _ in range(3):  # unsequenced and unanswered: a noisy line may eat one
                self.link.send_unsequenced(Bye(self._nonce))
        self._drop_link("closed")

    def _lose(self, reason: str) -> None:
        if self.connected:
            self._declare_lost(reason)

    def _declare_lost(self, reason: str) -> None:
        self._drop_link(reason)
        self.lost_reason = reason
        for ch in self.channels:
            ch.connection_lost()
        if self._engine is not None:
            for s in self._engine.steppers:
                s.force_stop_and_new_position(s.get_current_position())
        self._notify("lost", reason)

    def _notify(self, event: str, text: str) -> None:
        for fn in list(self.listeners):
            fn(event, text)

    # --------------------------------------------------------------- reports
    def _on_messages(self, msgs: list[Message], acked_mid: int) -> None:
        for m in msgs:
            if isinstance(m, Progress):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.apply(m, acked_mid)
            elif isinstance(m, Status):
                self.statuses[m.stepper] = m
                self._status_seen.add(m.stepper)
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.last_status = m
                    if self.connected:
                        ch.apply(m.progress(), acked_mid)
            elif isinstance(m, DeviceStatus):
                self.device_status = m
                self._status_count += 1
                if self.connected and not self._estopping:
                    if not m.state & D_SESSION:
                        self._problem = "device was reset"
                    elif m.state & D_WATCHDOG:
                        self._problem = "device watchdog stopped the motion"
                    elif m.state & D_ESTOP:
                        self._problem = "device in emergency stop"
            elif isinstance(m, SyncReply):
                self._sync_sample(m)
            elif isinstance(m, Input):
                self._input(m)
            elif isinstance(m, Started):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.started(self.host_tick(m.tick))
            elif isinstance(m, LimitHit):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.halted()
                self._notify_limit(m.stepper, m.pin, m.position, self.host_tick(m.tick))
            elif isinstance(m, Ident) and m.nonce == self._ident_wanted:
                self.ident = m

    def _input(self, m: Input) -> None:
        if m.pin not in self.watches:
            return
        tick = self.host_tick(m.tick)
        old = self.inputs.get(m.pin)
        self.inputs[m.pin] = m.value
        if old != m.value:
            self.input_ticks[m.pin] = tick
            self._notify_input(m.pin, m.value, tick)

    def host_tick(self, device_tick: int) -> int:
        """The host tick at which the device's counter showed ``device_tick`` (recent)."""
        now = self.now()
        return now + tick_diff32(device_tick, self.device_tick32(now))

    def _sync_sample(self, m: SyncReply) -> None:
        t1 = self.now()
        rtt = (t1 - m.stamp) & 0xFFFFFFFF
        if rtt > self.clock_hz * 5:
            return
        t0 = t1 - rtt
        offset = (m.device_tick - (t0 + rtt // 2)) & 0xFFFFFFFF
        self._sync_samples.append((rtt, offset))
        del self._sync_samples[:-SYNC_SAMPLES]
        best = min(self._sync_samples)
        self.rtt_ticks, self._offset32 = best
        if self.link is not None:
            self.link.stats.sync_samples += 1
            self.link.rtt_sample(rtt * NS_PER_S // self.clock_hz)
        self._update_planning()

    # ------------------------------------------------- the link's delays
    def _ns_ticks(self, ns: int) -> int:
        return ns * self.clock_hz // NS_PER_S

    def round_trip_ticks(self, rank: int = 1) -> int:
        """A high estimate of the line's round trip: the longest of the recent clock
        samples (the device answers them at once) - ``rank=2``: the second longest, so
        that one sample that waited behind a burst does not count - or, before there
        are any, the smoothed round trip of acknowledged frames plus four deviations."""
        if self._sync_samples:
            rtts = sorted(rtt for rtt, _ in self._sync_samples)
            return rtts[-min(rank, len(rtts))]
        link = self.link
        if link is not None and link.srtt_ns is not None:
            return self._ns_ticks(link.srtt_ns + 4 * link.rttvar_ns)
        return 0

    def retry_rounds(self) -> int:
        """Retransmission rounds to allow for: so many that a frame needs more only once
        in a thousand times, from the share of frames the link had to send again."""
        loss = self.link.loss if self.link is not None else 0.0
        if loss <= LOSS_TARGET:
            return 1
        return min(MAX_ROUNDS, math.ceil(math.log(LOSS_TARGET) / math.log(loss)))

    def retry_round_ticks(self) -> int:
        """One retransmission round: a lost frame shows a round trip after it went out
        (a NAK, or the clock sample sent after it as a probe); its repeat follows."""
        return self.round_trip_ticks() + self.wire_ticks(MAX_FRAME)

    def lossy(self) -> bool:
        return self.link is not None and self.link.loss > LOSS_TARGET

    def wire_ticks(self, n_bytes: int) -> int:
        return n_bytes * 10 * self.clock_hz // self.baud if self.baud else 0

    def _update_planning(self) -> None:
        """Forward planning beyond the library's own, once a queue runs: what the host
        may be late (host margin) plus a round trip plus the retransmission rounds -
        or what the user set (``link_planning_ms``)."""
        if self.link_planning_ms is not None:
            self.planning_extra_ticks = self.link_planning_ms * self.clock_hz // 1000
            return
        if self.profile is None:
            return
        self.planning_extra_ticks = (
            self.host_margin_ms * self.clock_hz // 1000 + self.round_trip_ticks()
            + self.retry_rounds() * self.retry_round_ticks()
            + self.report_ms * self.clock_hz // 1000)

    def cut_margin_ticks(self, report_ns: int) -> int:
        """How far ahead of the last report (received at ``report_ns``) a cut must lie so
        that the device has not begun it when the Truncate and the entries that follow
        it arrive: the report's way here and the Truncate's way there (a round trip),
        the next ramp task, the bytes queued before, and - on a line that loses
        frames - its retransmission rounds: the entries after the cut must be there
        before the motor reaches it."""
        link = self.link
        age = self._ns_ticks(max(0, self.clock.now_ns() - report_ns))
        # before the first entries after the cut: what is queued, the Truncate's frame,
        # a frame of entries
        backlog = (link.backlog_bytes() if link is not None else 0) + CUT_BYTES
        rtt = self.round_trip_ticks(rank=2)  # a refused cut is safe, only later
        margin = age + rtt + self.profile.fill_period_ticks + self.wire_ticks(backlog)
        if self.lossy():  # the Truncate and the entries after it may need repeats
            margin += self.retry_rounds() * (rtt + self.wire_ticks(MAX_FRAME))
        return margin

    # ------------------------------------------------------------ the loop
    def _service(self) -> None:
        link = self.link
        if link is None or not self.connected:
            return
        link.service()
        if link.closed:
            self._lose(link.closed)
            return
        if self._problem:
            self._lose(self._problem)
            return
        now_ns = self.clock.now_ns()
        if now_ns >= self._next_sync_ns:
            self._next_sync_ns = now_ns + self._sync_interval()
            link.sync_request(self.now())
        for ch in self.channels:
            if ch.halt is not None and now_ns >= ch.halt.next_ns:
                ch.resend_halt(now_ns)

    def _run_until(self, tick: int, pred: Callable[[], bool] | None = None) -> bool:
        """Let host time reach ``tick`` (or ``pred()`` hold): link, ramp task, waiting."""
        while True:
            self._service()
            if self.tasks.is_due(self.now()):
                self._run_task()
                continue
            if pred is not None and pred():
                return True
            now = self.now()
            if now >= tick:
                return False
            deadline = tick
            task_time = self.tasks.next_time()
            if task_time is not None:
                deadline = min(deadline, task_time)
            deadline_ns = self._ns_at(deadline)
            if self.connected and self.link is not None:
                self.link.wait(min(deadline_ns, self._timer_ns()))
            else:
                self.clock.wait(deadline_ns, None)

    # ---------------------------------------------------------- ramp task
    def attach_engine(self, engine) -> None:
        self._engine = engine
        # run 0 one period from now (and one new period from now if the period changes)
        self.tasks.start(self.now() + self.profile.fill_period_ticks, self.task_period_ticks)

    def set_task_period(self, ticks: int) -> None:
        """``engine.task_rate()``: runs after the last one follow the new period."""
        super().set_task_period(ticks)
        if self._engine is None:
            return
        self.tasks.set_period(self.task_period_ticks)
        self.tasks.next = self.tasks.last + 1

    def _run_task(self) -> None:
        tasks = self.tasks
        idx = tasks.catch_up(self.now())
        engine = self._engine
        self._update_planning()
        engine.credit_skipped_tasks(tasks.begin(idx))
        self._task_tick = tasks.time(idx)
        try:
            engine.manage_steppers()
        finally:
            self._task_tick = None
        self.task_runs += 1
        tasks.end(engine.quiescent_tasks())
        if self.link is not None and self.connected:
            self.link.flush()

    def wake_task(self) -> None:
        if self._engine is None:
            return
        self.tasks.wake(self.now())

    # ----------------------------------------------------------- channels
    def allocate_channel(self, queue: StepperQueue) -> SerialChannel:
        ch = SerialChannel(self, queue)
        self.channels.append(ch)
        self._by_index[queue.index] = ch
        return ch

    def send(self, msg: Message) -> int:
        """Queue a sequenced message for the device (0 while disconnected)."""
        if not self.connected or self.link is None:
            return 0
        return self.link.send(msg)

    def send_halt(self, index: int, stop_id: int) -> None:
        """Stop one queue on the device now, ahead of everything queued (unsequenced)."""
        if self.connected and self.link is not None:
            self._send_stop(Halt(index, stop_id, self._nonce))

    def _send_stop(self, msg: Message) -> None:
        """An unsequenced stop: on a line that loses frames, two copies back to back."""
        for _ in range(2 if self.link.loss > LOSSY else 1):
            self.link.send_unsequenced(msg)

    def repeat_ns(self) -> int:
        """How often an unanswered unsequenced stop is sent again: a round trip of the
        line and the stop's wire time (at least 5 ms)."""
        return max(5 * MS, (self.round_trip_ticks() + self.wire_ticks(16)) * NS_PER_S
                   // self.clock_hz)

    def send_start(self, index: int, at: int | None = None) -> int:
        """Start queue ``index`` at host tick ``at`` (default: as soon as it can)."""
        if at is None:
            at = self.earliest_start()
        self.last_start_at = at
        mid = self.send(Start(1 << index, self.device_tick32(at)))
        if self.link is not None:
            self.link.probe_after(mid)  # a lost Start shows a round trip later
            if self.connected:
                # the Start ends its frame: what is queued after it must not delay it
                # (a frame counts only when its last byte is in)
                self.link.flush()
        return mid

    def earliest_start(self) -> int:
        """The earliest host tick a Start sent now can name: the ramp task's time (or
        now) plus the lead."""
        base = self._task_tick if self._task_tick is not None else self.now()
        return base + self.start_lead_ticks()

    def start_lead_ticks(self) -> int:
        """How far ahead a start is scheduled: the way there and the time the bytes
        queued before it take - on the wire, or a round trip and a report period per
        window when more frames are queued than the window holds, more when frames are
        lost - and its retransmission rounds (one on a clean line)."""
        hz = self.clock_hz
        lead = self.start_lead_us * hz // 1_000_000
        link = self.link
        if link is None:
            return lead
        backlog = 16 + link.backlog_bytes()
        rtt = self.round_trip_ticks()
        frame = link.payload + 5
        windows = -(-backlog // (frame * link.window))
        turn = rtt + self.report_ms * hz // 1000
        deliver = max(self.wire_ticks(backlog), (windows - 1) * turn)
        # a clean line may lose a frame too, before any loss has been seen: one round
        lead += rtt + int(deliver / (1.0 - min(link.loss, 0.5)))
        return lead + self.retry_rounds() * self.retry_round_ticks()

    # --------------------------------------------------------------- pins
    def write_pin(self, pin: int, level: int) -> None:
        level = 1 if level else 0
        self.pins.pop(pin, None)
        self.pins[pin] = level
        self.send(Pin(pin, level))

    def read_pin(self, pin: int) -> int:
        for ch in self.channels:
            if ch.step_pin == pin and not ch.detached:
                return 0  # pulses are the device's; between them the pin is low
        return self.pins.get(pin, 0)

    # ---------------------------------------------------- user outputs (issue 12)
    def configure_pwm(self, number: int, pin: int, setting, count: int) -> None:
        message = OutputPwm(number, pin, setting.clock_div, setting.counts, count)
        self._pwm[number] = message
        self._outputs.pop((True, number), None)
        self.send(message)

    def _output_message(self, change, flags: int) -> OutputSet:
        return OutputSet(flags | (O_ANALOG if change.analog else 0), change.number, change.pin,
                         change.value)

    def set_output(self, change) -> None:
        self._outputs[(change.analog, change.number)] = self._output_message(change, 0)
        self.send(self._output_message(change, 0))

    def sync_output(self, change) -> object:
        """In order after the entries sent so far; the device makes it when its queues
        have run dry (docs/serial-protocol.md, section 16)."""
        self._outputs[(change.analog, change.number)] = self._output_message(change, 0)
        return self.send(self._output_message(change, O_SYNCHRONIZED))

    def sync_output_done(self, token: object) -> bool:
        # the device makes it before it reports its queues idle; the engine passes the
        # barrier only once it has seen that report
        return True

    def cancel_sync_outputs(self) -> None:
        self.send(OutputCancel())

    # ------------------------------------------------------- inputs (issue 13)
    def _features(self) -> int:
        """Ident's optional message families of the device (section 5)."""
        return self.ident.features if self.ident is not None else 0

    def watch_input(self, pin: int, analog: bool = False, pullup: bool = True,
                    period_ms: int = 0) -> bool:
        if self.connected and not self._features() & F_INPUTS:
            return False  # a device without inputs (section 18) would refuse the watch
        mode = W_ANALOG if analog else (W_PULLUP if pullup else W_DIGITAL)
        watch = WatchInput(pin, mode, min(max(period_ms, 0), 255))
        self.watches[pin] = watch
        self.send(watch)
        if self.link is not None and self.connected:
            self.link.flush()
        return True

    def read_input(self, pin: int) -> int | None:
        return self.inputs.get(pin)

    def drive_input(self, pin: int, value: int) -> bool:
        """A simulated device (Ident feature F_SIM_INPUTS: ``device --pty``, the firmware
        in simavr) lets the host turn its pots and press its switches: SetInput.  The
        device reads the pin as a board would and reports it (Input); a board's inputs
        are its pins (False)."""
        if not (self.connected and self._features() & F_SIM_INPUTS):
            return False
        w = self.watches.get(pin)
        analog = w.mode == W_ANALOG if w is not None else value > 1
        value = min(max(int(value), 0), 1023) if analog else (1 if value else 0)
        self.send(SetInput(pin, value, S_ANALOG if analog else 0))
        if self.link is not None:
            self.link.flush()
        return True

    def set_limit(self, index: int, pin: int, level: int, up: bool,
                  stop: tuple[int, ...] = ()) -> bool:
        if self.connected and not self._features() & F_INPUTS:
            return False  # a device without limit switches (section 18)
        mask = 0
        for i in stop:
            mask |= 1 << i
        limit = Limit(index, pin, 1 if level else 0, L_UP if up else 0, mask)
        self.limits[(index, bool(up))] = limit
        self.send(limit)
        if self.link is not None and self.connected:
            self.link.flush()
        return True

    def clear_limit(self, index: int, up: bool) -> None:
        if self.limits.pop((index, bool(up)), None) is not None:
            self.send(Limit(index, 0, 0, (L_UP if up else 0) | L_CLEAR, 0))

    def attach_pulse_counter(self, queue: StepperQueue, counter: PulseCounter) -> bool:
        if not self.connected:
            return False
        self._by_index[queue.index].attach_counter(counter)
        return True

    def detach_step_pin(self, queue: StepperQueue, detached: bool) -> None:
        self._by_index[queue.index].set_detached(detached)

    def wait_until(self, predicate: Callable[[], bool], timeout_ticks: int = 0) -> bool:
        limit = timeout_ticks or DEFAULT_WAIT_LIMIT_S * self.profile.ticks_per_s
        return self._run_until(self.now() + limit, predicate)

    # ------------------------------------------------------ application host
    def app_spend(self, ticks: int) -> None:
        self._run_until(self.now() + ticks)

    def app_wait_until(self, tick: int, until: Callable[[], bool] | None = None) -> bool:
        return self._run_until(tick, until)

    def next_event_time(self) -> int | None:
        """The next ramp task, or the next heartbeat: an idle application must still
        let the link run before the device's watchdog expires."""
        times = []
        task_time = self.tasks.next_time()
        if task_time is not None:
            times.append(task_time)
        if self.connected:
            times.append(self._tick_at_ns(self._timer_ns()))
        return min(times) if times else None

    def _timer_ns(self) -> int:
        """The backend's next own deadline: a clock sample, or a Halt to repeat."""
        t = self._next_sync_ns
        for ch in self.channels:
            if ch.halt is not None:
                t = min(t, ch.halt.next_ns)
        return t

    def _tick_at_ns(self, ns: int) -> int:
        return self._tick_base + -(-(ns - self._ns_base) * self.clock_hz // NS_PER_S)

    # --------------------------------------------------------------- extras
    def emergency_stop(self) -> bool:
        """Stop every motion on the device at once, take its positions, open a new session.

        False if the device could not be reached (the session is then lost).
        """
        link = self.link
        if link is None or not self.connected:
            return False
        self._estopping = True
        try:
            count = self._status_count
            self.estop_ns = self.clock.now_ns()
            self._send_stop(EmergencyStop(self._nonce))
            ok = self._await(lambda: self._status_count > count and self.device_status
                             is not None and bool(self.device_status.state & D_ESTOP),
                             self.connect_timeout_ns,
                             lambda: self._send_stop(EmergencyStop(self._nonce)),
                             self.repeat_ns())
            if not ok:
                self._lose(link.closed or "no answer to the emergency stop")
                return False
            stream = link.stream
            self._account(link)
            self.connected = False
            try:
                self._open_session(stream)
            except SerialError as exc:
                self._declare_lost(str(exc))
                return False
            return True
        finally:
            self._estopping = False

    def request_status(self, timeout_ms: int = 2000) -> DeviceStatus | None:
        """Ask the device for its counters and every stepper's status; wait for them."""
        link = self.link
        if link is None or not self.connected:
            return None
        count = self._status_count
        self._status_seen = set()
        wanted = {ch.index for ch in self.channels}
        ok = self._await(lambda: self._status_count > count and wanted <= self._status_seen,
                         timeout_ms * MS, lambda: link.send_unsequenced(StatusRequest()),
                         100 * MS)
        return self.device_status if ok else None

    def settle(self, timeout_ms: int = 2000) -> bool:
        """Wait until every message is acknowledged and the device reports all queues idle."""
        link = self.link
        if link is None or not self.connected:
            return False

        def done() -> bool:
            return link.idle() and not any(ch.is_running() for ch in self.channels)

        return self._run_until(self.now() + timeout_ms * self.clock_hz // 1000, done)

    def link_stats(self) -> dict[str, int]:
        """Link counters over every session so far (rtt: the current one)."""
        total = LinkStats(**self._closed_stats.as_dict())
        if self.link is not None:
            for name, value in self.link.stats.as_dict().items():
                if name != "rtt_us":
                    setattr(total, name, getattr(total, name) + value)
            total.rtt_us = self.link.stats.rtt_us
        out = total.as_dict()
        out["sessions"] = self.sessions
        return out

    def device_counters(self) -> dict[str, int]:
        return self.device_status.counters() if self.device_status is not None else {}
