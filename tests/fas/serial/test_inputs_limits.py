"""Inputs, limit switches and timed queues over the serial protocol (issue 13).

Host (SerialBackend) and device (the simulated one) on the virtual-clock loopback.
"""

from __future__ import annotations

import pytest

from fas import Engine
from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.gear import Gear, GearResult
from fas.serial.protocol import (
    F_INPUTS,
    F_SIM_INPUTS,
    F_TIMED_OUTPUTS,
    L_CLEAR,
    L_UP,
    S_ANALOG,
    W_ANALOG,
    Input,
    Limit,
    LimitHit,
    SetInput,
    Started,
    WatchInput,
    decode_messages,
)

TPS = 16_000_000
SWITCH, POT = 17, 14


def test_input_and_limit_messages_round_trip():
    msgs = [WatchInput(14, W_ANALOG, 50), Input(17, 1023, 0xFFFFFFFF),
            Limit(1, 17, 0, L_UP, 0b01), Limit(1, 0, 0, L_CLEAR, 0),
            LimitHit(1, 17, 200, -123456, 77), Started(0, 0x12345678),
            SetInput(14, 1023, S_ANALOG)]
    payload = b"".join(m.encode() for m in msgs)
    assert decode_messages(payload) == msgs
    assert [len(m.encode()) for m in msgs] == [4, 8, 6, 6, 12, 6, 5]


