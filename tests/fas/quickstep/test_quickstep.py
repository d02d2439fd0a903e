"""QuickStep (fas.quickstep): base time, plateaus, the FIFO, the timer-2 channel."""

from __future__ import annotations

from collections import Counter
from math import sqrt

import pytest

from fas import Engine, MoveResult
from fas.arch import get_profile
from fas.backend import Backend
from fas.quickstep.clock import QsConfigResult
from fas.quickstep.figures import quickstep_figures
from fas.quickstep.planner import QsMoveResult
from fas.quickstep.plateaus import (
    ACCELERATE,
    COAST,
    DECELERATE,
    MAX_ORDER_STEPS,
    plan_move,
)
from fas.quickstep.setup import clock_of, quickstep_of
from fas.quickstep.timebase import INTERVAL_MAX, INTERVAL_MIN, choose
from fas.sim import SimBackend
from fas.stepper import PLANNER_FAS, PLANNER_QUICKSTEP
from stepperdemo.demo.build import demo_build

TPS = 16_000_000
P328 = get_profile("atmega328p")
TIMER2 = quickstep_figures(P328).timer()


def _setup(arch="atmega328p", depth=32, plateaus=8, speed_us=100, accel=1000, relay=False,
           record=True):
    b = SimBackend(arch, record=record)
    if relay:  # the default of Backend: orders relayed into FastAccelStepper's queue
        b.allocate_order_channel = lambda q, fq, c: Backend.allocate_order_channel(b, q, fq, c)
    e = Engine(b)
    e.init()
    s = e.stepper_connect_to_pin(demo_build(b.profile).steppers[0].step)
    s.set_direction_pin(demo_build(b.profile).steppers[0].direction)
    s.set_speed_in_us(speed_us)
    s.set_acceleration(accel)
    assert s.set_planner(PLANNER_QUICKSTEP, depth, plateaus) == QsConfigResult.OK
    return b, e, s


def _periods(b, pin=9):
    r = b.recorder.rising(pin)
    return [y - x for x, y in zip(r, r[1:], strict=False)]


# ------------------------------------------------------------------ base time
def test_base_time_range_of_timer2_is_12us_to_16ms():
    lo = choose(P328, TIMER2, 1)
    assert (lo.prescaler, lo.top_counts, lo.base_ticks) == (1, 192, 192)  # 12 us
    hi = choose(P328, TIMER2, 10**9)
    assert (hi.prescaler, hi.top_counts, hi.base_ticks) == (1024, 256, 262144)  # 16.384 ms


def test_base_time_takes_the_finest_prescaler():
    tb = choose(P328, TIMER2, 1600)  # 100 us
    assert (tb.prescaler, tb.top_counts) == (8, 200)


def test_16_bit_timer_reaches_4_seconds():
    mega = get_profile("atmega2560")
    tb = choose(mega, quickstep_figures(mega).timer(3), 10**12)
    assert tb.base_ticks == 1024 * 65536  # 4.19 s


def test_intervals_are_clamped_to_1_to_255_base_times():
    tb = choose(P328, TIMER2, 1600)
    assert tb.interval_256(10) == INTERVAL_MIN
    assert tb.interval_256(10**9) == INTERVAL_MAX
    assert tb.period_ticks(INTERVAL_MIN) == 1600
    assert tb.period_ticks(INTERVAL_MAX) == 255 * 1600
    assert tb.period_ticks(384) == 2400  # 1.5 base times, whole timer counts


# ------------------------------------------------------------------- plateaus
def test_long_move_plateaus_follow_vmax_sqrt_k_over_n():
    plan = plan_move(TPS, 120000, 1600, 1000, 8)  # VMAX 10000 steps/s reachable
    assert plan.top_period_ticks == 1600
    acc = [p for p in plan.plateaus if p.phase == ACCELERATE]
    dec = [p for p in plan.plateaus if p.phase == DECELERATE]
    assert len(acc) == len(dec) == 8 and len(plan.plateaus) == 17  # A + D + 1
    for p in acc:
        assert TPS / p.period_ticks == pytest.approx(10000 * sqrt(p.level / 8), rel=1e-3)
    assert {p.steps for p in acc + dec} == {6250}  # VMAX^2 / (2 a N)
    assert plan.steps == 120000


def test_short_move_tops_out_where_the_acceleration_allows():
    plan = plan_move(TPS, 3200, 1600, 1000, 8)
    assert TPS / plan.top_period_ticks == pytest.approx(sqrt(1000 * 3200), rel=1e-3)
    assert plan.steps == 3200
    assert [p.level for p in plan.plateaus] == list(range(1, 9)) + [8] + list(range(8, 0, -1))


def test_tiny_moves_use_fewer_plateaus_one_step_each():
    plan = plan_move(TPS, 5, 1600, 10**6, 8)
    assert plan.steps == 5
    assert all(p.steps >= 1 for p in plan.plateaus)


def test_cruise_longer_than_an_int16_is_split():
    plan = plan_move(TPS, 100000, 1600, 10**6, 2)
    coast = [p for p in plan.plateaus if p.phase == COAST]
    assert len(coast) == 4 and max(p.steps for p in coast) == MAX_ORDER_STEPS


# --------------------------------------------------------------- on the chip
def test_move_3200_with_8_plateaus_has_8_step_periods():
    b, _, s = _setup()
    assert s.move(3200) == MoveResult.OK
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 3200
    periods = Counter(_periods(b))
    assert len(periods) == 8
    top = TPS / min(periods)
    assert top == pytest.approx(sqrt(1000 * 3200), rel=2e-3)
    assert TPS / max(periods) == pytest.approx(top * sqrt(1 / 8), rel=2e-3)


