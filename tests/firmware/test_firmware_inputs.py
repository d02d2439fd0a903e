"""Section 18 on the firmware (issue 13): watched inputs, limit switches, Started, and the
simulated world's SetInput - frame by frame in simavr (lockstep), and with the host
library through the serial backend.

The switches and pots are driven on the chip's pins by the harness (the world outside
the board): ``SimavrDevice.set_input`` / ``schedule_input``, or the host's SetInput.
"""

from __future__ import annotations

import pytest

from fas import Engine
from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.device.simavr import SimavrDevice, build
from fas.gear import Gear, GearResult
from fas.serial.protocol import (
    F_INPUTS,
    F_SIM_INPUTS,
    F_TIMED_OUTPUTS,
    L_CLEAR,
    L_UP,
    P_HALTED,
    PROTOCOL_VERSION,
    S_ANALOG,
    UNSEQUENCED,
    W_ANALOG,
    W_PULLUP,
    Config,
    Entry,
    ForceStop,
    FrameDecoder,
    Hello,
    Ident,
    Input,
    Limit,
    LimitHit,
    Progress,
    SetInput,
    Start,
    Started,
    WatchInput,
)
from rigs.firmware import MS, Host, need_firmware

TPS = 16_000_000
SWITCH, POT = 17, 14  # A3, A0
REACTION_TICKS = 20 * 16  # the firmware's limit reaction, without other interrupts (20 us)


@pytest.fixture(scope="module")
def elf():
    need_firmware()
    return build(115200).elf


@pytest.fixture
def host(elf, tmp_path):
    h = Host(elf, tmp_path / "trace.txt")
    yield h
    h.dev.close()


class Board(Host):
    """The firmware as on a board: the harness does not tell it it is simulated."""

    def __init__(self, elf, trace) -> None:
        self.dev = SimavrDevice(elf=elf, trace=trace, world=False)
        self.dev.run_to_cycle(20 * MS)
        self.decoder = FrameDecoder()


def _open(h: Host, nonce: int = 5) -> Ident:
    got = h.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, nonce, 500, 2))
    h.send(0, Config(0, 9, 5, 0, 0), Config(1, 10, 7, 0, 0))
    return [m for _, m in got if isinstance(m, Ident)][0]


def _all(got, cls) -> list:
    return [m for _, m in got if isinstance(m, cls)]


def _entry(stepper: int, index: int, steps: int = 10, up: bool = True,
           cont: bool = False) -> Entry:
    return Entry(stepper, index, steps, 3200, False, up, up, cont)


def test_ident_names_the_inputs_and_the_simulated_world(host):
    assert _open(host).features == F_INPUTS | F_SIM_INPUTS | F_TIMED_OUTPUTS


def test_on_a_board_set_input_is_refused(elf, tmp_path):
    board = Board(elf, tmp_path / "trace.txt")
    try:
        assert _open(board).features == F_INPUTS | F_TIMED_OUTPUTS
        got = board.send(1, WatchInput(SWITCH, W_PULLUP, 0))
        assert _all(got, Input)[0].value == 1
        got = board.send(2, SetInput(SWITCH, 0, 0))
        assert not _all(got, Input)  # nothing changed on the pin
        assert board.counters()["rejected"] == 1
        assert board.dev.pins()[SWITCH].level == 1
    finally:
        board.dev.close()


def test_a_digital_input_is_reported_at_once_and_when_it_changes(host):
    _open(host)
    got = host.send(1, WatchInput(SWITCH, W_PULLUP, 0))
    assert [(m.pin, m.value) for m in _all(got, Input)] == [(SWITCH, 1)]  # the pull-up
    at = host.dev.tick + 5 * 16_000
    host.dev.schedule_input(at, SWITCH, 0)
    got = host.run(8)
    changes = _all(got, Input)
    assert [(m.pin, m.value) for m in changes] == [(SWITCH, 0)]
    assert 0 <= changes[0].tick - at < 100  # read in the pin-change interrupt (6 us)
    got = host.run(110)  # the slow refresh tells it again
    assert [(m.value, m.tick) for m in _all(got, Input)] == [(0, changes[0].tick)]


def test_an_analog_input_reads_the_pot_at_its_sample(host):
    _open(host)
    got = host.send(1, WatchInput(POT, W_ANALOG, 20))
    assert [m.value for m in _all(got, Input)] == [512]  # untouched: a centred pot
    for value in (0, 1, 511, 700, 1022, 1023):
        at = host.dev.tick + 16_000
        host.dev.schedule_input(at, POT, value, analog=True)
        got = host.run(25)
        reports = [m for m in _all(got, Input) if m.value == value]
        assert reports, value  # the converter reads back exactly the pot's value
        assert 0 <= reports[0].tick - at < 20 * 16_000 + 4000  # at its next sample


