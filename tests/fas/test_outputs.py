"""User outputs on the simulated chip: synchronized vs immediate, PWM waveforms, pins."""

import math

import pytest

from fas import Engine
from fas.codes import AqeResult, MoveResult
from fas.outputs import OutputResult
from fas.sim import SimBackend
from stepperdemo.demo.build import demo_build

TPS = 16_000_000


def engine_with(profile: str = "esp32", steppers: int = 1, record: bool = True):
    b = SimBackend(profile, record=record)
    e = Engine(b)
    e.init()
    out = []
    for cfg in demo_build(b.profile).steppers[:steppers]:
        s = e.stepper_connect_to_pin(cfg.step)
        s.set_direction_pin(cfg.direction)
        s.set_speed_in_us(100)
        s.set_acceleration(20_000)
        out.append(s)
    return b, e, out


def edges(b, pin):
    b.machine.outputs.deliver_until(b.now())
    return list(zip(*b.recorder.pin_edges(pin), strict=True))


def idle(b, e, steppers, limit_s=60):
    assert b.wait_until(lambda: not e.sync.active()
                        and not any(s.is_running() for s in steppers), limit_s * TPS)


def test_power_on_leaves_the_output_pins_untouched_and_low():
    b, e, _ = engine_with("atmega328p")
    for n in range(4):
        pin = e.outputs.digital_pin(n)
        assert pin not in b.machine.pins.first_write
        assert b.read_pin(pin) == 0 and e.outputs.digital_applied(n) == 0
    assert e.outputs.analog_state(0).setting is None  # the timer is not even started


def test_synchronized_digital_change_lies_between_the_moves():
    b, e, (s,) = engine_with()
    assert s.move(800) == MoveResult.OK
    assert e.outputs.digital(0, True) == OutputResult.OK  # M62 P0
    assert s.move(-800) == MoveResult.OK  # held until the output changed
    assert e.outputs.digital(0, False) == OutputResult.OK  # M63 P0
    assert e.outputs.pending() == 2
    idle(b, e, [s])
    steps = b.recorder.rising(17)
    assert len(steps) == 1600
    dout0 = edges(b, 32)
    assert [lv for _, lv in dout0] == [1, 0]
    assert steps[799] < dout0[0][0] < steps[800]
    assert dout0[1][0] > steps[-1]
    assert s.get_current_position() == 0
    assert e.outputs.pending() == 0 and e.sync.held_calls == 1


def test_synchronized_change_waits_for_every_stepper():
    b, e, (s1, s2) = engine_with("atmega2560", steppers=2)
    s1.move(300)
    s2.move(2000)  # the longer one
    e.outputs.digital(2, True)
    idle(b, e, [s1, s2])
    rise = edges(b, 24)[0][0]
    assert b.recorder.rising(6)[-1] < rise
    assert b.recorder.rising(7)[-1] < rise
    # made when the last queue ran dry: within that stepper's final wait (one period)
    assert rise - b.recorder.rising(7)[-1] < TPS // 100


def test_immediate_change_happens_at_once_while_motion_runs():
    b, e, (s,) = engine_with()
    s.move(4000)
    b.run_for_ms(50)
    t = b.now()
    assert e.outputs.digital(1, True, synchronized=False) == OutputResult.OK  # M64 P1
    assert edges(b, 33) == [(t, 1)]
    assert s.is_running()
    idle(b, e, [s])


def test_motion_commanded_after_a_barrier_is_checked_now_and_made_later():
    b, e, (s,) = engine_with()
    s.move(500)
    e.outputs.digital(0, True)
    plain = e.stepper_connect_to_pin(15)  # a second stepper without speed
    assert plain.move(10) == MoveResult.ERR_SPEED_IS_UNDEFINED  # refused at once
    assert plain.move(-10) == MoveResult.ERR_NO_DIRECTION_PIN
    assert s.add_queue_entry(3200, 1) == AqeResult.QUEUE_FULL  # try again later
    assert s.move_to(0) == MoveResult.OK
    assert s.is_running()
    idle(b, e, [s])
    assert s.get_current_position() == 0
    assert s.add_queue_entry(3200, 1) == AqeResult.OK


