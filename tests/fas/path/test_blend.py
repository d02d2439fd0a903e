"""Corner blends (fas.path.blend): the geometry, each axis's steps in a blend, and
the exits a block can take when its corner is blended.

Expected figures are worked out here from the definitions (junction deviation as
Grbl's planner.c defines it, the blend as docs/path-planner.md describes it), and the
step times against a brute-force walk of the position; not from the code under test."""

from __future__ import annotations

import math
import random
from functools import partial

import pytest

from fas.path.blend import (
    axis_crossings,
    corner_blend,
    corner_steps,
    exit_window,
    fit_sqr,
    hold_blend,
    slowing_blend,
)
from rigs.path import edge_accel

SPU = 80.0
ACC = 1000.0  # mm/s^2 per axis (bench_path's)


def unit(x: float, y: float) -> tuple[float, float]:
    n = math.hypot(x, y)
    return (x / n, y / n)


def junction_speed(u, w, accel: float, deviation: float) -> float:
    """Grbl's junction speed, written out independently."""
    cos_theta = -sum(a * b for a, b in zip(u, w, strict=True))
    sin_half = math.sqrt((1 - cos_theta) / 2)
    bis = [b - a for a, b in zip(u, w, strict=True)]
    n = math.hypot(*bis)
    a_j = min(accel / abs(v / n) for v in bis if v)
    return math.sqrt(a_j * deviation * sin_half / (1 - sin_half))


CORNERS = [unit(0, 1), unit(-1, 0.05), unit(1, 1), unit(-1, 0.2), unit(-3, -1),
           unit(0.2, -1), unit(1, 0.05), unit(-1, 0.01)]


@pytest.mark.parametrize("w", CORNERS)
def test_a_blend_joins_both_blocks_at_the_junction_speed_within_every_axis_limit(w):
    u = (1.0, 0.0)
    v = junction_speed(u, w, ACC, 0.01)
    b = corner_blend(u, w, v, (ACC, ACC))
    assert b is not None
    assert b.position(0.0) == pytest.approx(tuple(-b.reach * x for x in u), abs=1e-12)
    assert b.position(b.duration) == pytest.approx(tuple(b.reach * x for x in w), abs=1e-12)
    assert b.velocity(0.0) == pytest.approx(tuple(v * x for x in u))
    assert b.velocity(b.duration) == pytest.approx(tuple(v * x for x in w))
    # at the speed v along the blocks it takes the time the unblended path takes
    assert b.reach == pytest.approx(v * b.duration / 2)
    bis = [y - x for x, y in zip(u, w, strict=True)]
    a_j = min(ACC / abs(c / math.hypot(*bis)) for c in bis if c)
    assert b.accel == pytest.approx(a_j)
    cos_half = math.sqrt((1 - sum(x * y for x, y in zip(u, w, strict=True))) / 2)
    assert b.reach == pytest.approx(v * v * cos_half / a_j)  # cos(theta/2) v^2 / a_j
    accs = [abs(b.axis_accel(i)) for i in range(2)]
    assert max(accs) == pytest.approx(ACC)  # the bisector's limit: one axis at it
    assert all(a <= ACC * (1 + 1e-12) for a in accs)
    # how far inside the corner: d sin(theta/2) (1 + sin(theta/2)) / 2 <= d
    cos_theta = -sum(x * y for x, y in zip(u, w, strict=True))
    s = math.sqrt((1 - cos_theta) / 2)
    assert b.inside == pytest.approx(0.01 * s * (1 + s) / 2)
    assert b.inside <= 0.01
    nearest = min(math.hypot(*b.position(b.duration * k / 4000)) for k in range(4001))
    assert nearest == pytest.approx(b.inside, rel=1e-6)


def test_no_blend_straight_on_or_at_a_stop():
    assert corner_blend((1.0, 0.0), (1.0, 0.0), 50.0, (ACC, ACC)) is None
    assert corner_blend((1.0, 0.0), (0.0, 1.0), 0.0, (ACC, ACC)) is None
    assert math.isinf(fit_sqr((1.0, 0.0), (1.0, 0.0), (ACC, ACC), 1.0, 1.0))


