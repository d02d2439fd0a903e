"""The per-platform parts of the API: queue allocation, FasDriver, task_rate, the I2S
multiplexer, the pulse counter, and what each profile's build of FastAccelStepper has."""

from __future__ import annotations

import pytest

from fas import Engine
from fas.arch import PROFILES, get_profile
from fas.codes import (
    DRIVER_DONT_CARE,
    DRIVER_I2S_DIRECT,
    DRIVER_MCPWM_PCNT,
    DRIVER_RMT,
    PIN_EXTERNAL_FLAG,
    PIN_I2S_FLAG,
    FasDriver,
)
from fas.errors import UnsupportedError
from fas.sim import SimBackend
from rigs.sim import make, run_until_idle
from stepperdemo.demo.build import demo_build


def engine(arch: str) -> Engine:
    e = Engine(SimBackend(arch))
    e.init()
    return e


# ------------------------------------------------------------- profile table
@pytest.mark.parametrize("arch,steppers", [
    ("atmega328p", 2), ("atmega2560", 3), ("atmega32u4", 3), ("sam_due", 6),
    ("rp2040", 8), ("rp2350", 12),
    ("esp32", 14), ("esp32_idf5", 49), ("esp32_idf6", 8),
    ("esp32s2", 4), ("esp32s3", 8), ("esp32c3", 2),
    ("esp32s2_idf5", 39), ("esp32s3_idf5", 43), ("esp32c3_idf5", 37),
    ("esp32c6", 39), ("esp32h2", 39), ("esp32p4", 39),
    ("esp32c6_idf6", 2), ("esp32h2_idf6", 2), ("esp32p4_idf6", 4),
])
def test_max_stepper_as_each_build(arch, steppers):
    assert get_profile(arch).max_steppers == steppers


def test_every_profile_is_offered_and_its_figures_hold_together():
    for name, p in PROFILES.items():
        assert p.name == name
        assert p.min_cmd_ticks >= p.max_speed_ticks(1)
        for pool in p.drivers:
            assert pool.queues > 0 and pool.max_speed_ticks >= 80
        assert len(demo_build(p).steppers) <= p.max_steppers
    with pytest.raises(ValueError, match="unknown architecture"):
        get_profile("z80")


def test_esp32_idf4_connects_six_mcpwm_then_eight_rmt_steppers():
    e = engine("esp32")
    pins = (17, 15, 2, 5, 16, 4, 14, 23, 32, 33, 25, 26, 22, 21)
    steppers = [e.stepper_connect_to_pin(p) for p in pins]
    assert [s.driver_type_string() for s in steppers] == ["MCPWM_PCNT"] * 6 + ["RMT"] * 8
    assert [s.index for s in steppers] == list(range(14))
    assert e.stepper_connect_to_pin(27) is None  # all 14 queues taken


def test_esp32_idf4_refuses_a_pin_twice_and_input_only_gpios():
    e = engine("esp32")
    assert e.stepper_connect_to_pin(17) is not None
    assert e.stepper_connect_to_pin(17) is None
    assert e.stepper_connect_to_pin(34) is None  # GPIO 34..39 are inputs
    assert e.stepper_connect_to_pin(5 | PIN_EXTERNAL_FLAG) is None


def test_esp32_idf4_driver_choice_takes_from_its_pool():
    e = engine("esp32")
    rmt = e.stepper_connect_to_pin(17, DRIVER_RMT)
    mcpwm = e.stepper_connect_to_pin(2, DRIVER_MCPWM_PCNT)
    assert rmt.driver_type() == FasDriver.RMT and rmt.index == 6  # queue 6: the first RMT
    assert mcpwm.driver_type() == FasDriver.MCPWM_PCNT and mcpwm.index == 0
    assert e.stepper_connect_to_pin(15, DRIVER_I2S_DIRECT) is None  # no I2S on ESP-IDF 4


