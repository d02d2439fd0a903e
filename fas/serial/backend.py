"""The serial backend: the library on this computer, its queue commands on a device.

:class:`SerialBackend` implements :class:`fas.backend.Backend` by composing the host
side's parts, each with one job:

* :class:`~fas.serial.session.HostSession` - the session's link (:mod:`.link`) and
  identity: Hello/Ident, Bye, the link's counters over all sessions;
* :class:`~fas.serial.clocksync.ClockSync` - host time in device ticks, the device
  counter's offset from clock samples;
* :class:`~fas.serial.margins.LinkMargins` - how far ahead to plan, start and cut for
  the link's measured delays;
* :class:`~fas.schedule.TaskSchedule` - the engine's periodic ramp task (the one the
  simulated backend runs, too);
* :class:`~fas.serial.outputs.OutputState`, :class:`~fas.serial.inputs.InputState` -
  what the host set on the device (pins, outputs, watched inputs, limits), replayed in
  every new session;
* :class:`~fas.serial.session.DeviceReports` - Status and DeviceStatus as reported;
* one :class:`~fas.serial.channel.SerialChannel` per stepper - the host's mirror of a
  device queue.

The engine's ramp task runs here every ``fill_period_ticks`` of host time; the entries
it writes go to the device through the channels and the link.  Host time is counted
in device ticks (the rate the device announces), from the first connection on; the
clock offset converts it to the device's own counter for synchronized starts.

Losing the device (port error, silence, a device reset or watchdog stop) is reported
to ``listeners`` once; every stepper is then force-stopped at its last known
position, time goes on, and :meth:`reconnect` opens a new session.  Reconnected to
the same device (same boot id), the host takes over the positions the device
reports, so the axes keep their coordinates.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from ..arch import Profile
from ..backend import (
    Backend,
    InputListener,
    LimitListener,
    OutputChange,
    PulseCounter,
    TaskEngine,
)
from ..pwm import PwmSetting
from ..queue import StepperQueue
from ..schedule import TaskSchedule
from .channel import SerialChannel
from .clock import Clock, RealClock
from .clocksync import NS_PER_S, ClockSync
from .inputs import InputState
from .link import LOSSY, HostLink
from .margins import HOST_MARGIN_MS, LinkMargins
from .outputs import OutputState
from .protocol import (
    F_INPUTS,
    F_SIM_INPUTS,
    F_TIMED_OUTPUTS,
    FRAME_OVERHEAD,
    MAX_PAYLOAD,
    TIMED_SLOTS,
    DeviceStatus,
    EmergencyStop,
    Halt,
    Ident,
    Input,
    LimitHit,
    Message,
    Progress,
    PwmGrid,
    Start,
    Started,
    Status,
    StatusRequest,
    SyncReply,
)
from .session import DeviceReports, HostSession, SerialError, check_ident
from .stream import ByteStream, LinkClosed, open_serial

__all__ = ["SerialBackend", "SerialError"]

MS = 1_000_000
DEFAULT_WAIT_LIMIT_S = 3600
REPORT_BYTES = 17  # a report frame: two Progress messages and a Nak
SYNC_SAMPLES_AT_OPEN = 3  # clock samples taken before a session counts as open
SYNC_WAIT_NS = 200 * MS
SYNC_REPEAT_NS = 50 * MS
STATUS_REPEAT_NS = 100 * MS

Listener = Callable[[str, str], None]  # (event, text): "lost", "connected"


class SerialBackend(Backend):
    """Drives a device that speaks docs/serial-protocol.md (see module text)."""

    def __init__(self, port: str | ByteStream, *, baud: int = 115200,
                 clock: Clock | None = None, watchdog_ms: int = 500,
                 report_ms: int | None = None, connect_timeout_ms: int = 3000,
                 start_lead_us: int = 1000, window: int = 16, max_payload: int = MAX_PAYLOAD,
                 sync_interval_ms: int = 1000, link_planning_ms: int | None = None,
                 host_margin_ms: int = HOST_MARGIN_MS,
                 opener: Callable[[str, int], ByteStream] = open_serial) -> None:
        self.clock: Clock = clock or RealClock()
        self.opener = opener
        self.port = port if isinstance(port, str) else None
        self.baud = baud
        self.watchdog_ms = watchdog_ms
        # the device's report period: reports of two running queues (17 bytes) take at
        # most a quarter of the line back, and come at least every 2 ms
        self.report_ms = report_ms or max(2, -(-REPORT_BYTES * 10 * 4 * 1000 // baud))
        self.connect_timeout_ns = connect_timeout_ms * MS
        self.sync_interval_ns = sync_interval_ms * MS
        self.planning_extra_ticks = 0
        self._profile: Profile | None = None  # the device names it (see profile)
        self.session = HostSession(self.clock, baud=baud, window=window,
                                   max_payload=max_payload, watchdog_ms=watchdog_ms,
                                   report_ms=self.report_ms)
        self.sync = ClockSync(self.clock)
        self.margins = LinkMargins(self.sync, baud=baud, report_ms=self.report_ms,
                                   start_lead_us=start_lead_us, host_margin_ms=host_margin_ms,
                                   link_planning_ms=link_planning_ms)
        self.reports = DeviceReports()
        self.outputs = OutputState()
        # timed output changes (section 16): waiting to be sent (host tick, change), and
        # the host ticks of those sent whose tick has not come (the device's slots)
        self._timed_wait: deque[tuple[int, OutputChange, int]] = deque()  # (+ device tick)
        self._timed_sent: list[int] = []
        # the device's PWM periods by pin (PwmGrid): (origin, period) in device ticks
        self.pwm_grids: dict[int, tuple[int, int]] = {}
        self.inputs = InputState()
        self.tasks = TaskSchedule()  # the ramp task's runs (attach_engine)
        self.listeners: list[Listener] = []
        self.input_listeners: list[InputListener] = []
        self.limit_listeners: list[LimitListener] = []
        self.channels: list[SerialChannel] = []
        self._by_index: dict[int, SerialChannel] = {}
        self.last_start_at = 0  # host tick of the last Start sent
        self._estopping = False
        self.estop_ns: int | None = None  # when the last emergency stop was asked for
        self._next_sync_ns = 0
        self._engine: TaskEngine | None = None
        self._task_tick: int | None = None  # the time of the ramp task that runs
        self.task_runs = 0
        self.connect(port if not isinstance(port, str) else None)

    # ------------------------------------------------- the parts, at a glance
    @property
    def profile(self) -> Profile:
        """The connected device's chip (it names it in its Ident): known from the first
        connection on, which the constructor makes."""
        if self._profile is None:
            raise SerialError("no device has connected yet: its profile is not known")
        return self._profile

    @profile.setter
    def profile(self, profile: Profile) -> None:
        self._profile = profile

    @property
    def link(self) -> HostLink | None:
        """The link of the current session (None: none is open)."""
        return self.session.link

    @property
    def connected(self) -> bool:
        return self.session.connected

    @property
    def ident(self) -> Ident | None:
        return self.session.ident

    @property
    def lost_reason(self) -> str | None:
        return self.session.lost_reason

    @property
    def sessions(self) -> int:
        return self.session.sessions

    @property
    def statuses(self) -> dict[int, Status]:
        """Every queue's last Status this session (position, pulses, underruns)."""
        return self.reports.statuses

    @property
    def device_status(self) -> DeviceStatus | None:
        return self.reports.device_status

    @property
    def clock_hz(self) -> int:
        """The device's tick rate per host-clock second (host time counts in it)."""
        return self.sync.clock_hz

    @property
    def link_planning_ms(self) -> int | None:
        """Planning beyond the library's as set (None: derived from the link)."""
        return self.margins.link_planning_ms

    # ------------------------------------------------------------------ time
    def now(self) -> int:
        return self.sync.now()

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
        self.session.drop("reconnect")
        self.connect()

    def _open_session(self, stream: ByteStream) -> None:
        session = self.session
        link = session.new_link(stream)
        link.handler = self._on_messages
        link.probe = lambda: link.sync_request(self.now())
        hello = session.hello()
        reports = self.reports
        statuses_before = reports.status_count
        reports.statuses = {}
        ok = session.wait_for(
            lambda: session.ident is not None and reports.status_count > statuses_before,
            self.connect_timeout_ns, lambda: link.send_unsequenced(hello), 50 * MS)
        ident = session.ident
        if not ok or ident is None:
            problem = link.closed or "no answer from the device"
            session.drop(problem)
            raise SerialError(problem)
        try:
            profile = check_ident(ident, self._profile)
        except SerialError:
            session.drop("unsuitable device")
            raise
        session.fit_link(ident)
        self.sync.set_rate(ident.clock_hz)
        self.sync.clear()
        for _ in range(SYNC_SAMPLES_AT_OPEN):
            self._sync_once(link)
        adopt = session.same_device(ident) and self._profile is not None
        self._profile = profile
        self._update_planning()
        session.opened(ident)
        self._next_sync_ns = self.clock.now_ns() + self._sync_interval()
        self._replay(link, ident, adopt)
        link.flush()
        self._notify("connected", f"{profile.name} boot {ident.boot_id:04x}")

    def _replay(self, link: HostLink, ident: Ident, adopt: bool) -> None:
        """A new session: the device learns what the host had set (pins, outputs, the
        queues, watched inputs and limits); the same device's positions are taken."""
        self.pwm_grids.clear()  # (the device reports them again after the OutputPwm)
        for message in self.outputs.replay():
            link.send(message)
        for ch in self.channels:
            ch.configure()
        if ident.features & F_INPUTS:  # issue 13
            for message in self.inputs.replay():
                link.send(message)
        if adopt and self._engine is not None:
            for s in self._engine.steppers:
                st = self.statuses.get(s.queue.index)
                if st is not None:
                    s.force_stop_and_new_position(st.position)

    def _sync_interval(self) -> int:
        """Host-clock ns between clock samples; they are the heartbeat, too, so at least
        four fall in the device's watchdog time (device ms; a sped-up device's are short)."""
        hz = self.sync.clock_hz
        profile = self._profile
        watchdog_ns = self.watchdog_ms * MS * (profile.ticks_per_s if profile else hz) // hz
        return min(self.sync_interval_ns, watchdog_ns // 4 or self.sync_interval_ns)

    def _sync_once(self, link: HostLink) -> None:
        count = len(self.sync.samples)
        self.session.wait_for(lambda: len(self.sync.samples) > count, SYNC_WAIT_NS,
                              lambda: link.sync_request(self.now()), resend_ns=SYNC_REPEAT_NS)

    def close(self) -> None:
        """End the session politely (the device stops without a watchdog trip)."""
        self.session.bye()
        self.session.drop("closed")

    def _lose(self, reason: str) -> None:
        if self.connected:
            self._declare_lost(reason)

    def _declare_lost(self, reason: str) -> None:
        self.session.drop(reason)
        self.session.lost_reason = reason
        for ch in self.channels:
            ch.connection_lost()
        if self._engine is not None:
            for s in self._engine.steppers:
                s.force_stop_and_new_position(s.get_current_position())
        self._notify("lost", reason)

    def _drop_unsendable(self, engine: TaskEngine) -> None:
        """No device: what a planner queued since the loss can never start (a channel
        starts only on a connected device).  Dropped at once, the stepper stands where
        it stood instead of "running" for ever; ``reconnect`` goes on from there."""
        for s in engine.steppers:
            if s.is_running():
                s.force_stop_and_new_position(s.get_current_position())

    def _notify(self, event: str, text: str) -> None:
        for fn in list(self.listeners):
            fn(event, text)

    # --------------------------------------------------------------- reports
    def _on_messages(self, msgs: list[Message], acked_mid: int) -> None:
        """The device's messages of one frame, which reflects every host message up to
        ``acked_mid``: to the channels, the clock, the inputs, the listeners."""
        for m in msgs:
            if isinstance(m, Progress):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.apply(m, acked_mid)
            elif isinstance(m, Status):
                self.reports.status(m)
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.last_status = m
                    if self.connected:
                        ch.apply(m.progress(), acked_mid)
            elif isinstance(m, DeviceStatus):
                problem = self.reports.device(m)
                if self.connected and not self._estopping and problem:
                    self.session.problem = problem
            elif isinstance(m, SyncReply):
                self._sync_sample(m)
            elif isinstance(m, Input):
                tick = self.sync.host_tick(m.tick)
                if self.inputs.reported(m, tick):
                    self._notify_input(m.pin, m.value, tick)
            elif isinstance(m, PwmGrid):
                if m.period:
                    self.pwm_grids[m.pin] = (m.origin, m.period)
                else:
                    self.pwm_grids.pop(m.pin, None)
            elif isinstance(m, Started):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.started(self.sync.host_tick(m.tick))
            elif isinstance(m, LimitHit):
                ch = self._by_index.get(m.stepper)
                if ch is not None:
                    ch.halted()
                self._notify_limit(m.stepper, m.pin, m.position, self.sync.host_tick(m.tick))
            elif isinstance(m, Ident):
                self.session.take_ident(m)

    def _sync_sample(self, m: SyncReply) -> None:
        rtt = self.sync.sample(m)
        if rtt is None:
            return
        link = self.link
        if link is not None:
            link.stats.sync_samples += 1
            link.rtt_sample(rtt * NS_PER_S // self.sync.clock_hz)
        self._update_planning()

    # ------------------------------------------------- the link's delays
    def _update_planning(self) -> None:
        """Forward planning beyond the library's own (:meth:`LinkMargins.planning_ticks`)."""
        ticks = self.margins.planning_ticks(self.link, self._profile)
        if ticks is not None:
            self.planning_extra_ticks = ticks

    def round_trip_ticks(self, rank: int = 1) -> int:
        """A high estimate of the line's round trip (:class:`LinkMargins`)."""
        return self.margins.round_trip_ticks(self.link, rank)

    def retry_rounds(self) -> int:
        """Retransmission rounds the margins allow for (:class:`LinkMargins`)."""
        return self.margins.retry_rounds(self.link)

    def cut_margin_ticks(self, report_ns: int) -> int:
        """How far ahead of the last report (received at ``report_ns``) a cut must lie
        (:meth:`LinkMargins.cut_margin_ticks`)."""
        return self.margins.cut_margin_ticks(self.link, self.clock.now_ns() - report_ns,
                                             self.profile.fill_period_ticks)

    def repeat_ns(self) -> int:
        """How often an unanswered unsequenced stop is sent again."""
        return self.margins.repeat_ns(self.link)

    # ------------------------------------------------------------ the loop
    def _service(self) -> None:
        link = self.link
        if link is None or not self.connected:
            return
        link.service()
        if link.closed:
            self._lose(link.closed)
            return
        if self.session.problem:
            self._lose(self.session.problem)
            return
        now_ns = self.clock.now_ns()
        if now_ns >= self._next_sync_ns:
            self._next_sync_ns = now_ns + self._sync_interval()
            link.sync_request(self.now())
        for ch in self.channels:
            if ch.halt is not None and now_ns >= ch.halt.next_ns:
                ch.resend_halt(now_ns)
        if self._timed_wait and self._timed_sent and min(self._timed_sent) <= self.now():
            self._send_timed()
            link.flush()

    def _run_until(self, tick: int, pred: Callable[[], bool] | None = None) -> bool:
        """Let host time reach ``tick`` (or ``pred()`` hold): link, ramp task, waiting."""
        tasks = self.tasks
        while True:
            self._service()
            if tasks.is_due(self.now()):
                self._run_task()
                continue
            if pred is not None and pred():
                return True
            now = self.now()
            if now >= tick:
                return False
            deadline = tick
            task_time = tasks.next_time()
            if task_time is not None:
                deadline = min(deadline, task_time)
            deadline_ns = self.sync.ns_at(deadline)
            link = self.link
            if self.connected and link is not None:
                link.wait(min(deadline_ns, self._timer_ns()))
            else:
                self.clock.wait(deadline_ns, None)

    def _timer_ns(self) -> int:
        """The backend's next own deadline: a clock sample, or a Halt to repeat."""
        t = self._next_sync_ns
        for ch in self.channels:
            if ch.halt is not None:
                t = min(t, ch.halt.next_ns)
        if self._timed_wait and self._timed_sent:  # a device slot comes free
            t = min(t, self.sync.ns_at(min(self._timed_sent)))
        return t

    # ---------------------------------------------------------- ramp task
    def attach_engine(self, engine: TaskEngine) -> None:
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
        assert engine is not None
        self._update_planning()
        engine.credit_skipped_tasks(tasks.begin(idx))
        self._task_tick = tasks.time(idx)
        try:
            engine.manage_steppers()
        finally:
            self._task_tick = None
        if not self.connected:
            self._drop_unsendable(engine)
        self.task_runs += 1
        tasks.end(engine.quiescent_tasks())
        link = self.link
        if link is not None and self.connected:
            link.flush()

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

    def send(self, msg: Message, *, overtake_entries: bool = False) -> int:
        """Queue a sequenced message for the device (0 while disconnected);
        ``overtake_entries``: see :meth:`HostLink.send`."""
        link = self.link
        if not self.connected or link is None:
            return 0
        return link.send(msg, overtake_entries=overtake_entries)

    def _send_and_flush(self, msg: Message) -> None:
        """A message that must not wait for the next ramp task's frame."""
        self.send(msg)
        link = self.link
        if link is not None and self.connected:
            link.flush()

    def send_halt(self, index: int, stop_id: int) -> None:
        """Stop one queue on the device now, ahead of everything queued (unsequenced)."""
        if self.connected and self.link is not None:
            self._send_stop(Halt(index, stop_id, self.session.nonce))

    def _send_stop(self, msg: Message) -> None:
        """An unsequenced stop: on a line that loses frames, two copies back to back."""
        link = self.link
        assert link is not None
        for _ in range(2 if link.loss > LOSSY else 1):
            link.send_unsequenced(msg)

    def send_start(self, index: int, at: int | None = None) -> int:
        """Start queue ``index`` at host tick ``at`` (default: as soon as it can)."""
        if at is None:
            at = self.earliest_start()
        self.last_start_at = at
        mid = self.send(Start(1 << index, self.sync.device_tick32(at)))
        link = self.link
        if link is not None:
            link.probe_after(mid)  # a lost Start shows a round trip later
            if self.connected:
                # the Start ends its frame: what is queued after it must not delay it
                # (a frame counts only when its last byte is in)
                link.flush()
        return mid

    def earliest_start(self) -> int:
        """The earliest host tick a Start sent now can name: the ramp task's time (or
        now) plus the lead (:meth:`LinkMargins.start_lead_ticks`)."""
        base = self._task_tick if self._task_tick is not None else self.now()
        return base + self.margins.start_lead_ticks(self.link)

    # --------------------------------------------------------------- pins
    def write_pin(self, pin: int, level: int) -> None:
        self.send(self.outputs.pin(pin, level))

    def read_pin(self, pin: int) -> int:
        for ch in self.channels:
            if ch.step_pin == pin and not ch.detached:
                return 0  # pulses are the device's; between them the pin is low
        return self.outputs.level(pin)

    # ---------------------------------------------------- user outputs (issue 12)
    def configure_pwm(self, number: int, pin: int, setting: PwmSetting, count: int) -> None:
        self.send(self.outputs.configure_pwm(number, pin, setting, count))

    def set_output(self, change: OutputChange) -> None:
        self.send(self.outputs.output(change))

    def sync_output(self, change: OutputChange) -> object:
        """In order after the entries sent so far; the device makes it when its queues
        have run dry (docs/serial-protocol.md, section 16)."""
        return self.send(self.outputs.output(change, synchronized=True))

    def sync_output_done(self, token: object) -> bool:
        # the device makes it before it reports its queues idle; the engine passes the
        # barrier only once it has seen that report
        return True

    def cancel_sync_outputs(self) -> None:
        self.send(self.outputs.cancel())

    def timed_output(self, change: OutputChange, tick: int) -> bool:
        """OutputAt at the device tick of host tick ``tick`` (a device with
        ``F_TIMED_OUTPUTS``): at most ``TIMED_SLOTS`` wait on the device, the next are
        sent as slots come free (docs/serial-protocol.md, section 16)."""
        if not self.connected or not self._features() & F_TIMED_OUTPUTS:
            return False
        wait = self._timed_wait
        device_tick = self.sync.device_tick32(tick)
        if change.analog:
            self._drop_replaced(change.pin, device_tick)
        wait.append((tick, change, device_tick))
        self._send_timed()
        link = self.link
        if self._task_tick is None and link is not None and self.connected:
            link.flush()  # (the ramp task flushes what it sends at its end)
        return True

    def cancel_timed_outputs(self) -> None:
        self._timed_wait.clear()
        self._hold_entries()
        if self._timed_sent:
            self._timed_sent.clear()
            if self.connected and self._features() & F_TIMED_OUTPUTS:
                self.send(self.outputs.timed_cancel())

    def _drop_replaced(self, pin: int, device_tick: int) -> None:
        """A new analog change of ``pin`` at ``device_tick`` replaces the one waiting
        (not sent) before it on that pin if both fall in one PWM period of the device
        (PwmGrid): a period shows the duty in force at its start, so the earlier one
        would never show - exactly the same pin either way (section 16)."""
        grid = self.pwm_grids.get(pin)
        if grid is None:
            return
        wait = self._timed_wait
        for i in range(len(wait) - 1, -1, -1):
            c = wait[i][1]
            if c.analog and c.pin == pin:
                origin, period = grid
                if ((wait[i][2] - origin) & 0xFFFFFFFF) // period == \
                        ((device_tick - origin) & 0xFFFFFFFF) // period:
                    del wait[i]
                return

    def _send_timed(self) -> None:
        """Send waiting timed changes while the device has slots for them."""
        if not self.connected:
            self._timed_wait.clear()  # a new session replays the outputs' last state
            self._timed_sent.clear()
            self._hold_entries()
            return
        now = self.now()
        sent = self._timed_sent = [t for t in self._timed_sent if t > now]
        wait = self._timed_wait
        while wait and len(sent) < TIMED_SLOTS:
            tick, change, device_tick = wait.popleft()
            # (made at its own tick: it need not wait behind queue entries not yet
            # framed - they have the link's planning time ahead of them)
            self.send(self.outputs.timed(change, device_tick), overtake_entries=True)
            if tick > now:
                sent.append(tick)
        self._hold_entries()

    def _hold_entries(self) -> None:
        """While timed changes wait for the device's slots, the link holds queue entries
        back so that the line is free when the next of them goes (when a slot comes
        free) and it arrives by its tick: entries carry the link's planning time ahead
        of them, a timed change only what the slots allow (section 16)."""
        link = self.link
        if link is None:
            return
        if not self._timed_wait:
            link.entries_by_ns = None
            return
        frame_ns = (FRAME_OVERHEAD + link.payload) * link.byte_ns
        tick_ns = self.sync.ns_at(self._timed_wait[0][0])
        link.entries_by_ns = tick_ns - frame_ns
        link.entries_hold_end_ns = tick_ns  # (past its tick it is late anyway)

    # ------------------------------------------------------- inputs (issue 13)
    def _features(self) -> int:
        """Ident's optional message families of the device (section 5)."""
        ident = self.ident
        return ident.features if ident is not None else 0

    def watch_input(self, pin: int, analog: bool = False, pullup: bool = True,
                    period_ms: int = 0) -> bool:
        if self.connected and not self._features() & F_INPUTS:
            return False  # a device without inputs (section 18) would refuse the watch
        self._send_and_flush(self.inputs.watch(pin, analog, pullup, period_ms))
        return True

    def read_input(self, pin: int) -> int | None:
        return self.inputs.values.get(pin)

    def drive_input(self, pin: int, value: int) -> bool:
        """A simulated device (Ident feature F_SIM_INPUTS: ``device --pty``, the firmware
        in simavr) lets the host turn its pots and press its switches: SetInput.  The
        device reads the pin as a board would and reports it (Input); a board's inputs
        are its pins (False)."""
        if not (self.connected and self._features() & F_SIM_INPUTS):
            return False
        self.send(self.inputs.drive(pin, value))
        link = self.link
        if link is not None:
            link.flush()
        return True

    def set_limit(self, index: int, pin: int, level: int, up: bool,
                  stop: tuple[int, ...] = ()) -> bool:
        if self.connected and not self._features() & F_INPUTS:
            return False  # a device without limit switches (section 18)
        self._send_and_flush(self.inputs.limit(index, pin, level, up, stop))
        return True

    def clear_limit(self, index: int, up: bool) -> None:
        message = self.inputs.clear_limit(index, up)
        if message is not None:
            self.send(message)

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
            times.append(self.sync.tick_at_ns(self._timer_ns()))
        return min(times) if times else None

    # --------------------------------------------------------------- extras
    def emergency_stop(self) -> bool:
        """Stop every motion on the device at once, take its positions, open a new session.

        False if the device could not be reached (the session is then lost).
        """
        link = self.link
        if link is None or not self.connected:
            return False
        session = self.session
        reports = self.reports
        self._estopping = True
        try:
            count = reports.status_count
            self.estop_ns = self.clock.now_ns()
            estop = EmergencyStop(session.nonce)
            self._send_stop(estop)
            ok = session.wait_for(lambda: reports.status_count > count and reports.estopped(),
                                  self.connect_timeout_ns, lambda: self._send_stop(estop),
                                  self.repeat_ns())
            if not ok:
                self._lose(link.closed or "no answer to the emergency stop")
                return False
            session.account(link)
            session.connected = False
            try:
                self._open_session(link.stream)
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
        reports = self.reports
        count = reports.status_count
        reports.status_seen = set()
        wanted = {ch.index for ch in self.channels}
        ok = self.session.wait_for(
            lambda: reports.status_count > count and wanted <= reports.status_seen,
            timeout_ms * MS, lambda: link.send_unsequenced(StatusRequest()), STATUS_REPEAT_NS)
        return reports.device_status if ok else None

    def settle(self, timeout_ms: int = 2000) -> bool:
        """Wait until every message is acknowledged and the device reports all queues idle."""
        link = self.link
        if link is None or not self.connected:
            return False

        def done() -> bool:
            return link.idle() and not any(ch.is_running() for ch in self.channels)

        return self._run_until(self.now() + timeout_ms * self.sync.clock_hz // 1000, done)

    def link_stats(self) -> dict[str, int]:
        """Link counters over every session so far (rtt: the current one)."""
        return self.session.link_stats()

    def device_counters(self) -> dict[str, int]:
        status = self.reports.device_status
        return status.counters() if status is not None else {}
