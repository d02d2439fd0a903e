"""A device that speaks the serial protocol and executes on the simulated machine.

It is what a board's firmware does, on this computer: the host's queue entries land
in real command queues, and a tick-exact model of the step timer
(:class:`fas.sim.channel.SimChannel`, the AVR compare-interrupt model) executes them.
The device reports queue progress, obeys stops and pin writes, and stops every motion
when the host has been silent longer than its watchdog time.

Time: the machine's tick counter is the device clock, advanced to ``clock`` - the
wall clock (optionally sped up) when serving a pty, or a
:class:`~fas.serial.clock.VirtualClock` in tests, where the device is a peer.
"""

from __future__ import annotations

import random
from collections.abc import Callable

from ..arch import Profile, get_profile
from ..backend import PulseCounter
from ..output_figures import PwmTimer, output_figures
from ..outputs import OutputChange
from ..pwm import PwmSetting
from ..queue import StepperQueue, i32
from ..sim.backend import SimBackend
from ..sim.channel import SimChannel
from ..sim.machine import PRIO_PLAIN, Event
from ..sim.pins import EdgeRecorder
from .clock import RealClock
from .protocol import (
    D_ESTOP,
    D_SESSION,
    D_WATCHDOG,
    DEVICE_COUNTERS,
    F_INPUTS,
    F_SIM_INPUTS,
    L_CLEAR,
    L_UP,
    MAX_PAYLOAD,
    P_CUT_REFUSED,
    P_DETACHED,
    P_HALTED,
    P_HAS_ENTRY,
    P_HAS_PCNT,
    P_RUNNING,
    P_START_PENDING,
    PROTOCOL_VERSION,
    S_ANALOG,
    UNSEQUENCED,
    W_ANALOG,
    W_OFF,
    W_PULLUP,
    Bye,
    Config,
    Detach,
    DeviceStatus,
    DirPin,
    EmergencyStop,
    Entry,
    ForceStop,
    FrameDecoder,
    Halt,
    Hello,
    Ident,
    Input,
    Limit,
    LimitHit,
    Message,
    Nak,
    OutputCancel,
    OutputPwm,
    OutputSet,
    PcntAttach,
    PcntClear,
    Pin,
    Progress,
    SetEndPos,
    SetInput,
    Start,
    Started,
    Status,
    StatusRequest,
    SyncReply,
    SyncRequest,
    Truncate,
    WatchInput,
    decode_prefix,
    encode_frame,
    pack_messages,
    seq_diff,
    tick_diff32,
)
from .stream import ByteStream, LinkClosed

NS_PER_S = 1_000_000_000
DEFAULT_WATCHDOG_MS = 500
DEFAULT_REPORT_MS = 2
DEFAULT_STATUS_MS = 100
FRAME_BREAK = b""  # in the output list: start a new frame (small frames survive noise)
DEVICE_STATUS_EVERY = 5  # status periods between unrequested DeviceStatus messages
DEFAULT_ANALOG_MS = 50  # WatchInput period 0: sample analog inputs every 50 ms
ANALOG_DEFAULT = 512  # an analog input nobody has set reads mid-scale (a centred pot)


def pwm_timer_for(profile: Profile, number: int, pin: int) -> PwmTimer | None:
    """The timer that makes analog output ``number`` on ``pin`` on this chip."""
    figures = output_figures(profile)
    unit = figures.pwm_pin(pin)
    if unit is not None:
        return figures.pwm_timer(unit.timer)
    if figures.pwm_any_pin and 0 <= number < len(figures.user_analog):
        return figures.pwm_timer(figures.user_analog[number].timer)
    return None


class DeviceChannel(SimChannel):
    """The simulated step timer, plus the position its emitted pulses amount to."""

    def __init__(self, machine, queue: StepperQueue) -> None:
        super().__init__(machine, queue)
        self.pulse_pos = 0  # exact position from the pulses made (survives any stop)
        self.underruns = 0

    def _emit(self, first: int, width: int, count: int, period: int = 1) -> None:
        q = self.q
        e = q.entries[q.read_idx % q.queue_len]
        self.pulse_pos = i32(self.pulse_pos + (count if e.count_up else -count))
        super()._emit(first, width, count, period)


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


