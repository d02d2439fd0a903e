"""The stepper API group by group, with the numbers upstream gives."""

from fas import Engine
from fas.codes import (
    PIN_EXTERNAL_FLAG,
    RAMP_DIRECTION_COUNT_DOWN,
    RAMP_DIRECTION_COUNT_UP,
    RAMP_DIRECTION_MASK,
    RAMP_STATE_MASK,
    AqeResult,
    DelayResult,
    MoveResult,
    RampState,
)
from fas.sim import SimBackend
from rigs.sim import make, periods, pin_position, rising, run_until_idle


# ------------------------------------------------------------------ speed
def test_speed_units_and_their_conversions():
    _, _, s = make()
    assert s.set_speed_in_us(100) == 0
    assert s.get_speed_in_ticks() == 1600 and s.get_speed_in_us() == 100
    assert s.get_speed_in_milli_hz() == 10_000_000
    assert s.set_speed_in_hz(4000) == 0
    assert s.get_speed_in_ticks() == 4000
    assert s.set_speed_in_milli_hz(2_500_000) == 0  # 2500 steps/s
    assert s.get_speed_in_ticks() == 6400
    assert s.set_speed_in_ticks(1234) == 0 and s.get_speed_in_ticks() == 1234


def test_bad_speed_values_return_minus_one_and_keep_the_old_speed():
    _, _, s = make()
    s.set_speed_in_us(100)
    assert s.set_speed_in_us(0) == -1
    assert s.set_speed_in_us(-5) == -1  # as uint32 it is far too slow
    assert s.set_speed_in_hz(0) == -1
    assert s.set_speed_in_hz(1_000_000) == -1  # faster than the chip allows
    assert s.set_speed_in_milli_hz(3) == -1
    assert s.set_speed_in_ticks(100) == -1
    assert s.set_speed_in_ticks(0xFFFFFFFF) == -1
    assert s.get_speed_in_us() == 100


def test_max_speed_depends_on_the_number_of_avr_steppers():
    backend = SimBackend("atmega328p")
    engine = Engine(backend)
    a = engine.stepper_connect_to_pin(9)
    assert a.get_max_speed_in_ticks() == 320 and a.get_max_speed_in_hz() == 50000
    b = engine.stepper_connect_to_pin(10)
    assert a.get_max_speed_in_ticks() == b.get_max_speed_in_ticks() == 426
    assert a.get_max_speed_in_us() == 26
    assert engine.stepper_connect_to_pin(10) is None  # taken
    assert engine.stepper_connect_to_pin(11) is None  # not a timer pin
    a.set_absolute_speed_limit(200)
    assert a.get_max_speed_in_ticks() == 200


def test_profiles_connect_their_pins():
    assert Engine(SimBackend("atmega2560")).stepper_connect_to_pin(8) is not None
    esp = Engine(SimBackend("esp32"))
    pins = (17, 15, 2, 5, 16, 4, 14, 23, 32, 33, 25, 26, 22, 21)
    steppers = [esp.stepper_connect_to_pin(p) for p in pins]
    assert all(steppers) and esp.stepper_connect_to_pin(18) is None  # 6 + 8 queues
    assert esp.stepper_connect_to_pin(34) is None  # input-only GPIO
    assert steppers[0].get_max_speed_in_hz() == 200_000
    sam = Engine(SimBackend("sam_due"))
    assert sam.stepper_connect_to_pin(34) is not None
    assert sam.stepper_connect_to_pin(35) is None  # same PWM group as 34
    assert sam.stepper_connect_to_pin(3) is None


# ---------------------------------------------------------- acceleration
def test_acceleration_and_undefined_errors():
    backend, _, s = make()
    assert s.move(100) == MoveResult.ERR_SPEED_IS_UNDEFINED
    s.set_speed_in_us(100)
    assert s.move(100) == MoveResult.ERR_ACCELERATION_IS_UNDEFINED
    assert s.set_acceleration(0) == -1
    assert s.set_acceleration(-5) == -1
    assert s.set_acceleration(1000) == 0 and s.get_acceleration() == 1000
    assert s.move(100) == MoveResult.OK
    backend.run_for_ms(30)
    assert s.get_current_acceleration() == 1000
    run_until_idle(backend, s)
    assert s.get_current_acceleration() == 0