def test_the_blend_fits_in_half_of_the_shorter_block_at_fit_speed():
    u, w = (1.0, 0.0), unit(1, 0.3)
    e = fit_sqr(u, w, (ACC, ACC), 0.4, 0.25)
    b = corner_blend(u, w, math.sqrt(e), (ACC, ACC))
    assert b is not None and b.reach == pytest.approx(0.125)
    e = fit_sqr(u, w, (ACC, ACC), 0.4, 0.25, share=0.25)
    b = corner_blend(u, w, math.sqrt(e), (ACC, ACC))
    assert b is not None and b.reach == pytest.approx(0.0625)


def test_an_axis_turns_round_once_inside_a_blend_where_its_direction_flips():
    b = corner_blend((1.0, 0.0), unit(-1, 1), 40.0, (ACC, ACC))
    assert b is not None
    t = b.turn_time(0)
    assert t is not None and 0 < t < b.duration
    assert b.velocity(t)[0] == pytest.approx(0.0, abs=1e-12)
    assert b.turn_time(1) is None


@pytest.mark.parametrize("ratio", [0.0, 0.3, 0.8, 1.0])
@pytest.mark.parametrize("w", CORNERS)
def test_a_slowing_blend_joins_both_blocks_at_its_two_speeds_within_every_axis_limit(
        w, ratio):
    """A hold's blend: from ``v_in u`` to ``v_out w`` at constant acceleration in the
    shortest time every axis allows (one axis at its limit), from ``v_in T / 2``
    before the corner to ``v_out T / 2`` after it; at ``v_out = v_in`` the planned
    blend."""
    u = (1.0, 0.0)
    v_in = 30.0
    v_out = ratio * v_in
    b = slowing_blend(u, w, v_in, v_out, (ACC, ACC))
    assert b is not None
    T = b.duration
    assert b.reach == pytest.approx(v_in * T / 2)
    assert b.reach_out == pytest.approx(v_out * T / 2)
    assert b.position(0.0) == pytest.approx(tuple(-b.reach * x for x in u), abs=1e-12)
    assert b.position(T) == pytest.approx(tuple(b.reach_out * x for x in w), abs=1e-12)
    assert b.velocity(0.0) == pytest.approx(tuple(v_in * x for x in u))
    assert b.velocity(T) == pytest.approx(tuple(v_out * x for x in w), abs=1e-12)
    accs = [abs(b.axis_accel(i)) for i in range(2)]
    assert max(accs) == pytest.approx(ACC)
    assert all(a <= ACC * (1 + 1e-12) for a in accs)
    # the acceleration is the velocity's change over T, axis by axis
    for i in range(2):
        assert b.axis_accel(i) == pytest.approx((v_out * w[i] - v_in * u[i]) / T)
    # against 4000 samples: the distance changes by at most the path between two
    # (speed <= v_in), so the samples' least is within half of that of the least
    nearest = min(math.hypot(*b.position(T * k / 4000)) for k in range(4001))
    assert abs(nearest - b.inside) <= v_in * T / 4000 / 2
    if ratio == 1.0:
        c = corner_blend(u, w, v_in, (ACC, ACC))
        assert c is not None
        assert b.duration == pytest.approx(c.duration)
        assert b.reach == pytest.approx(c.reach) and b.inside == pytest.approx(c.inside)


NEAR = 100


def hold_q(u, w, v_sqr, rest, a_in, a_out, r, near=True):
    """From the definitions: ``(Q, lo, hi)`` of a hold at ``v_sqr`` with ``rest`` to
    the corner through the blend slowing to ``r v_in``: what it runs after the corner
    (the blend's reach out plus the stop after it), and bounds on how near the corner
    it passes - ``hi`` the nearest of ``NEAR`` points of its Bezier, ``lo`` that less
    ``reach / NEAR`` (consecutive points lie within ``2 reach / NEAR``) - or None where
    that blend would begin before the hold's point (``near`` False: no bounds, 0).
    ``T = v_in tau``, tau from each axis's limit; the blend begins ``v_in T / 2``
    before the corner, where the deceleration at ``a_in`` reaches ``v_in``, and ends
    ``r v_in T / 2`` after it."""
    tau = max(abs(r * y - x) / ACC for x, y in zip(u, w, strict=True))
    den = 1 - a_in * tau
    if den <= 0:
        return None
    vin2 = (v_sqr - 2 * a_in * rest) / den
    if vin2 > v_sqr * (1 + 1e-9):  # (rounding: a blend that begins at the point)
        return None
    reach = vin2 * tau / 2
    q = r * reach + r * r * vin2 / (2 * a_out)
    if not near:
        return q, 0.0, 0.0
    hi = min(math.hypot(*(-(1 - t) ** 2 * reach * x + t * t * r * reach * y
                          for x, y in zip(u, w, strict=True)))
             for t in (k / NEAR for k in range(NEAR + 1)))
    return q, hi - reach / NEAR, hi


