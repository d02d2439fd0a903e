"""The protocol's session and link layer on the device (``firmware/session.c``).

Hello and Ident, sequencing with out-of-order slots and Naks, acknowledgements, the
unsequenced messages (clock samples, status, Bye, emergency stop, Halt), the periodic
reports and the host-silence watchdog (docs/serial-protocol.md, sections 3, 4, 6, 7,
9, 11).  Sequenced messages go to the handlers of the device's parts.
"""

from __future__ import annotations

from collections.abc import Callable

from ..serial.protocol import (
    D_ESTOP,
    D_SESSION,
    D_WATCHDOG,
    DEVICE_COUNTERS,
    MAX_PAYLOAD,
    PROTOCOL_VERSION,
    UNSEQUENCED,
    Bye,
    DeviceStatus,
    EmergencyStop,
    FrameDecoder,
    Halt,
    Hello,
    Ident,
    Message,
    Nak,
    StatusRequest,
    SyncReply,
    SyncRequest,
    decode_prefix,
    pack_messages,
    seq_diff,
)
from .board import FRAME_BREAK, Board
from .inputs import DeviceInputs
from .limits import DeviceLimits
from .outputs import DeviceOutputs
from .queues import DeviceQueues, Handler

DEFAULT_WATCHDOG_MS = 500
DEFAULT_REPORT_MS = 2
DEFAULT_STATUS_MS = 100
DEVICE_STATUS_EVERY = 5  # status periods between unrequested DeviceStatus messages
OLD_SESSIONS = 4  # ended sessions whose late Hello copies are ignored


