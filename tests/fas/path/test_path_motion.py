"""A path group on the simulated chip (fas.path): every figure from the recorded pins.

Units: 80 steps/mm unless a test says otherwise; feeds in mm/min.  The expected
figures come from Grbl's definitions (junction deviation, block acceleration along
the line) worked out in the tests, and the bounds from the issue: every axis within
one step of the path, corner speed within 1 %, hold within the deceleration distance
+-1 step per axis.
"""

from __future__ import annotations

import math

import pytest

from fas import planners
from fas.codes import MoveResult
from fas.path import AxisLimits, PathResult, PathState
from fas.path.settings import GROUP_TOLERANCE_STEPS
from rigs.path import (
    Stream,
    axes_edge_accel,
    axis_motion,
    axis_steps,
    edge_accel,
    feed_all,
    instants,
    interp,
    make_group,
    max_accel,
    path_deviation,
    random_path,
    run_with_random_holds,
)
from rigs.path import circles_of_chords as rig_circles

SPU = 80.0
LIMITS = AxisLimits(SPU, 6000.0, 500.0)  # 100 mm/s, 500 mm/s^2 per axis
SQUARE = [(3200, 0), (3200, 3200), (0, 3200), (0, 0)]


def vertex_ticks(ins, vertices):
    """The instant each vertex is reached (in order)."""
    out = []
    k = 0
    for t, p in ins:
        if k < len(vertices) and p == tuple(vertices[k]):
            out.append(t)
            k += 1
    assert k == len(vertices), f"vertex {vertices[k]} not reached at one instant"
    return out


def limit_along(limit: float, unit) -> float:
    return min(limit / abs(u) for u in unit if u)


# ---------------------------------------------------------------- the seam
def test_path_is_a_registered_planner_and_goes_back():
    backend, engine, group, pins, dirs = make_group()
    assert "path" in planners.names()
    assert [s.planner_name for s in group.steppers] == ["path", "path"]
    assert group.detach() == PathResult.OK
    assert [s.planner_name for s in group.steppers] == ["ramp", "ramp"]
    assert group.line((10, 10), 600.0) == PathResult.ERR_NOT_ATTACHED
    assert group.attach() == PathResult.OK  # and again


# ----------------------------------------------------------- path geometry
@pytest.mark.parametrize("profile", ["atmega328p", "atmega2560", "esp32", "esp32c3",
                                     "sam_due", "rp2040"])
def test_square_within_one_step_and_every_corner_on_one_tick(profile):
    backend, engine, group, pins, dirs = make_group(profile, limits=LIMITS)
    feed_all(backend, group, SQUARE, 3000.0)
    steps = axis_steps(backend, pins, dirs)
    ins = instants(steps, (0, 0))
    cheb, _ = path_deviation(ins, [(0, 0)] + SQUARE)  # every vertex at one instant
    assert cheb <= 1.0
    assert [s.get_current_position() for s in group.steppers] == [0, 0]
    assert group.stats.runs == 1 and group.stats.underruns == 0  # no queue ever stopped
    for st in group.axis_stats():
        assert st.shifted == 0 and st.early_ends == 0
    # the axes that move on both sides of a corner step on its tick
    ticks = vertex_ticks(ins, SQUARE)
    for axis, (tk, _d) in enumerate((list(zip(*s, strict=True)) for s in steps)):
        on_vertex = [t for t in ticks if t in set(tk)]
        assert len(on_vertex) == 2, (axis, ticks)  # its two blocks' last steps


@pytest.mark.parametrize("seed", [1, 2])
def test_random_3d_path_within_one_step(seed):
    import random

    rnd = random.Random(seed)
    limits = AxisLimits(80.0, 9000.0, 800.0)
    backend, engine, group, pins, dirs = make_group("atmega2560", 3, limits=limits,
                                                    junction_deviation=0.02, queue_blocks=16)
    pos = [0, 0, 0]
    pts = []
    for _ in range(60):
        scale = rnd.choice([2, 8, 40, 300])
        pos = [p + rnd.randint(-scale, scale) for p in pos]
        pts.append(tuple(pos))
    feed_all(backend, group, pts, rnd.choice([600.0, 3000.0, 6000.0]))
    ins = instants(axis_steps(backend, pins, dirs), (0, 0, 0))
    cheb, _ = path_deviation(ins, [(0, 0, 0)] + pts)
    assert cheb <= 1.0
    assert ins[-1][1] == pts[-1]
    assert group.stats.underruns == 0


