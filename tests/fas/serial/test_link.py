"""The host link's selective repeat, driven frame by frame without a device."""

from fas.serial.link import HostLink
from fas.serial.protocol import (
    Entry,
    FrameDecoder,
    Nak,
    SyncReply,
    encode_frame,
)
from fas.serial.stream import ByteStream

MS = 1_000_000


class Clock:
    def __init__(self) -> None:
        self.t = 0

    def now_ns(self) -> int:
        return self.t


class Wire(ByteStream):
    """Keeps what the host writes; hands it what the test puts in."""

    def __init__(self) -> None:
        self.written = bytearray()
        self.incoming = bytearray()

    def fileno(self) -> int:
        return -1

    def _read_raw(self) -> bytes:
        data = bytes(self.incoming)
        self.incoming.clear()
        return data

    def _write_raw(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def close(self) -> None:
        pass

    def frames(self) -> list[int]:
        """Sequence numbers of the frames written since the last call."""
        got = [seq for seq, _ in FrameDecoder().feed(bytes(self.written))]
        self.written.clear()
        return got


def _link(frames: int = 5) -> tuple[HostLink, Wire, Clock]:
    clock = Clock()
    wire = Wire()
    link = HostLink(wire, clock, window=9, max_payload=5)
    for i in range(frames):  # one entry per frame
        link.send(Entry(0, i, 1, 1000, False, True, True, True))
    link.flush()
    assert wire.frames() == list(range(frames))
    return link, wire, clock


def _device_says(link: HostLink, wire: Wire, expected: int, *msgs) -> None:
    wire.incoming += encode_frame(expected, b"".join(m.encode() for m in msgs))
    link.service()


def test_only_the_lost_frame_goes_again():
    link, wire, clock = _link()
    clock.t = 3 * MS
    # frame 0 taken, 1 lost, 2 and 3 held, 4 not yet seen
    _device_says(link, wire, 1, Nak(1, 0b011))
    assert wire.frames() == [1]
    assert link.stats.retransmissions == 1 and link.stats.frames_held == 2
    # the same Nak again (the repeat is on its way): nothing more
    _device_says(link, wire, 1, Nak(1, 0b011))
    assert wire.frames() == []
    # the repeat arrived: all of it is acknowledged at once
    _device_says(link, wire, 5)
    assert link.idle() and link.acked_mid == 5


def test_a_probe_shows_a_repeat_that_was_lost_again():
    link, wire, clock = _link(3)
    probes = []
    link.probe = lambda: probes.append(clock.t) or link.sync_request(clock.t)
    clock.t = 3 * MS
    _device_says(link, wire, 0, Nak(0, 0b011))  # frame 0 lost, 1 and 2 held
    assert wire.frames()[0] == 0 and probes == [3 * MS]  # the repeat, then a probe
    clock.t = 6 * MS
    # the probe's answer: frame 0 is still missing - the repeat was lost too
    _device_says(link, wire, 0, Nak(0, 0b011), SyncReply(3 * MS, 12345))
    assert wire.frames()[0] == 0
    assert link.stats.retransmissions == 2


def test_held_frames_never_go_again_on_a_timeout():
    link, wire, clock = _link(3)
    clock.t = 1 * MS
    _device_says(link, wire, 0, Nak(0, 0b011))
    wire.frames()
    clock.t = 2000 * MS  # long past every timeout
    link.flush()
    assert wire.frames() == [0]


def test_frame_size_follows_the_line():
    link = HostLink(Wire(), Clock(), baud=115200)
    link.set_limits(9, 32)
    assert link.payload == 32  # no loss seen: the largest frames
    link.srtt_ns = 5 * MS  # a short line: the wire bounds, not the window
    # a very noisy line: small frames get through (the loss estimate set, not measured)
    link.loss_tx, link._weight_tx = 0.4, 1.0  # noqa: SLF001 - a full-weight loss estimate
    link._fit_payload()  # noqa: SLF001 - the payload rule alone, without traffic
    assert 12 <= link.payload < 24
    link.loss_tx = 0.05
    link._fit_payload()  # noqa: SLF001 - the payload rule alone, without traffic
    assert link.payload == 32


def _messages(wire: Wire) -> list[type]:
    """The types of the messages written since the last call, in order."""
    from fas.serial.protocol import decode_messages

    got = [type(m) for _seq, payload in FrameDecoder().feed(bytes(wire.written))
           for m in decode_messages(payload)]
    wire.written.clear()
    return got


def test_a_timed_change_overtakes_only_the_entries_not_yet_framed():
    """``overtake_entries``: ahead of the queue entries waiting at the end of the
    messages not framed, never past another kind of message nor an earlier overtaker."""
    from fas.serial.protocol import OutputAt, OutputNext, OutputPwm

    link = HostLink(Wire(), Clock(), window=9, max_payload=5)
    e = Entry(0, 0, 1, 1000, False, True, True, True)
    for msg in (e, e, OutputPwm(1, 11, 64, 256, 0), e, e):
        link.send(msg)
    link.send(OutputAt(1, 1, 11, 10, 5000), overtake_entries=True)
    link.send(OutputNext(11, 100), overtake_entries=True)
    link.send(e)
    order = [m[1][0] for m in link.pending]
    assert order == [0x40, 0x40, 0x20, 0x23, 0x24, 0x40, 0x40, 0x40]
    mids = [m[0] for m in link.pending]
    assert mids[3:5] == [6, 7] and mids[5:7] == [4, 5]  # (ids stay those given)


def test_entries_wait_while_the_line_must_stay_clear_for_timed_changes():
    """``entries_by_ns``: no entry is framed that would keep the line busy past it
    (at the baud's pace, a quarter slower) until ``entries_hold_end_ns``; other messages
    go; None lifts it."""
    from fas.serial.protocol import OutputAt

    clock = Clock()
    wire = Wire()
    link = HostLink(wire, clock, window=9, max_payload=32, baud=115200)
    e = Entry(0, 0, 1, 1000, False, True, True, True)
    link.entries_by_ns, link.entries_hold_end_ns = 1 * MS, 3 * MS
    # (a 10-byte frame takes 0.87 ms at 115 200 baud)
    link.send(e)
    link.flush()
    assert _messages(wire) == []  # 0.87 ms * 1.25 > 1 ms
    link.entries_by_ns = 2 * MS
    link.flush()
    assert _messages(wire) == [Entry]
    link.send(e)
    link.send(OutputAt(1, 1, 11, 10, 5000), overtake_entries=True)
    link.flush()  # the line is busy until ~1.1 ms: the change goes, the entry waits
    assert _messages(wire) == [OutputAt]
    clock.t = 3 * MS  # the waiting change's tick: late anyway, the entries go
    link.flush()
    assert _messages(wire) == [Entry]
    link.send(e)
    link.entries_by_ns = None
    link.flush()
    assert _messages(wire) == [Entry]
