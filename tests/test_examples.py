"""The user-facing examples in sequences/examples: their expectations can fail, and
the timing figures their header comments quote (durations, peak speeds, first step
intervals) are what the pins show and what the physics of the ramp says.

The scenario format checks positions, pulse counts and text; the figures below are
the part of each header that the format cannot check (test_sequences.py runs the
files themselves)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

from fas.sim import SimBackend
from stepperdemo.program import make_program
from stepperdemo.scenarios.evaluate import stepper_pins
from stepperdemo.scenarios.runner import run_file
from stepperdemo.scenarios.scenario import load

EXAMPLES = Path(__file__).resolve().parent.parent / "sequences" / "examples"
# -zeta(1/2): a ramp that times its step n at 1/sqrt(2*a*n) ends this / sqrt(2a) s early
ZETA_HALF = 1.4603545


def step_ticks(name: str) -> tuple[dict[str, list[int]], int]:
    """Rising step edges (ticks) per stepper letter for an example, and ticks per s."""
    sc = load(EXAMPLES / f"{name}.toml")
    backend = SimBackend(sc.profile, record=True)
    app = make_program(sc.program, backend, scripted=True)
    app.run_script(sc.input, firmware_end=False,
                   max_ticks=int(sc.max_time_s * backend.profile.ticks_per_s))
    edges = {p.letter: list(backend.recorder.rising(p.step))
             for p in stepper_pins(backend.profile)}
    return {k: v for k, v in edges.items() if v}, backend.profile.ticks_per_s


def duration_s(rises: list[int], tps: int) -> float:
    return (rises[-1] - rises[0]) / tps


def shortest_us(rises: list[int], tps: int) -> float:
    return min(b - a for a, b in zip(rises, rises[1:], strict=False)) * 1e6 / tps


def first_interval_us(rises: list[int], tps: int) -> float:
    return (rises[1] - rises[0]) * 1e6 / tps


def ramp_shortfall_s(a: float) -> float:
    return ZETA_HALF / math.sqrt(2 * a)


def test_there_are_a_dozen_examples_each_with_a_header():
    files = sorted(EXAMPLES.glob("*.toml"))
    assert len(files) >= 12
    for f in files:
        lines = f.read_text(encoding="utf-8").splitlines()
        header = [ln for ln in lines[:40] if ln.startswith("#")]
        assert lines[0].startswith("# ") and len(header) >= 5, f.name
        assert any("Look at" in ln for ln in header), f.name


def test_every_example_is_listed_in_the_readme():
    readme = (EXAMPLES / "README.md").read_text(encoding="utf-8")
    for f in EXAMPLES.glob("*.toml"):
        assert f"[{f.name}]({f.name})" in readme, f.name


@pytest.mark.parametrize("edit, check", [
    (("position = 3200", "position = 3201"), "A position"),
    (("pulses = 3200", "pulses = 3190"), "A pulses"),
    (('contains = ["Move steps 3200"', 'contains = ["Move steps 3201"'), "transcript contains"),
    (('not_contains = ["ERROR"]', 'not_contains = ["ERROR", "ticks RED"]'), "transcript lacks"),
])
def test_a_broken_expectation_fails(tmp_path, edit, check):
    target = tmp_path / "trapezoid_ramp.toml"
    shutil.copy(EXAMPLES / "trapezoid_ramp.toml", target)
    text = target.read_text(encoding="utf-8")
    assert edit[0] in text
    target.write_text(text.replace(edit[0], edit[1], 1), encoding="utf-8")
    res = run_file(target)
    assert res.error is None
    assert not res.ok
    assert [c.what for c in res.checks if not c.ok] == [check]


def test_trapezoid_ramp_lasts_up_coast_down():
    (a, v, s) = (1000, 1000, 3200)
    steps, tps = step_ticks("trapezoid_ramp")
    ideal = v / a + (s - v * v / a) / v + v / a  # 1 + 2.2 + 1 s
    assert ideal == pytest.approx(4.2)
    got = duration_s(steps["A"], tps)
    assert got == pytest.approx(4.136, abs=0.0005)  # quoted in the header
    assert got == pytest.approx(ideal - 2 * ramp_shortfall_s(a), rel=0.001)
    assert shortest_us(steps["A"], tps) == 1000


@pytest.mark.parametrize("name, a, s, duration, period_us", [
    ("triangle_ramp", 2000, 2000, 1.955, 500.5),
    ("move_3200", 1000, 3200, 3.515, 560),
])
def test_triangle_peaks_at_sqrt_a_s(name, a, s, duration, period_us):
    steps, tps = step_ticks(name)
    peak_hz = 1e6 / shortest_us(steps["A"], tps)
    assert shortest_us(steps["A"], tps) == period_us
    assert peak_hz == pytest.approx(math.sqrt(a * s), rel=0.005)
    got = duration_s(steps["A"], tps)
    assert got == pytest.approx(duration, abs=0.0005)
    assert got == pytest.approx(2 * math.sqrt(s / a) - 2 * ramp_shortfall_s(a), rel=0.001)


def test_jump_start_starts_at_ramp_step_100():
    a, jump, s = 1000, 100, 3200
    steps, tps = step_ticks("jump_start")
    rises = steps["A"]
    assert first_interval_us(rises, tps) == 2228
    assert first_interval_us(rises, tps) == pytest.approx(1e6 / math.sqrt(2 * a * jump),
                                                          rel=0.005)
    # up for (s - jump) / 2 steps from ramp step `jump`, down (s + jump) / 2 to a stop
    peak = math.sqrt(2 * a * (s + jump) / 2)
    assert shortest_us(rises, tps) == 552
    assert 1e6 / shortest_us(rises, tps) == pytest.approx(peak, rel=0.005)
    expected = (peak - math.sqrt(2 * a * jump)) / a + peak / a - ramp_shortfall_s(a)
    assert duration_s(rises, tps) == pytest.approx(3.155, abs=0.0005)
    assert duration_s(rises, tps) == pytest.approx(expected, rel=0.002)


def test_linear_acceleration_follows_the_documented_curve():
    a, s_h, s = 1000, 500, 3200

    def speed(n: int) -> float:  # upstream's formulas for the speed at ramp step n
        if n <= s_h:
            return math.sqrt(1.5 * a) / s_h ** (1 / 6) * n ** (2 / 3)
        return math.sqrt(2 * a * (n - s_h / 4))

    steps, tps = step_ticks("linear_acceleration")
    rises = steps["A"]
    assert speed(s_h) == pytest.approx(math.sqrt(1.5 * a * s_h))  # the hand-over speed
    assert first_interval_us(rises, tps) == 72768
    assert first_interval_us(rises, tps) == pytest.approx(1e6 / speed(1), rel=0.005)
    assert shortest_us(rises, tps) == 583
    assert 1e6 / shortest_us(rises, tps) == pytest.approx(speed(s // 2), rel=0.005)
    per_side = sum(1 / speed(n) for n in range(1, s // 2 + 1))
    assert per_side == pytest.approx(2.406, abs=0.0005)
    assert duration_s(rises, tps) == pytest.approx(4.810, abs=0.0005)
    assert duration_s(rises, tps) == pytest.approx(2 * per_side, rel=0.001)


def test_speed_change_coasts_at_both_speeds():
    steps, tps = step_ticks("speed_change_while_running")
    rises = steps["A"]
    periods = [b - a for a, b in zip(rises, rises[1:], strict=False)]
    assert periods.count(tps // 1000) == 1054 and periods.count(tps // 4000) == 2926
    assert duration_s(rises, tps) == pytest.approx(9.732, abs=0.0005)


def test_isr_block_costs_one_timer_wrap_per_gap():
    steps, tps = step_ticks("isr_block_effect")
    rises = steps["A"]
    out, back = rises[:20000], rises[20000:]
    assert duration_s(out, tps) == pytest.approx(2.981, abs=0.0005)
    assert duration_s(back, tps) == pytest.approx(3.1448, abs=0.0005)
    wrap = 65536  # the ATmega's 16-bit timer

    def wraps(rises: list[int]) -> list[int]:  # a wrap + at most 200 us: a missed compare
        return [b - a for a, b in zip(rises, rises[1:], strict=False)
                if wrap < b - a < wrap + 3200]

    assert wraps(out) == []
    # each missed compare costs one wrap plus the step period (100 us); a chain of two
    # comes where the compare after a wrap meets a blocked section again (none with build
    # d's figures read, fortieth pass: 8 of 37 with those fitted before)
    assert len(wraps(back)) == 40
    assert all(4196 <= g * 1e6 / tps < 4200 for g in wraps(back))
    assert (back[-1] - back[0]) - (out[-1] - out[0]) == 40 * wrap


def test_esp32_runs_at_200_khz():
    steps, tps = step_ticks("esp32_200khz")
    rises = steps["A"]
    assert shortest_us(rises, tps) == 5
    assert duration_s(rises, tps) == pytest.approx(0.7, abs=0.001)
    assert rises[0] / tps == pytest.approx(5.3, abs=0.01)


def test_keep_running_and_mega_and_two_steppers_peaks():
    steps, tps = step_ticks("keep_running")  # 500 up, 1554 at 1000 steps/s, 500 down
    periods = [b - a for a, b in zip(steps["A"], steps["A"][1:], strict=False)]
    assert shortest_us(steps["A"], tps) == 1000 and periods.count(tps // 1000) == 1554
    mega, tps = step_ticks("mega2560_three_steppers")
    for letter, a, s, period in (("A", 2000, 4000, 354.25), ("B", 5000, 3000, 258.5),
                                 ("C", 10000, 5000, 141.75)):
        assert shortest_us(mega[letter], tps) == period
        assert 1e6 / period == pytest.approx(math.sqrt(a * s), rel=0.005)
    two, tps = step_ticks("two_steppers")
    for letter in "AB":
        assert shortest_us(two[letter], tps) == 408.5
        assert duration_s(two[letter], tps) == pytest.approx(1.596, abs=0.0005)
    assert (two["B"][0] - two["A"][0]) / tps == pytest.approx(0.0177, abs=0.0001)