def test_esp32_idf5_prefers_rmt_then_i2s_then_mcpwm_and_numbers_in_order():
    e = engine("esp32_idf5")
    pins = list(range(12, 20)) + [21, 22, 23, 25]
    kinds = [e.stepper_connect_to_pin(p).driver_type_string() for p in pins]
    assert kinds == ["RMT"] * 8 + ["I2S_DIRECT"] * 2 + ["MCPWM_PCNT"] * 2
    assert [s.index for s in e.steppers] == list(range(12))


def test_esp32_idf5_i2s_multiplexer():
    e = engine("esp32_idf5")
    assert e.stepper_connect_to_pin(PIN_I2S_FLAG | 3) is None  # mux not yet set up
    assert e.init_i2s_mux(12, 13, 14)
    assert not e.init_i2s_mux(12, 13, 14)  # only one
    s = e.stepper_connect_to_pin(PIN_I2S_FLAG | 3)
    assert s.driver_type_string() == "I2S_MUX"
    assert s.get_max_speed_in_hz() == 40000  # the mux runs at 250 kHz frames
    assert e.stepper_connect_to_pin(PIN_I2S_FLAG | 3) is None  # slot taken
    s.set_direction_pin(PIN_I2S_FLAG | 4)
    assert e.i2s_mux_get_bit(4)  # HIGH counts up: the slot is driven HIGH
    assert e.stepper_connect_to_pin(PIN_I2S_FLAG | 4) is None  # the dir slot is taken
    e.i2s_mux_set_bit(9, True)
    assert e.i2s_mux_get_bit(9) and not e.i2s_mux_get_bit(10)
    e.i2s_mux_set_bit(9, False)
    assert not e.i2s_mux_get_bit(9)
    # the mux took one of the two I2S controllers: one I2S_DIRECT stepper is left
    assert e.stepper_connect_to_pin(15, DRIVER_I2S_DIRECT) is not None
    assert e.stepper_connect_to_pin(16, DRIVER_I2S_DIRECT) is None


def test_i2s_mux_runs_a_stepper_on_its_slot():
    backend = SimBackend("esp32_idf5", record=True)
    e = Engine(backend)
    e.init()
    e.init_i2s_mux(12, 13, 14)
    s = e.stepper_connect_to_pin(PIN_I2S_FLAG | 0)
    s.set_direction_pin(PIN_I2S_FLAG | 1)
    s.set_enable_pin(PIN_I2S_FLAG | 2)
    s.set_auto_enable(True)
    s.set_speed_in_hz(10000)
    s.set_acceleration(100000)
    s.move(-200)
    run_until_idle(backend, s)
    assert s.get_current_position() == -200
    assert len(backend.recorder.rising(PIN_I2S_FLAG | 0)) == 200
    assert not e.i2s_mux_get_bit(1)  # counting down: the dir slot went LOW


def test_esp32_idf6_is_rmt_only_without_driver_types_or_pulse_counter():
    e = engine("esp32_idf6")
    s = e.stepper_connect_to_pin(17)
    with pytest.raises(UnsupportedError, match="driver_type"):
        s.driver_type()
    with pytest.raises(UnsupportedError):
        e.stepper_connect_to_pin(18, DRIVER_RMT)
    with pytest.raises(UnsupportedError, match="attach_to_pulse_counter"):
        s.attach_to_pulse_counter(7)
    assert e.stepper_connect_to_pin(18, DRIVER_DONT_CARE) is not None


def test_rmt_reports_positions_by_command_and_pauses_before_reversing():
    backend = SimBackend("esp32", record=True)
    e = Engine(backend)
    e.init()
    s = e.stepper_connect_to_pin(17, DRIVER_RMT)
    s.set_direction_pin(18)
    assert s.add_queue_entry(1000, 100, True) == 0
    backend.run_for(1000 * 50)
    assert s.get_current_position() == 0  # the command runs; RMT cannot tell how far
    run_until_idle(backend, s)
    assert s.get_current_position() == 100
    s.add_queue_entry(1000, 10, True)
    s.add_queue_entry(1000, 10, False)  # reversing: a MIN_CMD_TICKS pause goes first
    entries = []
    q = s.queue
    rp = q.read_idx
    while rp != q.next_write_idx:
        entries.append((q.entries[rp % q.queue_len].ticks, q.entries[rp % q.queue_len].total_steps))
        rp = (rp + 1) & 0xFF
    assert (3200, 0) in entries