def test_move_without_direction_pin():
    backend, _, s = make(dir_pin=None)
    s.set_speed_in_us(100)
    s.set_acceleration(1000)
    assert s.move(-10) == MoveResult.ERR_NO_DIRECTION_PIN
    assert s.move(10) == MoveResult.OK
    run_until_idle(backend, s)
    assert s.get_current_position() == 10


# --------------------------------------------------------------- positions
def test_retarget_while_moving_overshoots_and_returns_to_zero():
    backend, _, s = make()
    s.set_speed_in_us(200)
    s.set_acceleration(100_000)
    s.move_to(1000)
    assert backend.wait_until(lambda: s.get_current_position() >= 500)
    s.move_to(0)
    states, positions = set(), []
    while s.is_running():
        backend.machine.run_one()
        states.add(s.ramp_state() & RAMP_STATE_MASK)
        positions.append(s.get_current_position())
    peak = max(positions)
    assert 500 < peak < 1000  # decelerated past 500, never reached 1000
    assert RampState.REVERSE in states
    assert s.get_current_position() == 0
    assert pin_position(backend, 9, 5) == 0
    assert len(rising(backend, 9)) == 2 * peak


def test_position_wraps_through_32_bit_limits():
    backend, _, s = make()
    s.set_speed_in_us(50)
    s.set_acceleration(100_000)
    s.set_current_position(-2_147_483_600)
    # the README example: from -2e9 to 2e9 is the short way down, through the wrap;
    # here 100 steps below -2^31+48 lands at 2^31-52
    assert s.move_to(2_147_483_596) == MoveResult.OK
    run_until_idle(backend, s)
    assert s.get_current_position() == 2_147_483_596
    assert len(rising(backend, 9)) == 100
    assert pin_position(backend, 9, 5) == -100  # it counted down


def test_readme_wrap_direction_is_down():
    backend, _, s = make()
    s.set_speed_in_us(50)
    s.set_acceleration(100_000)
    s.set_current_position(-2_000_000_000)
    s.move_to(2_000_000_000)
    backend.run_for_ms(200)
    assert s.ramp_state() & RAMP_DIRECTION_MASK == RAMP_DIRECTION_COUNT_DOWN
    assert s.get_current_position() < -2_000_000_000


def test_set_current_position_while_moving_keeps_the_difference():
    backend, _, s = make()
    s.set_speed_in_us(100)
    s.set_acceleration(10_000)
    s.move(3000)
    backend.run_for_ms(200)
    before = s.get_current_position()
    assert 0 < before < 3000
    s.set_current_position(0)
    assert s.get_current_position() == 0
    assert s.get_position_after_commands_completed() == 3000 - before - (
        3000 - s.get_position_after_commands_completed() - before)
    run_until_idle(backend, s)
    # the move still makes all its steps; the frame moved by what was set
    assert len(rising(backend, 9)) == 3000
    assert s.get_current_position() == 3000 - before


# ------------------------------------------------------------ stop variants
def test_stop_move_decelerates():
    backend, _, s = make()
    s.set_speed_in_us(50)
    s.set_acceleration(20_000)
    s.run_forward()
    backend.run_for_ms(500)
    assert s.is_running_continuously()
    s.stop_move()
    assert s.is_stopping()
    run_until_idle(backend, s)
    p = periods(rising(backend, 9))
    assert p[-1] > 5 * min(p)  # slowed down before the last step


def test_force_stop_ends_within_the_queued_commands():
    backend, _, s = make()
    s.set_speed_in_us(50)
    s.set_acceleration(20_000)
    s.run_forward()
    backend.run_for_ms(500)
    queued_end = s.get_position_after_commands_completed()
    s.force_stop()
    t = backend.now()
    run_until_idle(backend, s)
    assert s.get_current_position() == queued_end
    assert backend.now() - t < 25 * 16000  # about 20 ms of queue


