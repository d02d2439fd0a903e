"""The look-ahead executor: the G-code blocks planned and executed by ``fas.path``.

Each block of the machine's :class:`~.motion.BlockQueue` is handed, as soon as it is
queued, to a :class:`fas.path.PathGroup` of the machine's axes - Grbl's planner:
junction speeds by junction deviation (``$11``), per-axis rate and acceleration
(``$110``-``$115``, ``$120``-``$125``) projected along each block, the reverse and
forward passes re-run as blocks arrive, the motion made final a forward-planning
time ahead and written as each axis's FastAccelStepper queue commands; blocks join
without a pause.  See ``docs/path-planner.md`` for the planner itself.

**The block queue is the planner's.**  The group holds as many blocks as the
machine's block queue (Grbl's 15 usable of 16, what ``Bf:`` reports) and a block
leaves the block queue when the group has made its last piece final - as Grbl
discards a planner block once its stepper segments are prepared.  So ``Bf:`` counts
the blocks still planned, and a line waits for room exactly as in Grbl.

**Starting.**  The group starts at once when the machine has taken everything it
received (Grbl's auto cycle start when no more input is waiting): the executor
flushes the group after every block it hands over - the group's run begins at its
next periodic task, by when every line received at the same instant has joined.

**Real-time requests.**  A feed hold decelerates along the planned path (the
group's :meth:`~fas.path.PathGroup.hold`), a resume goes on from where the axes
stand, a jog cancel drops the rest, Ctrl-X stops every axis at once; feed and rapid
overrides re-plan every queued block (jogs keep their feed).  A synchronized output
(M62/M63/M67) is handed to the library once every block before it is with the group:
the library makes the change when the group's queues have run dry.

**Where it cannot run.**  The group needs each axis's steps unshifted by the
library (no direction-change delay, no driver pausing at a direction change) and a
direction pin per axis: :func:`lookahead_fits` says whether the machine's steppers
allow it; otherwise the machine uses the exact-stop executor
(:mod:`.exact_stop`), as it does with ``$171=1``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fas.codes import PIN_UNDEFINED
from fas.path import AxisLimits, PathGroup, PathResult, PathSettings
from fas.path.settings import DEFAULT_ARC_TOLERANCE

from .interp import Move
from .motion import BlockQueue, HoldState, MotionExecutor, MotionHost, SpeedListener

if TYPE_CHECKING:  # pragma: no cover
    from .settings import GcodeSettings

#: enum members a line compares with, bound once (a class attribute look-up of an
#: enum member costs about ten times a global's)
_PATH_OK, _QUEUE_FULL, _EMPTY_BLOCK = PathResult.OK, PathResult.QUEUE_FULL, PathResult.EMPTY_BLOCK
_HOLD_NONE = HoldState.NONE


def path_settings(st: GcodeSettings, axes: int, blocks: int) -> PathSettings:
    """The group's figures from the machine's ``$`` settings."""
    limits = tuple(AxisLimits(st.steps_per_unit[i], st.max_rate[i], st.acceleration[i])
                   for i in range(axes))
    tolerance = st.arc_tolerance if st.arc_tolerance > 0 else DEFAULT_ARC_TOLERANCE
    return PathSettings(axes=limits, junction_deviation=st.junction_deviation,
                        arc_tolerance=tolerance, queue_blocks=max(2, blocks),
                        corner_blends=st.corner_blends,
                        plain_corner_steps=st.plain_corner_steps)


def lookahead_fits(steppers: list) -> bool:
    """Can these steppers be one path group (apart from auto enable, which the
    machine switches off before it moves)?  Two axes on one direction pin, a
    direction-change delay or a driver that pauses at a direction change cannot."""
    pins: set[int] = set()
    for s in steppers:
        if s.get_dir_change_delay_ticks() or PathGroup.driver_pauses(s):
            return False
        pin = s.get_direction_pin()
        if pin != PIN_UNDEFINED:
            if pin in pins:
                return False
            pins.add(pin)
    return True


class LookaheadExecutor(MotionExecutor):
    """Blocks planned with look-ahead by a :class:`fas.path.PathGroup` (module text)."""

    kind = "lookahead"

    def __init__(self, host: MotionHost, blocks: BlockQueue) -> None:
        super().__init__(host, blocks)
        axes = len(host.steppers)
        self.group = PathGroup(host.steppers, path_settings(host.settings, axes, blocks.size))
        self.handed = 0  # blocks at the front of the block queue that the group has
        self._queued = blocks.items  # (its deque: len() without a call, hot paths)
        self._hold = HoldState.NONE
        self._last: Move | None = None  # the block handed last
        self._errors = 0
        self._listener: SpeedListener | None = None
        self._lasers_only = False  # (set_speed_listener)
        #: (tick the run was asked for, ticks until its common start) of every run
        self.runs: list[tuple[int, int]] = []
        self._asked: int | None = None
        self._run_seen: int | None = None
        self.feed_percent = self.rapid_percent = 100

    # ------------------------------------------------------------- facts
    def hold_state(self) -> HoldState:
        if self._hold == HoldState.NONE:
            return HoldState.NONE
        return HoldState.STOPPING if self.group.run_active else HoldState.HELD

    def current(self) -> Move | None:
        queued = self._queued
        if queued:  # (the block queue's front: asked before every line)
            return queued[0]
        g = self.group
        if g.run_active:
            tag = g.tag_at(self.host.backend.now())
            if isinstance(tag, Move):
                return tag
        return self._last if g.busy() else None

    def busy(self) -> bool:
        if self._queued:
            return True
        g = self.group
        return g.run_active or bool(g.lookahead.blocks)  # (PathGroup.busy, written out)

    def moving(self) -> bool:
        return self.group.run_active or any(s.queue.is_running() for s in self.host.steppers)

    def committed(self) -> bool:
        return self._hold == HoldState.NONE and self.handed >= len(self.blocks)

    def path_rate(self) -> float:
        return self.group.current_speed()

    def set_speed_listener(self, fn: SpeedListener | None, lasers_only: bool = False) -> bool:
        self._listener = fn
        self._lasers_only = lasers_only
        # (lasers only: the group tells it from the first block handed with a laser
        # on - :meth:`_hand` - and not before: no path speed computed for the rest)
        self.group.speed_listener = None if fn is None or lasers_only else self._speed
        return True

    def _speed(self, tick: int, speed: float, tag: object) -> None:
        if self._listener is not None:
            self._listener(tick, speed, tag if isinstance(tag, Move) else None)

    # ---------------------------------------------------------- requests
    def hold(self) -> None:
        if self._hold != HoldState.NONE:
            return
        self._hold = HoldState.STOPPING
        self.group.hold()  # a run decelerates; queued blocks wait; nothing: nothing

    def resume(self) -> None:
        if self._hold == HoldState.NONE:
            return
        self._hold = HoldState.NONE
        g = self.group
        if g.holding:
            g.resume()
            self._asked = self.host.backend.now()
        g.flush()

    def discard(self) -> None:
        self.group.cancel()
        self.handed = 0  # the machine drops the block queue after this

    def abort(self) -> None:
        self.group.abort()
        for s in self.host.steppers:
            s.force_stop_and_new_position(s.get_current_position())
        self._asked = None
        self.handed = 0
        self._hold = HoldState.NONE
        self._last = None

    def set_overrides(self, feed_percent: int, rapid_percent: int) -> None:
        self.feed_percent, self.rapid_percent = feed_percent, rapid_percent
        self.group.set_overrides(feed_percent, rapid_percent)

    # ------------------------------------------------------------ driving
    def poll(self) -> None:
        g = self.group
        if g.stats.errors != self._errors:  # a queue refused a command: aborted
            self._errors = g.stats.errors
            self.host.motion_failed(_Refused())
            return
        start = g.run_start_tick
        if start is not None and start != self._run_seen:
            self._run_seen = start
            asked = self._asked if self._asked is not None else start
            self.runs.append((asked, start - asked))
            self._asked = None
        queued = self._queued
        if self.handed and queued:  # (_retire's common case first: nothing to retire)
            planned = g.lookahead.blocks
            if not planned or planned[0].tag is not queued[0]:
                self._retire()
        if self.handed != len(queued):  # (else _hand has nothing to do)
            self._hand()
        if (not (queued or g.run_active or g.lookahead.blocks)  # (not busy())
                and g.attached and not self.moving() and self._hold == HoldState.NONE):
            g.detach()  # the steppers' own planners back (StepperDemo's g mode)

    def wake_tick(self) -> int | None:
        b = self.host.backend
        g = self.group
        queued = self._queued
        if self.handed < len(queued):
            la = g.lookahead
            if la.size - len(la.blocks) > 0:  # (g.room())
                return b.now()
        if queued or g.run_active or g.lookahead.blocks or self.moving():
            return b.now() + b.task_period_ticks
        if self.group.attached and self._hold == HoldState.NONE:
            return b.now()  # detach (as poll does: not while held - a resume goes on)
        return None

    def _retire(self) -> None:
        """Blocks the group has made final leave the block queue (front first).  The
        group keeps its blocks in order, so the front is retired when the group no
        longer has it (before it there are at most blocks a hold put back)."""
        queued = self._queued
        planned = self.group.lookahead.blocks
        while self.handed and queued:
            front = queued[0]
            if planned and planned[0].tag is front:
                return  # (the common case: the group's first block)
            for b in planned:
                if b.tag is front:
                    return
            queued.popleft()
            self.handed -= 1

    def _hand(self) -> None:
        """Blocks not yet planned go to the group while it has room."""
        n = len(self._queued)
        if self.handed >= n:
            self.handed = n
            return
        g = self.group
        blocks = self.blocks
        la = g.lookahead
        if not (g.run_active or la.blocks):  # (not g.busy())
            self._asked = self.host.backend.now()
            if self._lasers_only:
                g.speed_listener = None  # (until a block with a laser on comes)
            if not g.attached:
                self.host.enable_drivers()  # (auto enable off: the group needs that)
            g.configure(path_settings(self.host.settings, len(self.host.steppers),
                                      blocks.size))
            g.lookahead.set_overrides(self.feed_percent / 100, self.rapid_percent / 100)
            if not g.attached:
                res = g.attach()
                if res != PathResult.OK:
                    self.host.motion_failed(_Refused(res.name))
                    return
        else:
            self.host.enable_drivers()
        handed_any = False
        la = g.lookahead  # (configure may have made it anew)
        queued = self._queued
        while self.handed < len(queued):  # (the blocks after the handed ones, in order)
            move = queued[self.handed]
            if la.size - len(la.blocks) <= 0:  # (the group's room)
                break
            if (move.laser is not None and g.speed_listener is None
                    and self._listener is not None):
                g.speed_listener = self._speed  # (lasers only: from this block on)
            res = g.line(move.target if move.exact is None else move.exact,
                         None if move.rapid else move.feed, tag=move,
                         through=move.exact is not None,
                         override=not move.jog)
            if res == _QUEUE_FULL:
                break
            if res != _PATH_OK and res != _EMPTY_BLOCK:
                self.host.motion_failed(_Refused(res.name))
                return
            self.handed += 1
            self._last = move
            handed_any = True
        if self._hold != _HOLD_NONE and not g.holding:
            g.hold()  # queued while held: they wait for the resume
        if handed_any:
            g.flush()  # Grbl's auto cycle start: everything received is in
            self._retire()  # (a block of no length leaves at once)


class _Refused:
    """What the machine's alarm message names when the group refused or aborted."""

    def __init__(self, name: str = "PATH_QUEUE_REFUSED") -> None:
        self.name = name