def test_held_blocking_move_returns_when_done():
    b, e, (s,) = engine_with()
    s.move(200)
    e.outputs.digital(0, True)
    assert s.move(-200, blocking=True) == MoveResult.OK
    assert not s.is_running() and s.get_current_position() == 0


def test_synchronized_change_with_nothing_moving_is_made_at_once():
    b, e, (s,) = engine_with()
    t = b.now()
    e.outputs.digital(3, True)
    assert edges(b, 25) == [(t, 1)]
    assert not e.sync.active()


def test_pwm_waveform_period_and_mean_duty_are_exact():
    b, e, _ = engine_with()
    assert e.outputs.analog(1, 23.87, synchronized=False) == OutputResult.OK
    st = e.outputs.analog_state(1)
    assert (st.count, st.setting.counts) == (1955, 8192)
    assert st.duty_percent == pytest.approx(23.8647, abs=1e-4)
    b.run_for_ms(200)
    ev = edges(b, 16)
    rises = [t for t, lv in ev if lv]
    falls = [t for t, lv in ev if not lv]
    periods = [b - a for a, b in zip(rises, rises[1:], strict=False)]
    assert set(periods) == {3200}  # 5000 Hz
    highs = [f - r for r, f in zip(rises, falls, strict=False)]  # the last may be high still
    assert set(highs) <= {763, 764}  # 763.67 ticks: the two nearest
    mean = sum(highs[:900]) / (900 * 3200) * 100
    assert mean == pytest.approx(100 * 1955 / 8192, abs=100 / 3200 / 900)
    # the change took effect at the start of the next period, not mid-period
    assert rises[0] == 3200


def test_duty_0_holds_low_100_holds_high_and_changes_wait_for_the_period():
    b, e, _ = engine_with()
    e.outputs.analog(0, 50, synchronized=False)
    b.run_for(3200 * 3 + 100)
    e.outputs.analog(0, 100, synchronized=False)  # from the next period: high
    b.run_for(3200 * 3)
    e.outputs.analog(0, -20, synchronized=False)  # clamped: 0 %
    b.run_for(3200 * 3)
    ev = edges(b, 5)
    assert ev[-2:] == [(3200 * 4, 1), (3200 * 7, 0)]
    assert e.outputs.analog_applied(0) == (0.0, 0)
    assert b.read_pin(5) == 0


def test_shared_timer_outputs_share_one_frequency():
    b, e, _ = engine_with("atmega328p")
    e.outputs.analog(0, 50, synchronized=False)
    assert e.outputs.set_frequency(1, 1000) == OutputResult.OK  # Aout1: timer 2 as Aout0
    assert e.outputs.analog_state(0).setting.frequency_hz == pytest.approx(976.5625)
    e.outputs.analog(1, 10, synchronized=False)
    assert e.outputs.analog_state(1).setting == e.outputs.analog_state(0).setting
    assert e.outputs.analog_state(0).count == 128  # recomputed for the new setting


