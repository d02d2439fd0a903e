"""Plain corners (PathSettings.plain_corner_steps, ``$173``): with corner blends on, a
corner whose blend no axis's step tells from Grbl's corner by more than the threshold
is written as Grbl's corner at the blend's clock (docs/path-planner.md, "Corners no
step can tell apart").  The lines of issue 25 that blend mode meets must keep
holding: within one step of the commanded path, every axis within its acceleration
from the pins (+ the grouping's 2 e / W^2, the tolerance near a plain corner shrunk
by its offset), the same clock as the blends."""

from __future__ import annotations

import math

import pytest

from fas.path import AxisLimits
from fas.path.blend import corner_blend, plain_offsets, zone_coefficient
from fas.path.executor import Executor
from fas.path.lookahead import Lookahead
from fas.path.settings import GROUP_TOLERANCE_STEPS, PLAIN_CORNER_STEPS, PathSettings
from rigs.path import (
    axes_edge_accel,
    axis_steps,
    commanded_deviation,
    feed_all,
    instants,
    make_group,
    path_as_run,
    timed_deviation,
)
from rigs.path import circles_of_chords as rig_circles

SPU = 80.0
BENCH_LIMITS = AxisLimits(SPU, 12000.0, 1000.0)  # issue 25's program figures
ACC_WINDOW_S = 0.02
SLACK = 2 * GROUP_TOLERANCE_STEPS / ACC_WINDOW_S ** 2  # the grouping's 2 e / W^2


def circles_of_chords(count: int) -> list[tuple[int, int]]:
    return rig_circles(count, SPU)


def run_circles(plain: float):
    backend, engine, group, pins, dirs = make_group(
        limits=BENCH_LIMITS, junction_deviation=0.01, corner_blends=True,
        plain_corner_steps=plain)
    pts = circles_of_chords(4)
    feed_all(backend, group, pts, 3000.0)
    return backend, group, pts, axis_steps(backend, pins, dirs)


@pytest.fixture(scope="module")
def both_runs():
    """The four circles of chords at $11 = 0.01 mm, blends only and with plain corners
    at 1/8 step."""
    return run_circles(0.0), run_circles(GROUP_TOLERANCE_STEPS)


def test_off_by_default_and_at_most_the_grouping_tolerance():
    assert PLAIN_CORNER_STEPS == 0.0
    axes = (BENCH_LIMITS, BENCH_LIMITS)
    assert PathSettings(axes=axes).plain_corner_steps == 0.0
    assert PathSettings(axes=axes, plain_corner_steps=GROUP_TOLERANCE_STEPS).problem(2) is None
    for bad in (-0.01, GROUP_TOLERANCE_STEPS + 0.001):
        p = PathSettings(axes=axes, plain_corner_steps=bad).problem(2)
        assert p is not None and "plain_corner_steps" in p


@pytest.mark.parametrize("turn_deg", [3, 20, 90, 150])
def test_offsets_are_the_largest_distance_per_axis_from_grbls_corner_at_its_clock(turn_deg):
    """plain_offsets against the blend sampled: the commanded corner at the blend's
    clock (the block in at v up to the corner, then the block out) minus the blend's
    position, per axis, largest over the blend - at its middle."""
    th = math.radians(turn_deg)
    u = (math.cos(0.3), math.sin(0.3))
    w = (math.cos(0.3 + th), math.sin(0.3 + th))
    acc = (1000.0, 700.0)
    spu = (80.0, 100.0)
    v = 25.0
    b = corner_blend(u, w, v, acc)
    assert b is not None
    worst = [0.0, 0.0]
    for j in range(2001):
        t = b.duration * j / 2000
        p = b.position(t)
        s = v * t - b.reach  # the commanded point's distance from the corner
        poly = [s * (u if s <= 0 else w)[i] for i in range(2)]
        for i in range(2):
            worst[i] = max(worst[i], abs(poly[i] - p[i]) * spu[i])
    got = plain_offsets(u, w, zone_coefficient(u, w, acc), v * v, spu, math.inf)
    assert got is not None
    assert got == pytest.approx(worst, rel=1e-6)
    assert plain_offsets(u, w, zone_coefficient(u, w, acc), v * v, spu,
                         0.999 * max(worst)) is None


