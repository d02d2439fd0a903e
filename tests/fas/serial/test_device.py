"""The device's side of the protocol, driven frame by frame over a pty."""

import os
import select

from fas.serial.clock import VirtualClock, Wire
from fas.serial.device import Device
from fas.serial.protocol import (
    UNSEQUENCED,
    Config,
    EmergencyStop,
    Entry,
    FrameDecoder,
    Hello,
    Ident,
    Nak,
    Start,
    decode_messages,
    encode_frame,
)
from fas.serial.stream import Pty


class Host:
    """Just enough of a host: writes frames to the pty, reads the device's frames."""

    def __init__(self) -> None:
        self.pty = Pty("test")
        self.wire = Wire(None, "from device")  # counts what the device wrote
        self.pty.stream.tx_wire = self.wire
        self.fd = os.open(self.pty.path, os.O_RDWR | os.O_NOCTTY)
        self.clock = VirtualClock()
        self.device = Device(self.pty.stream, "atmega328p", self.clock)
        self.clock.add_peer(self.device)
        self.decoder = FrameDecoder()

    def send(self, seq: int, *msgs) -> list:
        os.write(self.fd, encode_frame(seq, b"".join(m.encode() for m in msgs)))
        select.select([self.pty.stream.fileno()], [], [], 5)
        self.device.poll()
        self.device.flush()
        return self.receive()

    def receive(self) -> list:
        got = []
        while self.wire.received < self.wire.sent:
            select.select([self.fd], [], [], 5)
            data = os.read(self.fd, 4096)
            self.wire.received += len(data)
            for seq, payload in self.decoder.feed(data):
                got += [(seq, m) for m in decode_messages(payload)]
        return got

    def close(self) -> None:
        os.close(self.fd)
        self.pty.close()


def _entry(index: int, cont: bool = False) -> Entry:
    return Entry(0, index, 10, 3200, False, True, True, cont)


def test_hello_answers_ident_and_opens_a_session():
    h = Host()
    try:
        got = h.send(UNSEQUENCED, Hello(1, 77, 500, 2))
        idents = [m for _, m in got if isinstance(m, Ident)]
        assert idents and idents[0].nonce == 77 and idents[0].name == "atmega328p"
        assert idents[0].queue_len == 16 and idents[0].ticks_per_s == 16_000_000
        assert h.device.session
    finally:
        h.close()


def test_repeated_frames_act_once_and_gaps_are_nakked():
    h = Host()
    try:
        h.send(UNSEQUENCED, Hello(1, 5, 500, 2))
        h.send(0, Config(0, 9, 5, 0, 0))
        h.send(1, _entry(0))
        h.send(1, _entry(0))  # the same frame again (its acknowledgement was lost)
        dev = h.device
        assert dev.counters["frames_duplicate"] == 1
        assert dev.counters["entries"] == 1
        assert dev.queues[0].next_write_idx == 1
        got = h.send(3, _entry(2))  # frame 2 never arrived
        assert any(isinstance(m, Nak) and m.expected == 2 for _, m in got)
        assert all(seq == 2 for seq, _ in got)  # every device frame acknowledges
        assert dev.counters["frames_out_of_order"] == 1
        assert dev.queues[0].next_write_idx == 1
        h.send(2, _entry(1))
        h.send(3, _entry(2), Start(1, 0))
        assert dev.counters["entries"] == 3
        assert dev.counters["entries_lost"] == dev.counters["entries_duplicated"] == 0
        h.clock.run_until(10**9)
        assert dev.pulses(0) == 30 and dev.position(0) == 30
    finally:
        h.close()


def test_entry_index_check_counts_repeated_commands():
    h = Host()
    try:
        h.send(UNSEQUENCED, Hello(1, 5, 500, 2))
        h.send(0, Config(0, 9, 5, 0, 0))
        h.send(1, _entry(0), _entry(0))  # a host bug: the same command twice
        assert h.device.counters["entries_duplicated"] == 1
        assert h.device.counters["entries"] == 1
    finally:
        h.close()


def test_late_emergency_stop_of_an_old_session_is_ignored():
    h = Host()
    try:
        h.send(UNSEQUENCED, Hello(1, 5, 500, 2))
        h.send(UNSEQUENCED, Hello(1, 6, 500, 2))  # a new session
        h.send(UNSEQUENCED, EmergencyStop(5))
        assert not h.device.estopped
        h.send(UNSEQUENCED, EmergencyStop(6))
        assert h.device.estopped
        h.send(0, Config(0, 9, 5, 0, 0))
        h.send(1, _entry(0))
        assert h.device.counters["rejected"] >= 1
        assert h.device.queues[0].next_write_idx == 0
    finally:
        h.close()


def test_continuation_entry_restarts_a_dry_queue_as_underrun():
    h = Host()
    try:
        h.send(UNSEQUENCED, Hello(1, 5, 500, 2))
        h.send(0, Config(0, 9, 5, 0, 0))
        h.send(1, _entry(0), Start(1, 0))
        h.clock.run_until(10**8)  # 100 ms: ran dry long ago
        assert not h.device.running()
        h.send(2, _entry(1, cont=True))
        assert h.device.running()
        assert h.device.counters["underruns"] == 1
        h.clock.run_until(2 * 10**8)
        assert h.device.pulses(0) == 20
    finally:
        h.close()