@pytest.mark.parametrize("bounded", [False, True])
@pytest.mark.parametrize("w", CORNERS)
def test_a_hold_takes_the_slowing_blend_that_leaves_the_least_to_run(w, bounded):
    """hold_blend against a scan of 4 000 ratios, and never worse than the
    constant-speed blend at the slowest exit exit_window allows (what a hold took
    before); ``bounded``: among the blends that pass inside the corner by at most a
    deviation (0.9 of the unbounded choice's; a scan of 1 000)."""
    u = (1.0, 0.0) if bounded else unit(2, 1)
    a_in = min(ACC / abs(x) for x in u if x)
    a_out = min(ACC / abs(x) for x in w if x)
    rng = random.Random(7)
    for _ in range(10):
        v_sqr = rng.uniform(100.0, 3000.0)
        rest = rng.uniform(0.2, 0.99) * v_sqr / (2 * a_in)  # it cannot stop before
        got = hold_blend(u, w, v_sqr, rest, a_in, a_out, (ACC, ACC), math.inf)
        scan = sorted((h[0], k / 4000) for k in range(1, 4001)
                      if (h := hold_q(u, w, v_sqr, rest, a_in, a_out, k / 4000, False))
                      is not None)
        if got is None:
            assert not scan
            continue
        dev = math.inf
        if bounded:
            h = hold_q(u, w, v_sqr, rest, a_in, a_out, got[1] / math.sqrt(got[0]))
            assert h is not None
            dev = h[2] * 0.9
            got = hold_blend(u, w, v_sqr, rest, a_in, a_out, (ACC, ACC), math.inf, dev)
            # the least Q of the scan whose blend surely passes within the deviation
            least = next((q for q, r in scan[::4]
                          if (h := hold_q(u, w, v_sqr, rest, a_in, a_out, r)) is not None
                          and h[2] <= dev), None)
            if got is None:
                assert least is None
                continue
            scan = [] if least is None else [(least, 0.0)]
        vin2, v_out = got
        h = hold_q(u, w, v_sqr, rest, a_in, a_out, v_out / math.sqrt(vin2))
        assert h is not None
        q, lo, _hi = h
        assert lo <= dev
        if scan:
            assert q <= min(x for x, _r in scan) * (1 + 1e-9)
        if bounded:
            continue
        diff = [y - x for x, y in zip(u, w, strict=True)]
        n = math.hypot(*diff)
        k = n / (2 * min(ACC / abs(c / n) for c in diff if c))
        win = exit_window(v_sqr, rest, a_in, k)
        if win is not None and win[0] > 0:
            e = win[0]
            assert q <= (k * e + e / (2 * a_out)) * (1 + 1e-9)


def test_a_hold_stops_at_v2_over_2a_where_the_blend_slows_at_the_blocks_acceleration():
    """A zigzag corner, (4, 1) into (4, -1): X keeps its component, so the blend can
    slow along the polyline at the block's acceleration (X at its limit) - the stop
    lies v^2 / (2 a) along the polyline, as if there were no corner."""
    u, w = unit(4, 1), unit(4, -1)
    a = ACC / u[0]
    v_sqr, rest = 900.0, 0.3  # (v^2 / (2 a) = 0.44: it cannot stop before)
    got = hold_blend(u, w, v_sqr, rest, a, a, (ACC, ACC), math.inf)
    assert got is not None
    vin2, v_out = got
    b = slowing_blend(u, w, math.sqrt(vin2), v_out, (ACC, ACC))
    assert b is not None
    # the deceleration at a reaches v_in where the blend begins
    assert vin2 == pytest.approx(v_sqr - 2 * a * (rest - b.reach))
    after = b.reach_out + v_out * v_out / (2 * a)
    assert rest + after == pytest.approx(v_sqr / (2 * a))
    assert abs(b.axis_accel(0)) == pytest.approx(ACC)
    # nothing fits in a block out shorter than any blend's reach out
    assert hold_blend(u, w, v_sqr, rest, a, a, (ACC, ACC), 1e-6) is None


