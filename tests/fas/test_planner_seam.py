"""The planner seam (fas.planner, fas.planners): a new planner is one module and one
registry entry.  The module here is :class:`ConstantRate` - every step at the
stepper's speed, no ramp - which drives a stepper on the simulated chip."""

from __future__ import annotations

import pytest

from fas import MoveResult, planners
from fas.codes import RAMP_DIRECTION_COUNT_DOWN, RAMP_DIRECTION_COUNT_UP, AqeResult, RampState
from fas.outputs import OutputResult
from fas.planner import Planner, PlannerChange, PlannerHost
from fas.quickstep.clock import QsConfigResult
from fas.quickstep.setup import clock_of, quickstep_of
from fas.ramp.planner import RampPlanner
from rigs.sim import make, periods, pin_position, rising, run_until_idle

STEP, DIR = 9, 5


# ------------------------------------------------------- a planner of the tests
class ConstantRate(Planner):
    """Steps at the stepper's speed from the first step to the last (no ramp), in
    commands of up to 255 steps, planned ahead as far as the stepper asks."""

    def __init__(self, host: PlannerHost) -> None:
        super().__init__(host)
        self.queue = host.queue
        self.left = 0  # signed steps still to plan

    def _period(self) -> int:
        return self.host.settings.min_travel_ticks

    def check_move(self, delta: int) -> MoveResult:
        if delta < 0 and not self.host.has_direction_pin():
            return MoveResult.ERR_NO_DIRECTION_PIN
        return MoveResult.OK

    def move(self, delta: int) -> MoveResult:
        if self._period() <= 0:
            return MoveResult.ERR_SPEED_IS_UNDEFINED
        self.left += delta
        self.host.wake()
        return MoveResult.OK

    def move_to(self, position: int) -> MoveResult:
        return self.move(position - self.target_pos())

    def run(self, count_up: bool) -> MoveResult:
        return self.move(10**9 if count_up else -10**9)

    def keep_running(self) -> None:
        pass

    def keep_speed(self) -> None:
        pass

    def stop(self) -> None:
        self.left = 0

    def force_stop(self) -> None:
        self.left = 0
        self.queue.force_stop()

    def force_stop_at(self, position: int) -> None:
        self.force_stop()
        self.queue.queue_end_pos = position

    def single_step(self, count_up: bool) -> None:
        self.move(1 if count_up else -1)

    def fill(self) -> int:
        q = self.queue
        written = 0
        while (self.left and q.queue_entries() < q.queue_len - 1
               and q.ticks_in_queue() < self.host.settings.forward_planning_ticks):
            n = min(abs(self.left), 255)
            up = self.left > 0
            if self.host.write(self._period(), n, up, True) != AqeResult.OK:
                break
            self.left -= n if up else -n
            written += 1
        return written

    def is_running(self) -> bool:
        q = self.queue
        return q.is_running() or self.left != 0 or not q.is_queue_empty()

    def is_active(self) -> bool:
        return self.left != 0

    def ramp_state(self) -> int:
        if not self.left:
            return int(RampState.IDLE)
        up = RAMP_DIRECTION_COUNT_UP if self.left > 0 else RAMP_DIRECTION_COUNT_DOWN
        return int(RampState.COAST) | up

    def target_pos(self) -> int:
        return self.queue.queue_end_pos + self.left

    def steps_to_stop(self) -> int:
        return 0

    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        valid, ticks, up = self.queue.actual_ticks_with_direction()
        return (ticks, up) if valid else (0, True)

    def planned_period_ticks(self) -> int:
        return self._period() if self.left else 0

    def current_acceleration(self) -> int:
        return 0

    def fastest_period_ticks(self) -> int:
        return self.queue.max_speed_in_ticks

    def needs_task(self) -> bool:
        return self.is_running()


def make_constant(host: PlannerHost, current: Planner, kept: Planner | None
                  ) -> tuple[PlannerChange, Planner | None]:
    if isinstance(current, ConstantRate):
        return PlannerChange.OK, None
    if current.is_running():
        return PlannerChange.RUNNING, None
    return PlannerChange.OK, ConstantRate(host)


@pytest.fixture
def constant():
    planners.register("constant", make_constant)  # the one registry entry
    yield "constant"
    planners.unregister("constant")


# ----------------------------------------------------------------------- tests
def test_a_registered_planner_drives_a_stepper_at_one_rate(constant):
    b, _, s = make(enable_pin=None, auto_enable=False)
    s.set_speed_in_us(200)  # 3200 ticks
    assert s.set_planner(constant) == PlannerChange.OK
    assert s.planner_name == "constant" and isinstance(s.planner, ConstantRate)
    t0 = b.now()
    assert s.move(1000) == MoveResult.OK
    assert s.is_running() and s.target_pos() == 1000
    run_until_idle(b, s)
    edges = rising(b, STEP)
    assert len(edges) == 1000 and s.get_current_position() == 1000
    assert set(periods(edges)) == {3200}  # no ramp: every step at the speed
    assert edges[-1] - edges[0] == 999 * 3200
    task = b.profile.fill_period_ticks  # the first run of the periodic task starts it
    assert t0 + task < edges[0] < t0 + 2 * task
    assert pin_position(b, STEP, DIR) == 1000
    assert s.move_to(-200) == MoveResult.OK  # backwards, through the direction pin
    run_until_idle(b, s)
    assert s.get_current_position() == -200 == pin_position(b, STEP, DIR)
    assert set(periods(rising(b, STEP)[1000:])) == {3200}