def test_the_device_reports_when_a_queue_really_started():
    with Loopback() as lb:
        b = lb.backend
        engine, s1, s2 = rig(lb)
        s1.add_queue_entry(2000, 200, True, start=False)
        ch = s1.queue.channel
        at = ch.start_at(b.now() + TPS // 100)
        planned_end = ch.end_tick()
        assert planned_end == at + 400000
        ch.t_begin += 160  # pretend the host had planned 10 us too late
        ch.t_end += 160
        b.app_wait_until(b.now() + TPS * 15 // 1000)
        assert ch.t_begin is None  # confirmed by Started ...
        assert ch.end_tick() == planned_end  # ... and moved back to where it really is


def test_the_host_reads_the_device_inputs_as_they_change():
    with Loopback() as lb:
        b, dev = lb.backend, lb.device
        heard = []
        b.input_listeners.append(lambda pin, value, tick: heard.append((pin, value, tick)))
        dev.set_input(POT, 700, analog=True)  # before anyone watches: a pot at 700
        assert b.watch_input(SWITCH, pullup=True)
        assert b.watch_input(POT, analog=True, period_ms=50)
        b.wait_until(lambda: b.read_input(POT) is not None, TPS // 10)
        assert b.read_input(SWITCH) == 1 and b.read_input(POT) == 700
        t_switch = dev.machine.now + TPS // 20
        dev.schedule_input(t_switch, SWITCH, 0)
        t_pot = dev.machine.now + TPS // 10
        dev.schedule_input(t_pot, POT, 300)
        b.app_wait_until(b.now() + TPS // 5)
        assert b.read_input(SWITCH) == 0 and b.read_input(POT) == 300
        switch = [h for h in heard if h[0] == SWITCH][-1]
        pot = [h for h in heard if h[0] == POT][-1]
        # a switch is reported at once, a pot at its next 50 ms sample; the host gets
        # the device's tick of reading it
        assert b.sync.device_tick32(switch[2]) == t_switch & 0xFFFFFFFF
        assert 0 <= b.sync.device_tick32(pot[2]) - t_pot < 50 * TPS // 1000


def test_a_simulated_device_takes_the_hosts_pots_and_switches():
    """SetInput: the host turns the simulated board's pot and presses its switch; the
    values come back from the device's pins (Input reports), not from the host."""
    with Loopback() as lb:
        b, dev = lb.backend, lb.device
        assert b.ident.features == F_INPUTS | F_SIM_INPUTS | F_TIMED_OUTPUTS
        b.watch_input(SWITCH, pullup=True)
        b.watch_input(POT, analog=True, period_ms=20)
        b.wait_until(lambda: b.read_input(POT) is not None, TPS // 10)
        assert b.read_input(POT) == 512  # nobody turned it: centred
        assert b.drive_input(SWITCH, 0) and b.drive_input(POT, 1023)
        assert b.read_input(SWITCH) == 1  # not yet: the device has not reported it
        b.wait_until(lambda: b.read_input(POT) == 1023, TPS // 10)
        assert b.read_input(SWITCH) == 0 and b.read_input(POT) == 1023
        assert dev.machine.pins.get(SWITCH) == 0 and dev.inputs.analog[POT] == 1023
        assert b.drive_input(21, 300)  # a pin nobody watches: a value above 1 is a pot
        assert b.settle()
        assert dev.inputs.analog[21] == 300


def test_a_board_refuses_set_input_and_the_host_does_not_send_it():
    with Loopback(connect=False) as lb:
        dev = lb.device
        dev.features = F_INPUTS  # a board: its inputs are its pins
        b = lb.backend = lb.open_backend()
        b.watch_input(SWITCH)
        assert b.drive_input(SWITCH, 0) is False
        assert b.send(SetInput(SWITCH, 0, 0))  # a host that misbehaves
        assert b.settle() and b.request_status() is not None
        assert b.device_counters()["rejected"] == 1
        assert dev.machine.pins.get(SWITCH) == 1  # the pull-up still holds it


def test_a_device_without_inputs_gets_no_watch_and_no_limit():
    with Loopback(connect=False) as lb:
        lb.device.features = 0  # before section 18
        b = lb.backend = lb.open_backend()
        assert b.watch_input(SWITCH) is False
        assert b.set_limit(1, SWITCH, 0, True) is False
        assert b.settle() and b.request_status() is not None
        assert b.device_counters()["rejected"] == 0 and not lb.device.inputs.watches


def test_watches_come_back_after_a_reconnect():
    with Loopback() as lb:
        b, dev = lb.backend, lb.device
        b.watch_input(SWITCH)
        b.wait_until(lambda: b.read_input(SWITCH) is not None, TPS // 10)
        b.reconnect()
        dev.set_input(SWITCH, 0)
        b.wait_until(lambda: b.read_input(SWITCH) == 0, TPS // 5)
        assert b.read_input(SWITCH) == 0
        assert SWITCH in dev.inputs.watches


def rig(lb):
    b = lb.backend
    engine = Engine(b)
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
def test_a_device_limit_stops_without_a_step_after_the_switch(faults):
    with Loopback(record=True, faults=faults) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = rig(lb)
        b.watch_input(SWITCH)
        hits = []

        def stopped(index, pin, position, tick):
            hits.append((index, pin, position, tick))
            engine.stepper(index).force_stop_and_new_position(position)

        b.limit_listeners.append(stopped)
        assert b.set_limit(1, SWITCH, 0, True, stop=(0,))
        s1.run_forward()
        s2.run_forward()
        b.app_wait_until(b.now() + TPS // 4)
        t_switch = dev.machine.now + 1234
        dev.schedule_input(t_switch, SWITCH, 0)
        b.app_wait_until(b.now() + TPS // 10)
        assert b.settle()
        assert sorted(h[0] for h in hits) == [0, 1]
        for index, _pin, position, tick in hits:
            steps = dev.recorder.rising(dev.queues[index].step_pin)
            assert steps[-1] <= t_switch  # stopped by the device: no step after it
            assert position == len(steps) == engine.stepper(index).get_current_position()
            assert b.sync.device_tick32(tick) == t_switch & 0xFFFFFFFF
        assert not any(st.halted for st in dev.steppers.stops.values())  # the host's force stop
        # let the queues in again
        s2.move(-100)  # away from it
        assert b.wait_until(lambda: not s2.is_running(), TPS)
        assert b.settle()
        assert dev.position(1) == hits[-1][2] - 100 if hits[-1][0] == 1 else True


def test_a_halted_queue_refuses_entries_until_the_host_knows():
    with Loopback(record=True) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = rig(lb)
        b.watch_input(SWITCH)
        dev.set_input(SWITCH, 0)
        b.set_limit(1, SWITCH, 0, True)
        hits = []
        b.limit_listeners.append(lambda *a: hits.append(a))  # the host ignores it
        s2.move(500)  # towards the closed limit
        b.app_wait_until(b.now() + TPS // 5)
        assert hits and dev.steppers.stops[1].halted
        assert dev.recorder.rising(10) == []
        assert dev.counters["discarded"] > 0  # the entries that followed
        s2.force_stop_and_new_position(hits[0][2])
        b.clear_limit(1, True)
        assert b.settle()
        assert not dev.steppers.stops[1].halted
        s2.move(20)
        assert b.wait_until(lambda: not s2.is_running(), TPS)
        assert b.settle()
        assert len(dev.recorder.rising(10)) == 20


def test_a_limit_set_on_a_closed_switch_stops_a_queue_running_into_it():
    with Loopback(record=True) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = rig(lb)
        b.watch_input(SWITCH)
        hits = []
        b.limit_listeners.append(lambda *a: hits.append(a))
        s2.run_forward()
        b.app_wait_until(b.now() + TPS // 10)
        dev.set_input(SWITCH, 0)  # closed before anyone made it a limit
        b.app_wait_until(b.now() + TPS // 100)
        assert s2.is_running() and not hits
        at = dev.machine.now
        b.set_limit(1, SWITCH, 0, True)
        b.app_wait_until(b.now() + TPS // 20)
        assert [h[0] for h in hits] == [1]
        steps = dev.recorder.rising(10)
        assert steps[-1] < at + TPS // 100 and hits[0][2] == len(steps)


def test_gear_over_the_device_keeps_the_ratio_by_the_device_pins():
    with Loopback(record=True, faults=Faults(latency_ms=1, baud=115200, seed=2)) as lb:
        b, dev = lb.backend, lb.device
        engine, s1, s2 = rig(lb)
        s1.set_speed_in_us(60)
        s1.set_acceleration(40000)
        gear = Gear(engine, s1, s2)
        assert gear.engage(1, 3) == GearResult.OK
        s1.move(6000)
        assert b.wait_until(lambda: not s1.is_running() and not s2.is_running(), 10 * TPS)
        assert b.settle()
        s1_steps = [(t, 0) for t in dev.recorder.rising(9)]
        s2_steps = [(t, 1) for t in dev.recorder.rising(10)]
        pos = [0, 0]
        worst = 0.0
        events = sorted(s1_steps + s2_steps)
        i = 0
        while i < len(events):
            t = events[i][0]
            while i < len(events) and events[i][0] == t:
                pos[events[i][1]] += 1
                i += 1
            worst = max(worst, abs(pos[1] - pos[0] / 3))
        assert pos == [6000, 2000]
        assert worst <= 1.0
        assert dev.counters["underruns"] == 0 and dev.counters["late_starts"] == 0