# ----------------------------------------------------------------- the steps
def walk(x0: float, v0: float, a: float, T: float, p0: int, n: int = 200000):
    """Brute force: the position on a fine time grid; a step when it reaches the next
    integer in the direction it moves."""
    steps = []
    p = p0
    prev = x0
    for k in range(1, n + 1):
        t = T * k / n
        x = x0 + v0 * t + 0.5 * a * t * t
        while x > prev and x >= p + 1:
            p += 1
            steps.append((t, 1))
        while x < prev and x <= p - 1:
            p -= 1
            steps.append((t, -1))
        prev = x
    return steps, p


def check_against_walk(x0, v0, a, T, p0):
    got, p = axis_crossings(x0, v0, a, T, p0)
    want, pw = walk(x0, v0, a, T, p0)
    assert p == pw
    assert [d for _t, d in got] == [d for _t, d in want]
    for (tg, _), (tw, _) in zip(got, want, strict=True):
        assert tw - T / 200000 - 1e-12 <= tg <= tw + 1e-12
    # never a whole step from the position
    for t, _d in got:
        x = x0 + v0 * t + 0.5 * a * t * t
        assert abs(x - round(x)) < 1e-6  # a step where the position is an integer
    return got, p


def test_steps_in_a_blend_are_the_integer_crossings_of_each_axis():
    # the raster's 180-degree turn: X goes on, comes back; Y steps across
    check_against_walk(0.4, 120.0, -48000.0, 0.005, 0)
    check_against_walk(-0.4, -120.0, 48000.0, 0.005, 0)
    check_against_walk(0.0, 0.0, 30000.0, 0.01, 0)
    rng = random.Random(25)
    for _ in range(60):
        v0 = rng.uniform(-400.0, 400.0)
        a = rng.uniform(-80000.0, 80000.0)
        T = rng.uniform(0.001, 0.02)
        x0 = rng.uniform(-0.99, 0.99)
        p0 = math.floor(x0) if v0 > 0 else math.ceil(x0)
        check_against_walk(x0, v0, a, T, p0)


def test_an_axis_that_turns_short_of_the_next_step_makes_none():
    got, p = axis_crossings(0.3, 100.0, -40000.0, 0.004, 0)  # 0.3 up to 0.425, back to -0.1
    assert got == [] and p == 0


@pytest.mark.parametrize("u, w", [(unit(2, 1), unit(1, 2)), (unit(1, 1), unit(1, -1)),
                                  (unit(1, 0.1), unit(-1, 0.3))])
def test_a_corner_through_a_blend_measures_within_the_acceleration_from_the_pins(u, w):
    """A whole corner as steps: the block in at the junction speed, the blend, the
    block out; the divided difference of rigs.path.edge_accel (the bench's estimator)
    stays within the limit (exact times rounded to ticks), where the same corner
    with the velocity jumped (Grbl's execution, today's) is measured above it.  A
    deviation of 4 mm makes the blend longer than the estimator's windows, so the
    measurement sees the blend's own acceleration."""
    tps = 16_000_000
    v = junction_speed(u, w, ACC, 4.0)
    b = corner_blend(u, w, v, (ACC, ACC))
    assert b is not None
    run_in = 0.15  # s at the junction speed on each side
    corner = (8000.0, 8000.0)  # steps
    limit = ACC * SPU

    def axis_steps(i: int, blended: bool) -> tuple[list[int], list[int]]:
        t0 = 0.0
        x_start = corner[i] / SPU - u[i] * v * run_in  # units
        events: list[tuple[float, int]] = []
        p = math.floor(x_start * SPU)  # on the grid: starts on a step boundary
        x_start = p / SPU
        head = run_in - b.duration / 2 if blended else run_in
        g, p = axis_crossings(x_start * SPU, v * u[i] * SPU, 0.0, head, p)
        events += [(t0 + t, d) for t, d in g]
        x = x_start + v * u[i] * head
        if blended:
            g, p = axis_crossings(x * SPU, v * u[i] * SPU, b.axis_accel(i) * SPU,
                                  b.duration, p)
            events += [(head + t, d) for t, d in g]
            x = x + b.position(b.duration)[i] - b.position(0.0)[i]
            tail0, tail = head + b.duration, run_in - b.duration / 2
        else:
            tail0, tail = head, run_in
        g, p = axis_crossings(x * SPU, v * w[i] * SPU, 0.0, tail, p)
        events += [(tail0 + t, d) for t, d in g]
        ticks, xs, pos = [], [], 0
        for t, d in events:
            pos += d
            ticks.append(int(t * tps + 0.5))
            xs.append(pos)
        return ticks, xs

    for i in range(2):
        tk, xs = axis_steps(i, True)
        a, _at = edge_accel(tk, xs, tps, 0.02)
        # ticks rounded: each step within half a tick of its time
        assert a <= limit * (1 + 1e-3), (i, a / SPU)
        assert a >= 0.95 * abs(b.axis_accel(i)) * SPU  # it sees the blend
    worst = max(edge_accel(*axis_steps(i, False), tps, 0.02)[0] for i in range(2))
    assert worst > 1.2 * limit  # the jump, as executed today, is above it