def test_swapping_planners_returns_the_old_one_and_carries_position_and_direction(constant):
    b, _, s = make(enable_pin=None, auto_enable=False)
    s.set_speed_in_us(100)
    s.set_acceleration(10000)
    ramp = s.planner
    assert isinstance(ramp, RampPlanner)
    s.move(-500)
    run_until_idle(b, s)
    assert s.set_planner(constant) == 0
    assert s.get_current_position() == -500 and s.target_pos() == -500
    s.move(300)
    assert s.set_planner(planners.PLANNER_FAS) == PlannerChange.RUNNING  # it moves
    run_until_idle(b, s)
    assert s.set_planner(planners.PLANNER_FAS) == 0
    assert s.planner is ramp  # the ramp it had, resumed
    assert s.target_pos() == -200  # it takes over where the queue ends
    mine = ConstantRate(ramp.host)
    assert s.use_planner(mine) is ramp and s.planner is mine
    assert s.planner_name == "ConstantRate"  # (not made through the registry)
    assert s.use_planner(ramp) is mine and s.planner_name == planners.PLANNER_FAS
    s.move(-200)  # the ramp plans from where the constant rate stopped
    run_until_idle(b, s)
    assert s.get_current_position() == -400 == pin_position(b, STEP, DIR)


def test_unknown_planner_names_are_refused_with_the_known_ones():
    _, _, s = make()
    with pytest.raises(ValueError, match="no planner named 'nope'.*quickstep.*ramp"):
        s.set_planner("nope")
    with pytest.raises(ValueError):
        planners.unregister(planners.PLANNER_FAS)
    assert {"ramp", "quickstep", "gear"} <= set(planners.names())


def test_quickstep_swaps_its_own_queue_in_and_out():
    b, e, s = make("atmega328p", enable_pin=None, auto_enable=False)
    s.set_speed_in_us(200)
    s.set_acceleration(20000)
    s.move(-100)
    run_until_idle(b, s)
    commands = s.queue
    assert s.set_planner(planners.PLANNER_QUICKSTEP, 8, 4) == 0
    qs = quickstep_of(s)
    assert qs is not None and s.queue is qs.queue is not commands
    assert qs.queue.dir_pin == DIR and qs.queue.queue_end_pos == -100
    assert s.add_queue_entry(3200, 1) == AqeResult.QUEUE_FULL  # its FIFO holds orders
    assert clock_of(e).planners == [qs]
    assert e.allocator.timer_users("timer 2") == {"quickstep"}
    s.move(300)
    run_until_idle(b, s)
    assert s.get_current_position() == 200 == pin_position(b, STEP, DIR)
    assert s.set_planner(planners.PLANNER_FAS) == 0
    assert s.queue is commands and commands.queue_end_pos == 200
    assert clock_of(e).planners == [] and e.allocator.timer_users("timer 2") == set()
    s.move(-50)
    run_until_idle(b, s)
    assert s.get_current_position() == 150 == pin_position(b, STEP, DIR)


def test_one_allocator_books_timer_2_for_pwm_or_quickstep():
    """ATmega328P: Aout0 (pin 3), Aout1 (pin 11) and QuickStep share timer 2; whoever
    comes first has it, the other is refused until it is given back (QuickStep by
    ``l0``, a PWM output by moving to a pin of another timer)."""
    _, e, s = make(dir_pin=4, enable_pin=None, auto_enable=False)
    book = e.allocator
    assert e.outputs.analog(0, 50, synchronized=False) == OutputResult.OK
    assert e.outputs.analog(1, 20, synchronized=False) == OutputResult.OK
    assert book.timer_users("timer 2") == {"pwm"}
    assert s.set_planner(planners.PLANNER_QUICKSTEP) == QsConfigResult.TIMER_IN_USE
    assert quickstep_of(s) is None
    assert e.outputs.set_analog_pin(0, 6) == OutputResult.OK  # timer 0
    assert s.set_planner(planners.PLANNER_QUICKSTEP) == QsConfigResult.TIMER_IN_USE
    assert e.outputs.set_analog_pin(1, 5) == OutputResult.OK  # timer 0: timer 2 is free
    assert book.timer_users("timer 2") == set()
    assert s.set_planner(planners.PLANNER_QUICKSTEP) == 0
    assert book.timer_users("timer 2") == {"quickstep"}
    assert e.outputs.set_analog_pin(0, 3) == OutputResult.OK  # back on timer 2 ...
    assert e.outputs.analog(0, 50, synchronized=False) == OutputResult.ERR_TIMER_IN_USE
    assert s.set_planner(planners.PLANNER_FAS) == 0  # ... free again after l0
    assert book.timer_users("timer 2") == set()
    assert e.outputs.analog(0, 50, synchronized=False) == OutputResult.OK
    assert book.timer_users("timer 2") == {"pwm"}
