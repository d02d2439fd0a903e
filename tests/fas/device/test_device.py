"""The device's side of the protocol, driven frame by frame over a pty."""

import os
import select

from fas.device import Device
from fas.serial.clock import VirtualClock, Wire
from fas.serial.protocol import (
    O_SYNCHRONIZED,
    P_CUT_REFUSED,
    PROTOCOL_VERSION,
    UNSEQUENCED,
    Config,
    EmergencyStop,
    Entry,
    ForceStop,
    FrameDecoder,
    Halt,
    Hello,
    Ident,
    Nak,
    OutputSet,
    Progress,
    SetEndPos,
    Start,
    Truncate,
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
        # the ring is as deep as the Uno's RAM allows (fas/arch.py), not the chip's 16
        assert idents[0].queue_len == 64 and idents[0].ticks_per_s == 16_000_000
        assert idents[0].rx_slots == 8 and idents[0].slot_payload == 32
        assert h.device.board.session_open
    finally:
        h.close()


def _open(h: Host, nonce: int = 5) -> None:
    h.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, nonce, 500, 2))
    h.send(0, Config(0, 9, 5, 0, 0))


def test_repeated_frames_act_once():
    h = Host()
    try:
        _open(h)
        h.send(1, _entry(0))
        h.send(1, _entry(0))  # the same frame again (its acknowledgement was lost)
        dev = h.device
        assert dev.counters["frames_duplicate"] == 1
        assert dev.counters["entries"] == 1
        assert dev.queues[0].next_write_idx == 1
    finally:
        h.close()


def test_frames_after_a_gap_are_held_and_only_the_missing_one_is_asked_for():
    h = Host()
    try:
        _open(h)
        h.send(1, _entry(0))
        dev = h.device
        got = h.send(3, _entry(2))  # frame 2 never arrived
        naks = [m for _, m in got if isinstance(m, Nak)]
        assert naks == [Nak(2, 0b1)]  # expects 2, holds 3
        assert all(seq == 2 for seq, _ in got)  # every device frame acknowledges
        got = h.send(5, _entry(4))
        assert got == []  # a second hole: its Nak comes with the next report
        h.clock.run_until(h.clock.now_ns() + 10 * 10**6)
        naks = [m for _, m in h.receive() if isinstance(m, Nak)]
        assert naks and all(m == Nak(2, 0b101) for m in naks)  # holds 3 and 5
        assert dev.counters["frames_held"] == 2
        assert dev.queues[0].next_write_idx == 1  # nothing taken out of order
        got = h.send(2, _entry(1))  # the lost frame: 2 and the held 3 are taken
        assert dev.queues[0].next_write_idx == 3
        assert {seq for seq, _ in got} == {4}  # acknowledged at once
        assert [m for _, m in got if isinstance(m, Nak)] == [Nak(4, 0b1)]  # 4 still missing
        got = h.send(4, _entry(3), Start(1, 0))
        assert {seq for seq, _ in got} == {6}
        assert not [m for _, m in got if isinstance(m, Nak)]
        assert dev.counters["entries"] == 5
        assert dev.counters["entries_lost"] == dev.counters["entries_duplicated"] == 0
        h.clock.run_until(10**9)
        assert dev.pulses(0) == 50 and dev.position(0) == 50
    finally:
        h.close()


def test_a_frame_beyond_the_slots_is_dropped():
    h = Host()
    try:
        _open(h)
        slots = h.device.session.rx_slots
        got = h.send(1 + slots + 1, _entry(slots))  # frame 1 missing, this one too far
        assert [m for _, m in got if isinstance(m, Nak)] == [Nak(1, 0)]
        assert h.device.counters["frames_held"] == 0
        assert h.device.counters["frames_out_of_order"] == 1
    finally:
        h.close()


def test_unknown_message_type_loses_the_rest_of_its_frame_only():
    h = Host()
    try:
        _open(h)
        payload = _entry(0).encode() + b"\x3f" + _entry(1).encode()
        os.write(h.fd, encode_frame(1, payload))
        select.select([h.pty.stream.fileno()], [], [], 5)
        h.device.poll()
        h.device.flush()
        got = h.receive()
        assert {seq for seq, _ in got} <= {2}  # the frame is taken (acknowledged)
        assert h.device.counters["rejected"] == 1
        assert h.device.queues[0].next_write_idx == 1  # the entry before it counts
    finally:
        h.close()