# ------------------------------------------------------------ speeds
@pytest.mark.parametrize("turn_deg", [45, 90, 135])
def test_corner_speed_is_the_junction_deviation_formula(turn_deg):
    deviation = 0.05
    backend, engine, group, pins, dirs = make_group(limits=LIMITS,
                                                    junction_deviation=deviation)
    phi = math.radians(turn_deg)
    u1, u2 = (1.0, 0.0), (math.cos(phi), math.sin(phi))
    corner = (3200, 0)
    end = (3200 + round(3200 * u2[0]), round(3200 * u2[1]))
    feed_all(backend, group, [corner, end], 3000.0)
    steps = axis_steps(backend, pins, dirs)
    ins = instants(steps, (0, 0))
    t_corner = vertex_ticks(ins, [corner])[0]
    # Grbl: v^2 = a_j d sin(theta/2) / (1 - sin(theta/2)), theta the angle between the
    # segments, a_j the acceleration along the bisector
    cos_theta = -(u1[0] * u2[0] + u1[1] * u2[1])
    sin_half = math.sqrt((1 - cos_theta) / 2)
    bis = (u2[0] - u1[0], u2[1] - u1[1])
    n = math.hypot(*bis)
    a_j = limit_along(LIMITS.acceleration, (bis[0] / n, bis[1] / n))
    v_j = math.sqrt(a_j * deviation * sin_half / (1 - sin_half))  # mm/s
    assert v_j < 50.0  # below the feed: the corner limits it
    # Y starts at the corner: its first step (exact: a group's first) is where the path
    # entered with v_j and accelerates at the second block's acceleration
    tps = backend.profile.ticks_per_s
    first_y = next(t for t, _d in steps[1] if t > t_corner)
    t1 = (first_y - t_corner) / tps
    a2 = limit_along(LIMITS.acceleration, u2)
    dy = 1 / SPU / u2[1]  # path length to Y's first step
    v = (dy - a2 * t1 * t1 / 2) / t1
    assert v == pytest.approx(v_j, rel=0.01)


def test_rates_and_accelerations_from_the_pins_stay_within_each_axis():
    """Three axes with limits of their own; over windows of W = 20 ms inside each
    block: the largest |x(t+W) - 2 x(t) + x(t-W)| / W^2 and |x(t+W) - x(t)| / W of the
    position interpolated between step edges.  The step times are exact to 1/2 tick
    or placed up to GROUP_TOLERANCE_STEPS early (grouped steps), so the position is
    within e = tol + 1/16 step: the quantisation allows 4 e / W^2 and 2 e / W."""
    limits = (AxisLimits(80.0, 6000.0, 500.0), AxisLimits(100.0, 4800.0, 300.0),
              AxisLimits(400.0, 600.0, 100.0))
    backend, engine, group, pins, dirs = make_group("atmega2560", 3, limits=LIMITS)
    assert group.configure(group.settings.__class__(axes=limits)) == PathResult.OK
    pts = [(8000, 0, 0), (8000, 6000, 2000), (0, 2000, 0), (4000, 4000, 4000)]
    feed_all(backend, group, pts, None)  # rapid: every block at an axis's limit
    steps = axis_steps(backend, pins, dirs)
    ins = instants(steps, (0, 0, 0))
    assert path_deviation(ins, [(0, 0, 0)] + pts)[0] <= 1.0
    ticks = [ins[0][0] - 1] + vertex_ticks(ins, pts)
    tps = backend.profile.ticks_per_s
    w = 0.02
    e = GROUP_TOLERANCE_STEPS + 1 / 16
    for i, lim in enumerate(limits):
        tk, xs = axis_motion(steps[i])
        a_max = lim.acceleration * lim.steps_per_unit
        v_max = lim.max_rate / 60 * lim.steps_per_unit
        peak_v = 0.0
        for b in range(len(pts)):
            a, v = max_accel(tk, xs, ticks[b], ticks[b + 1], tps, w)
            assert a <= a_max + 4 * e / w ** 2, (i, b, a)
            assert v <= v_max + 2 * e / w, (i, b, v)
            peak_v = max(peak_v, v)
        assert peak_v > 0.9 * v_max  # the rapid reached each axis's limit somewhere