def test_the_host_turns_the_simulated_pot_and_presses_the_switch(host):
    _open(host)
    host.send(1, WatchInput(SWITCH, W_PULLUP, 0), WatchInput(POT, W_ANALOG, 10))
    got = host.send(2, SetInput(SWITCH, 0, 0), SetInput(POT, 900, S_ANALOG), ms=30)
    assert {(m.pin, m.value) for m in _all(got, Input)} == {(SWITCH, 0), (POT, 900)}
    # the harness made the change when the firmware took the message
    trace = host.dev.trace()
    change = [c for c, lv in zip(trace.cycles[SWITCH], trace.levels[SWITCH], strict=True)
              if lv == 0][0]
    assert host.frame_end < change < host.frame_end + MS


def test_watches_and_limits_belong_to_the_session(host):
    _open(host)
    host.send(1, WatchInput(SWITCH, W_PULLUP, 0), Limit(1, SWITCH, 0, L_UP, 0))
    _open(host, nonce=6)  # a new session: neither is left
    host.dev.set_input(SWITCH, 0)
    got = host.run(20)
    assert not _all(got, Input)
    got = host.send(1, _entry(1, 0), Start(2, 0), ms=60)
    assert not _all(got, LimitHit)
    assert host.pulses(10) == 10


def test_a_move_towards_a_closed_switch_makes_no_pulse(host):
    _open(host)
    host.dev.set_input(SWITCH, 0)  # closed before anything moves
    host.send(1, WatchInput(SWITCH, W_PULLUP, 0), Limit(1, SWITCH, 0, L_UP, 0))
    got = host.send(2, _entry(1, 0), _entry(1, 1), Start(2, 0), ms=30)
    hits = _all(got, LimitHit)
    assert [(h.stepper, h.pin, h.index, h.position) for h in hits] == [(1, SWITCH, 2, 0)]
    assert host.pulses(10) == 0
    assert any(p.flags & P_HALTED for p in _all(got, Progress) if p.stepper == 1)
    # halted: what the host sent before it heard of the stop is dropped
    host.send(3, _entry(1, 2), Start(2, 0))
    assert host.counters()["discarded"] == 2 and host.pulses(10) == 0
    # the host's ForceStop lets entries in again: away from the switch is allowed
    got = host.send(4, ForceStop(1, 3, 1), _entry(1, 3, up=False), Start(2, 0), ms=60)
    assert host.pulses(10) == 10 and not _all(got, LimitHit)
    _device, statuses = host.status()
    assert statuses[1].position == -10
    # the limit removed: towards the switch again
    host.send(5, Limit(1, 0, 0, L_UP | L_CLEAR, 0), _entry(1, 4), Start(2, 0), ms=60)
    assert host.pulses(10) == 20


def test_a_switch_that_closes_stops_the_move_and_the_queues_of_its_mask(host):
    _open(host)
    host.send(1, WatchInput(SWITCH, W_PULLUP, 0), Limit(1, SWITCH, 0, L_UP, 0b01))
    host.send(2, *[_entry(0, i, 200) for i in range(2)], *[_entry(1, i, 200) for i in range(2)])
    host.send(3, Start(3, 0), ms=30)
    at = host.dev.tick + 1600 + 777
    host.dev.schedule_input(at, SWITCH, 0)
    got = host.run(30)
    hits = {h.stepper: h for h in _all(got, LimitHit)}
    assert sorted(hits) == [0, 1] and {h.pin for h in hits.values()} == {SWITCH}
    trace = host.dev.trace()
    _device, statuses = host.status()
    for stepper, pin in ((0, 9), (1, 10)):
        steps = trace.rising(pin)
        assert steps[-1] < at + REACTION_TICKS  # within the reaction time
        assert hits[stepper].position == len(steps) == statuses[stepper].position
        assert 0 <= hits[stepper].tick - at < REACTION_TICKS
        assert hits[stepper].index == 2


