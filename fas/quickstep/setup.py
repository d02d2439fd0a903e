"""Switching a stepper between FastAccelStepper's ramp and QuickStep, with the checks
the seed asks for: a QuickStep timer on the profile, FIFO depth 1 .. 255, plateaus
1 .. 255, and all FIFOs together within the RAM the profile leaves for them."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .clock import QsConfigResult, QuickStepClock
from .orders import MAX_DEPTH, MIN_DEPTH, OrderQueue
from .planner import DEFAULT_DEPTH, DEFAULT_PLATEAUS, MAX_PLATEAUS, QuickStepPlanner

if TYPE_CHECKING:  # pragma: no cover
    from ..engine import Engine
    from ..stepper import Stepper


def clock_of(engine: Engine) -> QuickStepClock:
    if engine.quickstep_clock is None:
        engine.quickstep_clock = QuickStepClock(engine.profile)
    return engine.quickstep_clock


def check(stepper: Stepper, depth: int | None, plateaus: int | None) -> QsConfigResult:
    """Would QuickStep with these figures be accepted for ``stepper``?"""
    engine = stepper._engine
    clock = clock_of(engine)
    if clock.timer is None:
        return QsConfigResult.NOT_AVAILABLE
    if engine.outputs.pwm_uses_timer(f"timer {clock.timer.number}"):
        return QsConfigResult.TIMER_IN_USE
    if depth is not None and not MIN_DEPTH <= depth <= MAX_DEPTH:
        return QsConfigResult.DEPTH_OUT_OF_RANGE
    if plateaus is not None and not 1 <= plateaus <= MAX_PLATEAUS:
        return QsConfigResult.PLATEAUS_OUT_OF_RANGE
    qs = stepper.quickstep
    new_depth = depth if depth is not None else (qs.depth if qs else DEFAULT_DEPTH)
    if not clock.fits(new_depth, without=qs):
        return QsConfigResult.RAM
    if stepper.is_running():
        return QsConfigResult.RUNNING
    return QsConfigResult.OK


def select(stepper: Stepper, planner: int, depth: int | None,
           plateaus: int | None) -> QsConfigResult:
    from ..stepper import PLANNER_FAS
    engine = stepper._engine
    qs = stepper.quickstep
    if planner == PLANNER_FAS:
        if qs is None:
            return QsConfigResult.OK
        if stepper.is_running():
            return QsConfigResult.RUNNING
        _switch_queue(stepper, stepper._fas_queue)
        clock_of(engine).planners.remove(qs)
        stepper._qs = None
        return QsConfigResult.OK
    res = check(stepper, depth, plateaus)
    if res != QsConfigResult.OK:
        return res
    clock = clock_of(engine)
    if qs is not None:
        if plateaus is not None:
            qs.plateaus = plateaus
        if depth is not None and depth != qs.depth:
            qs.queue.depth = depth
        return QsConfigResult.OK
    fas_q = stepper._fas_queue
    backend = engine.backend
    queue = OrderQueue(fas_q.index, engine.profile, backend, fas_q.step_pin,
                       depth if depth is not None else DEFAULT_DEPTH,
                       lambda q: backend.allocate_order_channel(q, fas_q, clock))
    planner_obj = QuickStepPlanner(stepper, clock, queue,
                                   plateaus if plateaus is not None else DEFAULT_PLATEAUS)
    _switch_queue(stepper, queue)
    clock.planners.append(planner_obj)
    stepper._qs = planner_obj
    return QsConfigResult.OK


def _switch_queue(stepper: Stepper, new) -> None:
    """Hand position, direction pin and counters over to the other queue."""
    old = stepper._queue
    if old is new:
        return
    old.channel.sync()
    new.queue_end_pos = old.queue_end_pos
    new.queue_end_count_up = old.queue_end_count_up
    new.queue_end_dir = old.queue_end_dir
    new.dir_pin = old.dir_pin
    new.dir_high_counts_up = old.dir_high_counts_up
    counter = getattr(old.channel, "pulse_counter", None)
    if counter is not None and hasattr(new.channel, "pulse_counter"):
        new.channel.pulse_counter = counter
    new.channel.detached = getattr(old.channel, "detached", False)
    new.channel.sync()
    stepper._queue = new
    stepper._rg.set_target_position(new.queue_end_pos)
