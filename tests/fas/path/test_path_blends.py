"""A path group with corner blends on (``PathSettings(corner_blends=True)``, G-code
``$172=1``) on the simulated chip: every figure from the recorded pins.

The default (Grbl's junctions: the commanded polyline, every corner on one tick) is
tests/fas/path/test_path_motion.py.  Here every turning corner on whole steps is a
blend at constant acceleration (fas.path.blend, docs/path-planner.md "Corners:
blends"): every axis within one step of the path *as run* (the polyline with those
corners blended, ``PathGroup.blend_log``), every axis within its acceleration from the
pins at the corners too, and within ``$11`` + 1 step of the *commanded* polyline
(test_the_blends_keep_every_axis_within_11_plus_one_step_of_the_commanded_path).

Units: 80 steps/mm; feeds in mm/min.
"""

from __future__ import annotations

import math
import random

import pytest

from fas.path import AxisLimits, PathResult, PathState
from fas.path.settings import GROUP_TOLERANCE_STEPS
from rigs.path import (
    Stream,
    axes_edge_accel,
    axis_motion,
    axis_steps,
    blended_ticks,
    commanded_deviation,
    edge_accel,
    feed_all,
    instants,
    interp,
    make_group,
    max_accel,
    path_as_run,
    random_path,
    run_with_random_holds,
    timed_deviation,
)
from rigs.path import circles_of_chords as rig_circles

SPU = 80.0
LIMITS = AxisLimits(SPU, 6000.0, 500.0)  # 100 mm/s, 500 mm/s^2 per axis
SQUARE = [(3200, 0), (3200, 3200), (0, 3200), (0, 0)]
#: issue 25's program figures: 80 steps/mm, 1000 mm/s^2 and 12000 mm/min per axis
BENCH_LIMITS = AxisLimits(SPU, 12000.0, 1000.0)
ACC_WINDOW_S = 0.02  # step edges at least this far apart (rigs.path.edge_accel)
SLACK = 2 * GROUP_TOLERANCE_STEPS / ACC_WINDOW_S ** 2  # the grouping's 2 e / W^2


def blended(profile: str = "atmega328p", axes: int = 2, **kw):
    """rigs.path.make_group with corner blends on."""
    return make_group(profile, axes, corner_blends=True, **kw)


def blended_dev(ins, group, poly, stops=()) -> float:
    """The largest Chebyshev distance (steps) of the instants from the path as run:
    the polyline with each corner the executor blended replaced by its blend (and
    ``stops``, (tick, point), where a feed hold stopped), each instant against the
    path's pieces within 20 ms of its time."""
    spu = [a.steps_per_unit for a in group.settings.axes]
    path = sorted(path_as_run(poly, group.blend_log, ins, spu,
                              plain=group.executor.plain_log or ())
                  + [(t, tuple(float(c) for c in p)) for t, p in stops])
    return timed_deviation(ins, path, int(0.02 * group.tps))


def limit_along(limit: float, unit) -> float:
    return min(limit / abs(u) for u in unit if u)


def circles_of_chords(count: int) -> list[tuple[int, int]]:
    return rig_circles(count, SPU)


@pytest.fixture(scope="module")
def corner_run():
    """Four circles of chords at $11 = 0.01 mm (Grbl's default: 0.8 step) - the
    program of test_path_motion's strict xfail at the corners."""
    backend, engine, group, pins, dirs = blended(limits=BENCH_LIMITS,
                                                 junction_deviation=0.01)
    pts = circles_of_chords(4)
    feed_all(backend, group, pts, 3000.0)
    return backend, pts, axis_steps(backend, pins, dirs), group


