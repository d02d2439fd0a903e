"""PWM arithmetic of the user outputs: resolution/frequency pairs, nearest count, clamping."""

from fractions import Fraction

import pytest

from fas.arch import PROFILES, get_profile
from fas.output_figures import output_figures
from fas.pwm import (
    PwmFrequencyError,
    clamp_percent,
    count_percent,
    duty_count,
    frequency_range,
    pwm_setting,
)

ESP32 = get_profile("esp32")
LEDC = output_figures(ESP32).pwm_timers[0]


@pytest.mark.parametrize("hz, bits, div256", [
    (10_000, 12, 500),  # seed 003: 80 MHz / 10 kHz = 8000 -> 12 bits (4096)
    (5_000, 13, 500),  # 16000 -> 13 bits (the most allowed)
    (20_000, 11, 500),
    (50, 13, 50_000),  # RC servo: 13 bits, divider 195.3125
    (1_000, 13, 2_500),
    (40_000_000, 1, 256),  # the fastest: one bit, divider 1.0
    (1_234.5, 13, 2_025),  # not exact: the divider is truncated (ESP-IDF)
])
def test_esp32_resolution_is_whole_bits_of_80_mhz_at_most_13(hz, bits, div256):
    s = pwm_setting(LEDC, hz)
    assert s.counts == 2 ** bits
    assert s.bits == bits
    assert s.clock_div == div256
    assert s.frequency == Fraction(80_000_000 * 256, div256 * 2 ** bits)


def test_esp32_frequency_outside_the_divider_range_is_refused():
    low, high = frequency_range(LEDC)
    assert 9.53 < low < 9.54 and high == 40_000_000
    for hz in (9.5, 0, -5, 40_000_001, float("nan")):
        with pytest.raises(PwmFrequencyError):
            pwm_setting(LEDC, hz)
    assert pwm_setting(LEDC, 9.54).counts == 8192


def test_esp32_5khz_period_is_3200_ticks_of_the_16mhz_clock():
    assert pwm_setting(LEDC, 5000).period_ticks(16_000_000) == 3200
    # 1234.5 Hz does not divide the tick: the period is an exact fraction
    p = pwm_setting(LEDC, 1234.5).period_ticks(16_000_000)
    assert p == Fraction(12960) and float(pwm_setting(LEDC, 1234.5).frequency) == \
        pytest.approx(1234.5679, abs=1e-4)


@pytest.mark.parametrize("percent, count", [
    (23.87, 1955), (0, 0), (100, 8192), (50, 4096), (0.01, 1), (0.006, 0),
    (150, 8192), (-3, 0), (1e9, 8192),
])
def test_duty_is_the_nearest_count_clamped_to_0_100(percent, count):
    assert duty_count(8192, percent) == count


def test_duty_count_rounds_half_up_and_reports_the_produced_percentage():
    assert duty_count(4, 12.5) == 1  # exactly half a count
    assert duty_count(4, 12.4) == 0
    assert count_percent(1955, 8192) == pytest.approx(23.86474609375)
    assert clamp_percent(101) == 100 and clamp_percent(-0.5) == 0


def test_atmega328p_timer2_has_a_fixed_top_and_picks_the_nearest_prescaler():
    t2 = output_figures(get_profile("atmega328p")).pwm_timer("timer 2")
    s = pwm_setting(t2, 5000)  # 62500 / 7812.5 / 1953 Hz ...: 7812.5 is nearest
    assert (s.clock_div, s.counts, s.frequency) == (8, 256, Fraction(15625, 2))
    s = pwm_setting(t2, 50)  # the slowest: prescaler 1024
    assert (s.clock_div, s.frequency) == (1024, Fraction(1_000_000, 16384))
    assert pwm_setting(t2, 1_000_000).frequency == 62500


def test_atmega328p_timer0_runs_millis_and_makes_only_976_hz():
    t0 = output_figures(get_profile("atmega328p")).pwm_timer("timer 0")
    for hz in (50, 5000, 100_000):
        assert pwm_setting(t0, hz).frequency == Fraction(16_000_000, 64 * 256)


@pytest.mark.parametrize("timer, hz, prescaler, counts", [
    ("timer 1", 5000, 1, 3200),  # 16-bit with TOP in ICR1: smallest prescaler that fits
    ("timer 1", 50, 8, 40000),
    ("timer 1", 1, 256, 62500),
    ("timer 3", 333, 1, 48048),
    ("timer 2", 5000, 32, 100),  # 8-bit with TOP in OCR2A
    ("timer 2", 1000, 64, 250),
])
def test_atmega2560_variable_top_gives_the_best_resolution(timer, hz, prescaler, counts):
    s = pwm_setting(output_figures(get_profile("atmega2560")).pwm_timer(timer), hz)
    assert (s.clock_div, s.counts) == (prescaler, counts)


def test_atmega2560_8bit_timer_cannot_make_50_hz():
    t2 = output_figures(get_profile("atmega2560")).pwm_timer("timer 2")
    with pytest.raises(PwmFrequencyError) as exc:
        pwm_setting(t2, 50)
    assert exc.value.too_low and exc.value.lowest_hz == pytest.approx(61.035, abs=1e-3)
    assert pwm_setting(t2, 9_000_000).frequency == 8_000_000  # two counts: the fastest
    with pytest.raises(PwmFrequencyError):
        pwm_setting(t2, 13_000_000)  # fewer than two counts


def test_sam_timer_counter_period_is_exact_in_21_mhz_ticks():
    tc = output_figures(get_profile("sam_due")).pwm_timers[0]
    s = pwm_setting(tc, 5000)
    assert (s.clock_div, s.counts) == (2, 8400)
    assert s.period_ticks(21_000_000) == 4200


def test_every_profile_states_its_outputs_and_their_timers():
    for name in ("atmega328p", "atmega2560", "esp32", "sam_due"):
        p = output_figures(get_profile(name))
        assert len(p.user_digital_pins) == 4 and len(p.user_analog) == 4
    for profile in PROFILES.values():  # a profile without the table simply has no outputs
        p = output_figures(profile)
        assert len(p.user_digital_pins) in (0, 4) and len(p.user_analog) in (0, 4)
        for unit in (*p.user_analog, *p.pwm_pins):
            if unit.timer:
                assert p.pwm_timer(unit.timer) is not None, (profile.name, unit)
        # the default frequency works on every output that has a pin
        for unit in p.user_analog:
            if unit.timer:
                pwm_setting(p.pwm_timer(unit.timer), p.pwm_default_hz)
