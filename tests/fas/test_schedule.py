"""The periodic task's timeline (fas.schedule), which the simulated and the serial
backend share: due runs, skipped runs and their credit, period changes, waking."""

from __future__ import annotations

from fas import Engine
from fas.device.loopback import Loopback
from fas.schedule import TaskSchedule
from fas.serial.backend import SerialBackend
from fas.sim import SimBackend

P = 64_000  # 4 ms at 16 MHz


def test_runs_follow_the_period_from_the_first() -> None:
    s = TaskSchedule()
    s.start(1000, P)
    assert s.next == 0 and s.next_time() == 1000
    assert not s.is_due(999) and s.is_due(1000)
    assert s.begin(0) == 0  # nothing skipped before the first run (anchor -1)
    assert s.end(0) == 1 and s.next_time() == 1000 + P


def test_quiet_runs_are_skipped_and_credited() -> None:
    s = TaskSchedule()
    s.start(0, P)
    s.begin(0)
    assert s.end(5) == 6  # five runs would do nothing: the next one is run 6
    assert s.next_time() == 6 * P
    assert s.begin(6) == 5  # ... and those five are credited


def test_a_sleeping_task_wakes_at_the_next_slot_not_passed() -> None:
    s = TaskSchedule()
    s.start(0, P)
    s.begin(0)
    assert s.end(None) is None and s.next_time() is None and not s.is_due(10 * P)
    assert s.wake(3 * P + 1)  # slots 1..3 have passed: run 4
    assert s.next == 4
    assert not s.wake(3 * P + 2)  # planned already
    s.begin(4)
    s.end(None)
    assert s.wake(4 * P)  # the slot right after the last run, not passed yet
    assert s.next == 5
    s.next = 9
    assert s.wake(5 * P) and s.next == 5  # a later plan is brought forward


def test_a_period_change_keeps_the_last_run_and_follows_the_new_period() -> None:
    s = TaskSchedule()
    s.start(0, P)
    s.begin(0)
    s.end(0)
    s.begin(1)
    s.end(0)
    s.set_period(P // 2)
    assert s.time(1) == P  # the last run keeps its time
    assert s.time(2) == P + P // 2


def test_the_anchor_decides_the_first_run_after_an_early_period_change() -> None:
    sim = TaskSchedule()
    sim.start(500, P, anchor=0)  # the chip's phase: run 0 keeps its time
    sim.set_period(2 * P)
    assert sim.time(0) == 500 and sim.time(1) == 500 + 2 * P
    host = TaskSchedule()
    host.start(P, P)  # the serial host: run 0 one period after the start
    host.set_period(2 * P)
    assert host.time(0) == 2 * P


def test_a_late_run_does_not_run_twice() -> None:
    s = TaskSchedule()
    s.start(0, P)
    assert s.catch_up(0) == 0 and s.catch_up(P - 1) == 0
    assert s.catch_up(2 * P + 5) == 2  # runs 0 and 1 are gone: it is run 2


def _idle_then_move(backend: SimBackend | SerialBackend) -> None:
    """An idle engine's task sleeps after its first run; a move wakes it at the first
    slot not passed; every slot up to the last run is run or credited."""
    engine = Engine(backend)
    engine.init()
    tasks = backend.tasks
    assert tasks.next == 0
    backend.app_spend(3 * backend.task_period_ticks)
    assert backend.task_runs == 1 and tasks.last == 0 and tasks.next is None
    s = engine.stepper_connect_to_pin(9)
    s.set_direction_pin(5)
    s.set_speed_in_us(100)
    s.set_acceleration(1000)
    s.move(100)
    assert tasks.next == tasks.due(backend.now()) and tasks.next >= 2
    backend.wait_until(lambda: not s.is_running())
    assert s.get_current_position() == 100
    assert engine.task_runs == tasks.last + 1 > backend.task_runs


def test_the_simulated_backend_runs_the_engine_on_it() -> None:
    # build e's 328P: an idle task costs no CPU there, so the schedule sleeps
    _idle_then_move(SimBackend("atmega328p", build="e"))


def test_build_ds_idle_tasks_are_run_for_their_cpu() -> None:
    """Build d's 328P charges an idle task its CPU (idle_task_ticks, read from its
    replica; the default since the fortieth pass): no run is skipped."""
    backend = SimBackend("atmega328p")
    assert backend.machine.timing.idle_task_ticks > 0
    engine = Engine(backend)
    engine.init()
    tasks = backend.tasks
    backend.app_spend(3 * backend.task_period_ticks)
    # runs 0 and 1 are done (the first at the task's phase, 68 350 ticks), run 2 is next
    assert backend.task_runs == 2 and tasks.last == 1 and tasks.next == 2


def test_the_serial_backend_runs_the_engine_on_it() -> None:
    with Loopback() as lb:
        assert lb.backend is not None
        _idle_then_move(lb.backend)