def corner_timeline(start, d_in, d_out, b):
    """Per axis: the steps of a corner taken through the blend ``b`` - the block in from
    its start at the blend's entry speed, the blend, the block out to its end at its
    exit speed - as (t, +-1)."""
    v, vo = b.speed, b.speed_out
    len_in = math.hypot(*(d / SPU for d in d_in))
    len_out = math.hypot(*(d / SPU for d in d_out))
    t_blend = (len_in - b.reach) / v
    t_out = t_blend + b.duration
    per = corner_steps(start, d_in, d_out, b, (SPU, SPU))
    events = []
    for i in range(2):
        made, blend_steps, first = per[i]
        ev = []
        n_in, n_out = abs(d_in[i]), abs(d_out[i])
        for j in range(1, made + 1):
            ev.append((j * len_in / n_in / v, 1 if d_in[i] > 0 else -1))
        ev += [(t_blend + t, d) for t, d in blend_steps]
        for j in range(first + 1, n_out + 1):
            ev.append((t_out + (j * len_out / n_out - b.reach_out) / vo,
                       1 if d_out[i] > 0 else -1))
        events.append(ev)
    return events, t_blend, t_out, len_in, len_out


def blended_position(i, t, start, d_in, d_out, b, t_blend, t_out):
    u, w = b.u, b.w
    if t <= t_blend:
        return start[i] + u[i] * b.speed * t * SPU
    corner = start[i] + d_in[i]
    if t <= t_out:
        return corner + b.position(t - t_blend)[i] * SPU
    return corner + (b.reach_out + b.speed_out * (t - t_out)) * w[i] * SPU


@pytest.mark.parametrize("slowing", [False, True])
@pytest.mark.parametrize("seed", range(6))
def test_corner_steps_keep_every_axis_within_a_step_of_the_blended_path(seed, slowing):
    """Random corners on an 80 steps/mm grid (reversals, axes standing still on one
    side, tiny blocks): the block in's steps, the blend's and the block out's from
    where the blend left the axis make every axis's net steps the blocks' deltas,
    never a whole step from the blended path, each step in the direction the axis
    moves - for planned blends and for a hold's blends that slow down
    (``slowing``)."""
    rng = random.Random(seed)
    checked = 0
    while checked < 40:
        start = (rng.randint(-50, 50), rng.randint(-50, 50))
        d_in = (rng.randint(-40, 40), rng.randint(-40, 40))
        d_out = (rng.randint(-40, 40), rng.randint(-40, 40))
        if rng.random() < 0.3:
            d_out = (0, d_out[1]) if rng.random() < 0.5 else (d_out[0], 0)
        if d_in == (0, 0) or d_out == (0, 0):
            continue
        u = unit(d_in[0] / SPU, d_in[1] / SPU)
        w = unit(d_out[0] / SPU, d_out[1] / SPU)
        if -sum(x * y for x, y in zip(u, w, strict=True)) > 0.999999:
            continue  # a reversal: a stop
        len_in = math.hypot(*(d / SPU for d in d_in))
        len_out = math.hypot(*(d / SPU for d in d_out))
        if slowing:  # reach grows with the entry speed squared: a fit at speed 1
            r = rng.uniform(0.05, 0.95)
            b1 = slowing_blend(u, w, 1.0, r, (ACC, ACC))
            if b1 is None:
                continue
            v2 = min(len_in / b1.reach, len_out / b1.reach_out) * rng.uniform(0.1, 1.0)
            b = slowing_blend(u, w, math.sqrt(v2), r * math.sqrt(v2), (ACC, ACC))
        else:
            cap = fit_sqr(u, w, (ACC, ACC), len_in, len_out)
            v = min(junction_speed(u, w, ACC, rng.choice([0.01, 0.05, 0.2])),
                    math.sqrt(cap))
            b = corner_blend(u, w, v * rng.uniform(0.3, 1.0), (ACC, ACC))
        if b is None:
            continue
        events, t_blend, t_out, li, lo = corner_timeline(start, d_in, d_out, b)
        t_end = t_out + (lo - b.reach_out) / b.speed_out
        for i in range(2):
            ev = events[i]
            assert sum(d for _t, d in ev) == d_in[i] + d_out[i]
            assert all(ev[k][0] <= ev[k + 1][0] + 1e-12 for k in range(len(ev) - 1))
            p = start[i]
            times = [t for t, _d in ev]
            samples = sorted(times + [t_end * k / 400 for k in range(401)])
            k = 0
            for t in samples:
                while k < len(ev) and ev[k][0] <= t:
                    p += ev[k][1]
                    k += 1
                x = blended_position(i, t, start, d_in, d_out, b, t_blend, t_out)
                assert abs(x - p) < 1 + 1e-6, (seed, d_in, d_out, i, t, x, p)
            for t, d in ev:
                dt = 1e-9
                x1 = blended_position(i, t - dt, start, d_in, d_out, b, t_blend, t_out)
                x2 = blended_position(i, t + dt, start, d_in, d_out, b, t_blend, t_out)
                assert d * (x2 - x1) >= -1e-9  # never against the motion
        checked += 1


