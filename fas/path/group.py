"""A group of steppers moving along one path: the API a G-code machine calls.

    group = PathGroup([x, y, z], PathSettings(axes=(AxisLimits(80, 3000, 500),) * 3))
    group.attach()                          # each stepper's planner becomes "path"
    group.line((800, 0, 0), feed=1200)      # target in steps, feed in units/min
    group.line((800, 800, 0), feed=1200)    # ... QUEUE_FULL: call again later
    group.flush()                           # no more for now: run to the end
    group.hold(); group.resume(); group.cancel(); group.abort()

Blocks go into the look-ahead queue (:mod:`fas.path.lookahead`); the periodic task
(the fill of the group's lowest-numbered stepper) makes the motion final up to the
queues' forward-planning horizon (:mod:`fas.path.executor`) and writes every axis's
commands (:mod:`fas.path.stepping`).

**Runs.**  Motion happens in *runs*: every queue of the group starts on one tick (a
timed start where the backend has it) with a pause, and from then on each axis's
commands follow one common timeline - an axis that does not move writes pauses - so
the axes stay together for as long as the run lasts.  A run ends where the path stops
with nothing after it (end of the queued blocks, a feed hold): the queues run out,
and the next blocks begin a new run.  A run starts once the first block has waited
``start_delay_ms`` (more may follow at once), or earlier when the group is flushed,
its queue is full, or it holds twice the forward-planning time of motion.

**Feed hold.**  :meth:`hold` decelerates from the end of what the queues hold (at
most the forward-planning time plus one task period after the call) along the path,
through blocks if need be, at each block's acceleration; the group is then ``HELD``
with the rest of the path queued, starting from where the axes stand.
:meth:`resume` goes on from there; :meth:`cancel` drops the rest (a jog cancel).
:meth:`abort` stops every axis at once and drops everything.

**What the queues must allow.**  The axes' commands must not be shifted by anything
the library inserts: no auto enable (its enable delay), no direction-change delay,
no driver that pauses at a direction change (ESP32's RMT and I2S), and no direction
pin shared by two axes (:meth:`attach` refuses those with a :class:`PathResult`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from operator import sub
from typing import TYPE_CHECKING

from ..codes import PIN_UNDEFINED
from ..planner import PlannerChange
from .axis import PLANNER_PATH, PathAxis
from .executor import BlendSegment, Executor
from .lookahead import Block, Lookahead, pin_after
from .settings import BLEND_SHARE, AxisLimits, PathResult, PathSettings, PathState
from .stepping import MAX_TICKS, AxisStats, AxisWriter, SpeedListener, Wrote

if TYPE_CHECKING:  # pragma: no cover
    from ..backend import Backend
    from ..stepper import Stepper

INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1

#: enum members a task or a line returns or compares with, bound once (a class
#: attribute look-up of an enum member costs about ten times a global's)
_OK = PathResult.OK
_WROTE_ERROR = Wrote.ERROR


class PathStats:
    """What a group did (besides each axis's :class:`~fas.path.stepping.AxisStats`)."""

    __slots__ = ("blocks", "runs", "start_retries", "underruns", "errors", "holds")

    def __init__(self) -> None:
        self.blocks = 0  # blocks queued
        self.runs = 0  # runs started
        self.start_retries = 0  # a timed start came too late and was made again
        self.underruns = 0  # a queue ran dry inside a run: stopped at once, re-planned
        self.errors = 0  # a queue refused a command: the run was aborted
        self.holds = 0


class HoldStart:
    """Where a feed hold's deceleration began: tick, path speed (units/s), the block
    and the distance along it (units)."""

    __slots__ = ("tick", "speed", "block", "distance")

    def __init__(self, tick: float, speed: float, block: Block | None,
                 distance: float) -> None:
        self.tick = tick
        self.speed = speed
        self.block = block
        self.distance = distance


class PathGroup:
    """Steppers moving along one path (see the module text)."""

    def __init__(self, steppers: Sequence[Stepper], settings: PathSettings | None = None
                 ) -> None:
        self.steppers = list(steppers)
        n = len(self.steppers)
        if settings is None:
            settings = PathSettings(axes=(AxisLimits(),) * n)
        self.settings = settings
        self.axes: list[PathAxis] = []
        self.writers: list[AxisWriter] = []
        self._lead: PathAxis | None = None
        self.attached = False
        self.stats = PathStats()
        self.position = [0] * n  # steps: where the axes stand at the queued path's end
        self.exact = [0.0] * n  # ... and the path's end itself (between steps: an arc)
        self.lookahead = Lookahead(settings.axes, settings.junction_deviation,
                                   settings.queue_blocks,
                                   blend_share=BLEND_SHARE if settings.corner_blends else 0.0)
        self.lookahead.plain_steps = settings.plain_corner_steps
        self.backend: Backend | None = None
        self.tps = 1
        self.executor = Executor(self.lookahead, 1)
        #: when a list: every corner blend executed, (corner in steps, its segment) -
        #: what the path as run is measured against (tests, benches)
        self.blend_log: list[tuple[tuple[int, ...], BlendSegment]] | None = None
        self.run_active = False
        self.holding = False  # a feed hold decelerates or holds
        self.held = False  # ... and the axes stand
        self.cancel_pending = False
        self.flushing = False
        self.first_block_tick: int | None = None
        self.start_margin = 0
        self.hold_start: HoldStart | None = None
        self._listener: SpeedListener | None = None
        self._restart = False  # start the next run at once
        self.run_start_tick: int | None = None  # where the latest run began (its pause)

    # ------------------------------------------------------------ joining
    def attach(self) -> PathResult:
        """Make each stepper an axis of this group (its planner becomes ``"path"``)."""
        if self.attached:
            return PathResult.OK
        steppers = self.steppers
        problem = self.settings.problem(len(steppers))
        if problem is not None or not steppers:
            return PathResult.ERR_SETTINGS
        if len({id(s) for s in steppers}) != len(steppers):
            return PathResult.ERR_SAME_STEPPER
        dir_pins: set[int] = set()
        for s in steppers:
            if s.is_running():
                return PathResult.ERR_AXIS_BUSY
            if s.get_auto_enable():
                return PathResult.ERR_AUTO_ENABLE
            if s.get_dir_change_delay_ticks() or self._driver_pauses(s):
                return PathResult.ERR_DIR_DELAY
            pin = s.get_direction_pin()
            if pin != PIN_UNDEFINED:
                if pin in dir_pins:
                    return PathResult.ERR_SHARED_DIR_PIN
                dir_pins.add(pin)
        axes: list[PathAxis] = []
        for s in steppers:
            res = s.set_planner(PLANNER_PATH, self)
            planner = s.planner
            if res != PlannerChange.OK or not isinstance(planner, PathAxis):
                for done, axis in zip(steppers, axes, strict=False):
                    done.use_planner(axis.base)
                return PathResult.ERR_AXIS_BUSY
            axes.append(planner)
        self.axes = axes
        host = axes[0].host
        self.backend = host.backend
        p = host.profile
        self.tps = p.ticks_per_s
        self.start_margin = p.fill_period_ticks
        self.executor = Executor(self.lookahead, self.tps)
        self.executor.blends = self.blend_log
        self.writers = [AxisWriter(i, a.host, self.executor) for i, a in enumerate(axes)]
        for w in self.writers:
            w.listener = self._listener
        self._lead = min(axes, key=lambda a: a.host.index)
        self.attached = True
        self._configure_lookahead()
        self._sync_position()
        return PathResult.OK

    @staticmethod
    def _driver_pauses(stepper: Stepper) -> bool:
        """Does the stepper's driver add pauses at a direction change (ESP32's RMT, I2S)?"""
        kind = stepper.driver_kind()
        if kind is None:
            return False
        profile = stepper.queue.profile
        for pool in profile.drivers:
            if pool.driver == kind:
                # a pause before a direction change is left out after a command of at
                # least that many ticks - and every command before a change is one
                # step and its wait, or a pause, at least a minimum command long
                shortest = max(profile.min_cmd_ticks, pool.max_speed_ticks)
                return (pool.after_dir_change_ticks > 0
                        or pool.before_dir_change_ticks > shortest)
        return False

    #: public name: may ``stepper`` join a group, as far as its driver goes?
    driver_pauses = _driver_pauses

    def detach(self) -> PathResult:
        """Give each stepper its own planner back (only while the group is idle)."""
        if not self.attached:
            return PathResult.OK
        if self.busy():
            return PathResult.ERR_RUNNING
        for s, axis in zip(self.steppers, self.axes, strict=True):
            if s.planner is axis:
                s.use_planner(axis.base)  # (it goes on from the queue's end)
        self.axes = []
        self.writers = []
        self._lead = None
        self.attached = False
        return PathResult.OK

    def configure(self, settings: PathSettings) -> PathResult:
        """New figures (only while the group is idle)."""
        if settings.problem(len(self.steppers)) is not None:
            return PathResult.ERR_SETTINGS
        if self.busy():
            return PathResult.ERR_RUNNING
        self.settings = settings
        self.lookahead.size = settings.queue_blocks
        self.lookahead.blend_share = BLEND_SHARE if settings.corner_blends else 0.0
        self.lookahead.plain_steps = settings.plain_corner_steps
        self._configure_lookahead()
        return PathResult.OK

    def _configure_lookahead(self) -> None:
        s = self.settings
        tops = None
        if self.axes:  # the steppers' own top speed (a little below: rounding)
            tops = [self.tps / (a.queue.max_speed_in_ticks + 1) for a in self.axes]
        self.lookahead.configure(s.axes, s.junction_deviation, tops)

    # ------------------------------------------------------------ the path
    @property
    def speed_listener(self) -> SpeedListener | None:
        return self._listener

    @speed_listener.setter
    def speed_listener(self, fn: SpeedListener | None) -> None:
        """``fn(tick, speed, tag)`` at every command of a block's dominant axis: the
        path speed in units/min from ``tick`` on (0: the path stops there) - a laser's
        power proportional to speed (Grbl's M4) follows it."""
        self._listener = fn
        for w in self.writers:
            w.listener = fn

    def room(self) -> int:
        """Blocks the look-ahead queue takes now."""
        return self.lookahead.size - len(self.lookahead)

    def line(self, target: Sequence[float], feed: float | None = None, *,
             tag: object = None, override: bool = True,
             through: bool = False) -> PathResult:
        """Queue a straight move to ``target`` (steps per axis) at ``feed`` units/min
        (None: the rapid rate - every axis at most its ``max_rate``); ``override``
        False: the feed and rapid overrides leave it alone (a jog).  A target between
        steps (an arc's chord end, not rounded) is a point the path goes through:
        each axis stands on the step nearest to it, within half a step of the path
        on the way (:func:`fas.path.lookahead.pin_after`); a target on whole steps ends
        there exactly, every axis's last step on the block's end tick.  ``through``:
        the path goes on through ``target`` (an arc's chord end, whole steps or not):
        every axis on the step nearest to the path all the way."""
        if not self.attached:
            return PathResult.ERR_NOT_ATTACHED
        la = self.lookahead
        if len(la.blocks) >= la.size:  # (la.full())
            return PathResult.QUEUE_FULL
        axes = self.axes
        n = len(axes)
        if len(target) != n:
            return PathResult.ERR_AXES
        if feed is not None and not (feed > 0 and math.isfinite(feed)):
            return PathResult.ERR_FEED
        isfinite = math.isfinite
        for t in target:
            if not (isfinite(t) and INT32_MIN <= t <= INT32_MAX):
                return PathResult.ERR_RANGE
        for a in axes:
            if a.base.is_active():  # the stepper's own planner has motion to plan
                return PathResult.ERR_AXIS_BUSY
        if not (self.run_active or la.blocks):  # (not busy()): the path begins where
            self._sync_position()  # the axes are, at their top speed now
            self._configure_lookahead()
            la = self.lookahead  # (made anew)
        start = tuple(self.position)
        origin = tuple(self.exact)
        ints: tuple[int, ...] | None = None
        if not through and origin == start:  # (same length: every axis on a whole step)
            ints = tuple([int(t) for t in target])
            if ints != tuple(target):  # (a target between steps)
                ints = None
        if ints is not None:  # steps to steps
            exact = tuple([float(t) for t in ints])
            path: tuple[float, ...] | None = None
        else:  # (a point within a billionth of a step of a whole step is on it)
            exact = tuple([float(round(t)) if abs(t - round(t)) < 1e-9 else float(t)
                           for t in target])
            ints = tuple([pin_after(p, x0, x1)
                          for p, x0, x1 in zip(start, origin, exact, strict=True)])
            path = tuple([x1 - x0 for x1, x0 in zip(exact, origin, strict=True)])
        delta = tuple(map(sub, ints, start))  # (no zip with its keyword: it costs more)
        for i, d in enumerate(delta):  # (by index: see run_task)
            if d < 0 and not axes[i].host.has_direction_pin():
                return PathResult.ERR_NO_DIRECTION_PIN
        block = la.make_block(start, delta, feed, tag, override,
                              None if path is None else origin, path, through)
        if block is None:
            return PathResult.EMPTY_BLOCK
        was_empty = not la.blocks and not self.run_active
        la.add(block)
        self.position = list(ints)
        self.exact = list(exact)
        self.stats.blocks += 1
        if was_empty:
            self.first_block_tick = self._now()
        self._wake()
        return _OK

    def line_units(self, target: Sequence[float], feed: float | None = None, *,
                   tag: object = None, override: bool = True,
                   rounded: bool = True) -> PathResult:
        """:meth:`line` to a target in units (each axis rounded to its nearest step,
        as Grbl's planner does; ``rounded`` False: the point itself, an arc's chord
        end the path goes on through - :meth:`line`'s ``through``)."""
        if len(target) != len(self.settings.axes):
            return PathResult.ERR_AXES
        steps = []
        for v, a in zip(target, self.settings.axes, strict=True):
            x = v * a.steps_per_unit
            if not math.isfinite(x) or not INT32_MIN <= x <= INT32_MAX:
                return PathResult.ERR_RANGE
            steps.append(round(x) if rounded else x)
        return self.line(steps, feed, tag=tag, override=override, through=not rounded)

    def set_overrides(self, feed_percent: float, rapid_percent: float) -> None:
        """Grbl's feed override (blocks with a feed) and rapid override (rapid blocks),
        percent: every queued block is planned again with its new speed; the block in
        execution changes from the end of what is final (at most the forward planning
        time plus a task period from now).  Blocks queued with ``override=False`` keep
        their speed."""
        self.lookahead.set_overrides(feed_percent / 100.0, rapid_percent / 100.0)
        self._wake()

    def flush(self) -> None:
        """No more blocks for now: start at once and run to the end of the queue."""
        self.flushing = True
        self._wake()

    # ----------------------------------------------------------- feed hold
    def hold(self) -> None:
        """Feed hold: decelerate along the path to a stop (see the module text)."""
        if self.holding or not self.attached:
            return
        if self.run_active:
            self.holding = True
            self.stats.holds += 1
            self.executor.hold()
            self.hold_start = None
            self._wake()
        elif self.lookahead.blocks:
            self.holding = self.held = True  # not started: it simply does not start
            self.stats.holds += 1

    def resume(self) -> PathResult:
        """Go on after a feed hold (Grbl: only once the hold has stopped)."""
        if not self.holding:
            return PathResult.OK
        if not self.held:
            return PathResult.ERR_RUNNING
        self.holding = self.held = False
        self.executor.holding = False
        self.flushing = True  # start at once
        self._wake()
        return _OK

    def cancel(self) -> None:
        """Stop along the path (a feed hold) and drop every block after the stop."""
        if not self.attached:
            return
        if self.run_active:
            self.cancel_pending = True
            self.hold()
        else:
            self._drop_all()

    def abort(self) -> None:
        """Stop every axis at once (no deceleration) and drop everything."""
        if not self.attached:
            return
        self._stop_axes_now()
        self._end_run_now()
        self._drop_all()

    def _stop_axes_now(self) -> None:
        """Every queue stops at once; each axis's position is where its pulses stopped."""
        for a in self.axes:
            q = a.queue
            stop_now = getattr(q.channel, "stop_now", None)
            if stop_now is not None:
                # the simulated chip: a compare that raised the pin before the stop is a
                # step even while its interrupt still waits for the CPU (issue 23)
                pos = stop_now()
                q.force_stop()
            else:
                pos = q.current_position()
                q.force_stop()
            q.queue_end_pos = pos

    def _drop_all(self) -> None:
        self.lookahead.clear()
        self.holding = self.held = False
        self.cancel_pending = False
        self.flushing = False
        self.executor.holding = False
        self.first_block_tick = None
        self._sync_position()

    # --------------------------------------------------------------- state
    @property
    def state(self) -> PathState:
        if self.run_active:
            return PathState.HOLDING if self.holding else PathState.RUNNING
        if self.held:
            return PathState.HELD
        return PathState.QUEUED if self.lookahead.blocks else PathState.IDLE

    def busy(self) -> bool:
        return self.run_active or bool(self.lookahead.blocks)

    def is_idle(self) -> bool:
        return not self.busy()

    def planning(self) -> bool:
        if self.lookahead.blocks:
            return True
        if self.run_active:
            for w in self.writers:  # (not all(w.done ...), written out)
                if not w.done:
                    return True
        return False

    def needs_task(self) -> bool:
        return self.run_active or (bool(self.lookahead.blocks) and not self.held)

    def is_lead(self, axis: PathAxis) -> bool:
        return axis is self._lead

    def axis_target(self, axis: PathAxis) -> int:
        return self.position[self.axes.index(axis)]

    def axis_steps_to_stop(self, axis: PathAxis) -> int:
        """Steps ``axis`` makes in a feed hold from the executor's point on (about)."""
        ex = self.executor
        seg = ex.cur
        if seg is None or not self.run_active:
            return 0
        v = ex.v * self.tps
        block = seg.block
        i = self.axes.index(axis)
        d = v * v / (2.0 * block.acceleration)
        return int(d * abs(block.unit[i]) * self.settings.axes[i].steps_per_unit)

    def axis_positions_shifted(self, axis: PathAxis, delta: int) -> None:
        i = self.axes.index(axis)
        self.position[i] += delta
        self.exact[i] += delta
        for b in self.lookahead.blocks:
            start = list(b.start)
            start[i] += delta
            b.start = tuple(start)
            if b.origin is not None:
                origin = list(b.origin)
                origin[i] += delta
                b.origin = tuple(origin)

    def current_speed(self) -> float:
        """The path speed now, units/min (0 at rest)."""
        if not self.run_active:
            return 0.0
        return self.executor.speed_at(float(self._now())) * 60.0

    def tag_at(self, tick: int) -> object:
        """The tag of the block the path is in at ``tick`` (None outside a run)."""
        for seg in self.executor.segments:
            if seg.t_start <= tick <= seg.t_done:
                return seg.tag
        return None

    def axis_stats(self) -> list[AxisStats]:
        return [w.stats for w in self.writers]

    # ----------------------------------------------------------- the task
    def _now(self) -> int:
        return self.backend.now() if self.backend is not None else 0

    def _wake(self) -> None:
        if self.axes:
            self.axes[0].host.wake()

    def _horizon(self, now: int) -> float:
        axes = self.axes
        fp = axes[0].host.settings.forward_planning_ticks
        for a in axes:
            f = a.host.settings.forward_planning_ticks
            if f > fp:
                fp = f
        backend = axes[0].host.backend
        return float(now + fp + backend.planning_extra_ticks + backend.task_period_ticks)

    def run_task(self) -> None:
        """The group's part of one periodic task (from the lead axis's fill)."""
        if not self.attached:
            return
        backend = self.backend  # (self._now() written out: every task)
        now = backend.now() if backend is not None else 0
        if not self.run_active:
            if self._may_start(now):
                self._start_run(now)
            return
        # a queue ran dry inside the run (one writer per axis; by index: a zip with
        # its keyword costs more than the loop; the queue's is_queue_empty written out)
        axes = self.axes
        for i, w in enumerate(self.writers):
            if not w.done:
                q = axes[i].queue
                q.channel.sync()
                if q.next_write_idx == q.read_idx:
                    self._underran()
                    return
        ex = self.executor
        if self.holding and self.hold_start is None:
            seg = ex.cur
            self.hold_start = HoldStart(ex.t, ex.v * self.tps,
                                        seg.block if seg is not None else None,
                                        seg.s_done if seg is not None else 0.0)
        ex.commit(self._horizon(now))
        self._write(now)
        if ex.final:
            for w in self.writers:
                if not w.done:
                    return
            for a in self.axes:
                if a.queue.is_running():
                    return
            self._finish_run()

    def _write(self, now: int | None = None) -> None:
        if now is None:
            now = self._now()
        backend = self.axes[0].host.backend  # (a device: plus the link's lead)
        low_water = 2 * backend.task_period_ticks + backend.planning_extra_ticks
        error = _WROTE_ERROR
        writers = self.writers
        for w in writers:
            if w.fill(now, low_water) == error:
                self.stats.errors += 1
                self.abort()
                return
        keep = writers[0].seq  # the first segment an axis is still in ...
        for w in writers:
            seq = w.seq  # (cursor_seq)
            if seq < keep:
                keep = seq
        ex = self.executor
        for seg in ex.segments:  # ... and the segment the axes are in now
            if seg.t_done >= now:
                if seg.seq < keep:
                    keep = seg.seq
                break
        ex.trim(keep)

    def _may_start(self, now: int) -> bool:
        la = self.lookahead
        if not la.blocks or self.held:
            return False
        if self.flushing or self._restart or la.full():
            return True
        fp = max(a.host.settings.forward_planning_ticks for a in self.axes)
        if la.min_time() * self.tps >= 2 * fp:
            return True
        first = self.first_block_tick if self.first_block_tick is not None else now
        return now - first >= self.settings.start_delay_ms * (self.tps // 1000)

    def _start_run(self, now: int) -> None:
        """Start every queue on one tick with a pause, then write the path after it."""
        axes = self.axes
        host = axes[0].host
        p = host.profile
        for a in axes:
            a.queue.ignore_commands = False  # (a force stop before leaves it set)
        channels = [a.queue.channel for a in axes]
        earliest = [ch.earliest_start_tick() for ch in channels]
        timed = all(e is not None for e in earliest)
        if timed:
            t_s = max(e for e in earliest if e is not None) + self.start_margin
        else:  # no timed start: the queues start one after the other, now
            t_s = host.backend.now() + p.queue_start_ticks
        lead = min(MAX_TICKS, max(p.fill_period_ticks, host.backend.planning_extra_ticks))
        for a in axes:  # one pause each: the run's common beginning
            res = a.host.write(lead, 0, a.queue.queue_end_count_up, False)
            if res.value != 0:
                self._abandon_start()
                return
        self.stats.runs += 1
        self.run_active = True
        for a in axes:
            a.path_moved = True
        self._restart = False
        self.first_block_tick = None
        ex = self.executor
        ex.begin(float(t_s + lead + p.min_cmd_ticks))
        for w in self.writers:
            w.begin(t_s + lead, t_s)
        # the path's first commands are written before the start: a device behind a
        # link gets them ahead of its Start (a queue holding only the lead when it
        # starts would take up a later pause as a restart, twice as long)
        heard: list[tuple[int, float, object]] = []  # the speed listener's, held
        for w in self.writers:  # until the start tick is known
            w.listener = None if self._listener is None else (
                lambda tick, speed, tag: heard.append((tick, speed, tag)))
        ex.commit(self._horizon(now))
        self._write()
        for w in self.writers:
            w.listener = self._listener
        if not self.run_active:
            return  # a queue refused a command: aborted
        shift = 0
        if timed:
            need = max(ch.earliest_start_tick() or 0 for ch in channels)
            if need > t_s:  # the commands written take their time on the link
                shift = need + self.start_margin - t_s
                self._shift_timeline(shift)
                t_s += shift
            for ch in channels:
                if ch.start_at(t_s) != t_s:
                    self.stats.start_retries += 1
                    self.start_margin *= 2
                    self._stop_axes_now()
                    self._requeue()
                    self._restart = True
                    return
        else:
            for a in axes:
                a.host.write(None, 0, True, True)
        self.run_start_tick = t_s
        if self._listener is not None:
            for tick, speed, tag in heard:
                self._listener(tick + shift, speed, tag)

    def _shift_timeline(self, ticks: int) -> None:
        """The run starts ``ticks`` later than planned: everything made final so far
        (and every axis's commands, which are durations) moves with it."""
        self.executor.shift(ticks)
        for w in self.writers:
            w.shift(ticks)

    def _abandon_start(self) -> None:
        for a in self.axes:
            a.queue.force_stop()

    def _underran(self) -> None:
        """A queue ran dry inside the run (its commands came too late: run_task): the
        axes left their common timeline.  Stop at once and plan the rest again from
        rest."""
        self.stats.underruns += 1
        self._stop_axes_now()
        self._requeue()
        self._restart = True

    def _finish_run(self) -> None:
        """Every queue ran out: the run is over."""
        if self.holding:
            self._requeue()
            self.held = True
            if self.cancel_pending:
                self._drop_all()
            return
        self._end_run_now()
        if self.lookahead.blocks:
            self._restart = True  # they came while it ran: no start delay
        else:
            self.flushing = False

    def _end_run_now(self) -> None:
        self.run_active = False
        ex = self.executor
        ex.begin(ex.t)
        for w in self.writers:
            w.done = True

    def _requeue(self) -> None:
        """The axes stand inside the path (a feed hold, an underrun): the blocks not
        yet finished go back into the queue, the first from where the axes are."""
        ex = self.executor
        now = self._now()
        pos = [a.queue.queue_end_pos for a in self.axes]
        la = self.lookahead
        pending: list[Block] = []
        seen: set[int] = set()
        for seg in ex.segments:
            unfinished = seg.t_done > now or not seg.complete or seg is ex.stop_segment
            if unfinished and id(seg.block) not in seen:
                pending.append(seg.block)
                seen.add(id(seg.block))
        for b in la.blocks:
            if id(b) not in seen:
                pending.append(b)
                seen.add(id(b))
        la.clear()
        self._end_run_now()
        self.position = list(pos)
        self.exact = [float(p) for p in pos]
        self.first_block_tick = None
        for b in pending:
            if b.span is None:
                exact = tuple(float(e) for e in b.end)
            else:
                assert b.origin is not None
                exact = tuple(x0 + x for x0, x in zip(b.origin, b.span, strict=True))
            start, origin = tuple(self.position), tuple(self.exact)
            end = tuple(pin_after(p, x0, x1)
                        for p, x0, x1 in zip(start, origin, exact, strict=True))
            delta = tuple(e - s for e, s in zip(end, start, strict=True))
            whole = not b.through and all(
                x == p for x, p in zip(origin + exact, start + end, strict=True))
            span = None if whole else tuple(x1 - x0 for x1, x0 in zip(exact, origin,
                                                                    strict=True))
            nb = la.make_block(start, delta, b.feed, b.tag, b.override,
                               None if whole else origin, span, b.through)
            if nb is None:
                continue
            la.add(nb)
            self.position = list(end)
            self.exact = list(exact)

    def _sync_position(self) -> None:
        """The path begins where the axes' queues end."""
        if self.axes:
            self.position = [a.queue.queue_end_pos for a in self.axes]
        else:
            self.position = [s.get_position_after_commands_completed()
                             for s in self.steppers]
        self.exact = [float(p) for p in self.position]