def test_force_stop_and_new_position_emits_no_further_step():
    backend, _, s = make()
    s.set_speed_in_us(50)
    s.set_acceleration(20_000)
    s.run_backward()
    backend.run_for_ms(300)
    s.force_stop_and_new_position(1234)
    n = len(rising(backend, 9))
    backend.run_for_ms(100)
    assert len(rising(backend, 9)) == n
    assert not s.is_running()
    assert s.get_current_position() == 1234 == s.get_position_after_commands_completed()


# ---------------------------------------------------- speed while running
def test_apply_speed_acceleration_while_running():
    backend, _, s = make()
    s.set_speed_in_us(200)
    s.set_acceleration(50_000)
    s.run_forward()
    backend.run_for_ms(300)
    s.set_speed_in_us(100)
    backend.run_for_ms(200)
    assert s.get_period_in_us_after_commands_completed() == 200  # not applied yet
    s.apply_speed_acceleration()
    backend.run_for_ms(300)
    assert s.get_period_in_us_after_commands_completed() == 100
    assert s.get_current_speed_in_us() == 100
    assert s.get_current_speed_in_milli_hz() == 10_000_000


def test_move_by_acceleration_and_keep_running():
    backend, _, s = make()
    s.set_speed_in_us(100)
    assert s.move_by_acceleration(20_000) == MoveResult.OK
    backend.run_for_ms(800)
    assert s.get_current_speed_in_us() == 100
    assert s.move_by_acceleration(-20_000) == MoveResult.OK
    backend.run_for_ms(2000)
    assert s.get_current_speed_in_us() == -100
    assert s.ramp_state() & RAMP_DIRECTION_MASK == RAMP_DIRECTION_COUNT_DOWN
    s.move_by_acceleration(0)  # keep this speed (upstream does it with a = 1)
    backend.run_for_ms(500)
    assert s.get_current_speed_in_us() == -100
    assert s.get_acceleration() == 1
    s.set_acceleration(20_000)  # stop_move() does not apply new values by itself
    s.apply_speed_acceleration()
    s.stop_move()
    run_until_idle(backend, s)


def test_move_by_acceleration_0_without_a_speed_keeps_the_speed_undefined():
    """moveByAcceleration(0) sets both speeds through setSpeedInTicks(): a period of 0
    (not running) and an undefined speed (0 ticks) are refused there, so the speed
    stays undefined and the next move answers MOVE_ERR_SPEED_IS_UNDEFINED."""
    backend, _, s = make()
    assert s.move_by_acceleration(0) == MoveResult.OK
    assert s.get_speed_in_ticks() == 0 and s.get_acceleration() == 1
    assert s.move(100) == MoveResult.ERR_SPEED_IS_UNDEFINED
    backend.run_for_ms(100)
    assert rising(backend, 9) == [] and s.get_current_position() == 0
    # with a speed, a0 at rest keeps it (the period 0 is refused, not taken)
    s.set_speed_in_us(250)
    s.move_by_acceleration(0)
    assert s.get_speed_in_us() == 250 and s.move(10) == MoveResult.OK


def test_keep_running_turns_a_move_into_a_run():
    backend, _, s = make()
    s.set_speed_in_us(100)
    s.set_acceleration(10_000)
    s.move(100)
    backend.run_for_ms(10)  # the ramp task has taken over the move
    s.keep_running()
    backend.run_for_ms(500)
    assert s.is_running() and s.get_current_position() > 1000
    assert s.ramp_state() & RAMP_DIRECTION_MASK == RAMP_DIRECTION_COUNT_UP
    s.stop_move()
    run_until_idle(backend, s)


def test_blocking_move_returns_at_the_target():
    backend, _, s = make()
    s.set_speed_in_us(100)
    s.set_acceleration(50_000)
    assert s.move_to(777, blocking=True) == MoveResult.OK
    assert not s.is_running() and s.get_current_position() == 777


def test_single_steps():
    backend, _, s = make()
    s.forward_step(blocking=True)
    s.forward_step(blocking=True)
    s.backward_step(blocking=True)
    assert s.get_current_position() == 1
    assert len(rising(backend, 9)) == 3
    backend2, _, u = make(dir_pin=None)
    u.backward_step(blocking=True)  # no direction pin: a no-op
    assert u.get_current_position() == 0 and rising(backend2, 9) == []


