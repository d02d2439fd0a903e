"""A stepper's planner while it is an axis of a path group (registered as ``"path"``).

:class:`fas.path.group.PathGroup` joins each of its steppers with
``stepper.set_planner("path", group)``: the stepper's planner becomes a
:class:`PathAxis`, which wraps the planner it replaced (``base``).  The group writes
the stepper's command queue; the axis of the lowest stepper number runs the group's
work in its ``fill`` - once per periodic task, before the steppers numbered after it.

While the group has nothing queued, the stepper's own requests (``move``, ``run`` ...)
go to ``base`` as before.  While the group moves, a request of the stepper's own is
refused (``ERR_SPEED_IS_UNDEFINED``: its speed is the path's); ``stop_move`` cancels
the path (a deceleration along it), a force stop aborts it at once (every axis).
"""

from __future__ import annotations

from typing import Protocol

from ..codes import RAMP_DIRECTION_COUNT_DOWN, RAMP_DIRECTION_COUNT_UP, MoveResult, RampState
from ..planner import Planner, PlannerChange, PlannerHost

PLANNER_PATH = "path"


class PathMembership(Protocol):
    """What an axis asks of its group (:class:`fas.path.group.PathGroup`)."""

    def run_task(self) -> None:
        """One run of the periodic task for the whole group."""

    def busy(self) -> bool:
        """Blocks are queued or the group moves."""

    def needs_task(self) -> bool:
        """The periodic task must run again."""

    def planning(self) -> bool:
        """There is path still to plan or to write into the queues."""

    def is_lead(self, axis: PathAxis) -> bool:
        """``axis`` runs the group's work in its fill."""

    def axis_target(self, axis: PathAxis) -> int:
        """Where the queued path ends for ``axis`` (steps)."""

    def axis_steps_to_stop(self, axis: PathAxis) -> int:
        """Steps ``axis`` would still make in a feed hold from now."""

    def cancel(self) -> None:
        """Decelerate along the path and drop the rest."""

    def abort(self) -> None:
        """Stop every axis at once and drop everything."""

    def axis_positions_shifted(self, axis: PathAxis, delta: int) -> None:
        """The stepper renamed its positions by ``delta``."""


class PathAxis(Planner):
    """One stepper of a path group (see the module text)."""

    def __init__(self, host: PlannerHost, base: Planner, group: PathMembership) -> None:
        super().__init__(host)
        self.base = base
        self.group = group
        self.queue = host.queue
        #: the path moved the stepper since ``base`` last planned: before ``base`` takes
        #: a request it goes on from the queue's end (as when it becomes the planner)
        self.path_moved = False

    # ------------------------------------------------------- own requests
    def check_move(self, delta: int) -> MoveResult:
        return self.base.check_move(delta)

    def check_held(self) -> MoveResult:
        return self.base.check_held()

    def _own(self) -> MoveResult:
        if self.group.busy():
            return MoveResult.ERR_SPEED_IS_UNDEFINED
        if self.path_moved:
            self.path_moved = False
            self.base.attach(self)
        return MoveResult.OK

    def move(self, delta: int) -> MoveResult:
        res = self._own()
        return res if res != MoveResult.OK else self.base.move(delta)

    def move_to(self, position: int) -> MoveResult:
        res = self._own()
        return res if res != MoveResult.OK else self.base.move_to(position)

    def run(self, count_up: bool) -> MoveResult:
        res = self._own()
        return res if res != MoveResult.OK else self.base.run(count_up)

    def keep_running(self) -> None:
        if self._own() == MoveResult.OK:
            self.base.keep_running()

    def keep_speed(self) -> None:
        if not self.group.busy():
            self.base.keep_speed()

    def apply_settings(self) -> None:
        self.base.apply_settings()

    def stop(self) -> None:
        if self.group.busy():
            self.group.cancel()
        else:
            self.base.stop()

    def force_stop(self) -> None:
        if self.group.busy():
            self.group.abort()
        self.base.force_stop()

    def force_stop_at(self, position: int) -> None:
        if self.group.busy():
            self.group.abort()
        self.base.force_stop_at(position)

    def single_step(self, count_up: bool) -> None:
        if self._own() == MoveResult.OK:
            self.base.single_step(count_up)

    def positions_shifted(self, delta: int) -> None:
        self.group.axis_positions_shifted(self, delta)
        self.base.positions_shifted(delta)

    # ------------------------------------------------------- periodic task
    def fill(self) -> int:
        generated = self.base.fill()
        if self.group.is_lead(self):
            self.group.run_task()
        return generated

    def needs_task(self) -> bool:
        return self.group.needs_task() or self.base.needs_task()

    def wants_task_at_rest(self) -> bool:
        return self.base.wants_task_at_rest()

    # --------------------------------------------------------------- state
    def is_running(self) -> bool:
        return self.group.busy() or self.base.is_running()

    def is_active(self) -> bool:
        return self.group.planning() or self.base.is_active()

    def is_running_continuously(self) -> bool:
        return False if self.group.busy() else self.base.is_running_continuously()

    def is_stopping(self) -> bool:
        return False if self.group.busy() else self.base.is_stopping()

    def ramp_state(self) -> int:
        if not self.group.busy():
            return self.base.ramp_state()
        up = self.queue.queue_end_count_up
        return RampState.COAST | (RAMP_DIRECTION_COUNT_UP if up else RAMP_DIRECTION_COUNT_DOWN)

    def target_pos(self) -> int:
        return self.group.axis_target(self) if self.group.busy() else self.base.target_pos()

    def steps_to_stop(self) -> int:
        if self.group.busy():
            return self.group.axis_steps_to_stop(self)
        return self.base.steps_to_stop()

    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        if not self.group.busy():
            return self.base.current_speed(realtime)
        valid, ticks, up = self.queue.actual_ticks_with_direction()
        return (ticks, up) if valid else (0, True)

    def planned_period_ticks(self) -> int:
        if self.group.busy():
            return self.queue.last_command_ticks if self.group.planning() else 0
        return self.base.planned_period_ticks()

    def current_acceleration(self) -> int:
        return 0 if self.group.busy() else self.base.current_acceleration()

    def fastest_period_ticks(self) -> int:
        return self.queue.max_speed_in_ticks


def make(host: PlannerHost, current: Planner, kept: Planner | None,
         group: PathMembership) -> tuple[PlannerChange, Planner | None]:
    """The registry's factory: ``stepper.set_planner("path", group)`` (what
    :meth:`fas.path.group.PathGroup.attach` does).  Refused while the stepper moves
    or belongs to another group."""
    if isinstance(current, PathAxis):
        if current.group is group:
            return PlannerChange.OK, None
        return PlannerChange.RUNNING, None
    if current.is_running():
        return PlannerChange.RUNNING, None
    return PlannerChange.OK, PathAxis(host, current, group)