def test_collinear_joints_keep_the_feed():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    pts = [(30 * k, 40 * k) for k in range(1, 201)]  # 200 blocks of 0.625 mm
    feed_all(backend, group, pts, 3000.0)
    steps = axis_steps(backend, pins, dirs)
    tps = backend.profile.ticks_per_s
    for i, share in ((0, 0.6), (1, 0.8)):
        period = tps / (50.0 * share * SPU)  # 50 mm/s along (0.6, 0.8)
        tk = [t for t, _d in steps[i]]
        gaps = [b - a for a, b in zip(tk, tk[1:], strict=False)]
        cruise = gaps[len(gaps) // 5: 4 * len(gaps) // 5]  # 150 joints in there
        assert max(cruise) - period <= 1 and period - min(cruise) <= 1
    assert group.stats.runs == 1


def test_short_collinear_blocks_keep_the_queues_filled():
    """Blocks of 2 steps at 10 000 steps/s (0.2 ms each): commands that short would
    empty a 16-entry queue within a task period - groups go on across the blocks,
    every step still at or just before its tick."""
    limits = AxisLimits(1.0, 1_200_000.0, 200_000.0)
    backend, engine, group, pins, dirs = make_group(limits=limits, junction_deviation=1.0)
    pts = [(2 * k, 2 * k) for k in range(1, 1000)]
    feed_all(backend, group, pts, 600_000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == pts[-1]
    assert group.stats.underruns == 0 and group.stats.runs == 1
    stats = group.axis_stats()
    assert stats[0].early_ends > 0  # blocks' last steps inside groups ...
    steps0 = axis_steps(backend, pins, dirs)[0]
    period = backend.profile.ticks_per_s / (600_000 / 60 / math.sqrt(2))
    assert stats[0].early_max <= GROUP_TOLERANCE_STEPS * period * 8  # ... only a little early
    assert len(steps0) == pts[-1][0]


def test_exact_stop_with_zero_junction_deviation():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS, junction_deviation=0.0)
    feed_all(backend, group, [(1600, 0), (3200, 0)], 3000.0)  # collinear: no stop
    feed_all(backend, group, [(3200, 1600)], 3000.0)  # a corner: a stop
    steps = axis_steps(backend, pins, dirs)
    tk = [t for t, _d in steps[0]]
    gaps = [b - a for a, b in zip(tk, tk[1:], strict=False)]
    assert max(gaps[1000:2000]) - min(gaps[1000:2000]) <= 1  # through the joint at 1600
    tps = backend.profile.ticks_per_s
    y_first = steps[1][0][0]
    assert (y_first - tk[-1]) / tps > 0.01  # from rest: sqrt(2 / a) after the corner


# ----------------------------------------------------------------- hold
@pytest.mark.parametrize("seglen", [1000, 10])
def test_feed_hold_stops_within_the_deceleration_distance(seglen):
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    tps = backend.profile.ticks_per_s
    n = 20000 // seglen
    pts = [(3 * seglen * k // 5, 4 * seglen * k // 5) for k in range(1, n + 1)]
    stream = Stream(backend, group, pts, 3000.0)
    assert stream.run(until=lambda: backend.now() >= tps // 2)
    t_hold = backend.now()
    group.hold()
    assert group.state == PathState.HOLDING
    assert group.resume() == PathResult.ERR_RUNNING  # not before it stands (Grbl)
    assert stream.run(until=lambda: group.state == PathState.HELD, limit_s=5)
    hs = group.hold_start
    assert hs is not None and hs.speed == pytest.approx(50.0)
    fp = group.steppers[0].get_forward_planning_ticks()
    assert hs.tick - t_hold <= fp + 2 * backend.task_period_ticks
    stop = [s.get_current_position() for s in group.steppers]
    steps = axis_steps(backend, pins, dirs)
    # from where the pins were when the deceleration began, v^2 / (2 a) further along
    # (0.6, 0.8), a the block's acceleration: Y's 500 mm/s^2 / 0.8
    accel = limit_along(LIMITS.acceleration, (0.6, 0.8))
    d = hs.speed ** 2 / (2 * accel) * SPU
    for i, u in enumerate((0.6, 0.8)):
        tk, xs = axis_motion(steps[i])
        expected = interp(tk, xs, hs.tick) + d * u
        assert abs(stop[i] - expected) <= 1.0
        assert xs[-1] == stop[i]
    # the rest of the path, from the stop
    assert group.resume() == PathResult.OK
    assert stream.run(limit_s=60)
    assert [s.get_current_position() for s in group.steppers] == list(pts[-1])
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    k = sum(1 for p in pts if p[1] <= stop[1])  # the stop is a vertex of what ran
    assert path_deviation(ins, [(0, 0)] + pts[:k] + [tuple(stop)] + pts[k:])[0] <= 1.0


def test_hold_before_the_start_and_blocks_added_while_held():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    assert group.line((800, 0), 3000.0) == PathResult.OK
    group.hold()
    assert group.state == PathState.HELD
    backend.wait_until(lambda: False, backend.profile.ticks_per_s // 2)
    assert [s.get_current_position() for s in group.steppers] == [0, 0]  # nothing moved
    assert group.line((800, 800), 3000.0) == PathResult.OK
    assert group.resume() == PathResult.OK
    assert backend.wait_until(group.is_idle, 10 * backend.profile.ticks_per_s)
    assert [s.get_current_position() for s in group.steppers] == [800, 800]


def test_cancel_stops_along_the_path_and_drops_the_rest():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    stream = Stream(backend, group, [(8000, 0), (8000, 8000)], 3000.0)
    assert stream.run(until=lambda: backend.now() >= backend.profile.ticks_per_s // 2)
    group.cancel()
    assert backend.wait_until(group.is_idle, 5 * backend.profile.ticks_per_s)
    x, y = (s.get_current_position() for s in group.steppers)
    assert 0 < x < 8000 and y == 0
    assert group.position == [x, y] and group.state == PathState.IDLE
    steps = axis_steps(backend, pins, dirs)
    assert steps[0][-1][0] < backend.now() and len(steps[0]) == x
    assert group.line((x, 800), 3000.0) == PathResult.OK  # goes on from there
    group.flush()
    assert backend.wait_until(group.is_idle, 5 * backend.profile.ticks_per_s)
    assert [s.get_current_position() for s in group.steppers] == [x, 800]


def test_abort_stops_every_axis_at_once():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    stream = Stream(backend, group, [(8000, 6000)], 3000.0)
    assert stream.run(until=lambda: backend.now() >= backend.profile.ticks_per_s // 2)
    t_abort = backend.now()
    group.abort()
    assert group.is_idle()
    backend.wait_until(lambda: False, backend.profile.ticks_per_s // 10)
    steps = axis_steps(backend, pins, dirs)
    for i, s in enumerate(group.steppers):
        assert all(t <= t_abort for t, _d in steps[i])  # not a step after
        assert s.get_current_position() == sum(d for _t, d in steps[i])
    assert group.position == [s.get_current_position() for s in group.steppers]


def test_a_steppers_own_requests_while_the_path_moves():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    x = group.steppers[0]
    stream = Stream(backend, group, [(8000, 0)], 3000.0)
    assert stream.run(until=lambda: backend.now() >= backend.profile.ticks_per_s // 4)
    assert x.move(100) == MoveResult.ERR_SPEED_IS_UNDEFINED  # its speed is the path's
    assert x.is_running() and x.target_pos() == 8000
    x.stop_move()  # = cancel the path, along it
    assert backend.wait_until(group.is_idle, 5 * backend.profile.ticks_per_s)
    stopped = x.get_current_position()
    assert 0 < stopped < 8000
    x.set_speed_in_hz(2000)
    x.set_acceleration(10000)
    assert x.move(100) == MoveResult.OK  # idle group: its own planner moves it
    assert group.line((0, 0), 600.0) == PathResult.ERR_AXIS_BUSY
    assert backend.wait_until(lambda: not x.is_running(), backend.profile.ticks_per_s)
    assert x.get_current_position() == stopped + 100
    feed_all(backend, group, [(0, 0)], 3000.0)  # the path starts where the axes are
    assert x.get_current_position() == 0


# --------------------------------------------------------------- laser
def test_speed_listener_reports_every_command_of_the_dominant_axis():
    """The listener hears the path speed at the start of every command of a block's
    dominant axis (a command begins with a step).  From one such step to the next the
    pins give the path's average speed (steps times the path per step, over the
    time); the speed heard at its start differs from it by no more than the block's
    acceleration changes the speed in that time and the tolerance of grouped steps
    (a command inside a group ends up to GROUP_TOLERANCE_STEPS early)."""
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    heard: list[tuple[int, float, object]] = []
    group.speed_listener = lambda tick, speed, tag: heard.append((tick, speed, tag))
    blocks = [(4000, 1000), (5000, 5000)]
    for k, p in enumerate(blocks):
        assert group.line(p, 3000.0, tag=k) == PathResult.OK
    group.flush()
    assert backend.wait_until(group.is_idle, 10 * backend.profile.ticks_per_s)
    steps = axis_steps(backend, pins, dirs)
    tps = backend.profile.ticks_per_s
    assert heard[-1][1] == 0.0  # the path stops
    assert {tag for _t, _s, tag in heard} == {0, 1}
    assert len(heard) - 1 >= min(st.commands for st in group.axis_stats())
    units = [(4000 / math.hypot(4000, 1000), 1000 / math.hypot(4000, 1000)),
             (1000 / math.hypot(1000, 4000), 4000 / math.hypot(1000, 4000))]
    checked = 0
    for (tick, speed, tag), (nxt, _s, tag2) in zip(heard, heard[1:], strict=False):
        axis = 0 if tag == 0 else 1  # the dominant axis of each block
        tk = [t for t, _d in steps[axis]]
        assert tick in tk  # a command begins with a step
        if tag2 != tag or nxt == heard[-1][0]:
            continue
        n = sum(1 for t in tk if tick <= t < nxt)
        dt = (nxt - tick) / tps
        average = n / SPU / units[tag][axis] / dt * 60  # mm/min
        accel = limit_along(LIMITS.acceleration, units[tag]) * 60
        grouping = GROUP_TOLERANCE_STEPS / SPU / units[tag][axis] / dt * 60
        assert abs(average - speed) <= accel * dt + grouping + 1.0, (tick, speed)
        assert speed <= 3000.0 * 1.0001
        checked += 1
    assert checked > 50


# ---------------------------------------------------------------- arcs
def test_arcs_on_the_pins():
    from fas.path import Plane, arc_center_from_radius, arc_points

    tol = 0.01
    backend, engine, group, pins, dirs = make_group(limits=LIMITS, arc_tolerance=tol,
                                                    junction_deviation=0.01)
    circle = arc_points((0.0, 0.0), (0.0, 0.0), (10.0, 0.0), Plane.XY, True, tol)
    err, offset = arc_center_from_radius((0.0, 0.0), (20.0, 0.0), 10.0, Plane.XY, False)
    assert err == 0 and offset == pytest.approx((10.0, 0.0))
    half = arc_points((0.0, 0.0), (20.0, 0.0), offset, Plane.XY, False, tol)
    targets = [tuple(round(v * SPU) for v in p) for p in circle + half]
    feed_all(backend, group, targets, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == (1600, 0)  # the end point, exactly
    c, r = (10 * SPU, 0.0), 10 * SPU
    # at every block end (a vertex: all its axes' last steps on one tick) the radius
    # error is within the tolerance and the rounding to a step
    ticks = vertex_ticks(ins, targets)
    at = dict(ins)
    for t in ticks:
        p = at[t]
        assert abs(math.hypot(p[0] - c[0], p[1] - c[1]) - r) <= tol * SPU + 1
    # between them every step is within one step of the chords
    assert path_deviation(ins, [(0, 0)] + targets)[0] <= 1.0
    worst = max(abs(math.hypot(p[0] - c[0], p[1] - c[1]) - r) for _t, p in ins)
    assert worst <= tol * SPU + 2


def test_every_step_within_tolerance_plus_one_step_of_the_circle():
    """The chord ends as they are (between steps), not rounded: every axis stands on the
    step nearest to the path (but its last step, on the end tick), so every step is
    within the tolerance + one step of the circle (measured 0.8 + 0.68; with the
    vertices rounded to steps, as in the test above, 0.8 + 1.40)."""
    from fas.path import Plane, arc_points

    tol = 0.01
    backend, engine, group, pins, dirs = make_group(limits=LIMITS, arc_tolerance=tol,
                                                    junction_deviation=0.01)
    circle = arc_points((0.0, 0.0), (0.0, 0.0), (10.0, 0.0), Plane.XY, True, tol)
    points = [tuple(v * SPU for v in p) for p in circle]
    assert any(v != round(v) for p in points for v in p)
    feed_all(backend, group, points, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == (0, 0)  # the end point, exactly
    worst = max(abs(math.hypot(p[0] - 800, p[1]) - 800) for _t, p in ins)
    assert worst <= tol * SPU + 1
    assert group.stats.underruns == 0


def test_a_path_through_points_keeps_each_axis_on_the_nearest_step():
    """``through``: the path goes on through the point (an arc's chord end) - every axis
    stands on the step nearest to the path, also where the point happens to lie on a
    whole step (Y 5.0 here); the last block ends on its target, every axis's last step
    on one tick."""
    from rigs.path import Stream, perp_to_segment

    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    a, b, end = (0.0, 0.0), (400.3, 5.0), (800, 30)
    assert group.line(b, 3000.0, through=True) == PathResult.OK
    assert group.line(end, 3000.0) == PathResult.OK
    assert group.position == [800, 30]
    assert Stream(backend, group, [], 3000.0).run()
    steps = axis_steps(backend, pins, dirs)
    ins = instants(steps, (0, 0))
    assert ins[-1][1] == end
    assert steps[0][-1][0] == steps[1][-1][0]  # the last steps on one tick
    first = [p for _t, p in ins if p[0] <= 399]  # the pins in the first block
    assert len(first) > 390
    # each axis within half a step (+ early grouped steps while speeding up): Y, the
    # slow axis, would lag up to a whole step into the whole step Y 5 without it
    worst = max(perp_to_segment(p, a, b) for p in first)
    assert worst <= (0.5 + GROUP_TOLERANCE_STEPS) * math.sqrt(2), worst


# --------------------------------------------- acceleration at the corners
#: issue 25's program figures: 80 steps/mm, 1000 mm/s^2 and 12000 mm/min per axis
BENCH_LIMITS = AxisLimits(SPU, 12000.0, 1000.0)
ACC_WINDOW_S = 0.02  # step edges at least this far apart (rigs.path.edge_accel)


def circles_of_chords(count: int) -> list[tuple[int, int]]:
    return rig_circles(count, SPU)


def corner_run():
    backend, engine, group, pins, dirs = make_group(limits=BENCH_LIMITS,
                                                    junction_deviation=0.01)
    pts = circles_of_chords(4)
    feed_all(backend, group, pts, 3000.0)
    return backend, pts, axis_steps(backend, pins, dirs)


def test_circles_of_chords_within_one_step_and_each_axis_within_its_acceleration_inside_blocks():
    """The program of the strict xfail below: every step within one step of the chords,
    the end exact, and away from the junctions (inside each block) each axis's
    acceleration from the pins within the limit + the grouping's 2 e / W^2."""
    backend, pts, steps = corner_run()
    ins = instants(steps, (0, 0))
    assert path_deviation(ins, [(0, 0)] + pts)[0] <= 1.0
    assert ins[-1][1] == pts[-1]
    tps = backend.profile.ticks_per_s
    slack = 2 * GROUP_TOLERANCE_STEPS / ACC_WINDOW_S ** 2
    limit = BENCH_LIMITS.acceleration * SPU
    for i in range(2):
        tk, xs = axis_motion(steps[i])
        a, _v = max_accel(tk, xs, tk[0] - 1, tk[-1] + 1, tps, ACC_WINDOW_S)
        assert a > 0.5 * limit  # it measures something
    # one whole circle (r = 4 mm: no reversal in it) at the limit + slack
    ticks = [ins[0][0] - 1] + vertex_ticks(ins, pts)
    last = len(circles_of_chords(1))
    for i in range(2):
        tk, xs = axis_motion(steps[i])
        n = sum(1 for t in tk if t <= ticks[last])
        a, _at = edge_accel(tk[:n], xs[:n], tps, ACC_WINDOW_S)
        assert a <= limit + slack, (i, a / SPU)


@pytest.mark.xfail(strict=True, reason="measured Y 1014.4 mm/s^2 (limit 1000, resolution "
                   "+7.8) where the path turns back between two circles: junction "
                   "deviation's velocity jump beside a ramp at the axis's full limit; no "
                   "corner blend yet (docs/path-planner.md, Acceleration at corners)")
def test_every_axis_within_its_acceleration_from_the_pins_at_the_corners_too():
    """Issue 25: no axis above its acceleration, measured from the pins.  For every
    step, a divided difference over the axis's step edges at least 20 ms before and
    after it (rigs.path.edge_accel: the position at an edge is exact; steps up to
    GROUP_TOLERANCE_STEPS early make it off by at most 2 e / W^2)."""
    backend, pts, steps = corner_run()
    tps = backend.profile.ticks_per_s
    slack = 2 * GROUP_TOLERANCE_STEPS / ACC_WINDOW_S ** 2
    for i, (a, at) in enumerate(axes_edge_accel(steps[:2], tps, ACC_WINDOW_S)):
        assert a <= BENCH_LIMITS.acceleration * SPU + slack, (i, a / SPU, at / tps)


# ---------------------------------------------------------------- joining
def test_join_refusals():
    from fas import Engine
    from fas.path import PathGroup, PathSettings
    from fas.sim import SimBackend

    def two(profile="atmega328p"):
        b = SimBackend(profile)
        e = Engine(b)
        e.init()
        s = [e.stepper_connect_to_pin(p) for p in (9, 10)]
        s[0].set_direction_pin(5)
        s[1].set_direction_pin(6)
        return s

    settings = PathSettings(axes=(LIMITS, LIMITS))
    a, b = two()
    a.set_auto_enable(True)
    assert PathGroup([a, b], settings).attach() == PathResult.ERR_AUTO_ENABLE
    a, b = two()
    a.set_direction_pin(5, True, 100)
    assert PathGroup([a, b], settings).attach() == PathResult.ERR_DIR_DELAY
    a, b = two()
    b.set_direction_pin(5)
    assert PathGroup([a, b], settings).attach() == PathResult.ERR_SHARED_DIR_PIN
    a, b = two()
    assert PathGroup([a, a], settings).attach() == PathResult.ERR_SAME_STEPPER
    assert PathGroup([a], settings).attach() == PathResult.ERR_SETTINGS
    a.set_speed_in_hz(1000)
    a.set_acceleration(1000)
    a.move(1000)
    assert PathGroup([a, b], settings).attach() == PathResult.ERR_AXIS_BUSY
    # an ESP32 driver that pauses at every direction change (I2S) cannot take part
    from fas.codes import FasDriver

    be = SimBackend("esp32_idf5")
    e = Engine(be)
    e.init()
    i2s = e.stepper_connect_to_pin(4, FasDriver.I2S_DIRECT)
    rmt = e.stepper_connect_to_pin(5, FasDriver.RMT)
    i2s.set_direction_pin(20)
    rmt.set_direction_pin(21)
    assert PathGroup([i2s, rmt], settings).attach() == PathResult.ERR_DIR_DELAY
    assert PathGroup([rmt], PathSettings(axes=(LIMITS,))).attach() == PathResult.OK


def test_line_answers():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS, queue_blocks=4)
    assert group.line((1, 2, 3), 600.0) == PathResult.ERR_AXES
    assert group.line((100, 0), 0.0) == PathResult.ERR_FEED
    assert group.line((100, 0), float("nan")) == PathResult.ERR_FEED
    assert group.line((2 ** 31, 0), 600.0) == PathResult.ERR_RANGE
    assert group.line((0, 0), 600.0) == PathResult.EMPTY_BLOCK
    for k in range(1, 5):
        assert group.line((100 * k, 0), 600.0) == PathResult.OK
    assert group.room() == 0
    assert group.line((500, 0), 600.0) == PathResult.QUEUE_FULL
    assert group.line_units((1.0, 2.0), 600.0) == PathResult.QUEUE_FULL
    group.abort()
    assert group.line_units((1.0, 2.0), 600.0) == PathResult.OK
    assert group.position == [80, 160]
    group.steppers[1].set_direction_pin(255)
    assert group.line((80, 0), 600.0) == PathResult.ERR_NO_DIRECTION_PIN


# ------------------------------------------------------------ faults, device
def test_a_queue_run_dry_is_stopped_and_the_path_planned_again():
    """The periodic task runs later than the queues last (the ESP32's task rate
    raised to 40 ms in the middle of a run, and back to 4 ms once that showed): the
    queues run out of commands at different points of the path.  The group notices,
    stops every axis and plans the rest of the path from where they stand."""
    backend, engine, group, pins, dirs = make_group("esp32", limits=LIMITS)
    tps = backend.profile.ticks_per_s
    stream = Stream(backend, group, [(8000, 6000), (0, 6000)], 3000.0)
    assert stream.run(until=lambda: backend.now() >= tps // 2)
    engine.task_rate(40)
    assert stream.run(until=lambda: group.stats.underruns > 0, limit_s=1)
    engine.task_rate(4)
    assert stream.run(limit_s=30)
    assert group.stats.underruns == 1 and group.stats.runs == 2
    assert [s.get_current_position() for s in group.steppers] == [0, 6000]
    steps = axis_steps(backend, pins, dirs)
    assert [sum(d for _t, d in s) for s in steps] == [0, 6000]


def test_the_same_path_on_a_serial_device():
    """Through the serial backend to the Python device (a pty, virtual clock): the
    device's pins show the path within one step and the corners on one tick."""
    from fas import Engine
    from fas.device.loopback import Loopback
    from fas.path import PathGroup, PathSettings
    from rigs.path import dir_pins, step_pins
    from rigs.pins import steps_by_pins

    with Loopback("atmega328p", record=True) as lb:
        backend = lb.backend
        engine = Engine(backend)
        engine.init()
        pins, dirs = step_pins(backend.profile, 2), dir_pins(backend.profile, 2)
        steppers = []
        for sp, dp in zip(pins, dirs, strict=True):
            s = engine.stepper_connect_to_pin(sp)
            s.set_direction_pin(dp)
            steppers.append(s)
        group = PathGroup(steppers, PathSettings(axes=(LIMITS, LIMITS),
                                                 junction_deviation=0.05))
        assert group.attach() == PathResult.OK
        pts = [(800, 0), (800, 800), (1600, 300), (0, 0)]
        assert Stream(backend, group, pts, 3000.0).run(limit_s=60)
        assert backend.settle()
        dev = lb.device
        assert [dev.position(i) for i in sorted(dev.queues)] == [0, 0]
        rec = dev.recorder
        steps = [steps_by_pins(rec.pin_edges, sp, dp) for sp, dp in zip(pins, dirs, strict=True)]
        ins = instants(steps, (0, 0))
        assert path_deviation(ins, [(0, 0)] + pts)[0] <= 1.0
        assert group.stats.underruns == 0


def test_holds_and_resumes_at_random_moments():
    """A random path held and resumed at random moments (some blocks queued while
    held): it ends exactly at its end, and every step is within one step of the path
    as run - the queued blocks with each hold's stop point between them."""
    import random

    rnd = random.Random(3)
    backend, engine, group, pins, dirs = make_group(limits=LIMITS, junction_deviation=0.02,
                                                    queue_blocks=8)
    pts = random_path(rnd)
    stops = run_with_random_holds(backend, group, pts, rnd)
    assert len(stops) > 20
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == pts[-1]
    poly = [(0, 0)]  # the path as run: vertices and stop points in time order
    vi = si = 0
    for t, p in ins:
        while si < len(stops) and stops[si][0] <= t:
            if poly[-1] != stops[si][1]:
                poly.append(stops[si][1])
            si += 1
        if vi < len(pts) and p == pts[vi]:
            poly.append(pts[vi])
            vi += 1
            while vi < len(pts) and pts[vi] == pts[vi - 1]:  # a block of no length
                vi += 1
    assert path_deviation(ins, poly + pts[vi:])[0] <= 1.0