# ------------------------------------------------------------- enable pins
def test_auto_enable_with_delays():
    backend, _, s = make()
    s.set_speed_in_us(100)
    s.set_acceleration(100_000)
    assert s.set_delay_to_enable(30) == DelayResult.TOO_LOW  # 480 ticks < MIN_CMD_TICKS 640
    assert s.set_delay_to_enable(70_000) == DelayResult.TOO_HIGH  # > 15 * 65535 ticks
    assert s.set_delay_to_enable(5000) == DelayResult.OK
    s.set_delay_to_disable(100)
    s.move(100)
    run_until_idle(backend, s)
    en_times, en_levels = backend.recorder.pin_edges(6)
    steps = rising(backend, 9)
    enable_at = [t for t, lv in zip(en_times, en_levels, strict=True) if lv == 0][0]
    assert steps[0] - enable_at >= 5000 * 16  # the on-delay before the first step
    disable_at = [t for t, lv in zip(en_times, en_levels, strict=True) if lv == 1]
    assert len(disable_at) == 1  # only the initial HIGH so far
    backend.run_for_ms(150)
    en_times, en_levels = backend.recorder.pin_edges(6)
    off = [t for t, lv in zip(en_times, en_levels, strict=True) if lv == 1][-1]
    gap_ms = (off - steps[-1]) / 16000
    assert 90 <= gap_ms <= 110  # 100 ms off-delay in 4 ms task periods


def test_manual_enable_disable():
    backend, _, s = make(auto_enable=False)
    assert s.outputs_enabled() is False  # low active pin is HIGH
    assert s.enable_outputs()
    assert backend.read_pin(6) == 0 and s.outputs_enabled()
    assert s.disable_outputs()
    assert backend.read_pin(6) == 1


def test_both_enable_polarities_are_driven():
    backend, _, s = make(enable_pin=None, auto_enable=False)
    s.set_enable_pin(6, True)
    s.set_enable_pin(8, False)
    assert backend.read_pin(6) == 1 and backend.read_pin(8) == 0
    s.enable_outputs()
    assert backend.read_pin(6) == 0 and backend.read_pin(8) == 1


def test_shared_enable_pin_stays_on_while_one_stepper_runs():
    backend = SimBackend("atmega328p", record=True)
    engine = Engine(backend)
    a = engine.stepper_connect_to_pin(9)
    b = engine.stepper_connect_to_pin(10)
    for s, d in ((a, 5), (b, 7)):
        s.set_direction_pin(d)
        s.set_enable_pin(6)
        s.set_auto_enable(True)
        s.set_delay_to_disable(10)
        s.set_speed_in_us(100)
        s.set_acceleration(100_000)
    a.move(200)
    b.move(3000)
    backend.wait_until(lambda: not a.is_running())
    backend.run_for_ms(50)
    assert b.is_running() and backend.read_pin(6) == 0  # a agreed, b did not
    backend.wait_until(lambda: not b.is_running())
    backend.run_for_ms(50)
    assert backend.read_pin(6) == 1


def test_shared_direction_pin_waits_for_the_other_stepper():
    backend = SimBackend("esp32", record=True)
    engine = Engine(backend)
    a = engine.stepper_connect_to_pin(17)
    b = engine.stepper_connect_to_pin(15)
    a.set_direction_pin(18)
    b.set_direction_pin(18)
    assert a.add_queue_entry(5000, 50, True) == AqeResult.OK
    assert b.add_queue_entry(5000, 5, False) == AqeResult.DIR_PIN_IS_BUSY
    backend.wait_until(lambda: not a.is_running())
    assert b.add_queue_entry(5000, 5, False) == AqeResult.OK
    backend.wait_until(lambda: not b.is_running())
    assert a.get_current_position() == 50 and b.get_current_position() == -5


def test_direction_change_delay_is_inserted():
    backend, _, s = make(dir_pin=None, auto_enable=False)
    s.set_direction_pin(5, True, 1000)  # 1 ms before the first step after a reversal
    s.add_queue_entry(2000, 3, True)
    s.add_queue_entry(2000, 3, False)
    run_until_idle(backend, s)
    steps = rising(backend, 9)
    dir_times, _ = backend.recorder.pin_edges(5)
    reversal = dir_times[-1]
    first_back = [t for t in steps if t > reversal][0]
    assert first_back - reversal >= 1000 * 16
    assert s.get_current_position() == 0


