"""The QuickStep planner of one stepper: moves as plateau orders in a FIFO.

It is a planner of the seam :mod:`fas.planner`: a stepper switched to QuickStep
(``stepper.set_planner("quickstep", depth, plateaus)``, made by :func:`.setup.make`)
passes its motion calls to it.  A move is planned at once
into its orders (:mod:`.plateaus`); they go into the FIFO (:class:`.orders.
OrderQueue`) as far as it has room, the rest waits as *pending* orders and is
pushed as slots free - QuickStep's blocking enqueue.  ``move(..., wait=False)``
queues nothing and reports :attr:`QsMoveResult.FIFO_FULL` when the orders do not
all fit.

How the FastAccelStepper API maps onto it (the console's commands follow):

* ``move``/``move_to``: a new move is queued *after* everything queued before
  (QuickStep's FIFO); ``move_to`` counts from the position after those orders.
* speed (V/H), acceleration (A), plateaus: for moves planned afterwards; orders
  in the FIFO keep theirs (``apply_speed_acceleration`` changes nothing queued).
* ``run_forward``/``run_backward``: acceleration plateaus, then top-speed orders
  for as long as it runs; ``keep_running``: the running order's speed for ever.
* ``stop_move``: orders not yet started are dropped, the running one makes at most
  one plateau's steps more, then the deceleration plateaus below it.
* ``force_stop``/``force_stop_and_new_position``: everything is dropped at once.
"""

from __future__ import annotations

from collections import deque
from enum import IntEnum
from typing import Literal, overload

from ..codes import (
    RAMP_DIRECTION_COUNT_DOWN,
    RAMP_DIRECTION_COUNT_UP,
    MoveResult,
    RampState,
)
from ..planner import Planner, PlannerHost
from ..queue import i32
from .clock import QuickStepClock
from .orders import OrderInfo, OrderQueue
from .plateaus import (
    ACCELERATE,
    COAST,
    DECELERATE,
    MAX_ORDER_STEPS,
    Plateau,
    plan_move,
    plan_run,
    plan_stop,
    plateau_steps,
)


class QsMoveResult(IntEnum):
    """What ``move(..., wait=False)`` may answer beyond :class:`~fas.codes.MoveResult`."""

    FIFO_FULL = 1  # the FIFO has no room for all orders of the move: nothing queued


DEFAULT_DEPTH = 32
DEFAULT_PLATEAUS = 8
MAX_PLATEAUS = 255

_PHASE_STATE = {ACCELERATE: int(RampState.ACCELERATE), COAST: int(RampState.COAST),
                DECELERATE: int(RampState.DECELERATE)}


class PendingOrder:
    __slots__ = ("period", "steps", "count_up", "info")

    def __init__(self, period: int, steps: int, count_up: bool, info: OrderInfo) -> None:
        self.period = period
        self.steps = steps
        self.count_up = count_up
        self.info = info