def test_pulse_counter_units_per_build():
    e = engine("esp32")  # ESP-IDF 4: units 0..5 belong to the MCPWM/PCNT steppers
    steppers = [e.stepper_connect_to_pin(p) for p in (17, 15)]
    steppers[0].set_direction_pin(18)
    assert not steppers[0].attach_to_pulse_counter(1)  # unit 1 drives stepper 2
    assert not steppers[0].attach_to_pulse_counter(8)
    assert steppers[0].attach_to_pulse_counter(7)
    assert not steppers[1].attach_to_pulse_counter(7)  # taken
    assert steppers[1].attach_to_pulse_counter(6)
    e5 = engine("esp32_idf5")  # ESP-IDF 5 hands out the free units itself
    pins = (12, 13, 14, 15, 16, 17, 18, 19, 21, 22)
    got = [e5.stepper_connect_to_pin(p).attach_to_pulse_counter(0) for p in pins]
    assert got == [True] * 8 + [False] * 2
    with pytest.raises(UnsupportedError):
        engine("esp32c3").stepper_connect_to_pin(6).attach_to_pulse_counter(0)
    for arch in ("atmega328p", "sam_due", "rp2040"):
        backend, _, s = make(arch, dir_pin=None, enable_pin=None)
        with pytest.raises(UnsupportedError):
            s.attach_to_pulse_counter(0)


def test_pulse_counter_with_a_readback_pin_for_an_external_direction_pin():
    backend = SimBackend("esp32", record=True)
    e = Engine(backend)
    e.init()
    levels = {}

    def external(pin: int, value: int) -> bool:
        levels[pin] = value
        backend.write_pin(19, value)  # the expander's output is wired back to GPIO 19
        return bool(value)

    e.set_external_call_for_pin(external)
    s = e.stepper_connect_to_pin(17)
    s.set_direction_pin(PIN_EXTERNAL_FLAG | 3)
    assert s.attach_to_pulse_counter(7, -1000, 1000, dir_pin_readback=19)
    s.set_speed_in_us(200)
    s.set_acceleration(50000)
    s.move(300)
    run_until_idle(backend, s)
    s.move(-100)
    run_until_idle(backend, s)
    assert s.get_current_position() == 200
    assert s.read_pulse_counter() == 200
    t = SimBackend("esp32")  # without a readback, an external direction counts up
    e2 = Engine(t)
    e2.init()
    e2.set_external_call_for_pin(lambda pin, v: bool(v))
    s2 = e2.stepper_connect_to_pin(17)
    s2.set_direction_pin(PIN_EXTERNAL_FLAG | 3)
    s2.attach_to_pulse_counter(7, -1000, 1000)
    s2.set_speed_in_us(200)
    s2.set_acceleration(50000)
    s2.move(50)
    run_until_idle(t, s2)
    s2.move(-20)
    run_until_idle(t, s2)
    assert s2.get_current_position() == 30 and s2.read_pulse_counter() == 70


# ------------------------------------------------------------------ task rate
def test_task_rate_sets_the_ramp_task_period():
    backend = SimBackend("esp32")
    e = Engine(backend)
    e.init(cpu_core=1)
    assert e.get_task_rate() == 4 and e.cpu_core == 1
    s = e.stepper_connect_to_pin(17)
    s.set_speed_in_us(100)
    s.set_acceleration(10000)
    e.task_rate(10)
    assert e.get_task_rate() == 10
    runs = backend.task_runs
    s.move(100000)
    backend.run_for_ms(1000)
    assert 95 <= backend.task_runs - runs <= 102  # every 10 ms instead of every 4
    with pytest.raises(UnsupportedError):
        engine("atmega328p").task_rate(2)
    with pytest.raises(UnsupportedError):
        Engine(SimBackend("sam_due")).init(cpu_core=0)


