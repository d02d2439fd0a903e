"""Inputs (switches, pots) and limit switches on the simulated backend; queue timing."""

from __future__ import annotations

from fas import Engine
from fas.sim import SimBackend

PIN_SWITCH, PIN_POT = 17, 14


def stepper_rig():
    backend = SimBackend("atmega328p", record=True)
    engine = Engine(backend)
    engine.init()
    s = engine.stepper_connect_to_pin(10)
    s.set_direction_pin(7)
    s.set_speed_in_us(200)
    s.set_acceleration(100000)
    return backend, engine, s


def test_inputs_read_what_the_world_drives_and_tell_the_listeners():
    backend = SimBackend("atmega328p")
    heard = []
    backend.input_listeners.append(lambda pin, value, tick: heard.append((pin, value)))
    assert backend.read_input(PIN_SWITCH) is None  # not watched
    assert backend.watch_input(PIN_SWITCH, pullup=True)
    assert backend.watch_input(PIN_POT, analog=True, period_ms=50)
    assert backend.read_input(PIN_SWITCH) == 1  # the pull-up holds it high
    assert backend.read_input(PIN_POT) is None  # nobody turned it yet
    assert backend.drive_input(PIN_POT, 900)
    assert backend.drive_input(PIN_POT, 2000)  # clamped
    assert backend.drive_input(PIN_SWITCH, 0)
    assert backend.drive_input(PIN_SWITCH, 0)  # no change: nobody is told
    assert backend.read_input(PIN_POT) == 1023
    assert backend.read_input(PIN_SWITCH) == 0
    assert heard == [(PIN_POT, 900), (PIN_POT, 1023), (PIN_SWITCH, 0)]


def test_a_closing_limit_stops_the_pulses_at_once_at_the_exact_position():
    backend, engine, s = stepper_rig()
    backend.watch_input(PIN_SWITCH)
    hits = []
    backend.limit_listeners.append(lambda *a: hits.append(a))
    assert backend.set_limit(s.queue.index, PIN_SWITCH, 0, True)
    s.run_forward()
    backend.run_for_ms(300)
    t_switch = backend.now()
    backend.drive_input(PIN_SWITCH, 0)
    assert len(hits) == 1
    index, pin, position, tick = hits[0]
    s.force_stop_and_new_position(position)  # what the application does
    backend.run_for_ms(100)
    steps = backend.recorder.rising(10)
    assert (index, pin, tick) == (s.queue.index, PIN_SWITCH, t_switch)
    assert steps[-1] <= t_switch  # no pulse after the switch closed
    assert position == len(steps)  # the position is where the pulses stopped
    assert s.get_current_position() == position


def test_moving_away_from_a_closed_limit_is_allowed_and_towards_it_is_stopped():
    backend, engine, s = stepper_rig()
    backend.watch_input(PIN_SWITCH)
    backend.drive_input(PIN_SWITCH, 0)  # closed before anything moves
    hits = []

    def stopped(index, pin, position, tick):  # what the application does
        hits.append((index, pin, position, tick))
        s.force_stop_and_new_position(position)

    backend.limit_listeners.append(stopped)
    backend.set_limit(s.queue.index, PIN_SWITCH, 0, True)
    s.move(-50)  # away: fine
    backend.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == -50 and not hits
    s.move(100)  # towards it: the first command is stopped before its first pulse
    backend.run_for_ms(100)
    assert len(hits) == 1 and hits[0][2] == -50
    assert len(backend.recorder.rising(10)) == 50


def test_a_limit_also_stops_the_queues_named_with_it():
    backend, engine, s2 = stepper_rig()
    s1 = engine.stepper_connect_to_pin(9)
    s1.set_direction_pin(5)
    s1.set_speed_in_us(100)
    s1.set_acceleration(100000)
    backend.watch_input(PIN_SWITCH)
    hits = []
    backend.limit_listeners.append(lambda *a: hits.append(a))
    backend.set_limit(s2.queue.index, PIN_SWITCH, 0, True, stop=(s1.queue.index,))
    s1.run_forward()
    s2.run_forward()
    backend.run_for_ms(200)
    backend.drive_input(PIN_SWITCH, 0)
    t = backend.now()
    assert sorted(h[0] for h in hits) == [0, 1]
    for index, _pin, position, _tick in hits:
        st = s1 if index == s1.queue.index else s2
        st.force_stop_and_new_position(position)
        assert position == len(backend.recorder.rising(st.get_step_pin()))
    backend.run_for_ms(50)
    assert max(backend.recorder.rising(9)) <= t


def test_timed_start_and_queue_end_tick():
    backend, engine, s = stepper_rig()
    ch = s.queue.channel
    assert ch.end_tick() is None
    s.add_queue_entry(1000, 10, True, start=False)
    s.add_queue_entry(2000, 5, True, start=False)
    at = backend.now() + 50000
    assert ch.start_at(at) == at
    assert ch.is_running() and ch.end_tick() == at + 10 * 1000 + 5 * 2000
    backend.run_for(50000 + 15000)  # into the second command
    steps = backend.recorder.rising(10)
    assert steps[:10] == list(range(at, at + 10000, 1000))  # the first command on time
    assert ch.end_tick() == at + 20000
    s.add_queue_entry(3000, 2, True)
    assert ch.end_tick() == at + 26000
    backend.run_for(20000)
    assert ch.end_tick() is None  # ran out
    assert backend.recorder.rising(10)[-2:] == [at + 20000, at + 23000]
    assert ch.start_at(0) is None  # nothing queued
