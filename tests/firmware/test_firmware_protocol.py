"""The firmware's side of the protocol, driven frame by frame in simavr (lockstep).

The same situations as the Python device's tests (test_device.py): sessions, repeated
and out-of-order frames, unknown messages, cuts, halts, the entry index check, stale
emergency stops, continuation entries, user outputs.  What the chip did is read from
its own reports (Status, DeviceStatus) and from its pins.
"""

from __future__ import annotations

import pytest

from fas.device.simavr import build
from fas.serial.protocol import (
    D_ESTOP,
    P_CUT_REFUSED,
    P_HALTED,
    PROTOCOL_VERSION,
    UNSEQUENCED,
    Config,
    DeviceStatus,
    EmergencyStop,
    Entry,
    ForceStop,
    Halt,
    Hello,
    Ident,
    Nak,
    Progress,
    SetEndPos,
    Start,
    SyncReply,
    SyncRequest,
    Truncate,
)
from rigs.firmware import Host, need_firmware


@pytest.fixture(scope="module")
def elf():
    need_firmware()
    return build(115200).elf


@pytest.fixture
def host(elf, tmp_path):
    h = Host(elf, tmp_path / "trace.txt")
    yield h
    h.dev.close()


def _open(h: Host, nonce: int = 5) -> None:
    h.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, nonce, 500, 2))
    h.send(0, Config(0, 9, 5, 0, 0))


def _entry(index: int, cont: bool = False, steps: int = 10) -> Entry:
    return Entry(0, index, steps, 3200, False, True, True, cont)


def test_hello_answers_ident_and_the_state_as_found(host):
    got = host.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 77, 500, 2))
    idents = [m for _, m in got if isinstance(m, Ident)]
    assert len(idents) == 1
    ident = idents[0]
    assert ident.nonce == 77 and ident.name == "atmega328p" and ident.version == 2
    assert ident.ticks_per_s == ident.clock_hz == 16_000_000
    assert ident.max_steppers == 2 and ident.queue_len == 64
    assert ident.rx_slots == 8 and ident.slot_payload == 32
    assert ident.min_cmd_ticks_div == 25_000 and ident.watchdog_ms == 500
    assert any(isinstance(m, DeviceStatus) for _, m in got)
    # the same nonce again only repeats the answer
    got = host.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 77, 500, 2))
    assert [m.nonce for _, m in got if isinstance(m, Ident)] == [77]


def test_sync_request_is_answered_with_the_tick_of_its_arrival(host):
    _open(host)
    got = host.send(UNSEQUENCED, SyncRequest(0xDEADBEEF))
    replies = [m for _, m in got if isinstance(m, SyncReply)]
    assert len(replies) == 1 and replies[0].stamp == 0xDEADBEEF
    arrival = host.frame_end - host.dev.info().timer1_start  # the request's last byte
    assert abs(replies[0].device_tick - arrival) < 100


def test_repeated_frames_act_once(host):
    _open(host)
    host.send(1, _entry(0))
    got = host.send(1, _entry(0))  # the same frame again (its acknowledgement was lost)
    assert got and all(seq == 2 for seq, _ in got)  # acknowledged
    c = host.counters()
    assert c["frames_duplicate"] == 1 and c["entries"] == 1


def test_frames_after_a_gap_are_held_and_only_the_missing_one_is_asked_for(host):
    _open(host)
    host.send(1, _entry(0))
    got = host.send(3, _entry(2))  # frame 2 never arrived
    naks = [m for _, m in got if isinstance(m, Nak)]
    assert naks and naks[0] == Nak(2, 0b1)  # expects 2, holds 3
    assert all(seq == 2 for seq, _ in got)  # every device frame acknowledges
    got = host.send(5, _entry(4))  # a second hole
    naks = [m for _, m in got if isinstance(m, Nak)]
    assert naks and naks[-1] == Nak(2, 0b101)  # holds 3 and 5
    got = host.send(2, _entry(1))  # the lost frame: 2 and the held 3 are taken
    assert {seq for seq, _ in got} == {4}
    assert [m for _, m in got if isinstance(m, Nak)][:1] == [Nak(4, 0b1)]  # 4 still missing
    got = host.send(4, _entry(3), Start(1, 0))
    assert {seq for seq, _ in got} == {6}
    assert not [m for _, m in got if isinstance(m, Nak)]
    host.run(300)
    device, statuses = host.status()
    c = device.counters()
    assert c["entries"] == 5 and c["frames_held"] == 2
    assert c["entries_lost"] == c["entries_duplicated"] == 0
    assert statuses[0].pulses == 50 == statuses[0].position == host.pulses()


def test_a_frame_beyond_the_slots_is_dropped(host):
    _open(host)
    got = host.send(1 + 8 + 1, _entry(8))  # frame 1 missing, this one too far ahead
    assert [m for _, m in got if isinstance(m, Nak)][:1] == [Nak(1, 0)]
    c = host.counters()
    assert c["frames_held"] == 0 and c["frames_out_of_order"] == 1