class Device:
    """The protocol's device side on a :class:`SimBackend` machine (see module text)."""

    def __init__(self, stream: ByteStream | None, profile: Profile | str | None = None,
                 clock=None, *, watchdog_ms: int = DEFAULT_WATCHDOG_MS,
                 status_ms: int = DEFAULT_STATUS_MS, record: bool = False,
                 boot_id: int | None = None, queue_len: int | None = None,
                 rx_slots: int | None = None) -> None:
        self.profile = get_profile(profile)
        p = self.profile
        # the queue rings as deep as the firmware's RAM allows (or as a test asks)
        self.ring_profile = p.with_queue_len(queue_len or p.serial_queue_len)
        self.rx_slots = p.serial_rx_slots if rx_slots is None else rx_slots
        self.slot_payload = p.serial_slot_payload
        self.clock = clock or RealClock()
        self.sim = SimBackend(p)  # the machine and its pins; no engine runs here
        self.machine = self.sim.machine
        self.recorder: EdgeRecorder | None = None
        if record:
            self.recorder = EdgeRecorder()
            self.machine.pins.sinks.append(self.recorder)
        self.tps = p.ticks_per_s
        self.boot_ns = self.clock.now_ns()
        self.boot_id = random.getrandbits(16) if boot_id is None else boot_id & 0xFFFF
        self.default_watchdog_ms = watchdog_ms
        self.watchdog_ticks = self._ms_ticks(watchdog_ms)
        self.report_ticks = self._ms_ticks(DEFAULT_REPORT_MS)
        self.status_ticks = self._ms_ticks(status_ms)
        self.queues: dict[int, StepperQueue] = {}
        self.stops: dict[int, StopState] = {}
        self.stop_ticks: dict[int, int] = {}  # when a stop last ended a queue's motion
        self.start_events: dict[int, Event] = {}
        self.held: dict[int, bytes] = {}  # out-of-order frames by sequence number
        self.decoder = FrameDecoder()
        self.expected = 0
        self.nonce: int | None = None
        self._old_nonces: tuple[tuple[int, int], ...] = ()  # (nonce, tick) of ended sessions
        self.session = False
        self.watchdog_tripped = False
        self.estopped = False
        self.halt_tick: int | None = None
        self.estop_tick: int | None = None  # when the last emergency stop was taken
        self.last_rx_tick = 0
        self.out: list[bytes] = []
        self.ack_due = False  # an acknowledgement is owed; it rides the next report ...
        self._ack_now = False  # ... unless the host is waiting for it (it repeated a frame)
        self.last_progress: dict[int, tuple[int, int, int, int]] = {}
        self.next_report_tick = 0
        self.next_status_tick = 0
        self._refresh_round = 0
        self._nak_owed = False
        self.counters = dict.fromkeys(DEVICE_COUNTERS, 0)
        self.listeners: list[Callable[[str], None]] = []  # session events, for the CLI
        # watched inputs: pin -> [mode, sample period (ticks), next sample, value reported]
        self.watches: dict[int, list[int]] = {}
        self.analog: dict[int, int] = {}  # the analog inputs' values (set_input)
        # limit switches: (stepper, up) -> (pin, level, stop mask)
        self.limits: dict[tuple[int, bool], tuple[int, int, int]] = {}
        # optional message families (Ident): inputs, limits and Started (section 18);
        # the inputs are this simulation's, so the host may set them (SetInput)
        self.features = F_INPUTS | F_SIM_INPUTS
        self.sequenced_handlers = self._default_handlers()
        self.stream: ByteStream | None = None
        self.in_wires: list = []
        self.attach(stream)

    # ---------------------------------------------------------------- clock
    def _ms_ticks(self, ms: int) -> int:
        return ms * self.tps // 1000

    def tick_at(self, now_ns: int) -> int:
        return (now_ns - self.boot_ns) * self.tps // NS_PER_S

    def ns_at(self, tick: int) -> int:
        return self.boot_ns + -(-tick * NS_PER_S // self.tps)

    @property
    def now(self) -> int:
        return self.machine.now

    @property
    def clock_hz(self) -> int:
        return int(self.tps * self.clock.scale)

    # ----------------------------------------------------------- the line
    def attach(self, stream: ByteStream | None) -> None:
        """Plug a line in (``None``: unplugged; the machine keeps running)."""
        self.stream = stream
        self.decoder.reset()
        self.in_wires = [stream.rx_wire] if stream is not None and stream.rx_wire else []

    def unplug(self) -> None:
        if self.stream is not None:
            if self.stream.rx_wire is not None:
                self.stream.rx_wire.drain()
            self.stream.close()
        self.attach(None)

    def poll(self) -> None:
        """Take every byte that arrived and act on the frames in it."""
        for seq, payload in self._receive():
            self._on_frame(seq, payload)

    def _receive(self) -> list[tuple[int, bytes]]:
        if self.stream is None:
            return []
        try:
            data = self.stream.read_available()
        except LinkClosed:
            self.attach(None)
            return []
        frames = self.decoder.feed(data) if data else []
        self.counters["crc_errors"] = self.decoder.crc_errors
        self.counters["framing_errors"] = self.decoder.framing_errors
        return frames

    def flush(self) -> bool:
        """Send what is queued (and a bare acknowledgement if one is due).

        While frames are missing (a Nak is owed, or out-of-order frames are held),
        every frame sent begins with a Nak with the held frames' bitmap."""
        if not self.out and not (self.ack_due and self._ack_now) and not self._nak_owed:
            return False
        if self.ack_due:
            self._changed_progress(only_changed=True)
        nak = self._nak().encode() if self._nak_owed or self.held else b""
        payloads = []
        group: list[bytes] = []
        for m in [*self.out, FRAME_BREAK]:
            if not m:  # FRAME_BREAK (every message has at least its type byte)
                payloads += pack_messages(group, MAX_PAYLOAD - len(nak))
                group = []
            else:
                group.append(m)
        payloads = [nak + p for p in payloads] or [nak]
        self.out = []
        self.ack_due = self._ack_now = self._nak_owed = False
        if self.stream is None:
            return False
        wrote = False
        for payload in payloads:
            try:
                n = self.stream.write(encode_frame(self.expected, payload))
            except LinkClosed:
                self.attach(None)
                return wrote
            wrote = wrote or n > 0
        self.counters["tx_dropped"] = getattr(self.stream, "tx_dropped", 0)
        return wrote

    def _nak(self) -> Nak:
        held = 0
        for seq in self.held:
            held |= 1 << ((seq - self.expected - 1) & 0x7F)
        return Nak(self.expected, held)

    # --------------------------------------------------------------- time
    def advance(self, now_ns: int) -> None:
        """Run the machine up to ``now_ns``; stop on host silence; queue due reports."""
        t = self.tick_at(now_ns)
        m = self.machine
        deadline = self._watchdog_deadline()
        if deadline is not None and deadline <= t:
            if deadline > m.now:
                m.run_until(deadline)
            self._trip_watchdog()
        if t > m.now:
            m.run_until(t)
        if self.session and self.watches:
            self._sample_inputs()
        if self.session and t >= self.next_report_tick:
            self.next_report_tick = t - (t % self.report_ticks) + self.report_ticks
            self._changed_progress(only_changed=False)
            self._ack_now = self.ack_due
        if self.session and t >= self.next_status_tick:
            # the slow refresh: every queue's state (a lost report heals here) and,
            # every few rounds, the device state - small, so acknowledgements and
            # reports never queue long behind it on a 115200-baud line
            self.next_status_tick = t + self.status_ticks
            self._refresh_round += 1
            for idx, q in self.queues.items():
                key = self._progress_key(idx, q)
                self.last_progress[idx] = key
                self.out.append(Progress(idx, *key).encode())
            for pin, w in self.watches.items():  # a lost input report heals here
                self.out.append(Input(pin, w[3], m.now & 0xFFFFFFFF).encode())
            if self._refresh_round % DEVICE_STATUS_EVERY == 0:
                self.out.append(self._device_status().encode())

    def next_ns(self) -> int | None:
        times = []
        t = self.machine.next_event_time()
        if t is not None:
            times.append(t)
        if self.session:
            times.append(self.next_status_tick)
            if self.ack_due or self._reporting():
                times.append(self.next_report_tick)
            deadline = self._watchdog_deadline()
            if deadline is not None:
                times.append(deadline)
            for pin, w in self.watches.items():
                if w[0] == W_ANALOG and self._input_value(pin, w[0]) != w[3]:
                    times.append(w[2])  # a changed analog input is read at its sample
        if not times:
            return None
        return self.ns_at(max(min(times), self.machine.now + 1))

    def _watchdog_deadline(self) -> int | None:
        if not self.session or self.watchdog_tripped or not self.watchdog_ticks:
            return None
        return self.last_rx_tick + self.watchdog_ticks + 1

    def _reporting(self) -> bool:
        for idx, q in self.queues.items():
            if q.channel.running or idx in self.start_events:
                return True
            if self.last_progress.get(idx) != self._progress_key(idx, q):
                return True
        return False

    def serve(self, stop: Callable[[], bool] = lambda: False,
              each: Callable[[], None] | None = None) -> None:
        """Run in real time until ``stop()`` (the device's main loop on a pty);
        ``each()`` runs once per turn of the loop (e.g. inputs typed at the terminal)."""
        clock = self.clock
        while not stop():
            if each is not None:
                each()
            self.advance(clock.now_ns())
            self.flush()
            nxt = self.next_ns()
            limit = clock.now_ns() + int(0.2 * NS_PER_S * clock.scale)  # look at stop()
            nxt = limit if nxt is None else min(nxt, limit)
            clock.wait(nxt, self.stream)
            # frames that waited in the buffer while this process was busy arrived before
            # now: they count for the watchdog before time is caught up (a UART interrupt
            # would have taken them on arrival)
            now = clock.now_ns()
            frames = self._receive()
            if frames and self.session:
                self.last_rx_tick = max(self.last_rx_tick, self.tick_at(now))
            self.advance(now)
            for seq, payload in frames:
                self._on_frame(seq, payload)
            self.flush()

    # ------------------------------------------------------------- frames
    def _on_frame(self, seq: int, payload: bytes) -> None:
        if self.session:
            self.last_rx_tick = self.machine.now
        if seq & UNSEQUENCED:
            for m in self._decode(payload):
                self._unsequenced(m)
            return
        if not self.session:
            self.counters["rejected"] += 1
            self.out.append(self._device_status().encode())
            return
        d = seq_diff(seq, self.expected)
        self.ack_due = True
        if d < 0 or seq in self.held:
            self.counters["frames_duplicate"] += 1
            self._ack_now = True  # the host repeats itself: it waits for this
            self._nak_owed = bool(self.held)
            return
        if d > 0:
            # a gap: hold the frame if it is within the slots, and say what is missing -
            # at once for a new gap, else with the next report
            self.counters["frames_out_of_order"] += 1
            if not self.held:
                self._nak_owed = True
            if d <= self.rx_slots and len(payload) <= self.slot_payload:
                self.held[seq] = payload
                self.counters["frames_held"] += 1
            return
        self._take(payload)
        if self.held:
            while self.expected in self.held:  # the gap is filled: the held ones follow
                self._take(self.held.pop(self.expected))
            self._ack_now = True
            self._nak_owed = bool(self.held)

    def _take(self, payload: bytes) -> None:
        """The next frame in sequence: act on its messages, in order."""
        self.expected = (self.expected + 1) & 0x7F
        self.counters["frames_ok"] += 1
        for m in self._decode(payload):
            self._sequenced(m)

    def _decode(self, payload: bytes) -> list[Message]:
        msgs, error = decode_prefix(payload)
        if error:  # a message the device does not know: the rest of the frame is lost
            self.counters["rejected"] += 1
        return msgs

    def _unsequenced(self, m: Message) -> None:
        if isinstance(m, Hello):
            self._hello(m)
        elif isinstance(m, SyncRequest):
            self.out.append(SyncReply(m.stamp, self.machine.now & 0xFFFFFFFF).encode())
        elif isinstance(m, Halt):
            self._halt_stepper(m)
        elif isinstance(m, StatusRequest):
            self._queue_status()
        elif isinstance(m, Bye):
            if self.session and m.nonce == self.nonce:
                self._halt()
                self.session = False
                self._old_nonces = (*self._old_nonces, (m.nonce, self.machine.now))[-4:]
                self.nonce = None
                self._notify("session closed")
        elif isinstance(m, EmergencyStop):
            if m.nonce not in (0, self.nonce):
                self.counters["rejected"] += 1
                return
            if not self.estopped:
                self.estopped = True
                self.estop_tick = self.machine.now
                self._halt()
                self._notify("emergency stop")
            self._queue_status()
        else:
            self.counters["rejected"] += 1

    def _hello(self, m: Hello) -> None:
        if any(n == m.nonce and self.machine.now - t < self.tps
               for n, t in self._old_nonces):
            self.counters["rejected"] += 1  # a late copy from a session just ended
            return
        p = self.profile
        # the same nonce again: the host did not hear the answer and still shakes hands
        # (it has sent no command yet), so a watchdog stop meanwhile is simply undone
        new_session = (m.nonce != self.nonce or not self.session or self.watchdog_tripped
                       or self.estopped)
        watchdog_ms = (m.watchdog_ms or self.default_watchdog_ms) if new_session \
            else self.watchdog_ticks * 1000 // self.tps
        self.out.append(Ident(PROTOCOL_VERSION, m.nonce, self.boot_id, p.ticks_per_s,
                              self.clock_hz, p.max_steppers, self.ring_profile.queue_len,
                              self.rx_slots, self.slot_payload, watchdog_ms,
                              p.ticks_per_s // p.min_cmd_ticks, self.features,
                              p.name).encode())
        # the state as the new host finds it (positions, a watchdog stop, counters) ...
        self._queue_status()
        if new_session:
            # ... then a fresh session: motion stopped, counters from zero
            self.counters = dict.fromkeys(DEVICE_COUNTERS, 0)
            self.decoder.crc_errors = self.decoder.framing_errors = 0
            if self.nonce is not None and self.nonce != m.nonce:
                self._old_nonces = (*self._old_nonces, (self.nonce, self.machine.now))[-4:]
            self.nonce = m.nonce
            self._halt()
            self.session = True
            self.watchdog_tripped = False
            self.estopped = False
            self.expected = 0
            self.held.clear()
            self._nak_owed = False
            self.stops = {idx: StopState() for idx in self.queues}
            self.watches.clear()  # the new host asks for the inputs it wants
            self.limits.clear()
            self.watchdog_ticks = self._ms_ticks(m.watchdog_ms or self.default_watchdog_ms)
            if m.report_ms:
                self.report_ticks = self._ms_ticks(m.report_ms)
            self.last_rx_tick = self.machine.now
            self.next_status_tick = self.machine.now + self.status_ticks
            self._notify("session opened")

    def _sequenced(self, m: Message) -> None:
        handler = self.sequenced_handlers.get(type(m))
        if handler is None:
            self.counters["rejected"] += 1
        else:
            handler(m)

    def _default_handlers(self) -> dict[type[Message], Callable[[Message], None]]:
        """The sequenced messages this device acts on (a new message type adds its
        handler here: docs/serial-protocol.md, section 5)."""
        return {Entry: self._entry, Start: self._start, Pin: self._pin,
                ForceStop: self._force_stop, SetEndPos: self._set_end_pos,
                Config: self._config, DirPin: self._dir_pin, Detach: self._detach,
                PcntAttach: self._pcnt_attach, PcntClear: self._pcnt_clear,
                Truncate: self._truncate, OutputPwm: self._output, OutputSet: self._output,
                OutputCancel: self._output, WatchInput: self._watch, Limit: self._limit,
                SetInput: self._set_input}

    def _pin(self, m: Pin) -> None:
        self.machine.pins.set(m.pin, m.level, self.machine.now)

    def _dir_pin(self, m: DirPin) -> None:
        q = self._queue(m.stepper)
        if q is not None:
            q.dir_pin = m.dir_pin

    def _detach(self, m: Detach) -> None:
        q = self._queue(m.stepper)
        if q is not None:
            q.channel.detached = bool(m.detached)

    def _pcnt_attach(self, m: PcntAttach) -> None:
        q = self._queue(m.stepper)
        if q is not None:
            q.channel.sync()
            counter = PulseCounter(m.low, m.high, bool(m.dir_high_counts_up))
            counter.value = m.value
            q.channel.pulse_counter = counter

    def _pcnt_clear(self, m: PcntClear) -> None:
        q = self._queue(m.stepper)
        if q is not None and q.channel.pulse_counter is not None:
            q.channel.sync()
            q.channel.pulse_counter.clear()

    # -------------------------------------------------- user outputs (issue 12)
    def _output(self, m: Message) -> None:
        """PWM timers, output changes at once or after every queue ran dry, cancel."""
        sim = self.sim
        if isinstance(m, OutputCancel):
            sim.cancel_sync_outputs()
            return
        if isinstance(m, OutputPwm):
            timer = pwm_timer_for(self.profile, m.number, m.pin)
            if timer is None or m.counts < 2 or m.clock_div < 1:
                self.counters["rejected"] += 1
                return
            setting = PwmSetting(timer.name, timer.clock_hz, timer.divider_frac_bits,
                                 m.clock_div, m.counts, 0.0)
            sim.configure_pwm(m.number, m.pin, setting, min(m.count, m.counts))
            return
        change = OutputChange(m.analog, m.number, m.pin, m.value if m.analog else
                              (1 if m.value else 0))
        if m.synchronized and not (self.watchdog_tripped or self.estopped):
            sim.sync_output(change)
        elif m.synchronized:
            self.counters["rejected"] += 1
        else:
            sim.set_output(change)

    # ------------------------------------------------------------ queues
    def allocate_channel(self, queue: StepperQueue) -> DeviceChannel:
        """(StepperQueue calls this while it is built: the device is its backend.)"""
        ch = DeviceChannel(self.machine, queue)
        ch.on_idle = self.sim._queue_idle  # synchronized outputs wait for this (issue 12)
        self.sim.channels.append(ch)
        return ch

    def _queue(self, stepper: int) -> StepperQueue | None:
        q = self.queues.get(stepper)
        if q is None:
            self.counters["rejected"] += 1
        return q

    def _config(self, m: Config) -> None:
        if m.stepper >= self.profile.max_steppers:
            self.counters["rejected"] += 1
            return
        q = self.queues.get(m.stepper)
        if q is not None and q.step_pin != m.step_pin:
            self._stop_queue(m.stepper, q)
            self.sim.channels.remove(q.channel)
            q = None
        if q is None:
            q = StepperQueue(m.stepper, self.ring_profile, self, m.step_pin)
            self.queues[m.stepper] = q
        else:
            self._stop_queue(m.stepper, q)
        self.stops[m.stepper] = StopState()
        q.dir_pin = m.dir_pin
        q.channel.pulses = 0
        q.channel.underruns = 0
        q.read_idx = q.next_write_idx = m.index & 0xFF
        q.queue_end_pos = m.end_pos
        q.channel.pulse_pos = m.end_pos
        self.last_progress.pop(m.stepper, None)

    def _stop_queue(self, stepper: int, q: StepperQueue) -> None:
        ev = self.start_events.pop(stepper, None)
        if ev is not None:
            self.machine.cancel(ev)
        if q.channel.running or ev is not None:
            self.stop_ticks[stepper] = self.machine.now
        q.channel.force_stop()

    def _discarding(self, stepper: int) -> bool:
        """Halted or after a refused cut: this message for ``stepper`` is dropped."""
        if self.stops[stepper].discarding:
            self.counters["discarded"] += 1
            return True
        return False

    def _entry(self, m: Entry) -> None:
        q = self._queue(m.stepper)
        if q is None:
            return
        if self.watchdog_tripped or self.estopped:
            self.counters["rejected"] += 1
            return
        if self._discarding(m.stepper):
            return
        wp = q.next_write_idx
        gap = (m.index - wp) & 0x0F
        if gap >= 8:
            self.counters["entries_duplicated"] += 1
            return
        if gap:
            self.counters["entries_lost"] += gap
        if ((wp - q.read_idx) & 0xFF) >= q.queue_len:
            self.counters["overflows"] += 1
            return
        e = q.entries[wp % q.queue_len]
        e.steps = e.total_steps = m.steps
        e.ticks = m.ticks
        q.durations[wp % q.queue_len] = m.ticks * m.steps if m.steps > 1 else m.ticks
        e.count_up = m.count_up
        e.toggle_dir = m.toggle_dir
        e.dir_level = m.dir_level
        e.end_pos = i32(q.queue_end_pos + (m.steps if m.count_up else -m.steps))
        q.next_write_idx = (wp + 1) & 0xFF
        q.queue_end_pos = e.end_pos
        q.queue_end_count_up = m.count_up
        q.queue_end_dir = m.dir_level
        q.entries_added += 1
        self.counters["entries"] += 1
        ch = q.channel
        if m.cont and not ch.running and m.stepper not in self.start_events:
            # the host meant this to follow a running queue, which already ran dry
            self.counters["underruns"] += 1
            ch.underruns += 1
            self._start_queue(m.stepper, q)

    def _start(self, m: Start) -> None:
        delta = tick_diff32(m.at, self.machine.now & 0xFFFFFFFF)
        for idx in range(8):
            if not m.mask & (1 << idx):
                continue
            q = self._queue(idx)
            if q is None:
                continue
            if self.watchdog_tripped or self.estopped:
                self.counters["rejected"] += 1
                continue
            if self._discarding(idx):
                continue
            old = self.start_events.pop(idx, None)
            if old is not None:
                self.machine.cancel(old)
            if delta <= 0:
                if delta < 0:
                    self.counters["late_starts"] += 1
                self._start_queue(idx, q)
            else:
                self.start_events[idx] = self.machine.schedule(
                    self.machine.now + delta, lambda i=idx: self._timed_start(i), PRIO_PLAIN)

    def _timed_start(self, idx: int) -> None:
        self.start_events.pop(idx, None)
        q = self.queues.get(idx)
        if q is not None:
            self._start_queue(idx, q)

    def _start_queue(self, idx: int, q: StepperQueue) -> None:
        """Start the step timer on the queue and tell the host when its first entry
        begins (the host plans other queues on that timeline, section 18)."""
        ch = q.channel
        was = ch.is_running()
        begin = ch.earliest_start_tick()
        ch.start()
        if not was and ch.is_running():
            self.out.append(Started(idx, begin & 0xFFFFFFFF).encode())

    def _force_stop(self, m: ForceStop) -> None:
        q = self._queue(m.stepper)
        if q is None:
            return
        self._stop_queue(m.stepper, q)
        # the position is where the pulses stopped; the host may rename it (SetEndPos)
        q.read_idx = q.next_write_idx = m.index & 0xFF
        q.queue_end_pos = q.channel.pulse_pos
        st = self.stops[m.stepper]
        st.halted = st.refused = False
        st.halt_id = m.stop_id
        self.sim._queue_idle()  # synchronized outputs wait for idle queues (section 16)

    def _halt_stepper(self, m: Halt) -> None:
        """Halt (unsequenced): stop one queue now; drop its motion until the ForceStop."""
        q = self.queues.get(m.stepper)
        if not self.session or m.nonce != self.nonce or q is None:
            self.counters["rejected"] += 1
            return
        st = self.stops[m.stepper]
        if m.stop_id == st.halt_id:
            return  # a copy of a Halt already acted on (or whose ForceStop came)
        st.halt_id = m.stop_id
        st.halted = True
        st.refused = False
        self.counters["halts"] += 1
        self.stop_ticks[m.stepper] = self.machine.now
        self._stop_queue(m.stepper, q)
        q.read_idx = q.next_write_idx
        q.queue_end_pos = q.channel.pulse_pos
        self._report(m.stepper)
        self.sim._queue_idle()

    def _truncate(self, m: Truncate) -> None:
        """Drop the entries from ``m.index`` on, if none of them has begun (a cut)."""
        q = self._queue(m.stepper)
        if q is None:
            return
        st = self.stops[m.stepper]
        if st.halted:
            self.counters["discarded"] += 1
            return
        ch = q.channel
        ch.sync()
        rp, wp = q.read_idx, q.next_write_idx
        fill = (wp - rp) & 0xFF
        d = (m.index - rp) & 0xFF
        if d > fill or (d == 0 and fill and ch.running):
            # too late: the cut point has begun or passed; the queue runs on as it is
            st.refused = True
            self.counters["cuts_refused"] += 1
            self._report(m.stepper)
            return
        st.refused = False
        if d == fill:
            return  # a cut at the write index drops nothing
        self.counters["cuts"] += 1
        i = m.index
        while i != wp:
            e = q.entries[i % q.queue_len]
            q.queue_end_pos = i32(q.queue_end_pos - (e.total_steps if e.count_up
                                                     else -e.total_steps))
            i = (i + 1) & 0xFF
        q.next_write_idx = m.index & 0xFF

    def _set_end_pos(self, m: SetEndPos) -> None:
        q = self._queue(m.stepper)
        if q is None or self._discarding(m.stepper):
            return
        delta = i32(m.pos - q.queue_end_pos)
        if delta:
            q.shift_positions(delta)
            q.channel.pulse_pos = i32(q.channel.pulse_pos + delta)

    def _halt(self) -> None:
        """Stop every queue at once; positions stay exact (where the pulses stopped).
        Synchronized output changes not made yet are dropped; outputs stay as they are."""
        self.halt_tick = self.machine.now
        self.sim.cancel_sync_outputs()
        for idx, q in self.queues.items():
            self._stop_queue(idx, q)
            q.read_idx = q.next_write_idx
            q.queue_end_pos = q.channel.pulse_pos

    def _trip_watchdog(self) -> None:
        self.watchdog_tripped = True
        self.counters["watchdog_trips"] += 1
        self._halt()
        self._queue_status()
        self._notify("watchdog: host silent, motion stopped")

    def _notify(self, event: str) -> None:
        for fn in self.listeners:
            fn(event)

    # ------------------------------------------------- inputs (section 18)
    def _watch(self, m: WatchInput) -> None:
        if m.mode == W_OFF:
            self.watches.pop(m.pin, None)
            return
        if m.mode > W_ANALOG:
            self.counters["rejected"] += 1
            return
        pins = self.machine.pins
        if m.mode == W_PULLUP and m.pin not in pins.first_write:
            pins.set(m.pin, 1, self.machine.now)  # the pull-up holds an open input high
        period = self._ms_ticks(m.period_ms or DEFAULT_ANALOG_MS)
        value = self._input_value(m.pin, m.mode)
        self.watches[m.pin] = [m.mode, period, self.machine.now + period, value]
        self.out.append(Input(m.pin, value, self.machine.now & 0xFFFFFFFF).encode())

    def _input_value(self, pin: int, mode: int) -> int:
        if mode == W_ANALOG:
            return self.analog.get(pin, ANALOG_DEFAULT)
        return self.machine.pins.get(pin)

    def _sample_inputs(self) -> None:
        """Digital inputs are reported as soon as they change, analog ones when their
        sample is due and shows a new value."""
        now = self.machine.now
        for pin, w in self.watches.items():
            mode = w[0]
            if mode == W_ANALOG:
                if now < w[2]:
                    continue
                w[2] += w[1] * ((now - w[2]) // w[1] + 1)
            value = self._input_value(pin, mode)
            if value != w[3]:
                w[3] = value
                self.out.append(Input(pin, value, now & 0xFFFFFFFF).encode())

    def set_input(self, pin: int, value: int, analog: bool | None = None) -> None:
        """The world outside the board: a switch pulls ``pin`` to ``value`` (0/1) or a
        pot turns analog input ``pin`` to ``value`` (0..1023).  ``analog`` None: as the
        host watches the pin (digital if it does not)."""
        w = self.watches.get(pin)
        if analog is None:
            analog = (w is not None and w[0] == W_ANALOG) or (w is None and pin in self.analog)
        if analog:
            self.analog[pin] = min(max(int(value), 0), 1023)
        else:
            self.machine.pins.set(pin, 1 if value else 0, self.machine.now)
        if self.session and w is not None:
            self._sample_inputs()
        if not analog:
            self._limit_pin_changed(pin, 1 if value else 0)

    def _set_input(self, m: SetInput) -> None:
        """SetInput: the host turns a pot or presses a switch of this simulated board."""
        if not self.features & F_SIM_INPUTS:
            self.counters["rejected"] += 1
            return
        self.set_input(m.pin, m.value, analog=bool(m.flags & S_ANALOG))

    def schedule_input(self, tick: int, pin: int, value: int,
                       analog: bool | None = None) -> None:
        """``set_input`` at device tick ``tick`` (a switch that closes at a known time)."""
        self.machine.schedule(tick, lambda: self.set_input(pin, value, analog), PRIO_PLAIN)

    # ------------------------------------------ limit switches (section 18)
    def _limit(self, m: Limit) -> None:
        q = self._queue(m.stepper)
        if q is None:
            return
        key = (m.stepper, bool(m.flags & L_UP))
        if m.flags & L_CLEAR:
            self.limits.pop(key, None)
            return
        lim = (m.pin, 1 if m.level else 0, m.stop_mask)
        self.limits[key] = lim
        q.channel.entry_guard = lambda e, i=m.stepper: self._guard(i, e)
        # a switch already closed while the queue steps towards it stops it now
        if self.machine.pins.get(lim[0]) == lim[1] and q.channel.is_running() \
                and q.channel.moving_up() == key[1]:
            self._limit_stop(m.stepper, lim)

    def _guard(self, idx: int, entry) -> bool:
        lim = self.limits.get((idx, entry.count_up))
        if lim is None or self.machine.pins.get(lim[0]) != lim[1]:
            return False
        self.queues[idx].channel.on_halt = lambda: self._limit_stop(idx, lim)
        return True

    def _limit_pin_changed(self, pin: int, level: int) -> None:
        for (idx, up), lim in list(self.limits.items()):
            if lim[0] != pin or lim[1] != level:
                continue
            q = self.queues.get(idx)
            if q is not None and q.channel.is_running() and q.channel.moving_up() == up:
                self._limit_stop(idx, lim)

    def _limit_stop(self, idx: int, lim: tuple[int, int, int]) -> None:
        """Stop the queue and those in the limit's mask where their pulses are; tell the
        host; drop their entries and starts until the host's ForceStop (as a Halt)."""
        now = self.machine.now
        for i in sorted({idx} | {j for j in self.queues if lim[2] & (1 << j)}):
            q = self.queues[i]
            if i != idx and not q.channel.is_running():
                continue
            q.channel.on_halt = None
            self._stop_queue(i, q)
            q.read_idx = q.next_write_idx
            q.queue_end_pos = q.channel.pulse_pos
            st = self.stops[i]
            st.halted = True
            st.refused = False
            self.out.append(LimitHit(i, lim[0], q.next_write_idx, q.channel.pulse_pos,
                                     now & 0xFFFFFFFF).encode())
        self.sim._queue_idle()

    # ------------------------------------------------------------ reports
    def _progress_key(self, idx: int, q: StepperQueue) -> tuple[int, int, int, int]:
        ch = q.channel
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

    def _report(self, idx: int) -> None:
        """Progress of queue ``idx`` in the next frame (a stop or a refused cut)."""
        key = self._progress_key(idx, self.queues[idx])
        self.last_progress[idx] = key
        self.out.append(Progress(idx, *key).encode())

    def _changed_progress(self, only_changed: bool) -> None:
        for idx, q in self.queues.items():
            key = self._progress_key(idx, q)
            moving = key[0] & (P_RUNNING | P_START_PENDING)
            if key != self.last_progress.get(idx) or (moving and not only_changed):
                self.last_progress[idx] = key
                self.out.append(Progress(idx, *key).encode())

    def _queue_status(self) -> None:
        for idx, q in self.queues.items():
            key = self._progress_key(idx, q)
            self.last_progress[idx] = key
            flags, rp, steps, pcnt = key
            self.out.append(FRAME_BREAK)
            self.out.append(Status(idx, flags, rp, steps, q.current_position(),
                                   q.channel.pulses & 0xFFFFFFFF,
                                   q.channel.underruns & 0xFFFF, pcnt).encode())
        self.out.append(FRAME_BREAK)
        self.out.append(self._device_status().encode())
        self.out.append(FRAME_BREAK)

    def _device_status(self) -> DeviceStatus:
        state = (D_WATCHDOG if self.watchdog_tripped else 0) | (D_ESTOP if self.estopped else 0) \
            | (D_SESSION if self.session else 0)
        c = self.counters
        wrap = [c[name] & (0xFFFFFFFF if i < 2 else 0xFFFF)
                for i, name in enumerate(DEVICE_COUNTERS)]
        return DeviceStatus(self.machine.now & 0xFFFFFFFF, state, *wrap)

    # ---------------------------------------------------------- inspection
    def position(self, stepper: int) -> int:
        return self.queues[stepper].current_position()

    def pulses(self, stepper: int) -> int:
        return self.queues[stepper].channel.pulses

    def step_edges(self, stepper: int) -> int:
        """Rising edges seen on the stepper's step pin."""
        return self.machine.pins.rising(self.queues[stepper].step_pin)

    def running(self) -> bool:
        return any(q.channel.running for q in self.queues.values()) or bool(self.start_events)
