"""The look-ahead queue (fas.path.lookahead): block figures, junction speeds by
junction deviation, the reverse and forward passes and the planned pointer.

The expected figures are worked out here from Grbl's definitions (planner.c), not
taken from the code under test."""

from __future__ import annotations

import math
import random

import pytest

from fas.path.lookahead import BIG, Lookahead
from fas.path.settings import AxisLimits

SPU = 80.0
ACC = 500.0


def la(size: int = 16, deviation: float = 0.05, limits: tuple[AxisLimits, ...] | None = None
       ) -> Lookahead:
    limits = limits or (AxisLimits(SPU, 6000.0, ACC),) * 2
    return Lookahead(limits, deviation, size)


def queue(q: Lookahead, points, feed: float | None = 3000.0) -> None:
    pos = tuple(0 for _ in points[0])
    for p in points:
        b = q.make_block(pos, tuple(t - s for t, s in zip(p, pos, strict=True)), feed, None)
        assert b is not None
        q.add(b)
        pos = tuple(p)


def test_block_figures_limit_each_axis_along_the_line():
    limits = (AxisLimits(80.0, 6000.0, 500.0), AxisLimits(100.0, 1200.0, 100.0))
    q = la(limits=limits)
    b = q.make_block((0, 0), (800, 1000), None, "tag")  # 10 mm by 10 mm
    assert b is not None
    assert b.length == pytest.approx(math.hypot(10, 10))
    u = 1 / math.sqrt(2)
    assert b.unit == pytest.approx((u, u))
    assert b.acceleration == pytest.approx(100.0 / u)  # Y's 100 mm/s^2 along the line
    assert b.rapid_rate == pytest.approx(20.0 / u)  # Y's 1200 mm/min = 20 mm/s
    assert b.nominal_speed == b.rapid_rate  # G0: the rapid rate
    slow = q.make_block((0, 0), (800, 1000), 600.0, None)
    assert slow is not None and slow.nominal_speed == pytest.approx(10.0)  # F600
    assert q.make_block((5, 5), (0, 0), 600.0, None) is None  # no length


def junction_expected(u1, u2, accel_per_axis: float, deviation: float) -> float:
    """Grbl's junction speed^2, written out independently."""
    dot = sum(a * b for a, b in zip(u1, u2, strict=True))
    cos_theta = -dot
    sin_half = math.sqrt((1 - cos_theta) / 2)
    bis = [b - a for a, b in zip(u1, u2, strict=True)]
    n = math.hypot(*bis)
    a_j = min(accel_per_axis / abs(v / n) for v in bis if v)
    return a_j * deviation * sin_half / (1 - sin_half)


@pytest.mark.parametrize("turn_deg", [10, 45, 90, 135, 170])
def test_junction_speed_follows_junction_deviation(turn_deg):
    q = la(deviation=0.05)
    phi = math.radians(turn_deg)
    u1 = (1.0, 0.0)
    u2 = (math.cos(phi), math.sin(phi))
    assert q.junction_sqr(u1, u2) == pytest.approx(junction_expected(u1, u2, ACC, 0.05))


def test_straight_on_is_unlimited_and_a_reversal_stops():
    q = la()
    assert q.junction_sqr((0.6, 0.8), (0.6, 0.8)) == BIG
    assert q.junction_sqr((0.6, 0.8), (-0.6, -0.8)) == 0.0


def test_first_block_starts_from_rest_and_the_last_stops():
    q = la()
    queue(q, [(800, 0)])
    assert q.blocks[0].max_junction_sqr == 0.0
    assert q.blocks[0].entry_sqr == 0.0
    assert q.exit_sqr() == 0.0


