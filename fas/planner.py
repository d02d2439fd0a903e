"""The planner seam: what a planner is, and what a stepper lends it.

A :class:`~fas.stepper.Stepper` keeps its pins, the driver's enable handling, its
position and the public API; the *motion* - moves, runs, stops and filling the queue
in the periodic task - comes from its :class:`Planner`.  The stepper passes every
motion call on to its planner without knowing which one it is.

A planner gets a :class:`PlannerHost` when it is made: the stepper's motion settings
(speed, acceleration ...), its command queue, a way to write a command into that
queue (with auto enable and direction-change pauses), a way to wake the periodic
task, the time, and the engine's allocator and shared state.  A planner writes the
stepper's command queue, or a queue of its own (QuickStep's FIFO of orders); the
queue it writes is :attr:`Planner.queue`, where the stepper reads its position.

Planners are found by name in :mod:`fas.planners` (``stepper.set_planner(name)``);
:meth:`~fas.stepper.Stepper.use_planner` swaps one in directly and returns the old
one, carrying position and direction across (the new planner's queue takes over
from the old one's, :meth:`fas.queue.StepperQueue.take_over`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from enum import IntEnum
from typing import TYPE_CHECKING, Protocol, TypeVar

from .codes import MoveResult

if TYPE_CHECKING:  # pragma: no cover
    from .allocate import Allocator
    from .arch import Profile
    from .backend import Backend
    from .codes import AqeResult
    from .motion import MotionSettings
    from .queue import StepperQueue

T = TypeVar("T")


class SharedStore(Protocol):
    """``store(key, make)``: one object per engine and ``key``, made by ``make()`` on
    first use (:meth:`fas.engine.Engine.shared`)."""

    def __call__(self, key: str, make: Callable[[], T]) -> T: ...


class PlannerChange(IntEnum):
    """Result of choosing a planner by name; a planner's factory may add reasons of its
    own with other values (QuickStep's :class:`~fas.quickstep.clock.QsConfigResult`
    uses the same value for ``RUNNING``)."""

    OK = 0
    RUNNING = 7  # not while the stepper moves


class PlannerHost:
    """What a stepper lends its planner (made by the stepper, one per stepper)."""

    __slots__ = ("index", "profile", "backend", "settings", "queue", "write", "wake",
                 "wait_until", "has_direction_pin",
                 "start_delay", "command_written", "report_abort", "allocator", "_shared")

    def __init__(self, *, index: int, profile: Profile, backend: Backend,
                 settings: MotionSettings, queue: StepperQueue,
                 write: Callable[[int | None, int, bool, bool], AqeResult],
                 wake: Callable[[], None],
                 wait_until: Callable[[Callable[[], bool]], object],
                 has_direction_pin: Callable[[], bool],
                 start_delay: Callable[[], int],
                 command_written: Callable[[], None],
                 report_abort: Callable[[AqeResult, object], None],
                 allocator: Allocator,
                 shared: SharedStore) -> None:
        self.index = index  # the stepper's number
        self.profile = profile
        self.backend = backend  # the time (backend.now()), channels, the link's lead
        self.settings = settings  # speed, acceleration, forward planning (fas.motion)
        self.queue = queue  # the stepper's command queue
        #: write(ticks, steps, count_up, start): one command into the command queue,
        #: with auto enable, the enable delay and direction-change pauses before it
        #: (``ticks`` None: only start the queue)
        self.write = write
        self.wake = wake  # the periodic task must run again from its next slot
        self.wait_until = wait_until  # let time pass until predicate() holds (blocking)
        self.has_direction_pin = has_direction_pin
        #: before a planner writes a queue of its own that is idle: auto enable switches
        #: the driver on; returns the ticks its first step must wait for that
        self.start_delay = start_delay
        #: after a planner wrote a queue of its own: auto disable counts from now
        self.command_written = command_written
        self.report_abort = report_abort  # a command was refused for good: (res, cmd)
        self.allocator = allocator  # timers, pulse counters, multiplexer slots
        self._shared = shared

    def shared(self, key: str, make: Callable[[], T]) -> T:
        """One object per engine and ``key``, made by ``make()`` on first use (state
        a kind of planner shares between steppers: QuickStep's timer)."""
        return self._shared(key, make)


class Planner(ABC):
    """One motion source of a stepper (see the module text).

    Requests return what FastAccelStepper's API returns for them; a planner that
    cannot make a request returns the code that says why.  ``fill()`` runs once per
    periodic task for the planner in use."""

    #: the queue this planner writes; the stepper reads its position there
    queue: StepperQueue
    #: True: the planner derives its commands from other steppers' queues, so the
    #: engine runs its fill after every other planner's in each periodic task
    fills_late: bool = False

    def __init__(self, host: PlannerHost) -> None:
        self.host = host

    # ------------------------------------------------------------ hand-over
    def attach(self, previous: Planner | None) -> None:  # noqa: B027 - optional: no-op by default
        """The planner has become its stepper's instead of ``previous`` (None: the
        stepper's first); its queue has taken over position and direction."""

    def detach(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """Another planner takes over (this one is at rest)."""

    # ------------------------------------------------------------- requests
    def check_move(self, delta: int) -> MoveResult:
        """What ``move(delta)`` refuses at once, even while a synchronized output holds
        the request back (:mod:`fas.sync`)."""
        return MoveResult.OK

    def check_held(self) -> MoveResult:
        """What a request held back by a synchronized output can check at once."""
        return MoveResult.OK

    @abstractmethod
    def move(self, delta: int) -> MoveResult:
        """A move by ``delta`` steps (int32)."""

    @abstractmethod
    def move_to(self, position: int) -> MoveResult:
        """A move to ``position`` (int32)."""

    @abstractmethod
    def run(self, count_up: bool) -> MoveResult:
        """Run on for ever, up or down."""

    @abstractmethod
    def keep_running(self) -> None:
        """Go on for ever in the direction and at the speed of the present motion."""

    @abstractmethod
    def keep_speed(self) -> None:
        """``move_by_acceleration(0)``: neither speed up nor slow down any more."""

    def apply_settings(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """``apply_speed_acceleration``: new settings for the motion under way."""

    @abstractmethod
    def stop(self) -> None:
        """Stop with the deceleration ramp."""

    @abstractmethod
    def force_stop(self) -> None:
        """Stop at once (the queue may run on to its end where it cannot be cut)."""

    @abstractmethod
    def force_stop_at(self, position: int) -> None:
        """Stop at once, drop every queued command; the position is ``position`` now."""

    @abstractmethod
    def single_step(self, count_up: bool) -> None:
        """One step (``forward_step``/``backward_step``), the stepper at rest."""

    def positions_shifted(self, delta: int) -> None:  # noqa: B027 - optional: no-op by default
        """The stepper renamed its positions by ``delta`` (``set_current_position``)."""

    @abstractmethod
    def fill(self) -> int:
        """One run of the periodic task: fill the queue; returns commands written."""

    # ---------------------------------------------------------------- state
    @abstractmethod
    def is_running(self) -> bool:
        """The stepper moves or has motion queued or still to plan."""

    @abstractmethod
    def is_active(self) -> bool:
        """There is motion still to plan (``isRampGeneratorActive``)."""

    def is_running_continuously(self) -> bool:
        return False

    def is_stopping(self) -> bool:
        return False

    @abstractmethod
    def ramp_state(self) -> int:
        """``rampState()``: a :class:`~fas.codes.RampState` or'ed with the direction."""

    @abstractmethod
    def target_pos(self) -> int:
        """Where the motion planned so far ends."""

    @abstractmethod
    def steps_to_stop(self) -> int:
        """Steps a stop with deceleration would still make."""

    @abstractmethod
    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        """(ticks between steps, count up) now (``realtime``: as executed) - 0 ticks
        at rest."""

    @abstractmethod
    def planned_period_ticks(self) -> int:
        """The step period at the end of what is planned (0: at rest)."""

    @abstractmethod
    def current_acceleration(self) -> int:
        """Signed acceleration of the present motion (steps/s^2)."""

    @abstractmethod
    def fastest_period_ticks(self) -> int:
        """The shortest step period ``set_speed_in_ticks`` accepts."""

    @abstractmethod
    def needs_task(self) -> bool:
        """The next runs of the periodic task must not be skipped."""

    def wants_task_at_rest(self) -> bool:
        """Given up for another planner (so at rest), does this one still keep the
        periodic task from being skipped?  (The ramp: a force stop at rest leaves
        upstream's immediate-stop flag set until its next move.)"""
        return False
