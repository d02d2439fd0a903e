"""The straight-line planner: limits, command rules, axes on the line and ending together."""

import math

import pytest

from stepperdemo.gcode.line import (
    Limits,
    StepTimes,
    axis_commands,
    line_commands,
    line_profile,
    speed_profile,
    split_wait,
)

AVR = Limits(16_000_000, 640, 427, 32_000)
ESP32 = Limits(16_000_000, 3200, 80, 32_000)


def pulses(cmds):
    """Pulse ticks and the end tick of a command list (the queue's meaning)."""
    t, out = 0, []
    for ticks, steps, _ in cmds:
        out.extend(t + j * ticks for j in range(steps))
        t += ticks * steps if steps else ticks
    return out, t


def check_rules(cmds, limits):
    for ticks, steps, _ in cmds:
        assert 0 < ticks <= 65535 and 0 <= steps <= 255
        assert (ticks * steps if steps > 1 else ticks) >= limits.min_cmd_ticks
        if steps:
            assert ticks >= limits.min_step_ticks


def max_deviation(xs, ys, dx, dy):
    """Largest distance (steps) of the pin position from the straight line."""
    events = sorted([(t, 0) for t in xs] + [(t, 1) for t in ys])
    x = y = 0
    worst = 0.0
    length = math.hypot(dx, dy)
    i = 0
    while i < len(events):
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            if events[i][1]:
                y += 1
            else:
                x += 1
            i += 1
        worst = max(worst, abs(x * dy - y * dx) / length)
    return worst


def test_profile_is_a_trapezoid_or_a_triangle():
    p = speed_profile(0.5, 1.0)  # top speed reached after a quarter of the path
    assert p.s_acc == pytest.approx(0.125) and p.duration == pytest.approx(2.5)
    assert p.time_at(1.0) == pytest.approx(p.duration)
    assert p.time_at(0.5) == pytest.approx(1.25)
    t = speed_profile(10, 1.0)  # never reaches 10: a triangle
    assert t.s_acc == 0.5 and t.duration == pytest.approx(2 * math.sqrt(1.0))


def test_every_axis_within_its_own_limits():
    p = line_profile([10_000, 3_000], [10_000, 500], [10_000, 10_000], None)
    # Y at 500 steps/s for 3000 steps limits the path: 1/6 of the path per second
    assert p.v == pytest.approx(500 / 3000)
    p = line_profile([10_000, 3_000], [10_000, 10_000], [10_000, 600], None)
    assert p.a == pytest.approx(600 / 3000)
    p = line_profile([1000, 0], [10_000, 10_000], [10_000, 10_000], 0.5)
    assert p.v == pytest.approx(0.5)  # the feed rate is lower than the axes allow
    with pytest.raises(ValueError):
        line_profile([0, 0], [1, 1], [1, 1], None)


@pytest.mark.parametrize("limits", [AVR, ESP32], ids=["avr", "esp32"])
@pytest.mark.parametrize("steps", [(10_000, 3_000), (3_000, -10_000), (1, 5), (255, 254),
                                   (7, 0), (40_000, 39_999)])
def test_diagonal_stays_on_the_line_and_ends_on_one_tick(steps, limits):
    profile = line_profile(steps, [20_000, 20_000], [30_000, 30_000], None)
    cmds = line_commands(steps, profile, limits.min_cmd_ticks, limits.min_cmd_ticks, limits)
    xs, x_end = pulses(cmds[0])
    ys, y_end = pulses(cmds[1])
    for c in cmds:
        check_rules(c, limits)
    assert (len(xs), len(ys)) == (abs(steps[0]), abs(steps[1]))
    assert max_deviation(xs, ys, abs(steps[0]), abs(steps[1])) <= 1.0
    if steps[1]:
        assert xs[-1] == ys[-1]  # the last steps on the same tick
        assert x_end == y_end  # and the queues run dry together
    assert all(up == (steps[0] > 0) for _, _, up in cmds[0])


def test_first_command_is_the_lead_pause_and_long_waits_are_split():
    assert split_wait(65535, AVR) == [65535]
    parts = split_wait(200_000, AVR)
    assert sum(parts) == 200_000 and all(AVR.min_cmd_ticks <= p <= 65535 for p in parts)
    slow = line_profile([3], [10], [1], None)  # steps seconds apart
    times = StepTimes(slow, 3, 640, 16_000_000)
    cmds = list(axis_commands(times, True, 640, AVR))
    check_rules(cmds, AVR)
    assert cmds[0][1] == 0  # the lead: no step
    got, _ = pulses(cmds)
    assert got == list(times)  # each step exactly on time


def test_step_times_are_computed_on_demand():
    p = line_profile([10**9], [10_000], [10_000], None)
    times = StepTimes(p, 10**9, 640, 16_000_000)
    assert len(times) == 10**9
    assert times[0] < times[1] < times[10**9 - 1]
    with pytest.raises(IndexError):
        times[10**9]