def test_passes_plan_the_textbook_profile():
    """Three collinear 1 mm blocks at F6000 (100 mm/s), 500 mm/s^2: each entry is the
    largest that the blocks after it can still stop from (reverse pass) and that
    acceleration from rest reaches (forward pass)."""
    q = la()
    queue(q, [(80, 0), (160, 0), (240, 0)], feed=6000.0)
    e = [math.sqrt(b.entry_sqr) for b in q.blocks]
    # reverse: the last enters at sqrt(2 a 1mm) = 31.6, the middle at sqrt(2 a 2mm);
    # forward: from rest, block 1 reaches sqrt(2 a 1mm) at its end - the lower wins
    assert e[0] == 0.0
    assert e[1] == pytest.approx(math.sqrt(2 * ACC * 1.0))
    assert e[2] == pytest.approx(math.sqrt(2 * ACC * 1.0))


def test_a_longer_queue_raises_the_junctions():
    q = la(deviation=0.05)
    queue(q, [(80 * k, 0) for k in range(1, 4)], feed=3000.0)
    before = [b.entry_sqr for b in q.blocks]
    b = q.make_block((240, 0), (80, 0), 3000.0, None)
    assert b is not None
    q.add(b)
    after = [x.entry_sqr for x in q.blocks]
    assert after[2] > before[2]  # the block that had to stop may now go on
    assert after[:2] == pytest.approx(before[:2]) or after[1] >= before[1]


def full_plan(q: Lookahead) -> list[float]:
    """The plan recomputed from scratch: the same blocks, both passes over all."""
    fresh = Lookahead(tuple(AxisLimits(s, r * 60, a) for s, r, a
                            in zip(q.spu, q.max_rate, q.accel, strict=True)),
                      q.junction_deviation, q.size)
    for b in q.blocks:
        fresh.blocks.append(b)  # same junction limits as planned
    saved = [b.entry_sqr for b in q.blocks]
    for b in fresh.blocks[1:]:
        b.entry_sqr = 0.0
    fresh.planned = 0
    fresh.recalculate()
    planned = [b.entry_sqr for b in fresh.blocks]
    for b, e in zip(q.blocks, saved, strict=True):
        b.entry_sqr = e
    return planned


@pytest.mark.parametrize("seed", range(6))
def test_incremental_planning_equals_planning_everything_again(seed):
    """The planned pointer only skips blocks whose plan cannot change: after every
    block queued (and blocks taken from the front), the incremental plan equals the
    plan computed again over the whole queue."""
    rnd = random.Random(seed)
    q = la(size=12, deviation=rnd.choice([0.01, 0.05, 0.2]))
    pos = (0, 0)
    for _ in range(200):
        step = rnd.choice([3, 20, 80, 400])
        target = (pos[0] + rnd.randint(-step, step), pos[1] + rnd.randint(-step, step))
        b = q.make_block(pos, (target[0] - pos[0], target[1] - pos[1]),
                         rnd.choice([600.0, 3000.0, 6000.0, None]), None)
        if b is None:
            continue
        if q.full():
            q.pop_first()
        q.add(b)
        pos = target
        incremental = [x.entry_sqr for x in q.blocks]
        assert incremental == pytest.approx(full_plan(q), rel=1e-9, abs=1e-9)
        for x in q.blocks:
            assert x.entry_sqr <= x.max_entry_sqr + 1e-9
    assert q.pass_steps < 200 * 2 * q.size  # the pointer saved work


def test_every_plan_can_stop_and_accelerate_within_its_blocks():
    rnd = random.Random(7)
    q = la(size=32, deviation=0.02)
    pos = (0, 0)
    for _ in range(100):
        t = (pos[0] + rnd.randint(-50, 50), pos[1] + rnd.randint(-50, 50))
        b = q.make_block(pos, (t[0] - pos[0], t[1] - pos[1]), 3000.0, None)
        if b is not None:
            if q.full():
                q.pop_first()
            q.add(b)
            pos = t
    blocks = q.blocks
    exits = [x.entry_sqr for x in blocks[1:]] + [0.0]
    for b, exit_sqr in zip(blocks, exits, strict=True):
        reach = 2 * b.acceleration * b.remaining
        assert exit_sqr <= b.entry_sqr + reach + 1e-6  # reachable accelerating
        assert b.entry_sqr <= exit_sqr + reach + 1e-6  # can slow down in time