# ----------------------------------------------------------- the switch
def test_blends_are_off_by_default_and_on_with_the_setting():
    backend, engine, group, pins, dirs = make_group(limits=LIMITS)
    assert group.settings.corner_blends is False
    assert group.lookahead.blend_share == 0.0
    feed_all(backend, group, SQUARE, 3000.0)
    assert group.blend_log == []  # Grbl's junctions: no blend
    settings = group.settings.__class__(axes=(LIMITS, LIMITS), corner_blends=True)
    assert group.configure(settings) == PathResult.OK
    assert group.lookahead.blend_share > 0.0
    feed_all(backend, group, SQUARE[:2], 3000.0)
    assert [c for c, _b in group.blend_log] == [SQUARE[0]]


# ----------------------------------------------------------- path geometry
@pytest.mark.parametrize("profile", ["atmega328p", "esp32", "rp2040"])
def test_square_within_one_step_and_every_corner_blended(profile):
    backend, engine, group, pins, dirs = blended(profile, limits=LIMITS)
    feed_all(backend, group, SQUARE, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert [c for c, _b in group.blend_log] == SQUARE[:3]  # each corner blended
    assert blended_dev(ins, group, [(0, 0)] + SQUARE) <= 1.0
    assert ins[-1][1] == SQUARE[-1]
    assert [s.get_current_position() for s in group.steppers] == [0, 0]
    assert group.stats.runs == 1 and group.stats.underruns == 0
    for st in group.axis_stats():
        assert st.shifted == 0 and st.early_ends == 0


@pytest.mark.parametrize("seed", [1, 2])
def test_random_3d_path_within_one_step_of_the_path_as_run(seed):
    rnd = random.Random(seed)
    backend, engine, group, pins, dirs = blended("atmega2560", 3, limits=LIMITS)
    pts = []
    pos = [0, 0, 0]
    for _ in range(25):
        pos = [p + rnd.randint(-1500, 1500) for p in pos]
        pts.append(tuple(pos))
    feed_all(backend, group, pts, rnd.choice([600.0, 3000.0, 6000.0]))
    ins = instants(axis_steps(backend, pins, dirs), (0, 0, 0))
    assert blended_dev(ins, group, [(0, 0, 0)] + pts) <= 1.0
    assert ins[-1][1] == pts[-1]
    assert group.stats.underruns == 0


def test_the_blends_keep_every_axis_within_11_plus_one_step_of_the_commanded_path(
        corner_run):
    """The blends' own figure against the COMMANDED polyline (issue 25 asks every axis
    within 1 step of it; Grbl's junctions meet that, test_path_motion).  A blend passes
    inside its corner by v T |w - u| / 8 = d sin(theta/2) (1 + sin(theta/2)) / 2 <= d
    at the junction speed (fas.path.blend; less at a lower speed), d = $11 - a
    Euclidean distance, so no axis is further than d from the polyline on the path as
    run; the steps are within 1 step of that path (blended_dev).  Bound: $11 + 1 step
    per axis (Chebyshev <= Euclidean).  At $11 = 0.01 mm = 0.8 step the steps led
    towards the commanded corner meet the issue's 1 step on four circles of chords
    (the next test); on the square at $11 = 0.05 mm = 4 steps: 2.0 steps (Grbl's
    junctions: 0) - a blend 2.4 steps inside its corner."""
    backend, pts, steps, group = corner_run
    ins = instants(steps, (0, 0))
    tps = backend.profile.ticks_per_s
    dev = commanded_deviation(ins, [(0, 0)] + pts, group.blend_log, int(0.02 * tps))
    assert dev <= 0.01 * SPU + 1.0, dev
    assert len(group.blend_log) > 0.9 * (len(pts) - 1)  # (nearly) every corner blended
    # the square, $11 = 0.05 mm
    backend, engine, group, pins, dirs = blended(limits=LIMITS, junction_deviation=0.05)
    feed_all(backend, group, SQUARE, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    dev = commanded_deviation(ins, [(0, 0)] + SQUARE, group.blend_log, int(0.02 * tps))
    assert dev <= 0.05 * SPU + 1.0, dev
    assert dev > 1.0  # each blend passes 0.030 mm = 2.4 steps inside its corner


def test_with_blends_every_axis_within_one_step_of_the_commanded_path_at_grbls_11(
        corner_run):
    """Issue 25's line "every axis within 1 step of the commanded path at every step",
    with the blends, at Grbl's default $11 = 0.01 mm (0.8 step): each blend step comes
    where the commanded corner reaches its integer if that is earlier, at most
    GROUP_TOLERANCE_STEPS before the blend does (fas.path.blend.lead_to_polyline) -
    without it 1.038 steps on these circles (floor rounding along the motion, 0.992
    step, plus the blend's 0.088 step inside the chord after the corner).  The other two
    lines on the same run: every axis within its acceleration from the pins
    (test_every_axis_within_its_acceleration_from_the_pins_at_the_corners_too) and the
    corner speed (test_corner_speed_is_the_junction_deviation_formula_through_the_blend)."""
    backend, pts, steps, group = corner_run
    ins = instants(steps, (0, 0))
    tps = backend.profile.ticks_per_s
    assert commanded_deviation(ins, [(0, 0)] + pts, group.blend_log, int(0.02 * tps)) <= 1.0
    assert blended_dev(ins, group, [(0, 0)] + pts) <= 1.0


@pytest.mark.xfail(strict=True, reason="measured 1.178 steps (seed 3; 1.238 without the led "
                   "steps): a 12-degree corner at (319, 769) taken at the junction-deviation "
                   "speed 42.5 mm/s, its blend 0.793 step inside - floor rounding plus that "
                   "gap, more than the 1/8 step a step may be led (docs/path-planner.md, "
                   "'Where the 1.038 came from')")
def test_with_blends_a_random_path_within_one_step_of_the_commanded_path_at_grbls_11():
    """The same line on a random path (rigs.path.random_path: sharp and shallow corners,
    tiny blocks) at Grbl's $11 = 0.01 mm: where junction deviation sets the speed of a
    shallow corner the blend passes nearly $11 (0.8 step) inside it, and the 1-step line
    holds only as $11 + 1 step (the test above it) - the conflict between the corner
    speed of the formula and the 1-step line that blends cannot avoid."""
    rnd = random.Random(3)
    backend, engine, group, pins, dirs = blended(limits=BENCH_LIMITS, junction_deviation=0.01)
    pts = random_path(rnd)
    feed_all(backend, group, pts, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    verts = [(0, 0)] + [p for k, p in enumerate(pts) if k == 0 or p != pts[k - 1]]
    assert blended_dev(ins, group, verts) <= 1.0  # (met: the path as run)
    dev = commanded_deviation(ins, verts, group.blend_log, int(0.02 * group.tps))
    assert dev <= 0.01 * SPU + 1.0  # (met: the bound)
    assert dev <= 1.0, dev


@pytest.mark.parametrize("turn_deg", [45, 135])
def test_corner_speed_is_the_junction_deviation_formula_through_the_blend(turn_deg):
    backend, engine, group, pins, dirs = blended(limits=LIMITS, junction_deviation=0.05)
    u1 = (1.0, 0.0)
    a = math.radians(turn_deg)
    u2 = (math.cos(a), math.sin(a))
    corner = (3200, 0)
    end = (3200 + round(3200 * u2[0]), round(3200 * u2[1]))
    feed_all(backend, group, [corner, end], 3000.0)
    steps = axis_steps(backend, pins, dirs)
    cos_theta = -(u1[0] * u2[0] + u1[1] * u2[1])
    sin_half = math.sqrt((1 - cos_theta) / 2)
    bis = (u2[0] - u1[0], u2[1] - u1[1])
    n = math.hypot(*bis)
    a_j = limit_along(LIMITS.acceleration, (bis[0] / n, bis[1] / n))
    v_j = math.sqrt(a_j * 0.05 * sin_half / (1 - sin_half))  # mm/s
    assert v_j < 50.0  # below the feed: the corner limits it
    [(at, bseg)] = group.blend_log
    assert at == corner
    assert bseg.b.speed == pytest.approx(v_j, rel=0.01)
    # from the pins: Y starts in the blend (exact: a command's first step), from rest
    # at the blend's acceleration along Y: 1 step after sqrt(2 / a_y)
    tps = backend.profile.ticks_per_s
    a_y = bseg.b.axis_accel(1) * SPU  # steps/s^2
    assert bseg.b.reach * u2[1] * SPU > 1  # Y's first step is inside the blend
    first_y = steps[1][0][0]
    # 2 ticks: the step on a whole tick (rounding <= 1) after the blend's start,
    # itself a fractional tick (<= 1)
    assert abs(first_y - (bseg.t_start + math.sqrt(2 / a_y) * tps)) <= 2


def test_rates_and_accelerations_from_the_pins_stay_within_each_axis():
    """As test_path_motion's (over windows of W = 20 ms inside each block, the
    quantisation allowing 4 e / W^2 and 2 e / W), the blocks between the blends."""
    limits = (AxisLimits(80.0, 6000.0, 500.0), AxisLimits(100.0, 4800.0, 300.0),
              AxisLimits(400.0, 600.0, 100.0))
    backend, engine, group, pins, dirs = blended("atmega2560", 3, limits=LIMITS)
    assert group.configure(group.settings.__class__(axes=limits, corner_blends=True)
                           ) == PathResult.OK
    pts = [(8000, 0, 0), (8000, 6000, 2000), (0, 2000, 0), (4000, 4000, 4000)]
    feed_all(backend, group, pts, None)
    steps = axis_steps(backend, pins, dirs)
    ins = instants(steps, (0, 0, 0))
    assert len(group.blend_log) == 3
    assert blended_dev(ins, group, [(0, 0, 0)] + pts) <= 1.0
    ticks = [ins[0][0] - 1] + blended_ticks(pts, group.blend_log, ins)
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
        assert peak_v > 0.9 * v_max


def test_blends_into_and_out_of_an_arc_between_steps_keep_its_chord_ends():
    """A corner on whole steps next to an arc whose chord ends lie between steps: the
    corners into the arc's first chord and out of its last are blended, the chord
    ends between steps are kept (no blend there), every step within one step of the
    path as run, the end exact."""
    from fas.path import Plane, arc_points

    tol = 0.01
    backend, engine, group, pins, dirs = blended(limits=LIMITS, arc_tolerance=tol,
                                                 junction_deviation=0.01)
    quarter = arc_points((5.0, 0.0), (10.0, 5.0), (0.0, 5.0), Plane.XY, False, tol)
    arc = [tuple(v * SPU for v in p) for p in quarter]
    assert any(v != round(v) for p in arc[:-1] for v in p)
    targets = [(400.0, 0.0)] + arc + [(800.0, 1200.0)]
    feed_all(backend, group, targets, 3000.0)
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == (800, 1200)
    assert [c for c, _seg in group.blend_log] == [(400, 0), (800, 400)]
    assert blended_dev(ins, group, [(0, 0)] + targets) <= 1.0
    assert group.stats.underruns == 0


# --------------------------------------------- acceleration at the corners
def test_circles_of_chords_within_one_step_of_the_path_as_run(corner_run):
    backend, pts, steps, group = corner_run
    ins = instants(steps, (0, 0))
    assert blended_dev(ins, group, [(0, 0)] + pts) <= 1.0
    assert ins[-1][1] == pts[-1]
    assert len(group.blend_log) > 0.9 * (len(pts) - 1)


def test_every_axis_within_its_acceleration_from_the_pins_at_the_corners_too(corner_run):
    """Issue 25: no axis above its acceleration, measured from the pins (the divided
    difference of rigs.path.edge_accel over step edges >= 20 ms apart, + 2 e / W^2) -
    test_path_motion's strict xfail in the default mode (Grbl's junctions), met with
    the blends."""
    backend, pts, steps, _group = corner_run
    tps = backend.profile.ticks_per_s
    for i, (a, at) in enumerate(axes_edge_accel(steps[:2], tps, ACC_WINDOW_S)):
        assert a <= BENCH_LIMITS.acceleration * SPU + SLACK, (i, a / SPU, at / tps)
        assert a > 0.5 * BENCH_LIMITS.acceleration * SPU  # it measures something


def test_every_axis_within_its_acceleration_from_the_pins_where_it_turns_round():
    """bench_path's first six circles (radius 4, 10, 16, 6, 12, 18 mm, all through
    (0, 0), the direction flipping): where two of them meet Y turns round in a blend
    at 0.27 mm/s.  Steps grouped early are early along the motion, so on the two
    sides of a turn in opposite directions; the bound 2 e / W^2 holds there because
    an axis's steps are on their ticks for TURN_EXACT_S after its last step before a
    turn (1008.9 mm/s^2 without that, against 1000 + 7.8)."""
    from fas.path import Plane, arc_points

    radii = [4.0]
    while len(radii) < 6:
        radii.append(4.0 + (radii[-1] + 2.0) % 16.0)
    pts: list[tuple[int, int]] = []
    for r in radii:
        for p in arc_points((0.0, 0.0), (0.0, 0.0), (r, 0.0), Plane.XY, len(pts) % 2 == 0,
                            0.002):
            pts.append((round(p[0] * SPU), round(p[1] * SPU)))
    backend, engine, group, pins, dirs = blended(limits=BENCH_LIMITS,
                                                 junction_deviation=0.01)
    feed_all(backend, group, pts, 3000.0)
    steps = axis_steps(backend, pins, dirs)
    assert instants(steps, (0, 0))[-1][1] == pts[-1]
    tps = backend.profile.ticks_per_s
    for i, (a, at) in enumerate(axes_edge_accel(steps[:2], tps, ACC_WINDOW_S)):
        assert a <= BENCH_LIMITS.acceleration * SPU + SLACK, (i, a / SPU, at / tps)


@pytest.mark.parametrize("seed", [3, 5])
def test_holds_and_resumes_at_random_moments(seed):
    """A random path held and resumed at random moments: it ends exactly at its end,
    every step within one step of the path as run - the blended polyline with each
    hold's stop point - and within $11 + 1 step of the commanded polyline: a hold's
    blends that slow down pass inside their corners by at most $11 too
    (fas.path.blend.hold_blend), as the planned ones do."""
    rnd = random.Random(seed)
    backend, engine, group, pins, dirs = blended(limits=LIMITS, junction_deviation=0.02,
                                                 queue_blocks=8)
    pts = random_path(rnd)
    stops = run_with_random_holds(backend, group, pts, rnd)
    assert len(stops) > 20
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == pts[-1]
    verts = [(0, 0)] + [p for k, p in enumerate(pts) if k == 0 or p != pts[k - 1]]
    assert blended_dev(ins, group, verts, stops) <= 1.0
    assert group.blend_log
    assert any(s.b.speed_out < s.b.speed for _c, s in group.blend_log)  # a hold's
    dev = commanded_deviation(ins, verts, group.blend_log, int(0.02 * group.tps))
    assert dev <= 0.02 * SPU + 1.0, dev


# ----------------------------------------------------------------- hold
def zigzag(m: int, count: int) -> list[tuple[int, int]]:
    """Legs of (4 m, +-m) steps from (0, 0): every corner a turn of 28 degrees, gentle
    enough that a hold takes it as a blend."""
    return [(4 * m * j, m if j % 2 else 0) for j in range(1, count + 1)]


#: hold_walk's blends slow to this share of their entry speed (derived there)
HOLD_RATIO = 3 / 5


def hold_walk(pts, block_start, distance, speed, limits: AxisLimits):
    """Where a hold from ``distance`` (units) along the block from ``block_start`` at
    ``speed`` (units/s) stops, by the definitions (fas.path.blend.hold_blend): on each
    block it decelerates at the block's acceleration ``a`` (each axis's limit ``A``
    along it); a corner it cannot stop before is a blend that slows from ``v_in u`` to
    ``v_out w``, ``v_out = r v_in``, in ``T = v_in tau(r)``, ``tau(r) = max_i |r w_i -
    u_i| / A`` (the axes at their limit); it begins ``c v_in^2`` before the corner
    (``c = tau / 2``), where the deceleration reaches ``v_in^2``, ends ``r c v_in^2``
    into the block out, and the hold takes the ``r`` that leaves the least to run
    after it (the largest of equals).

    On these legs, directions (4, +-1) / sqrt(17), X keeps its component through the
    corner: ``tau = max(4 (1 - r), 1 + r) / (sqrt(17) A)``, X's term for ``r <= 3/5``.
    There ``tau = (1 - r) / a``: the blend slows along the polyline (``(1 + r) v_in T /
    2`` of it) at exactly ``a``, so the stop lies ``v^2 / (2 a)`` along the polyline
    whatever ``r``; above 3/5 Y sets ``tau`` and the blend slows less.  So ``r = 3/5``,
    and ``v_in^2 = (v^2 - 2 a rest) / r`` (from ``v_in^2 = v^2 - 2 a (rest - c
    v_in^2)``), possible while ``v_in <= v`` - the blend begins after the hold's point.

    Returns (stop point in steps, the polyline's length from the hold's start to the
    stop (steps), main's bound ``v^2 / (2 a)`` (steps), and each corner's ``(v_in,
    v_out)`` (units/s))."""
    spu = limits.steps_per_unit
    acc = limits.acceleration
    verts = [(0, 0)] + list(pts)
    i = verts.index(tuple(block_start))

    def unit(p, q):
        d = [(b - a) / spu for a, b in zip(p, q, strict=True)]
        n = math.hypot(*d)
        return [x / n for x in d], n

    u, length = unit(verts[i], verts[i + 1])
    a = limit_along(acc, u)
    v2 = speed * speed
    bound = v2 / (2 * a)
    r = HOLD_RATIO
    s, along = distance, 0.0
    corners = []
    while True:
        rest = length - s
        if v2 <= 2 * a * rest:  # stops in this block
            s += v2 / (2 * a)
            along += v2 / (2 * a)
            stop = [p + x * s * spu for p, x in zip(verts[i], u, strict=True)]
            return stop, along * spu, bound * spu, corners
        w, nlen = unit(verts[i + 1], verts[i + 2])
        assert w[0] == pytest.approx(u[0]) and w[1] == pytest.approx(-u[1])  # the legs
        assert limit_along(acc, w) == a
        tau = max(abs(r * y - x) / acc for x, y in zip(u, w, strict=True))
        assert tau == pytest.approx((1 - r) / a)  # X sets it: slowing at a
        vin2 = (v2 - 2 * a * rest) / r
        assert vin2 <= v2  # (these holds: the blend begins after the hold's point)
        c = tau / 2
        reach_out = r * c * vin2
        assert reach_out <= nlen / 2
        corners.append((math.sqrt(vin2), r * math.sqrt(vin2)))
        along += rest + reach_out  # the ramp to the blend, the blend over the corner
        i, u, length, v2, s = i + 1, w, nlen, r * r * vin2, reach_out


#: (leg m, the hold's moment in s): one corner after a cruise and in the plan's
#: deceleration to it (1000-step legs), one and three corners (100-step legs)
ZIGZAG_HOLDS = [(250, 0.55), (250, 0.57), (25, 0.43), (25, 0.4)]


@pytest.mark.parametrize(("m", "hold_s"), ZIGZAG_HOLDS)
def test_feed_hold_with_blends_stops_where_deceleration_and_blends_take_it(m, hold_s):
    """test_path_motion's hold on a zigzag with the blends on: the hold decelerates at
    each block's acceleration from the speed where it began (the end of what was final)
    and takes each corner it cannot stop before as a blend that slows down (hold_walk:
    the definitions) - here at the block's acceleration along the polyline, so the stop
    lies main's ``v^2 / (2 a)`` along it.  The stop within one step per axis of that
    point, each of the hold's blends at the speeds the definitions give, and every
    axis within its acceleration from the pins."""
    backend, engine, group, pins, dirs = blended(limits=LIMITS)
    tps = backend.profile.ticks_per_s
    pts = zigzag(m, 20000 // (4 * m))
    stream = Stream(backend, group, pts, 3000.0)
    assert stream.run(until=lambda: backend.now() >= int(hold_s * tps))
    group.hold()
    assert stream.run(until=lambda: group.state == PathState.HELD, limit_s=5)
    hs = group.hold_start
    assert hs is not None and hs.block is not None
    stop = [s.get_current_position() for s in group.steppers]
    steps = axis_steps(backend, pins, dirs)
    exp, along, bound, corners = hold_walk(pts, hs.block.start, hs.distance, hs.speed,
                                           LIMITS)
    for i in range(2):
        tk, xs = axis_motion(steps[i])
        assert abs(stop[i] - exp[i]) <= 1.0, (i, stop, exp, along, bound)
        assert xs[-1] == stop[i]
        a, at = edge_accel(tk, xs, tps, ACC_WINDOW_S)
        assert a <= LIMITS.acceleration * SPU + SLACK, (i, a / SPU, at / tps)
    held = [seg.b for _c, seg in group.blend_log if seg.t_start >= hs.tick]
    assert len(held) == len(corners) >= 1  # (these moments: the hold takes a corner)
    for b, (v_in, v_out) in zip(held, corners, strict=True):
        assert b.speed == pytest.approx(v_in, rel=1e-6)
        assert b.speed_out == pytest.approx(v_out, rel=1e-6)
    assert along == pytest.approx(bound)
    # the hold's start: where the pins were at its tick (the executor's point)
    u0 = [d / math.hypot(*hs.block.delta) for d in hs.block.delta]
    for i in range(2):
        tk, xs = axis_motion(steps[i])
        at = hs.block.start[i] + hs.distance * SPU * u0[i]
        assert abs(interp(tk, xs, hs.tick) - at) <= 1.0
    assert group.resume() == PathResult.OK
    assert stream.run(limit_s=60)
    assert [s.get_current_position() for s in group.steppers] == list(pts[-1])


def point_along(pts, block_start, distance, length, spu: float):
    """The point ``length`` (units) along the polyline from ``distance`` along the
    block from ``block_start`` (steps)."""
    verts = [(0, 0)] + list(pts)
    i = verts.index(tuple(block_start))
    s = distance + length
    while True:
        p, q = verts[i], verts[i + 1]
        n = math.hypot(*(b - a for a, b in zip(p, q, strict=True))) / spu
        if s <= n or i + 2 == len(verts):
            return [a + (b - a) * s / n for a, b in zip(p, q, strict=True)]
        s -= n
        i += 1


def test_feed_hold_with_blends_within_mains_deceleration_distance():
    """Main's bound with the blends on: the stop within one step per axis of the point
    v^2 / (2 a) along the polyline from where the hold began (1000-step legs, the hold
    at 0.55 s from 46.2 mm/s takes one corner: a blend that slows down)."""
    backend, engine, group, pins, dirs = blended(limits=LIMITS)
    tps = backend.profile.ticks_per_s
    pts = zigzag(250, 20)
    stream = Stream(backend, group, pts, 3000.0)
    assert stream.run(until=lambda: backend.now() >= int(0.55 * tps))
    group.hold()
    assert stream.run(until=lambda: group.state == PathState.HELD, limit_s=5)
    hs = group.hold_start
    assert hs is not None and hs.block is not None
    accel = limit_along(LIMITS.acceleration, hs.block.unit)
    d = hs.speed ** 2 / (2 * accel)
    exp = point_along(pts, hs.block.start, hs.distance, d, SPU)
    stop = [s.get_current_position() for s in group.steppers]
    assert all(abs(s - e) <= 1.0 for s, e in zip(stop, exp, strict=True)), (stop, exp)