def blend_x(b, i: int, corner: int, t: float) -> float:
    """Axis ``i``'s position (steps) in the blend ``t`` s after it began."""
    return corner + b.position(t)[i] * SPU


def commanded_x(b, i: int, corner: int, t: float) -> float:
    """Axis ``i`` on the commanded corner at the blend's clock: the block in at
    ``speed`` up to ``T/2``, the block out after."""
    half = b.duration / 2
    if t <= half:
        return corner + (b.speed * t - b.reach) * b.u[i] * SPU
    return corner + b.speed_out * (t - half) * b.w[i] * SPU


def first_at(f, target: float, sgn: int, T: float) -> float:
    """Bisection: the first time in [0, T] at which ``f`` has reached ``target``
    moving the way ``sgn`` (f monotone)."""
    lo, hi = 0.0, T
    if sgn * (f(lo) - target) >= 0.0:
        return 0.0
    for _ in range(80):
        mid = (lo + hi) / 2
        if sgn * (f(mid) - target) >= 0.0:
            hi = mid
        else:
            lo = mid
    return hi


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_led_steps_come_where_the_commanded_corner_reaches_them_at_most_an_eighth_early(seed):
    """``corner_steps``' ``leads``: each blend step at the earlier of where the blend
    reaches its integer and where the commanded corner does (the control polygon at
    the blend's clock: the block in at ``speed`` up to ``T/2``, the block out after),
    never more than ``lead`` steps before the blend reaches it; an axis that turns
    round or is at rest at either end keeps the blend's own times.  Times found by
    bisection on the blend's position (``Blend.position``), independently."""
    rng = random.Random(seed)
    lead = 0.125
    checked = moved = 0
    while checked < 40:
        d_in = (rng.randint(-40, 40), rng.randint(-40, 40))
        d_out = (rng.randint(-40, 40), rng.randint(-40, 40))
        if rng.random() < 0.2:
            d_out = (0, d_out[1]) if rng.random() < 0.5 else (d_out[0], 0)
        if d_in == (0, 0) or d_out == (0, 0):
            continue
        u = unit(d_in[0] / SPU, d_in[1] / SPU)
        w = unit(d_out[0] / SPU, d_out[1] / SPU)
        if -sum(x * y for x, y in zip(u, w, strict=True)) > 0.999999:
            continue
        len_in = math.hypot(*(d / SPU for d in d_in))
        len_out = math.hypot(*(d / SPU for d in d_out))
        cap = fit_sqr(u, w, (ACC, ACC), len_in, len_out)
        v = min(junction_speed(u, w, ACC, rng.choice([0.01, 0.05])), math.sqrt(cap))
        b = corner_blend(u, w, v * rng.uniform(0.3, 1.0), (ACC, ACC))
        if b is None:
            continue
        start = (rng.randint(-50, 50), rng.randint(-50, 50))
        leads: list[list[float]] = []
        per = corner_steps(start, d_in, d_out, b, (SPU, SPU), leads=leads, lead=lead)
        T = b.duration
        for i in range(2):
            corner = start[i] + d_in[i]
            steps = per[i][1]
            if u[i] * w[i] <= 0.0:
                assert leads[i] == [t for t, _d in steps]
                continue

            sgn = 1 if d_in[i] > 0 else -1
            p = start[i] + sgn * per[i][0]
            for (t_b, d), t_l in zip(steps, leads[i], strict=True):
                p += sgn
                assert d == sgn
                want = min(t_b, max(
                    first_at(partial(commanded_x, b, i, corner), p, sgn, T),
                    first_at(partial(blend_x, b, i, corner), p - sgn * lead, sgn, T)))
                assert t_l == pytest.approx(want, abs=1e-9 * T + 1e-12), (d_in, d_out, i, p)
                # at most 1/8 step early
                assert sgn * (p - blend_x(b, i, corner, t_l)) <= lead + 1e-9
                moved += t_l < t_b - 1e-9 * T
        checked += 1
    assert moved > 0