def test_pins_missing_taken_or_without_pwm_are_refused():
    b, e, steppers = engine_with("esp32", steppers=5)
    assert e.outputs.analog(1, 10) == OutputResult.ERR_PIN_IN_USE  # stepper 5's step pin
    assert e.outputs.pin_user(16) == "stepper 5 step"
    assert e.outputs.set_analog_pin(1, 0) == OutputResult.OK  # any GPIO on ESP32
    assert e.outputs.analog(1, 10, synchronized=False) == OutputResult.OK
    steppers[3].set_enable_pin(25)
    assert e.outputs.digital(3, True) == OutputResult.ERR_PIN_IN_USE  # stepper 4 enable
    assert e.outputs.digital(4, True) == OutputResult.ERR_NO_SUCH_OUTPUT
    assert e.outputs.analog(0, math.nan) == OutputResult.ERR_NOT_A_NUMBER
    b, e, _ = engine_with("atmega328p")
    assert e.outputs.analog(2, 10) == OutputResult.ERR_NO_PIN  # no free timer
    assert e.outputs.set_analog_pin(2, 7) == OutputResult.ERR_NOT_PWM_PIN
    assert e.outputs.set_analog_pin(2, 5) == OutputResult.ERR_PIN_IN_USE  # M1's direction
    assert e.outputs.set_analog_pin(2, 6) == OutputResult.OK  # timer 0, OC0A
    assert e.outputs.analog(2, 10, synchronized=False) == OutputResult.OK
    assert e.outputs.analog_state(2).setting.frequency_hz == 976.5625  # millis() timer
    assert e.outputs.set_frequency(0, 10) == OutputResult.OK  # nearest: 61 Hz
    assert e.outputs.set_digital_pin(0, 3) == OutputResult.ERR_PIN_IN_USE  # Aout0


def test_frequency_change_waits_for_a_synchronized_duty_of_that_timer():
    b, e, (s,) = engine_with()
    s.move(400)
    e.outputs.analog(2, 30)  # synchronized, waits for the move
    assert e.outputs.set_frequency(2, 1000) == OutputResult.ERR_BUSY
    assert e.outputs.set_frequency(3, 1000) == OutputResult.OK  # another timer
    idle(b, e, [s])
    assert e.outputs.set_frequency(2, 1000) == OutputResult.OK


def test_alarm_drops_pending_changes_and_held_motion_outputs_unchanged():
    b, e, (s,) = engine_with()
    e.outputs.digital(1, True, synchronized=False)
    s.move(3000)
    e.outputs.digital(0, True)
    s.move(-3000)
    b.run_for_ms(30)
    s.force_stop_and_new_position(s.get_current_position())
    assert e.outputs.cancel_pending() == 1
    b.run_for_ms(300)
    assert edges(b, 32) == [] and e.outputs.digital_level(0) == 0
    assert e.outputs.digital_applied(1) == 1 and b.read_pin(33) == 1
    assert not s.is_running() and 0 < s.get_current_position() < 3000


def test_reset_switches_every_output_off():
    b, e, _ = engine_with()
    e.outputs.digital(0, True, synchronized=False)
    e.outputs.analog(1, 40, synchronized=False)
    b.run_for_ms(5)
    e.outputs.reset()
    b.run_for_ms(5)
    assert b.read_pin(32) == 0 and b.read_pin(16) == 0
    assert e.outputs.analog_applied(1) == (0.0, 0)


def test_pwm_without_listeners_costs_no_edges():
    b, e, _ = engine_with(record=False)
    e.outputs.analog(0, 25, synchronized=False)
    b.run_for(16_000_000)  # one second: 5000 periods
    assert b.read_pin(5) in (0, 1)
    assert b.machine.pins.rising(5) == 0  # nothing was made
    wave = b.machine.outputs.waves[5]
    b.machine.outputs.deliver_until(b.now())
    assert wave.k >= 4999  # but it knows where it is


def test_a_profile_without_an_output_table_has_no_outputs():
    from dataclasses import replace

    from fas.arch import get_profile

    # an ESP32 variant that fas.output_figures does not list (the simulator times it as
    # its family)
    bare = replace(get_profile("esp32"), name="bare")
    e = Engine(SimBackend(bare))
    e.init()
    assert e.outputs.digital(0, True) == OutputResult.ERR_NO_PIN
    assert e.outputs.analog(0, 10) == OutputResult.ERR_NO_PIN
    assert e.outputs.set_analog_pin(0, 5) == OutputResult.ERR_NOT_PWM_PIN
    assert e.outputs.set_digital_pin(0, 5) == OutputResult.OK
    assert e.outputs.digital(0, True) == OutputResult.OK