class Session:
    """One host's session with the device, and the frames of the link (module text)."""

    def __init__(self, board: Board, queues: DeviceQueues, limits: DeviceLimits,
                 inputs: DeviceInputs, outputs: DeviceOutputs, decoder: FrameDecoder, *,
                 boot_id: int, clock_hz: int, queue_len: int, rx_slots: int,
                 slot_payload: int, watchdog_ms: int = DEFAULT_WATCHDOG_MS,
                 status_ms: int = DEFAULT_STATUS_MS) -> None:
        self.board = board
        self.queues = queues
        self.limits = limits
        self.inputs = inputs
        self.outputs = outputs
        self.decoder = decoder  # its error counters restart with a session
        # what Ident says
        self.boot_id = boot_id
        self.clock_hz = clock_hz
        self.queue_len = queue_len
        self.rx_slots = rx_slots
        self.slot_payload = slot_payload
        self.default_watchdog_ms = watchdog_ms
        self.watchdog_ticks = board.ms_ticks(watchdog_ms)
        self.report_ticks = board.ms_ticks(DEFAULT_REPORT_MS)
        self.status_ticks = board.ms_ticks(status_ms)
        # sequencing
        self.held: dict[int, bytes] = {}  # out-of-order frames by sequence number
        self.expected = 0
        self.nonce: int | None = None
        self._old_nonces: tuple[tuple[int, int], ...] = ()  # (nonce, tick) of ended sessions
        self.ack_due = False  # an acknowledgement is owed; it rides the next report ...
        self._ack_now = False  # ... unless the host is waiting for it (it repeated a frame)
        self._nak_owed = False
        # time
        self.halt_tick: int | None = None  # when every queue was last stopped at once
        self.estop_tick: int | None = None  # when the last emergency stop was taken
        self.last_rx_tick = 0
        self.next_report_tick = 0
        self.next_status_tick = 0
        self._refresh_round = 0
        self.listeners: list[Callable[[str], None]] = []  # session events, for the CLI
        # the sequenced messages the device acts on (a new message type adds its handler:
        # docs/serial-protocol.md, section 5)
        self.sequenced_handlers: dict[type[Message], Handler] = {}
        for part in (queues, outputs, inputs, limits):
            self.sequenced_handlers.update(part.handlers())

    # ------------------------------------------------------------- frames
    def on_frame(self, seq: int, payload: bytes) -> None:
        """A valid frame from the line."""
        board = self.board
        if board.session_open:
            self.last_rx_tick = board.machine.now
        if seq & UNSEQUENCED:
            for m in self._decode(payload):
                self._unsequenced(m)
            return
        if not board.session_open:
            board.reject()
            board.send(self.device_status())
            return
        counters = board.counters
        d = seq_diff(seq, self.expected)
        self.ack_due = True
        if d < 0 or seq in self.held:
            counters["frames_duplicate"] += 1
            self._ack_now = True  # the host repeats itself: it waits for this
            self._nak_owed = bool(self.held)
            return
        if d > 0:
            # a gap: hold the frame if it is within the slots, and say what is missing -
            # at once for a new gap, else with the next report
            counters["frames_out_of_order"] += 1
            if not self.held:
                self._nak_owed = True
            if d <= self.rx_slots and len(payload) <= self.slot_payload:
                self.held[seq] = payload
                counters["frames_held"] += 1
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
        self.board.counters["frames_ok"] += 1
        for m in self._decode(payload):
            self._sequenced(m)

    def _decode(self, payload: bytes) -> list[Message]:
        msgs, error = decode_prefix(payload)
        if error:  # a message the device does not know: the rest of the frame is lost
            self.board.reject()
        return msgs

    def _sequenced(self, m: Message) -> None:
        handler = self.sequenced_handlers.get(type(m))
        if handler is None:
            self.board.reject()
        else:
            handler(m)

    def _unsequenced(self, m: Message) -> None:
        board = self.board
        if isinstance(m, Hello):
            self._hello(m)
        elif isinstance(m, SyncRequest):
            board.send(SyncReply(m.stamp, board.machine.now & 0xFFFFFFFF))
        elif isinstance(m, Halt):
            if not board.session_open or m.nonce != self.nonce \
                    or m.stepper not in self.queues.queues:
                board.reject()
                return
            self.queues.halt(m.stepper, m.stop_id)
        elif isinstance(m, StatusRequest):
            self.queue_status()
        elif isinstance(m, Bye):
            if board.session_open and m.nonce == self.nonce:
                self.halt_all()
                board.session_open = False
                self._end_session(m.nonce)
                self.nonce = None
                self._notify("session closed")
        elif isinstance(m, EmergencyStop):
            if m.nonce not in (0, self.nonce):
                board.reject()
                return
            if not board.estopped:
                board.estopped = True
                self.estop_tick = board.machine.now
                self.halt_all()
                self._notify("emergency stop")
            self.queue_status()
        else:
            board.reject()

    def _end_session(self, nonce: int) -> None:
        """Late copies of this session's Hello are ignored for a while."""
        self._old_nonces = (*self._old_nonces, (nonce, self.board.machine.now))[-OLD_SESSIONS:]

    def _hello(self, m: Hello) -> None:
        board = self.board
        now = board.machine.now
        if any(n == m.nonce and now - t < board.tps for n, t in self._old_nonces):
            board.reject()  # a late copy from a session just ended
            return
        p = board.profile
        # the same nonce again: the host did not hear the answer and still shakes hands
        # (it has sent no command yet), so a watchdog stop meanwhile is simply undone
        new_session = (m.nonce != self.nonce or not board.session_open
                       or board.watchdog_tripped or board.estopped)
        watchdog_ms = (m.watchdog_ms or self.default_watchdog_ms) if new_session \
            else self.watchdog_ticks * 1000 // board.tps
        board.send(Ident(PROTOCOL_VERSION, m.nonce, self.boot_id, p.ticks_per_s,
                         self.clock_hz, p.max_steppers, self.queue_len, self.rx_slots,
                         self.slot_payload, watchdog_ms, p.ticks_per_s // p.min_cmd_ticks,
                         board.features, p.name))
        # the state as the new host finds it (positions, a watchdog stop, counters) ...
        self.queue_status()
        if new_session:
            # ... then a fresh session: motion stopped, counters from zero
            board.reset_counters()
            self.decoder.crc_errors = self.decoder.framing_errors = 0
            if self.nonce is not None and self.nonce != m.nonce:
                self._end_session(self.nonce)
            self.nonce = m.nonce
            self.halt_all()
            board.session_open = True
            board.watchdog_tripped = False
            board.estopped = False
            self.expected = 0
            self.held.clear()
            self._nak_owed = False
            self.queues.reset_stops()
            self.inputs.reset()
            self.limits.reset()
            self.outputs.new_session()
            self.watchdog_ticks = board.ms_ticks(m.watchdog_ms or self.default_watchdog_ms)
            if m.report_ms:
                self.report_ticks = board.ms_ticks(m.report_ms)
            self.last_rx_tick = board.machine.now
            self.next_status_tick = board.machine.now + self.status_ticks
            self._notify("session opened")

    def take_frames(self) -> list[bytes] | None:
        """The payloads to send now - what is queued, and an acknowledgement or a Nak
        that is owed - or None when nothing is owed.

        While frames are missing (a Nak is owed, or out-of-order frames are held),
        every frame sent begins with a Nak with the held frames' bitmap."""
        board = self.board
        if not board.out and not (self.ack_due and self._ack_now) and not self._nak_owed:
            return None
        if self.ack_due:
            self.queues.report_changed(only_changed=True)
        nak = self._nak().encode() if self._nak_owed or self.held else b""
        payloads: list[bytes] = []
        group: list[bytes] = []
        for m in [*board.out, FRAME_BREAK]:
            if not m:  # FRAME_BREAK (every message has at least its type byte)
                payloads += pack_messages(group, MAX_PAYLOAD - len(nak))
                group = []
            else:
                group.append(m)
        payloads = [nak + p for p in payloads] or [nak]
        board.out.clear()
        self.ack_due = self._ack_now = self._nak_owed = False
        return payloads

    def _nak(self) -> Nak:
        held = 0
        for seq in self.held:
            held |= 1 << ((seq - self.expected - 1) & 0x7F)
        return Nak(self.expected, held)

    # ---------------------------------------------------------- stops
    def halt_all(self) -> None:
        """Stop every queue at once; positions stay exact (where the pulses stopped).
        Synchronized output changes not made yet are dropped; outputs stay as they are."""
        self.halt_tick = self.board.machine.now
        self.outputs.cancel()
        self.queues.halt_all()

    def watchdog_deadline(self) -> int | None:
        """The tick at which the host's silence stops the motion (None: no watchdog)."""
        board = self.board
        if not board.session_open or board.watchdog_tripped or not self.watchdog_ticks:
            return None
        return self.last_rx_tick + self.watchdog_ticks + 1

    def trip_watchdog(self) -> None:
        board = self.board
        board.watchdog_tripped = True
        board.counters["watchdog_trips"] += 1
        self.halt_all()
        self.queue_status()
        self._notify("watchdog: host silent, motion stopped")

    def _notify(self, event: str) -> None:
        for fn in self.listeners:
            fn(event)

    # ------------------------------------------------------------ reports
    def report(self, t: int) -> None:
        """The periodic reports due at device tick ``t`` (the session is open)."""
        queues = self.queues
        if t >= self.next_report_tick:
            self.next_report_tick = t - (t % self.report_ticks) + self.report_ticks
            queues.report_changed(only_changed=False)
            self._ack_now = self.ack_due
        if t >= self.next_status_tick:
            # the slow refresh: every queue's state (a lost report heals here) and,
            # every few rounds, the device state - small, so acknowledgements and
            # reports never queue long behind it on a 115200-baud line
            self.next_status_tick = t + self.status_ticks
            self._refresh_round += 1
            queues.report_all()
            self.inputs.refresh()
            if self._refresh_round % DEVICE_STATUS_EVERY == 0:
                self.board.send(self.device_status())

    def wake_ticks(self) -> list[int]:
        """The ticks at which the session has something to do (the session is open)."""
        times = [self.next_status_tick]
        if self.ack_due or self.queues.reporting():
            times.append(self.next_report_tick)
        deadline = self.watchdog_deadline()
        if deadline is not None:
            times.append(deadline)
        return times

    def queue_status(self) -> None:
        """Status of every queue, then DeviceStatus, each in a frame of its own."""
        board = self.board
        self.queues.send_status()
        board.frame_break()
        board.send(self.device_status())
        board.frame_break()

    def device_status(self) -> DeviceStatus:
        board = self.board
        state = (D_WATCHDOG if board.watchdog_tripped else 0) \
            | (D_ESTOP if board.estopped else 0) | (D_SESSION if board.session_open else 0)
        c = board.counters
        wrap = [c[name] & (0xFFFFFFFF if i < 2 else 0xFFFF)
                for i, name in enumerate(DEVICE_COUNTERS)]
        return DeviceStatus(board.machine.now & 0xFFFFFFFF, state, *wrap)