def test_started_tells_the_tick_of_the_first_step(host):
    _open(host)
    host.send(1, _entry(0, 0))
    at = host.dev.tick + 30_000
    got = host.send(2, Start(1, at), ms=30)
    started = _all(got, Started)
    assert [(m.stepper, m.tick) for m in started] == [(0, at + 10)]
    assert host.dev.trace().rising(9)[0] == at + 10 + 1  # simavr: the compare's cycle + 1
    # a start that passed begins now; the report says when
    host.send(3, _entry(0, 1))
    got = host.send(4, Start(1, 0), ms=30)
    first = host.dev.trace().rising(9)[10]
    assert [m.tick + 1 for m in _all(got, Started)] == [first]
    # a continuation entry that restarts a queue that ran dry: Started, too
    got = host.send(5, _entry(0, 2, cont=True), ms=30)
    assert [m.tick + 1 for m in _all(got, Started)] == [host.dev.trace().rising(9)[20]]
    # a timed start stopped before its tick reports nothing
    host.send(6, _entry(0, 3))
    got = host.send(7, Start(1, host.dev.tick + 200_000), ForceStop(0, 4, 1), ms=30)
    got += host.run(30)
    assert not _all(got, Started) and host.pulses() == 30


def _rig(lb):
    engine = Engine(lb.backend)
    engine.init()
    s1 = engine.stepper_connect_to_pin(9)
    s1.set_direction_pin(5)
    s2 = engine.stepper_connect_to_pin(10)
    s2.set_direction_pin(7)
    for s in (s1, s2):
        s.set_speed_in_us(200)
        s.set_acceleration(100000)
    return engine, s1, s2


@pytest.mark.parametrize("faults", [None, Faults(latency_ms=2, baud=115200, seed=3)])
def test_the_library_follows_a_limit_stop_on_the_firmware(faults):
    """As test_inputs_limits does it on the Python device: the firmware stops S2 and,
    by the stop mask, S1; the host force-stops both where the pulses stopped."""
    with Loopback(device="simavr", faults=faults) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = _rig(lb)
        assert b.watch_input(SWITCH)
        hits = []

        def stopped(index, pin, position, tick):
            hits.append((index, pin, position, tick))
            engine.stepper(index).force_stop_and_new_position(position)

        b.limit_listeners.append(stopped)
        assert b.set_limit(1, SWITCH, 0, True, stop=(0,))
        s1.run_forward()
        s2.run_forward()
        b.app_wait_until(b.now() + TPS // 4)
        at = dev.tick + 1234
        dev.schedule_input(at, SWITCH, 0)
        b.app_wait_until(b.now() + TPS // 10)
        assert b.settle()
        trace = dev.trace()
        assert sorted(h[0] for h in hits) == [0, 1]
        for index, _pin, position, tick in hits:
            steps = trace.rising(9 + index)
            assert steps[-1] < at + REACTION_TICKS
            assert position == len(steps) == engine.stepper(index).get_current_position()
            assert 0 <= b.sync.device_tick32(tick) - at < REACTION_TICKS
        # away from the switch
        s2.move(-100)
        assert b.wait_until(lambda: not s2.is_running(), TPS)
        assert b.settle() and b.request_status() is not None
        assert b.statuses[1].position == hits[-1][2] - 100 if hits[-1][0] == 1 else True
        assert len(dev.trace().rising(10)) == b.statuses[1].pulses
        c = b.device_counters()
        assert c["entries_lost"] == c["entries_duplicated"] == c["overflows"] == 0


def test_gear_over_the_firmware_keeps_the_ratio_by_its_pins():
    """fas.gear on the firmware's queue timing (Started, timed starts): at 1:3 every
    step instant within one step of S1/3 on the chip's pins."""
    with Loopback(device="simavr", faults=Faults(latency_ms=1, baud=115200, seed=2)) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = _rig(lb)
        s1.set_speed_in_us(60)
        s1.set_acceleration(40000)
        gear = Gear(engine, s1, s2)
        assert gear.engage(1, 3) == GearResult.OK
        s1.move(6000)
        assert b.wait_until(lambda: not s1.is_running() and not s2.is_running(), 10 * TPS)
        assert b.settle()
        trace = dev.trace()
        events = sorted([(t, 0) for t in trace.rising(9)] + [(t, 1) for t in trace.rising(10)])
        pos = [0, 0]
        worst = 0.0
        i = 0
        while i < len(events):
            t = events[i][0]
            while i < len(events) and events[i][0] == t:
                pos[events[i][1]] += 1
                i += 1
            worst = max(worst, abs(pos[1] - pos[0] / 3))
        assert pos == [6000, 2000]
        assert worst <= 1.0
        c = b.device_counters()
        assert c["underruns"] == 0 and c["late_starts"] == 0