def test_corner_steps_refuse_a_blend_longer_than_a_block():
    u, w = (1.0, 0.0), (0.0, 1.0)
    b = corner_blend(u, w, 40.0, (ACC, ACC))
    assert b is not None and b.reach > 0.5
    with pytest.raises(ValueError):
        corner_steps((0, 0), (40, 0), (0, 40), b, (SPU, SPU))


# ------------------------------------------------------------- the exits
def reachable(v_sqr: float, rest: float, accel: float, zone: float, e: float) -> bool:
    """Brute force: a ramp at most ``accel`` from v over rest - zone e reaches e."""
    room = rest - zone * e
    if room < 0:
        return False
    return abs(e - v_sqr) <= 2 * accel * room + 1e-8 * (v_sqr + 2 * accel * rest) + 1e-9


@pytest.mark.parametrize("zone", [0.0, 1e-4, 4e-4, 1.2e-3])
def test_exit_window_is_the_set_of_exits_a_ramp_reaches(zone):
    rng = random.Random(int(zone * 1e6))
    for _ in range(300):
        v_sqr = rng.uniform(0, 60.0) ** 2
        rest = rng.uniform(0.0, 3.0)
        accel = rng.uniform(200.0, 2000.0)
        got = exit_window(v_sqr, rest, accel, zone)
        grid = [k * 40.0 for k in range(0, 200)]
        ok = [e for e in grid if reachable(v_sqr, rest, accel, zone, e)]
        if got is None:
            assert ok == [], (v_sqr, rest, accel, zone)
            continue
        lo, hi = got
        assert reachable(v_sqr, rest, accel, zone, lo)
        assert reachable(v_sqr, rest, accel, zone, hi)
        assert all(lo - 1e-6 <= e <= hi + 1e-6 for e in ok)
        assert all(reachable(v_sqr, rest, accel, zone, e) for e in grid if lo <= e <= hi)


def test_a_higher_exit_can_need_a_lower_entry_at_sharp_corners():
    """Why the planner keeps reserves rather than the blends' own lengths
    (docs/path-planner.md, "Corners: blends"): where
    2 a k > 1 (the zone grows faster with the exit than a ramp takes it back) a
    higher exit lowers the largest entry a block can have - Grbl's reverse pass
    assumes the opposite.  Brute force over entries."""
    accel, length = 1000.0, 1.0
    grid = [k * 5.0 for k in range(0, 800)]

    def best_entry(zone: float, e_out: float) -> float:
        return max(e for e in grid if reachable(e, length, accel, zone, e_out))

    sharp = corner_blend((1.0, 0.0), unit(-1, 0.2), 30.0, (ACC, ACC))
    mild = corner_blend((1.0, 0.0), unit(1, 0.5), 30.0, (ACC, ACC))
    assert sharp is not None and mild is not None
    assert 2 * accel * sharp.zone > 1 > 2 * accel * mild.zone
    assert best_entry(sharp.zone, 400.0) < best_entry(sharp.zone, 100.0)
    assert best_entry(mild.zone, 400.0) > best_entry(mild.zone, 100.0)