def test_the_tolerance_shrinks_by_the_offset_near_a_plain_corner_only():
    """Executor.tolerance_near: steps whose ticks meet a plain corner's blend time,
    widened by TURN_EXACT_S (20 ms) on both sides, group within tol - offset."""
    la = Lookahead((BENCH_LIMITS, BENCH_LIMITS), 0.01, 32, blend_share=0.5)
    ex = Executor(la, 16_000_000)
    ex.note_plain(1_000_000.0, 1_100_000.0, (0.05, 0.1))
    tol = GROUP_TOLERANCE_STEPS
    assert ex.tolerance_near(0, 0, 100_000, tol) == tol  # more than 20 ms before
    assert ex.tolerance_near(0, 0, 700_000, tol) == pytest.approx(tol - 0.05)
    assert ex.tolerance_near(1, 1_050_000, 1_060_000, tol) == pytest.approx(tol - 0.1)
    assert ex.tolerance_near(1, 1_400_000, 1_500_000, tol) == pytest.approx(tol - 0.1)
    assert ex.tolerance_near(1, 1_430_000, 1_500_000, tol) == tol  # more than 20 ms after
    assert ex.tolerance_near(1, 1_050_000, 1_060_000, 0.0) == 0.0  # never below 0


def test_most_corners_are_plain_and_the_clock_is_the_blends(both_runs):
    """490 corners blended without; at 1/8 step 430 of them are plain and 60 stay
    blends (every turning corner is one or the other), and the motion keeps the blends'
    clock: each axis's last step on the same tick."""
    (b0, g0, pts, s0), (b1, g1, _pts, s1) = both_runs
    plain = g1.executor.plain_log
    assert len(g0.blend_log) == 490 and g0.executor.plain_log == []
    assert len(plain) + len(g1.blend_log) == len(g0.blend_log)
    assert (len(plain), len(g1.blend_log)) == (430, 60)
    assert [s[-1][0] for s in s1] == [s[-1][0] for s in s0]
    assert [s.get_current_position() for s in g1.steppers] == list(pts[-1])


def test_with_plain_corners_within_one_step_of_the_commanded_path(both_runs):
    """Issue 25's 1-step line on the circles: 1.000 with blends only, 0.970 with the
    plain corners (Grbl's corner is the commanded path itself)."""
    _r0, (backend, group, pts, steps) = both_runs
    ins = instants(steps, (0, 0))
    tps = backend.profile.ticks_per_s
    verts = [(0, 0)] + pts
    plain = group.executor.plain_log
    assert commanded_deviation(ins, verts, group.blend_log, int(0.02 * tps), plain) <= 1.0
    path = path_as_run(verts, group.blend_log, ins, (SPU, SPU), plain=plain)
    assert timed_deviation(ins, path, int(0.02 * tps)) <= 1.0


def test_with_plain_corners_every_axis_within_its_acceleration_from_the_pins(both_runs):
    """The acceleration line with the plain corners: a plain corner's steps are up to
    its offset from the blend's, and near it grouping keeps within 1/8 step minus that
    offset, so the divided difference over step edges >= 20 ms apart stays within
    the limit + 2 e / W^2 (Y 1002.6 mm/s^2; 1001.6 with blends only)."""
    _r0, (backend, _group, _pts, steps) = both_runs
    tps = backend.profile.ticks_per_s
    for i, (a, at) in enumerate(axes_edge_accel(steps[:2], tps, ACC_WINDOW_S)):
        assert a <= BENCH_LIMITS.acceleration * SPU + SLACK, (i, a / SPU, at / tps)
        assert a > 0.5 * BENCH_LIMITS.acceleration * SPU  # it measures something


@pytest.mark.parametrize("seed", [3, 5])
def test_holds_and_resumes_at_random_moments_with_plain_corners(seed):
    """test_path_blends' random holds with plain corners at 1/8 step: a hold never
    takes a corner plain (its corner slows down: a blend of its own), a plain corner
    made final before the hold keeps its constant-speed piece into the block out; the
    path ends exactly at its end, every step within one step of the path as run (with
    each hold's stop point) and within $11 + 1 step of the commanded polyline."""
    import random

    from rigs.path import random_path, run_with_random_holds

    limits = AxisLimits(SPU, 6000.0, 500.0)
    rnd = random.Random(seed)
    backend, engine, group, pins, dirs = make_group(
        limits=limits, junction_deviation=0.02, queue_blocks=8, corner_blends=True,
        plain_corner_steps=GROUP_TOLERANCE_STEPS)
    pts = random_path(rnd)
    stops = run_with_random_holds(backend, group, pts, rnd)
    assert len(stops) > 20
    ins = instants(axis_steps(backend, pins, dirs), (0, 0))
    assert ins[-1][1] == pts[-1]
    verts = [(0, 0)] + [p for k, p in enumerate(pts) if k == 0 or p != pts[k - 1]]
    plain = group.executor.plain_log
    assert plain and group.blend_log
    path = sorted(path_as_run(verts, group.blend_log, ins, (SPU, SPU), plain=plain)
                  + [(t, tuple(float(c) for c in p)) for t, p in stops])
    assert timed_deviation(ins, path, int(0.02 * group.tps)) <= 1.0
    dev = commanded_deviation(ins, verts, group.blend_log, int(0.02 * group.tps), plain)
    assert dev <= 0.02 * SPU + 1.0, dev