def test_non_blocking_move_reports_full_and_queues_nothing():
    b, _, s = _setup(depth=8, plateaus=8)
    qs = quickstep_of(s)
    assert qs.move(3200, wait=False) == QsMoveResult.FIFO_FULL
    assert s.queue_entries() == 0 and not s.is_running()
    assert qs.start_move(3200) == MoveResult.OK
    assert s.queue_entries() == 8 and qs.pending_orders() == 9
    b.wait_until(lambda: qs.pending_orders() == 0)
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 3200


def test_blocking_move_returns_when_the_last_order_is_queued():
    b, _, s = _setup(depth=4, plateaus=8)
    t0 = b.now()
    assert s.move(3200) == MoveResult.OK
    assert b.now() > t0  # it waited for room
    assert quickstep_of(s).pending_orders() == 0
    assert s.target_pos() == 3200
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 3200


def test_depth_one_stops_between_orders_depth_twenty_does_not():
    starts = {}
    for depth in (1, 20):
        b, _, s = _setup(depth=depth, plateaus=4, speed_us=250, accel=20000)
        for _ in range(3):
            s.move(400)
        b.wait_until(lambda s=s: not s.is_running())
        assert s.get_current_position() == 1200
        starts[depth] = s.queue.channel.starts
    assert starts[20] == 1
    assert starts[1] == 27  # every one of 3 x 9 orders starts from rest


def test_stop_decelerates_through_the_plateaus_below():
    b, _, s = _setup(plateaus=4, speed_us=200, accel=4000)
    assert s.run_forward() == MoveResult.OK
    b.run_for(2 * TPS)
    assert s.is_running_continuously()
    pos = s.get_current_position()
    s.stop_move()
    b.wait_until(lambda: not s.is_running())
    # top 5000 steps/s, plateau length 5000^2 / (2 * 4000 * 4) = 781 steps
    assert 3 * 781 < s.get_current_position() - pos <= 4 * 781 + 1


def test_force_stop_and_new_position():
    b, _, s = _setup()
    s.move(100000)
    b.run_for(TPS)
    s.force_stop_and_new_position(7)
    assert not s.is_running()
    assert s.get_current_position() == 7
    assert s.move(10) == MoveResult.OK
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 17


def test_settings_refused_while_running_or_beyond_ram():
    b, e, s = _setup(depth=200)
    s2 = e.stepper_connect_to_pin(10)
    assert s2.set_planner(PLANNER_QUICKSTEP, 100) == QsConfigResult.RAM  # 1200 > 1024 B
    assert s2.set_planner(PLANNER_QUICKSTEP, 56) == QsConfigResult.OK  # 1024 B
    assert s.set_planner(PLANNER_QUICKSTEP, 0) == QsConfigResult.DEPTH_OUT_OF_RANGE
    assert s.set_planner(PLANNER_QUICKSTEP, None, 256) == QsConfigResult.PLATEAUS_OUT_OF_RANGE
    s.move(1000)
    assert s.set_planner(PLANNER_FAS) == QsConfigResult.RUNNING
    assert clock_of(e).set_base(50) == QsConfigResult.RUNNING
    assert clock_of(e).set_base(5) == QsConfigResult.BASE_OUT_OF_RANGE
    b.wait_until(lambda: not s.is_running())
    assert s.set_planner(PLANNER_FAS) == QsConfigResult.OK
    assert s.get_current_position() == 1000
    s.move(-1000)
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 0


def test_quickstep_is_not_available_without_a_timer():
    b = SimBackend("esp32")
    e = Engine(b)
    e.init()
    s = e.stepper_connect_to_pin(17)
    assert s.set_planner(PLANNER_QUICKSTEP) == QsConfigResult.NOT_AVAILABLE
    assert quickstep_of(s) is None


def test_speed_beyond_the_timer_runs_at_the_nearest_allowed():
    b, e, s = _setup(plateaus=1, speed_us=100, accel=10**7)
    clock_of(e).set_base(1000)  # 1 ms: the fastest interval is 1 ms
    s.move(20)
    b.wait_until(lambda: not s.is_running())
    assert set(_periods(b)) == {16000}


def test_timer_interrupt_costs_cpu_per_base_period():
    b, e, s = _setup(plateaus=1, speed_us=100)
    s.move(1000)
    b.run_for(1000)  # the order has started
    load = s.queue.channel.load  # the timer's load on the machine
    p = quickstep_figures(P328)
    assert load.block_cpu_between(b.now(), b.now() + 16000) == \
        10 * (p.period_isr_ticks + p.motor_isr_ticks)


def test_blocked_interrupts_lose_period_interrupts_of_a_fast_base():
    b, e, s = _setup(plateaus=1, speed_us=1000, accel=10**7)
    clock_of(e).set_base(20)  # 20 us: a 100 us block swallows 4 period interrupts
    s.move(50)
    b.run_for(10 * 16000 + 2000)  # between two steps
    before = s.get_current_position()
    b.machine.block_interrupts(1600)
    b.wait_until(lambda: not s.is_running())
    ch = s.queue.channel
    assert ch.lost_periods >= 4
    assert s.get_current_position() == 50 and before < 50
    assert max(_periods(b)) == 16000 + ch.lost_periods * 320


def test_relay_runs_the_same_orders_through_fastaccelstepper_queue():
    b, _, s = _setup(relay=True)
    s.move(3200)
    b.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 3200
    assert len(Counter(_periods(b))) == 8