def test_sim_task_period_follows_the_task_rate_and_a_reset():
    # SimBackend keeps task_period_ticks as a plain attribute (a property's call on the
    # planner's per-task path costs): the period set, then the profile's after a reset
    backend = SimBackend("esp32")
    p = backend.profile
    assert backend.task_period_ticks == p.fill_period_ticks == 4 * p.ticks_per_ms
    e = Engine(backend)
    e.init(cpu_core=1)
    e.task_rate(10)
    assert backend.task_period_ticks == 10 * p.ticks_per_ms
    backend.reset_chip()
    assert backend.task_period_ticks == p.fill_period_ticks


@pytest.mark.parametrize("arch,half_period_ms", [
    ("atmega328p", 122 * 65536 // 16000),  # 122 timer overflows: ~1 Hz
    ("esp32", 50 * 4), ("rp2040", 50 * 4), ("sam_due", 50 * 2)])  # 50 task runs
def test_debug_led_toggles_every_half_period(arch, half_period_ms):
    backend = SimBackend(arch, record=True)
    e = Engine(backend)
    e.init()
    e.set_debug_led(30)
    e.stepper_connect_to_pin(demo_build(backend.profile).steppers[0].step)
    backend.run_for_ms(3000)
    times, _ = backend.recorder.pin_edges(30)
    assert abs(len(times) - 3000 // half_period_ms) <= 1, arch


# ---------------------------------------------------------------- SAM, Pico, AVR
def test_sam_due_channel_groups_and_every_valid_pin():
    groups = ((34, 67, 73, 35), (17, 36, 72, 37, 42), (38, 43, 63, 39), (40, 64, 69, 41),
              (9,), (8, 44), (7, 45), (6,))
    assert get_profile("sam_due").step_pin_groups == groups
    for group in groups:
        for pin in group:
            assert engine("sam_due").stepper_connect_to_pin(pin) is not None, pin
    e = engine("sam_due")
    got = [e.stepper_connect_to_pin(group[0]) for group in groups]
    assert all(got[:6]) and got[6] is None and got[7] is None  # six queues
    assert [s.index for s in got[:6]] == list(range(6))
    with pytest.raises(UnsupportedError):
        got[0].set_absolute_speed_limit(100)


def test_pico_takes_any_pin_below_32():
    e = engine("rp2040")
    assert e.stepper_connect_to_pin(32) is None
    got = [e.stepper_connect_to_pin(p) for p in range(9)]
    assert all(got[:8]) and got[8] is None  # 2 PIOs x 4 state machines
    assert got[0].get_max_speed_in_hz() == 200_000


@pytest.mark.parametrize("arch,pins", [("atmega2560_timer1", (11, 12, 13)),
                                        ("atmega2560_timer3", (5, 2, 3)),
                                        ("atmega2560", (6, 7, 8)),
                                        ("atmega2560_timer5", (46, 45, 44)),
                                        ("atmega32u4", (9, 10, 11))])
def test_avr_timer_pins(arch, pins):
    e = engine(arch)
    assert e.stepper_connect_to_pin(9 if pins[0] != 9 else 6) is None
    got = [e.stepper_connect_to_pin(p) for p in pins]
    assert [s.index for s in got] == [0, 1, 2]
    assert got[0].get_max_speed_in_ticks() == 16_000_000 // 20000  # three steppers


def test_atmega32u4_has_no_external_direction_pin():
    backend, _, s = make("atmega32u4", dir_pin=None, enable_pin=None)
    with pytest.raises(UnsupportedError, match="ATmega32U4"):
        s.set_direction_pin(PIN_EXTERNAL_FLAG | 5)
    s.set_direction_pin(26)  # a GPIO is fine