class QuickStepPlanner(Planner):
    queue: OrderQueue

    def __init__(self, host: PlannerHost, clock: QuickStepClock, queue: OrderQueue,
                 plateaus: int) -> None:
        super().__init__(host)
        self.clock = clock
        self.queue = queue
        self.plateaus = plateaus
        self.pending: deque[PendingOrder] = deque()
        self.endless: PendingOrder | None = None  # repeated while running continuously
        self.orders_queued = 0
        self.moves = 0
        self.fifo_full_waits = 0  # times a move had to wait for room

    # ------------------------------------------------------------- settings
    @property
    def depth(self) -> int:
        return self.queue.depth

    def speed_period_ticks(self) -> int:
        return self.host.settings.min_travel_ticks

    def acceleration(self) -> int:
        return self.host.settings.acceleration

    def attach(self, previous: Planner | None) -> None:
        self.clock.add(self)

    def detach(self) -> None:
        self.clock.remove(self)

    def has_orders(self) -> bool:
        q = self.queue
        return bool(self.pending) or self.endless is not None or q.is_running() or \
            not q.is_queue_empty()

    # -------------------------------------------------------------- queries
    def is_running(self) -> bool:
        return self.has_orders()

    def is_active(self) -> bool:
        return self.has_orders()

    def needs_task(self) -> bool:
        return self.has_orders()

    def fastest_period_ticks(self) -> int:
        return 1  # a speed beyond the timer runs at the nearest interval allowed

    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        ticks, _, up = self.running_info()
        return ticks, up

    def planned_period_ticks(self) -> int:
        return self.current_period_ticks()

    def pending_orders(self) -> int:
        return len(self.pending)

    def target_pos(self) -> int:
        pos = self.queue.queue_end_pos
        for p in self.pending:
            pos = i32(pos + (p.steps if p.count_up else -p.steps))
        return pos

    def running_info(self) -> tuple[int, OrderInfo | None, bool]:
        """(period ticks, info, count_up) of the order being executed."""
        head = self.queue.running_order()
        if head is None:
            return 0, None, True
        e, info = head
        return e.ticks, info, e.count_up

    def ramp_state(self) -> int:
        if not self.has_orders():
            return int(RampState.IDLE)
        ticks, info, up = self.running_info()
        if info is None:
            if self.pending:
                info, up = self.pending[0].info, self.pending[0].count_up
            else:
                return int(RampState.IDLE)
        state = _PHASE_STATE.get(info.phase, int(RampState.COAST))
        return state | (RAMP_DIRECTION_COUNT_UP if up else RAMP_DIRECTION_COUNT_DOWN)

    def current_period_ticks(self) -> int:
        ticks, info, _ = self.running_info()
        return ticks

    def current_acceleration(self) -> int:
        _, info, up = self.running_info()
        if info is None or info.phase == COAST or not info.phase:
            return 0
        a = info.accel if info.phase == ACCELERATE else -info.accel
        return a if up else -a

    def steps_to_stop(self) -> int:
        head = self.queue.running_order()
        if head is None:
            return 0
        e, info = head
        if info is None or not info.phase:
            return e.steps
        length = plateau_steps(self.queue.profile.ticks_per_s, info.top_period_ticks,
                               info.accel, info.plateaus)
        return min(e.steps, length) + length * (min(info.level, info.plateaus) - 1)

    def is_running_continuously(self) -> bool:
        return self.endless is not None

    def plateau_label(self) -> str:
        """``k/N`` of the running order (for status lines), or ``""``."""
        _, info, _ = self.running_info()
        if info is None or not info.phase:
            return ""
        return f"{info.level}/{info.plateaus}"

    # ------------------------------------------------------------- planning
    def _check(self) -> MoveResult:
        if self.speed_period_ticks() <= 0:
            return MoveResult.ERR_SPEED_IS_UNDEFINED
        if self.acceleration() <= 0:
            return MoveResult.ERR_ACCELERATION_IS_UNDEFINED
        return MoveResult.OK

    def _orders(self, plateaus: list[Plateau] | tuple[Plateau, ...], count_up: bool,
                top: int, accel: int) -> list[PendingOrder]:
        tb = self.clock.timebase(self.host.backend.now())
        out = []
        for p in plateaus:
            if p.steps <= 0:
                continue
            interval = tb.interval_256(p.period_ticks)
            info = OrderInfo(interval, p.phase, p.level, self.plateaus, top, accel)
            out.append(PendingOrder(tb.period_ticks(interval), p.steps, count_up, info))
        return out

    def plan(self, delta: int) -> list[PendingOrder]:
        """The orders of a relative move of ``delta`` steps (none for 0)."""
        if delta == 0:
            return []
        ticks_per_s = self.queue.profile.ticks_per_s
        accel = self.acceleration()
        plan = plan_move(ticks_per_s, abs(delta), self.speed_period_ticks(), accel,
                         self.plateaus)
        return self._orders(plan.plateaus, delta > 0, plan.top_period_ticks, accel)

    def start_move(self, delta: int) -> MoveResult:
        """Queue what fits of a relative move; the rest stays pending until :meth:`pump`
        finds room (a host that keeps running meanwhile, as the console does)."""
        return self.move(delta, wait=None)

    # only wait=False may answer FIFO_FULL beyond the seam's MoveResult; the stepper's
    # calls wait, as FastAccelStepper's move does
    @overload
    def move(self, delta: int, wait: Literal[True] | None = True) -> MoveResult: ...
    @overload
    def move(self, delta: int, wait: bool | None) -> MoveResult | QsMoveResult: ...

    def move(self, delta: int, wait: bool | None = True) -> MoveResult | QsMoveResult:
        """Queue a relative move (after everything queued); see the module text.

        ``wait``: True blocks until every order is in the FIFO, False queues nothing
        and returns :attr:`QsMoveResult.FIFO_FULL` if they do not all fit, None leaves
        the rest pending.
        """
        res = self._check()
        if res != MoveResult.OK:
            return res
        if delta < 0 and not self.host.has_direction_pin():
            return MoveResult.ERR_NO_DIRECTION_PIN
        orders = self.plan(delta)
        if wait is False and len(orders) + len(self.pending) > self.queue.free_slots():
            return QsMoveResult.FIFO_FULL
        self.endless = None
        if orders:
            self.moves += 1
        self.pending.extend(orders)
        self.pump()
        if self.pending:
            self.fifo_full_waits += 1
            if wait:
                self.host.wait_until(lambda: self.pump() >= 0 and not self.pending)
        return MoveResult.OK

    @overload
    def move_to(self, position: int, wait: Literal[True] | None = True) -> MoveResult: ...
    @overload
    def move_to(self, position: int, wait: bool | None) -> MoveResult | QsMoveResult: ...

    def move_to(self, position: int, wait: bool | None = True) -> MoveResult | QsMoveResult:
        return self.move(i32(position - self.target_pos()), wait)

    def run(self, count_up: bool) -> MoveResult:
        res = self._check()
        if res != MoveResult.OK:
            return res
        if not count_up and not self.host.has_direction_pin():
            return MoveResult.ERR_NO_DIRECTION_PIN
        ticks_per_s = self.queue.profile.ticks_per_s
        accel = self.acceleration()
        speed = self.speed_period_ticks()
        if self.endless is not None and self.endless.count_up == count_up:
            return MoveResult.OK
        acc, top = plan_run(ticks_per_s, speed, accel, self.plateaus)
        orders: list[PendingOrder] = []
        head = self._cut_to_running()
        if head is not None:
            _, info, up = head
            level = info.level if info is not None and info.phase else 1
            if up != count_up:
                orders += self._orders(plan_stop(ticks_per_s, speed, accel, self.plateaus,
                                                 level), up, speed, accel)
                level = 0
            acc = [p for p in acc if p.level > level]
        orders += self._orders(acc, count_up, speed, accel)
        cruise = self._orders([top], count_up, speed, accel)[0]
        self.pending.extend(orders)
        self.endless = cruise
        self.moves += 1
        self.pump()
        return MoveResult.OK

    def keep_running(self) -> None:
        head = self._cut_to_running()
        if head is None:
            return
        ticks, info, up = head
        if info is None:
            return
        self.endless = PendingOrder(ticks, MAX_ORDER_STEPS, up,
                                    OrderInfo(info.interval_256, COAST, info.level,
                                              info.plateaus, info.top_period_ticks,
                                              info.accel))
        self.pump()

    def keep_speed(self) -> None:
        self.keep_running()

    def _cut_to_running(self) -> tuple[int, OrderInfo | None, bool] | None:
        """Drop what has not started; return (period, info, count_up) of the running order."""
        self.pending.clear()
        self.endless = None
        self.queue.drop_pending()
        last = self.queue.last_order()
        if last is None:
            return None
        e, info = last
        return e.ticks, info, e.count_up

    def stop(self) -> None:
        head = self._cut_to_running()
        if head is None:
            return
        _, info, up = head
        if info is None or not info.phase:
            return
        ticks_per_s = self.queue.profile.ticks_per_s
        length = plateau_steps(ticks_per_s, info.top_period_ticks, info.accel, info.plateaus)
        self.queue.shorten_last(max(1, length))
        below = plan_stop(ticks_per_s, info.top_period_ticks, info.accel, info.plateaus,
                          info.level - 1)
        self.pending.extend(self._orders(below, up, info.top_period_ticks, info.accel))
        self.pump()

    def _drop_orders(self) -> None:
        self.pending.clear()
        self.endless = None

    def force_stop(self) -> None:
        self._drop_orders()
        self.queue.force_stop()

    def force_stop_at(self, position: int) -> None:
        q = self.queue
        self._drop_orders()
        q.ignore_commands = False
        q.force_stop()
        q.queue_end_pos = i32(position)

    def single_step(self, count_up: bool) -> None:
        tb = self.clock.timebase(self.host.backend.now())
        speed = self.speed_period_ticks() or tb.base_ticks
        interval = tb.interval_256(speed)
        self.pending.append(PendingOrder(tb.period_ticks(interval), 1, count_up,
                                         OrderInfo(interval, "", 1, 1, speed, 0)))
        self.pump()

    # ---------------------------------------------------------------- pushing
    def fill(self) -> int:
        return self.pump()

    def pump(self) -> int:
        """Push pending (then endless) orders while the FIFO has room; returns how many."""
        q = self.queue
        pushed = 0
        while q.free_slots() > 0:
            if self.pending:
                o = self.pending[0]
            elif self.endless is not None:
                o = self.endless
            else:
                break
            delay = self.host.start_delay()
            q.channel.start_delay_ticks = delay
            res = q.add_order(o.period, o.steps, o.count_up, o.info)
            if res != 0:
                break
            if self.pending and o is self.pending[0]:
                self.pending.popleft()
            pushed += 1
            self.orders_queued += 1
            self.host.command_written()
        q.channel.sync()  # (a relay to FastAccelStepper's queue expands them there)
        return pushed