def _running(h: Host, entries: int = 6, steps: int = 100) -> None:
    """Stepper 0 executes ``entries`` entries of ``steps`` steps at 3200 ticks."""
    for i in range(entries):
        h.send(1 + i, Entry(0, i, steps, 3200, False, True, True, False))
    h.send(1 + entries, Start(1, 0))
    h.clock.run_until(h.clock.now_ns() + 10**6)


def test_truncate_drops_entries_not_yet_begun():
    h = Host()
    try:
        _open(h)
        _running(h)  # 6 x 20 ms
        dev = h.device
        got = h.send(8, Truncate(0, 2))
        q = dev.queues[0]
        assert q.next_write_idx == 2 and q.queue_end_pos == 200
        assert dev.counters["cuts"] == 1
        assert not any(isinstance(m, Progress) and m.flags & P_CUT_REFUSED for _, m in got)
        h.send(9, Entry(0, 2, 10, 3200, False, True, True, True))  # the stop, after the cut
        h.clock.run_until(10**9)
        assert dev.pulses(0) == 210 and dev.position(0) == 210
        assert dev.counters["underruns"] == 0
    finally:
        h.close()


def test_late_truncate_is_refused_and_the_queue_runs_on():
    h = Host()
    try:
        _open(h)
        _running(h)
        dev = h.device
        h.clock.run_until(h.clock.now_ns() + 50 * 10**6)  # entry 2 is being executed
        got = h.send(8, Truncate(0, 2))
        reports = [m for _, m in got if isinstance(m, Progress)]
        assert reports and reports[-1].flags & P_CUT_REFUSED
        assert dev.counters["cuts_refused"] == 1
        # until the next cut: entries, starts and renumbering are dropped
        h.send(9, Entry(0, 2, 10, 3200, False, True, True, True), SetEndPos(0, 5000))
        assert dev.counters["discarded"] == 2
        assert dev.queues[0].next_write_idx == 6
        h.send(10, Truncate(0, 6))  # at the write index: drops nothing, ends the refusal
        h.send(11, Entry(0, 6, 10, 3200, False, True, True, True))
        h.clock.run_until(10**9)
        assert dev.pulses(0) == 610 and dev.position(0) == 610
    finally:
        h.close()


def test_halt_stops_at_once_and_its_force_stop_ends_it():
    h = Host()
    try:
        _open(h)
        _running(h)
        dev = h.device
        h.clock.run_until(h.clock.now_ns() + 30 * 10**6)
        h.send(UNSEQUENCED, Halt(0, 1, 5))  # overtakes what is on its way
        stopped = dev.pulses(0)
        assert 0 < stopped < 600 and not dev.running()
        assert dev.steppers.stop_ticks[0] == dev.machine.now
        # what was sent before the stop arrives after it: dropped
        h.send(8, Entry(0, 6, 10, 3200, False, True, True, True), Start(1, 0))
        assert dev.counters["discarded"] == 2 and not dev.running()
        h.send(9, ForceStop(0, 7, 1), SetEndPos(0, 0))
        h.send(UNSEQUENCED, Halt(0, 1, 5))  # a late copy: already done
        assert dev.counters["halts"] == 1
        h.send(10, Entry(0, 7, 10, 3200, False, True, True, False), Start(1, 0))
        h.clock.run_until(10**9)
        assert dev.pulses(0) == stopped + 10 and dev.position(0) == 10
        h.send(UNSEQUENCED, Halt(0, 2, 6))  # another session's
        assert dev.counters["rejected"] == 1 and dev.counters["halts"] == 1
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
        assert not h.device.board.estopped
        h.send(UNSEQUENCED, EmergencyStop(6))
        assert h.device.board.estopped
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


def test_a_synchronized_output_waits_for_the_halted_queue():
    h = Host()
    try:
        _open(h)
        _running(h)
        dev = h.device
        h.send(8, OutputSet(O_SYNCHRONIZED, 0, 2, 1))  # after the motion before it
        h.clock.run_until(h.clock.now_ns() + 20 * 10**6)
        dev.machine.outputs.deliver_until(dev.machine.now)
        assert dev.machine.pins.get(2) == 0  # still moving
        h.send(UNSEQUENCED, Halt(0, 1, 5))  # X: the queue is idle now
        dev.machine.outputs.deliver_until(dev.machine.now)
        assert dev.machine.pins.get(2) == 1
    finally:
        h.close()