def test_unknown_message_type_loses_the_rest_of_its_frame_only(host):
    _open(host)
    got = host.send(1, payload=_entry(0).encode() + b"\x3f" + _entry(1).encode())
    assert {seq for seq, _ in got} <= {2}  # the frame is taken (acknowledged)
    c = host.counters()
    assert c["rejected"] == 1 and c["entries"] == 1  # the entry before it counts


def _running(h: Host, entries: int = 6, steps: int = 100) -> None:
    """Stepper 0 executes ``entries`` entries of ``steps`` steps at 3200 ticks (20 ms)."""
    for i in range(entries):
        h.send(1 + i, _entry(i, steps=steps), ms=0)
    h.send(1 + entries, Start(1, 0), ms=1)


def test_truncate_drops_entries_not_yet_begun(host):
    _open(host)
    _running(host)  # 6 x 20 ms
    got = host.send(8, Truncate(0, 2))
    assert not any(isinstance(m, Progress) and m.flags & P_CUT_REFUSED for _, m in got)
    host.send(9, _entry(2, cont=True))  # the stop, after the cut
    host.run(1000)
    device, statuses = host.status()
    assert device.cuts == 1 and device.underruns == 0
    assert statuses[0].pulses == 210 == statuses[0].position == host.pulses()


def test_late_truncate_is_refused_and_the_queue_runs_on(host):
    _open(host)
    _running(host)
    host.run(50)  # entry 2 is being executed
    got = host.send(8, Truncate(0, 2))
    assert any(isinstance(m, Progress) and m.flags & P_CUT_REFUSED for _, m in got)
    # until the next cut: entries, starts and renumbering are dropped
    host.send(9, _entry(2, cont=True), SetEndPos(0, 5000))
    c = host.counters()
    assert c["cuts_refused"] == 1 and c["discarded"] == 2
    host.send(10, Truncate(0, 6))  # at the write index: drops nothing, ends the refusal
    host.send(11, _entry(6, cont=True))
    host.run(1000)
    _device, statuses = host.status()
    assert statuses[0].pulses == 610 == statuses[0].position == host.pulses()


def test_halt_stops_at_once_and_its_force_stop_ends_it(host):
    _open(host)
    _running(host)
    host.run(30)
    got = host.send(UNSEQUENCED, Halt(0, 1, 5))  # overtakes what is on its way
    assert any(isinstance(m, Progress) and m.flags & P_HALTED for _, m in got)
    stopped = host.pulses()
    assert 0 < stopped < 600
    # what was sent before the stop arrives after it: dropped
    host.send(8, _entry(6, cont=True), Start(1, 0))
    assert host.counters()["discarded"] == 2 and host.pulses() == stopped
    host.send(9, ForceStop(0, 7, 1), SetEndPos(0, 0))
    host.send(UNSEQUENCED, Halt(0, 1, 5))  # a late copy: already done
    assert host.counters()["halts"] == 1
    host.send(10, _entry(7), Start(1, 0))
    host.run(1000)
    device, statuses = host.status()
    assert host.pulses() == stopped + 10 == statuses[0].pulses
    assert statuses[0].position == 10
    host.send(UNSEQUENCED, Halt(0, 2, 6))  # another session's
    c = host.counters()
    assert c["rejected"] == 1 and c["halts"] == 1


def test_entry_index_check_counts_repeated_commands(host):
    _open(host)
    host.send(1, _entry(0), _entry(0))  # a host bug: the same command twice
    c = host.counters()
    assert c["entries_duplicated"] == 1 and c["entries"] == 1


def test_late_emergency_stop_of_an_old_session_is_ignored(host):
    host.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 5, 500, 2))
    host.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 6, 500, 2))  # a new session
    host.send(UNSEQUENCED, EmergencyStop(5))
    assert not host.status()[0].state & D_ESTOP
    host.send(UNSEQUENCED, EmergencyStop(6))
    assert host.status()[0].state & D_ESTOP
    host.send(0, Config(0, 9, 5, 0, 0))
    host.send(1, _entry(0), Start(1, 0))
    assert host.counters()["rejected"] >= 1
    host.run(100)
    assert host.pulses() == 0


def test_continuation_entry_restarts_a_dry_queue_as_underrun(host):
    _open(host)
    host.send(1, _entry(0), Start(1, 0))
    host.run(100)  # ran dry long ago
    host.send(2, _entry(1, cont=True))
    host.run(100)
    device, statuses = host.status()
    assert device.underruns == 1 and statuses[0].underruns == 1
    assert host.pulses() == 20 == statuses[0].pulses


def test_sequenced_frame_without_a_session_says_so(host):
    got = host.send(0, Config(0, 9, 5, 0, 0))
    status = [m for _, m in got if isinstance(m, DeviceStatus)]
    assert status and not status[0].state & 0x04 and status[0].rejected == 1


def test_watchdog_stops_the_motion_and_says_so_at_once(host):
    host.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 5, 100, 2))  # 100 ms watchdog
    host.send(0, Config(0, 9, 5, 0, 0))
    _running(host)
    got = host.run(200)  # the host says nothing
    status = [m for _, m in got if isinstance(m, DeviceStatus) and m.state & 0x01]
    assert status and status[0].watchdog_trips == 1
    stopped = host.pulses()
    host.run(200)
    assert host.pulses() == stopped < 600