def test_external_direction_pin_via_callback():
    backend = SimBackend("atmega328p", record=True)
    engine = Engine(backend)
    calls = []
    engine.set_external_call_for_pin(lambda pin, value: calls.append((pin, value)) or value)
    s = engine.stepper_connect_to_pin(9)
    s.set_direction_pin(PIN_EXTERNAL_FLAG | 3)
    s.set_speed_in_us(200)
    s.set_acceleration(10_000)
    s.move(100)
    run_until_idle(backend, s)
    s.move(-50)
    run_until_idle(backend, s)
    assert s.get_current_position() == 50
    assert (PIN_EXTERNAL_FLAG | 3, 0) in calls


# ----------------------------------------------------------- pulse counter
def test_pulse_counter_counts_independently_and_wraps():
    backend, _, s = make("esp32", dir_pin=18, enable_pin=26)
    assert s.attach_to_pulse_counter(7, -100, 100)
    s.set_speed_in_us(100)
    s.set_acceleration(50_000)
    s.move(250)
    run_until_idle(backend, s)
    assert s.read_pulse_counter() == 50  # 250 mod 100
    s.move(-70)
    run_until_idle(backend, s)
    assert s.read_pulse_counter() == -20
    s.clear_pulse_counter()
    assert s.read_pulse_counter() == 0
    assert not s.attach_to_pulse_counter(7, 5, 10)  # low must not be positive


def test_switching_auto_enable_on_while_steps_are_queued_enables_the_driver_at_once():
    # found by fuzzing (`F b O`): upstream runs the queued steps with the driver off
    backend, _, s = make(auto_enable=False)
    s.set_speed_in_us(100)
    s.set_acceleration(10_000)
    s.disable_outputs()
    s.run_backward()
    backend.run_for_ms(100)
    assert backend.read_pin(6) == 1  # driver off, steps running (the user asked for it)
    s.set_auto_enable(True)
    assert backend.read_pin(6) == 0
    n = len(rising(backend, 9))
    backend.run_for_ms(50)
    times, levels = backend.recorder.pin_edges(6)
    assert levels[-1] == 0 and len(rising(backend, 9)) > n


# ------------------------------------------------------- milli-Hz as uint32_t
def test_milli_hz_getters_compute_in_uint32_t_as_the_cpp():
    """getMaxSpeedInMilliHz()/getCurrentSpeedInMilliHz(): ((uint32_t)250 *
    TICKS_PER_S) / ticks * 4.  On the SAM Due (21 MHz) 250 * TICKS_PER_S is
    5 250 000 000 and wraps to 955 032 704; / 420 * 4 = 9 095 548, not 50 000 000.
    getSpeedInMilliHz() (divForMilliHz, rounded) wraps the same way: 9 095 550."""
    _, _, s = make("sam_due")
    assert s.get_max_speed_in_ticks() == 420
    assert s.get_max_speed_in_milli_hz() == 9_095_548
    assert s.get_max_speed_in_hz() == 50_000 and s.get_max_speed_in_us() == 20
    assert s.set_speed_in_hz(50_000) == 0 and s.get_speed_in_ticks() == 420
    assert s.get_speed_in_milli_hz() == 9_095_550
    _, _, a = make("atmega328p")  # 250 * 16 MHz fits: no wrap
    assert a.get_max_speed_in_ticks() == 320 and a.get_max_speed_in_milli_hz() == 50_000_000


def test_current_speed_in_milli_hz_wraps_on_the_sam_due_both_ways():
    backend, _, s = make("sam_due", dir_pin=18, enable_pin=26)
    s.set_speed_in_hz(50_000)
    s.set_acceleration(1_000_000)
    s.run_forward()
    backend.run_for_ms(300)
    assert s.get_current_speed_in_milli_hz() == 9_095_548
    s.run_backward()
    backend.run_for_ms(600)
    assert s.get_current_speed_in_milli_hz() == -9_095_548
