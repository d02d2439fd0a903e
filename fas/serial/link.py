"""The host end of the serial link: reliable, ordered delivery of messages to a device.

Sequenced messages (queue entries, pins, starts, stops) are packed into frames of at
most ``max_payload`` bytes, numbered mod 128 and kept until the device acknowledges
them.  Every frame from the device carries its acknowledgement in the SEQ byte.  The
device holds up to ``rx_slots`` frames that arrive after a gap and says which in a
NAK; only the missing frames are sent again (selective repeat): a frame the NAK
shows missing although a later one arrived, or one not acknowledged within its
retransmission timeout.  At most ``rx_slots + 1`` frames are in flight, so every
frame lands in a slot.  The device drops repeated frames, so a message takes effect
exactly once.

Unsequenced messages (hello, clock sync, status request, emergency stop) travel in
frames of their own, are never repeated by the link and may overtake the rest.

Each message gets a message id (``mid``).  ``acked_mid`` is the highest id the device
has processed; a report that arrives in a frame tells the state after exactly those
messages, which is how the backend knows whether a report already reflects, say, a
start it sent.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, fields

from .clock import Clock
from .protocol import (
    ENTRY_BASE,
    FRAME_OVERHEAD,
    MAX_FRAME,
    MAX_PAYLOAD,
    MAX_RX_SLOTS,
    MAX_STEPPERS,
    SEQ_MASK,
    SEQ_MOD,
    UNSEQUENCED,
    FrameDecoder,
    Message,
    Nak,
    SyncReply,
    SyncRequest,
    decode_prefix,
    encode_frame,
)
from .stream import ByteStream, LinkClosed

MS = 1_000_000  # ns


@dataclass
class LinkStats:
    frames_sent: int = 0
    bytes_sent: int = 0
    messages_sent: int = 0
    retransmissions: int = 0  # frames sent again
    retransmit_timeouts: int = 0
    naks: int = 0
    frames_received: int = 0
    bytes_received: int = 0
    crc_errors: int = 0
    framing_errors: int = 0
    discarded_bytes: int = 0
    bad_payloads: int = 0
    stale_acks: int = 0
    frames_held: int = 0  # frames a NAK showed held by the device (not resent)
    sync_samples: int = 0
    rtt_us: int = 0  # smoothed round trip of acknowledged frames

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


class _Frame:
    __slots__ = ("data", "held", "last_mid", "order", "resent", "sent_ns", "seq")

    def __init__(self, seq: int, data: bytes, last_mid: int, sent_ns: int) -> None:
        self.seq = seq
        self.data = data
        self.last_mid = last_mid
        self.sent_ns = sent_ns  # the last time it went out
        self.order = 0  # ... and its place among everything written (the line's order)
        self.resent = False
        self.held = False  # the device holds it (a NAK said so): never resent


LOSS_AVERAGE = 32  # frames over which the share of frames sent again is averaged
MAX_LOSS = 0.9  # a loss estimate is capped here (a few bad frames at first read high)
LOSSY = 0.05  # above this share of lost frames, the frame holding up the window goes twice
PROBES = 8  # clock samples remembered as loss probes


Handler = Callable[[list[Message], int], None]


class HostLink:
    """Framing, acknowledgement, retransmission and clock samples over one stream."""

    def __init__(self, stream: ByteStream, clock: Clock, *, window: int = 9,
                 max_payload: int = 32, min_payload: int = 12, min_rto_ms: float = 10.0,
                 initial_rto_ms: float = 100.0, max_rto_ms: float = 250.0,
                 silence_ms: float = 1500.0, baud: int = 115200) -> None:
        self.stream = stream
        self.clock = clock
        self.window = window
        self.max_payload = min(max_payload, MAX_PAYLOAD)
        self.min_payload = min(min_payload, self.max_payload)
        self.payload = self.max_payload  # current frame size limit (see _fit_payload)
        self.frame_len = float(FRAME_OVERHEAD + self.max_payload)  # average sent, moving
        self._backoff = 0
        self.min_rto_ns = int(min_rto_ms * MS)
        self.max_rto_ns = int(max_rto_ms * MS)
        self.rto_ns = int(initial_rto_ms * MS)
        self.silence_ns = int(silence_ms * MS)
        self.byte_ns = 10 * 1_000_000_000 // baud if baud else 0  # wire time of one byte
        self.srtt_ns: int | None = None
        self.rttvar_ns = 0
        # line quality, as moving averages: the share of our frames that had to be sent
        # again, and the share of the device's frames that arrived damaged
        self.loss_tx = 0.0
        self.loss_rx = 0.0
        self._weight_tx = 0.0  # how much of each average is samples (bias correction:
        self._weight_rx = 0.0  # an average that starts at 0 reads low at first)
        self.decoder = FrameDecoder()
        self.next_seq = 0
        self.unacked: deque[_Frame] = deque()
        self.pending: deque[tuple[int, bytes]] = deque()  # (mid, encoded) not yet framed
        self.next_mid = 1
        self.acked_mid = 0
        # the line's own pace: when the bytes written so far will have left (estimated
        # at the baud rate), and - while timed output changes wait for the device's
        # slots (SerialBackend) - the time by which the line must be free of queue
        # entries, so that the next of them, sent when a slot comes free, is not
        # queued behind entries (None: no limit)
        self.line_free_ns = 0
        self.entries_by_ns: int | None = None
        self.entries_hold_end_ns = 0  # ... and held no longer than until this time
        # (for that estimate a byte takes a quarter longer than the baud says: a busy
        # device may take bytes slower - the firmware in simavr takes ~100 000 baud of
        # a 117 647-baud line while its interrupts compete)
        self._slow_byte_ns = self.byte_ns * 5 // 4
        self.handler: Handler | None = None
        self.probe: Callable[[], None] | None = None  # sends a clock sample (backend)
        self._probes: dict[int, int] = {}  # stamp of a clock sample -> its write order
        self._order = 0  # writes so far: a serial line delivers in this order
        self._probe_mid = 0  # send a probe right after the frame with this message
        self.stats = LinkStats()
        now = clock.now_ns()
        self.last_rx_ns = now
        self.last_tx_ns = now
        self.closed: str | None = None

    # ----------------------------------------------------------------- sending
    def send(self, msg: Message, *, overtake_entries: bool = False) -> int:
        """Queue a sequenced message; returns its message id.

        ``overtake_entries``: the message goes ahead of the queue entries waiting at the
        end of the queue of messages not yet framed (never past any other message, nor
        past another that overtook them): for a message whose effect does not depend on
        its order with entries (a timed output change, made at its own tick).  Its id is
        still a new one; the ids the link tracks (``acked_mid``) are those of messages
        that are not entries, whose order stays as sent."""
        mid = self.next_mid
        self.next_mid += 1
        enc = msg.encode()
        pending = self.pending
        i = len(pending)
        if overtake_entries:
            while i and ENTRY_BASE <= pending[i - 1][1][0] < ENTRY_BASE + MAX_STEPPERS:
                i -= 1
        if i == len(pending):
            pending.append((mid, enc))
        else:
            pending.insert(i, (mid, enc))
        self.stats.messages_sent += 1
        return mid

    def send_unsequenced(self, *msgs: Message) -> None:
        """Send at once in a frame outside the sequence (never repeated by the link)."""
        payload = b"".join(m.encode() for m in msgs)
        self._write(encode_frame(UNSEQUENCED, payload))
        self.stats.messages_sent += len(msgs)

    def in_flight(self) -> int:
        return len(self.unacked)

    def backlog_bytes(self) -> int:
        """Bytes sent but not acknowledged plus bytes queued (for start-time leads)."""
        return sum(len(f.data) for f in self.unacked) + sum(len(m) for _, m in self.pending)

    def idle(self) -> bool:
        return not self.unacked and not self.pending

    @property
    def loss(self) -> float:
        """The share of frames lost on this line (the worse direction)."""
        tx = self.loss_tx / self._weight_tx if self._weight_tx else 0.0
        rx = self.loss_rx / self._weight_rx if self._weight_rx else 0.0
        return min(max(tx, rx), MAX_LOSS)

    def set_limits(self, window: int, max_payload: int) -> None:
        """The device's receive figures: frames in flight and the largest payload."""
        self.window = max(1, window)
        self.max_payload = max(1, min(max_payload, MAX_PAYLOAD))
        self.min_payload = min(self.min_payload, self.max_payload)
        self._fit_payload()

    def flush(self) -> None:
        """Frame queued messages while the window has room; retransmit when due."""
        if self.closed:
            return
        now = self.clock.now_ns()
        if self.unacked:
            timeout = self._timeout_ns()
            due = [f for f in self.unacked if not f.held and now >= f.sent_ns + timeout]
            if due:
                self.stats.retransmit_timeouts += 1
                self._backoff = min(self._backoff + 1, 1)
                self._retransmit(due, now)
        while self.pending and len(self.unacked) < self.window:
            payload = bytearray()
            last_mid = 0
            while self.pending:
                mid, enc = self.pending[0]
                if payload and len(payload) + len(enc) > self.payload:
                    break
                if self._entry_held(enc, len(payload), now):
                    break
                payload += enc
                last_mid = mid
                self.pending.popleft()
            if not payload:
                break  # (entries held back: see entries_by_ns)
            seq = self.next_seq
            self.next_seq = (seq + 1) % SEQ_MOD
            data = encode_frame(seq, bytes(payload))
            self.frame_len += (len(data) - self.frame_len) / LOSS_AVERAGE
            frame = _Frame(seq, data, last_mid, now)
            self.unacked.append(frame)
            self._write(data)
            frame.order = self._order
            if self._probe_mid and last_mid >= self._probe_mid:
                self._probe_mid = 0
                if self.probe is not None:
                    self.probe()

    def _entry_held(self, enc: bytes, framed: int, now: int) -> bool:
        """A queue entry waits while it would keep the line busy past ``entries_by_ns``
        (``framed``: payload bytes already in the frame being made)."""
        if self.entries_by_ns is None or not ENTRY_BASE <= enc[0] < ENTRY_BASE + MAX_STEPPERS:
            return False
        if now >= self.entries_hold_end_ns:
            return False  # (the change is late anyway: the motion is not held for it)
        frame = FRAME_OVERHEAD + framed + len(enc)
        return max(self.line_free_ns, now) + frame * self._slow_byte_ns > self.entries_by_ns

    def _timeout_ns(self) -> int:
        """Retransmission timeout of an open frame: the round trip plus the wire time of
        everything sent with it (a busy 115200-baud line queues frames)."""
        wire = self.byte_ns * (sum(len(f.data) for f in self.unacked) + MAX_FRAME)
        return min(self.rto_ns << self._backoff, self.max_rto_ns) + wire

    def _retransmit(self, frames: list[_Frame], now: int) -> None:
        """Send ``frames`` again (in sequence order), then a clock sample as a probe:
        the device answers it at once, with a Nak if frames are still missing, so a
        repeat that is lost again shows one round trip later.  On a lossy line the
        oldest frame - it holds up the window - goes twice (the device drops the
        second copy)."""
        for f in frames:
            f.sent_ns = now
            f.resent = True
            copies = 2 if f is self.unacked[0] and self.loss > LOSSY else 1
            for _ in range(copies):
                self.stats.retransmissions += 1
                self._write(f.data)
                f.order = self._order
        if self.probe is not None:
            self.probe()

    def _write(self, data: bytes) -> None:
        try:
            self.stream.write(data)
        except LinkClosed as exc:
            self._close(str(exc))
            return
        self._order += 1
        self.stats.frames_sent += 1
        self.stats.bytes_sent += len(data)
        now = self.last_tx_ns = self.clock.now_ns()
        self.line_free_ns = max(self.line_free_ns, now) + len(data) * self._slow_byte_ns

    # --------------------------------------------------------------- receiving
    def service(self) -> None:
        """Take what arrived, process acknowledgements and messages, send what is due."""
        if self.closed:
            return
        try:
            data = self.stream.read_available()
        except LinkClosed as exc:
            self._close(str(exc))
            return
        now = self.clock.now_ns()
        if data:
            self.stats.bytes_received += len(data)
            for seq, payload in self.decoder.feed(data):
                self.last_rx_ns = now
                self.stats.frames_received += 1
                self.loss_rx -= self.loss_rx / LOSS_AVERAGE
                self._weight_rx += (1.0 - self._weight_rx) / LOSS_AVERAGE
                self._on_frame(seq, payload, now)
                # mypy keeps the narrowing of the check above across the call; a frame
                # may close the link (a device reset)
                if self.closed:
                    return  # type: ignore[unreachable]
            d = self.decoder
            bad = d.crc_errors + d.framing_errors - self.stats.crc_errors \
                - self.stats.framing_errors
            for _ in range(bad):
                self.loss_rx += (1.0 - self.loss_rx) / LOSS_AVERAGE
                self._weight_rx += (1.0 - self._weight_rx) / LOSS_AVERAGE
            self.stats.crc_errors = d.crc_errors
            self.stats.framing_errors = d.framing_errors
            self.stats.discarded_bytes = d.discarded_bytes
        elif now - self.last_rx_ns > self.silence_ns:
            self._close("device silent")
            return
        self.flush()

    def _on_frame(self, seq: int, payload: bytes, now: int) -> None:
        self._ack(seq & SEQ_MASK, now)
        msgs, error = decode_prefix(payload)
        if error:  # a message this host does not know: the rest of the frame is lost
            self.stats.bad_payloads += 1
        for m in msgs:
            if isinstance(m, Nak):
                self._on_nak(m.expected, m.held, now)
            elif isinstance(m, SyncReply):
                self._on_probe(m.stamp, now)
        if self.handler is not None and msgs:
            self.handler(msgs, self.acked_mid)

    def _ack(self, expected: int, now: int) -> None:
        if not self.unacked:
            return
        n = (expected - self.unacked[0].seq) % SEQ_MOD
        if n > len(self.unacked):
            self.stats.stale_acks += 1
            return
        if not n:
            return
        self._backoff = 0
        done = [self.unacked.popleft() for _ in range(n)]
        # a round trip only from acknowledgements no repeated or held frame delayed
        clean = not any(f.resent or f.held for f in done)
        for f in done:
            self.acked_mid = max(self.acked_mid, f.last_mid)
            self.loss_tx += ((1.0 if f.resent else 0.0) - self.loss_tx) / LOSS_AVERAGE
            self._weight_tx += (1.0 - self._weight_tx) / LOSS_AVERAGE
            if clean:
                self.rtt_sample(now - f.sent_ns)
        self._fit_payload()

    def _fit_payload(self) -> None:
        """Frames as long as pays on this line.  A frame of L bytes carries L-5 and
        gets through with s = (1-p)^L for a byte error rate p (from the loss and the
        average frame length).  The bytes that arrive per second are bounded by the
        wire, rate * (L-5)/L * s, and by the window, window * (L-5) * s per round trip
        of which a lost frame costs more (s again); the payload is the L that gives the
        most under both bounds."""
        loss = min(self.loss, 0.9)
        if loss <= 0.0:
            self.payload = self.max_payload
            return
        per_byte = -math.log1p(-loss) / self.frame_len  # -ln(1-p)
        wire = 1e9 / self.byte_ns if self.byte_ns else math.inf  # bytes/s
        rtt_s = (self.srtt_ns or self.rto_ns) / 1e9
        best_payload, best = self.max_payload, -1.0
        for payload in range(self.min_payload, self.max_payload + 1):
            length = payload + FRAME_OVERHEAD
            ok = math.exp(-per_byte * length)
            rate = min(wire * payload / length, self.window * payload * ok / rtt_s) * ok
            if rate > best:
                best_payload, best = payload, rate
        self.payload = best_payload

    def _on_nak(self, expected: int, held: int, now: int) -> None:
        """The device holds the frames in ``held`` after ``expected``: the frames it
        misses although a later one arrived are lost (a serial line keeps the order) -
        unless they were sent again after that later one."""
        self.stats.naks += 1
        frames = list(self.unacked)
        last = -1  # the newest frame the device holds
        for k, f in enumerate(frames):
            i = (f.seq - expected - 1) % SEQ_MOD
            if i < MAX_RX_SLOTS and held >> i & 1:
                if not f.held:
                    f.held = True
                    self.stats.frames_held += 1
                last = k
        # a missing frame is lost if a later one arrived (the line keeps the order), or
        # if it went out a round trip ago (this NAK would have seen it)
        newest = frames[last].order if last >= 0 else -1
        guard = now - self._nak_guard_ns()
        lost = [f for f in frames[:max(last, 1)]
                if not f.held and (f.order < newest or f.sent_ns <= guard)]
        if lost:
            self._retransmit(lost, now)

    def probe_after(self, mid: int) -> None:
        """Send a clock sample as a probe right after message ``mid`` goes out: if its
        frame is lost, the answer shows it one round trip later (a Start at the end
        of a burst has no later frame whose arrival would tell)."""
        self._probe_mid = max(self._probe_mid, mid)

    def _on_probe(self, stamp: int, now: int) -> None:
        """A clock sample came back.  Its frame tells what the device had when it took
        the sample (acknowledgement and, while it holds frames, a Nak): every frame sent
        before the sample and neither acknowledged nor held was lost."""
        order = self._probes.pop(stamp, None)
        if order is None:
            return
        lost = [f for f in self.unacked if not f.held and f.order < order]
        if lost:
            self._retransmit(lost, now)

    def _nak_guard_ns(self) -> int:
        """How long after sending a frame a NAK that still misses it means it is lost."""
        if self.srtt_ns is None:
            return self.rto_ns
        return self.srtt_ns + 2 * self.rttvar_ns

    def rtt_sample(self, rtt: int) -> None:
        """A measured round trip (acknowledged frame or clock sample), in ns."""
        if self.srtt_ns is None:
            self.srtt_ns = rtt
            self.rttvar_ns = rtt // 2
        else:
            self.rttvar_ns += (abs(self.srtt_ns - rtt) - self.rttvar_ns) // 4
            self.srtt_ns += (rtt - self.srtt_ns) // 8
        self.rto_ns = min(max(self.min_rto_ns, self.srtt_ns + 4 * self.rttvar_ns),
                          self.max_rto_ns)
        self.stats.rtt_us = self.srtt_ns // 1000

    # ------------------------------------------------------------------ timing
    def next_deadline_ns(self) -> int | None:
        """When :meth:`service` must run again even if nothing arrives."""
        if self.closed:
            return None
        times = [self.last_rx_ns + self.silence_ns + 1]
        if self.unacked:
            times.append(self.unacked[0].sent_ns + self._timeout_ns())
        return min(times)

    def wait(self, deadline_ns: int | None) -> None:
        """Sleep until input arrives or ``deadline_ns`` (or a link timer) comes."""
        self.flush()
        own = self.next_deadline_ns()
        if own is not None and (deadline_ns is None or own < deadline_ns):
            deadline_ns = own
        self.clock.wait(deadline_ns, None if self.closed else self.stream)

    def sync_request(self, stamp: int) -> None:
        stamp &= 0xFFFFFFFF
        self.send_unsequenced(SyncRequest(stamp))
        self._probes[stamp] = self._order
        while len(self._probes) > PROBES:
            del self._probes[next(iter(self._probes))]

    def _close(self, reason: str) -> None:
        if self.closed is None:
            self.closed = reason
        self.stream.close()

    def close(self, reason: str = "closed by host") -> None:
        self._close(reason)


__all__ = ["HostLink", "LinkStats", "SyncReply"]
