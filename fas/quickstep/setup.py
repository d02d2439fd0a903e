"""QuickStep's factory: switching a stepper to QuickStep, with the checks the seed asks
for - a QuickStep timer on the profile that no user PWM output runs on, FIFO depth
1 .. 255, plateaus 1 .. 255, all FIFOs together within the RAM the profile leaves
for them, the stepper at rest.

Registered as ``"quickstep"`` in :mod:`fas.planners`:
``stepper.set_planner("quickstep", depth, plateaus)`` (None: the current or default
figure); asked again while QuickStep runs, it changes depth and plateaus.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, TypeVar, cast

from .clock import QsConfigResult, QuickStepClock
from .orders import MAX_DEPTH, MIN_DEPTH, OrderQueue
from .planner import DEFAULT_DEPTH, DEFAULT_PLATEAUS, MAX_PLATEAUS, QuickStepPlanner
from .relay import OrderRelay

if TYPE_CHECKING:  # pragma: no cover
    from collections.abc import Callable

    from ..allocate import Allocator
    from ..arch import Profile
    from ..channel import OrderChannel
    from ..planner import Planner, PlannerHost

T = TypeVar("T")
SHARED_KEY = "quickstep"  # the engine's shared state of QuickStep: its clock


class EngineLike(Protocol):
    """An engine, or what a stepper lends its planner: both can give the clock."""

    profile: Profile
    allocator: Allocator

    def shared(self, key: str, make: Callable[[], T]) -> T: ...


class HasPlanner(Protocol):
    """A stepper, as far as :func:`quickstep_of` asks it."""

    @property
    def planner(self) -> Planner: ...


def quickstep_of(stepper: HasPlanner) -> QuickStepPlanner | None:
    """The stepper's QuickStep planner while it runs QuickStep (else None): its FIFO,
    plateaus and moves that may wait for room."""
    planner = stepper.planner
    # (isinstance, without the ABC's check: no class is registered as one)
    if QuickStepPlanner in type(planner).__mro__:
        return cast(QuickStepPlanner, planner)
    return None


def clock_of(engine: EngineLike) -> QuickStepClock:
    """The engine's QuickStep timer (one for every QuickStep motor), made on first use."""
    return engine.shared(SHARED_KEY, lambda: QuickStepClock(engine.profile, engine.allocator))


def check(host: PlannerHost, current: Planner, depth: int | None,
          plateaus: int | None) -> QsConfigResult:
    """Would QuickStep with these figures be accepted for the stepper of ``host``?"""
    clock = clock_of(host)
    if clock.timer is None:
        return QsConfigResult.NOT_AVAILABLE
    if clock.timer_taken():
        return QsConfigResult.TIMER_IN_USE
    if depth is not None and not MIN_DEPTH <= depth <= MAX_DEPTH:
        return QsConfigResult.DEPTH_OUT_OF_RANGE
    if plateaus is not None and not 1 <= plateaus <= MAX_PLATEAUS:
        return QsConfigResult.PLATEAUS_OUT_OF_RANGE
    qs = current if isinstance(current, QuickStepPlanner) else None
    new_depth = depth if depth is not None else (qs.depth if qs else DEFAULT_DEPTH)
    if not clock.fits(new_depth, without=qs):
        return QsConfigResult.RAM
    if current.is_running():
        return QsConfigResult.RUNNING
    return QsConfigResult.OK


def make(host: PlannerHost, current: Planner, kept: Planner | None,
         depth: int | None = None,
         plateaus: int | None = None) -> tuple[QsConfigResult, Planner | None]:
    """QuickStep for the stepper of ``host`` (a new FIFO each time it is chosen)."""
    res = check(host, current, depth, plateaus)
    if res != QsConfigResult.OK:
        return res, None
    clock = clock_of(host)
    if isinstance(current, QuickStepPlanner):  # already QuickStep: new figures
        if plateaus is not None:
            current.plateaus = plateaus
        if depth is not None and depth != current.depth:
            current.queue.depth = depth
        return res, None
    commands = host.queue
    backend = host.backend

    def make_channel(q: OrderQueue) -> OrderChannel:
        # the chip's own timer if the backend has one, else relayed into the commands
        channel = backend.allocate_order_channel(q, commands, clock)
        return channel if channel is not None else OrderRelay(q, commands, clock)

    queue = OrderQueue(commands.index, host.profile, backend, commands.step_pin,
                       depth if depth is not None else DEFAULT_DEPTH, make_channel)
    planner = QuickStepPlanner(host, clock, queue,
                               plateaus if plateaus is not None else DEFAULT_PLATEAUS)
    return res, planner
