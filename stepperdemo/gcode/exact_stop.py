"""Today's executor: every block a straight line from rest to rest (exact stop).

A block is executed as one or more *runs*.  A run starts all moving axes together
(their queues filled, then started on one tick, after a lead for the drivers'
enable and direction delays) and follows one time law (:mod:`.timelaw`) along the
path: axis i makes its step j when the path fraction reaches ``j / n_i``, so every
axis stays within a step of the line and all arrive on the same tick.  An arc's chord
(``Move.exact``: its ends between steps) runs from rest to rest between its ends
rounded to steps, along the chord itself: each axis's step where the chord is half a
step before it (the axis on the step nearest to the chord), the last on the end where
the block ends on a whole step of the axis (:meth:`AxisFeed.fraction`); its speeds
from the chord's own lengths.

The queues are fed only a short time ahead (:attr:`ExactStopExecutor.ahead_ticks`),
so the law can still be changed from the *frontier* - the latest tick any axis's
commands reach - on:

* a feed hold replaces the rest of the law by a deceleration along the path with the
  block's acceleration; the run ends at rest where it stopped (Grbl's ``Hold:1`` ->
  ``Hold:0``); a resume is a new run of the same block from there, from rest, with
  each axis's step count carried over - no step is lost or added;
* an override change re-plans the rest of the law towards the new speed.

Step times become queue commands as in :mod:`.line`: steady steps grouped (at most
255, spanning at most ``group_span`` ticks, at least the minimum command time), a
group ends exactly where its next step is due; a step far from the next one is a
short command followed by pauses of at most ``ahead_ticks`` each (so that a slow
axis does not commit the law far ahead); the last step of a run is followed by the
common ``tail``, so the queues run dry together.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from fas.codes import AqeResult

from .interp import Move
from .line import MAX_STEPS, MAX_TICKS, Limits, group_commands
from .motion import BlockQueue, HoldState, MotionExecutor, MotionHost, SpeedListener
from .timelaw import TimeLaw, ramp_to_rest, stop_from

Command = tuple[int, int, bool]


@dataclass
class HoldRecord:
    """One feed hold, for reports and tests: when it was asked, where the deceleration
    begins (the frontier) and from what state (path fraction and fraction/s)."""

    asked: int
    frontier: int
    s: float
    v: float
    accel: float
    block: Move
    stopped_at: int | None = None
    s_stop: float | None = None


class AxisFeed:
    """One moving axis of a run: how far its commands reach and how many steps of the
    block they make."""

    def __init__(self, index: int, stepper, n: int, done: int, up: bool, start: int,
                 path: tuple[float, float, int] | None = None) -> None:
        self.index = index
        self.stepper = stepper
        self.n = n  # steps of the whole block
        self.done = done  # steps made by commands computed so far (earlier runs included)
        self.up = up
        self.cur = start  # tick at which the next command begins
        self.finished = False  # no more steps in this run
        self.pending: deque[Command] = deque()  # computed, not yet in the queue
        #: a path between steps (an arc's chord ends): its start and end on this axis
        #: and the step the axis starts on (None: from a step to a step)
        self.path = path

    def fraction(self, j: int) -> float:
        """The path fraction at which step ``j`` (1..n) is due: from a step to a step
        ``j / n``; along a path between steps where the path is half a step before it
        (the axis on the step nearest to the path), the last on the end where the
        block ends on a whole step of the axis."""
        path = self.path
        if path is None:
            return j / self.n
        x0, x1, p0 = path
        if j == self.n and float(p0 + (j if self.up else -j)) == x1:
            return 1.0
        d = 1 if self.up else -1
        s = (p0 + j * d - 0.5 * d - x0) / (x1 - x0)
        return 0.0 if s < 0.0 else 1.0 if s > 1.0 else s


@dataclass
class Run:
    block: Move
    law: TimeLaw
    origin: int  # tick of the law's t = 0 (the start plus the lead)
    start: int
    lead: int
    length: float  # path length, units
    accel: float  # path fractions/s²
    cruise: float  # path fractions/s
    axes: list[AxisFeed] = field(default_factory=list)
    started: bool = False
    stopping: bool = False  # a hold replaced the law's rest

    def emitted(self) -> bool:
        return all(a.finished and not a.pending for a in self.axes)


class ExactStopExecutor(MotionExecutor):
    """Blocks from rest to rest, with feed hold, resume, jog cancel and overrides."""

    kind = "exact_stop"

    def __init__(self, host: MotionHost, blocks: BlockQueue,
                 ahead_ms: float = 20.0) -> None:
        super().__init__(host, blocks)
        backend = host.backend
        p = backend.profile
        self.tps = p.ticks_per_s
        self.min_cmd = p.min_cmd_ticks
        self.group_span = max(2 * p.min_cmd_ticks, p.ticks_per_s // 500)  # as .line
        self._ahead_base = int(ahead_ms * p.ticks_per_ms)
        # a pause commits the law this far at most (a slow axis waits in pieces)
        self.piece = max(self.group_span, self._ahead_base)
        self.tail = self.min_cmd  # after a run's last step (set per run)
        self.run: Run | None = None
        self._hold = HoldState.NONE
        self._remainder: tuple[Move, float, list[int]] | None = None  # held mid-block
        #: the last block completed: its target and exact end (an arc's chord end)
        self._from: tuple[tuple[int, ...], tuple[float, ...] | None] | None = None
        self._resume = False
        self.feed_percent = 100
        self.rapid_percent = 100
        self.runs: list[tuple[int, int]] = []  # (start tick, lead ticks) of every run
        self.holds: list[HoldRecord] = []
        self.speed_listener: SpeedListener | None = None  # the laser hook (issue 25)

    # ------------------------------------------------------------- facts
    @property
    def ahead_ticks(self) -> int:
        """How far ahead the queues are fed: a device behind a link needs its margin too
        (measured by the serial backend as it goes)."""
        return self._ahead_base + int(getattr(self.host.backend, "planning_extra_ticks", 0))

    def _limits(self, stepper) -> Limits:
        return Limits(self.tps, self.min_cmd, stepper.get_max_speed_in_ticks(),
                      self.group_span)

    def hold_state(self) -> HoldState:
        return self._hold

    def current(self) -> Move | None:
        if self.run is not None:
            return self.run.block
        if self._remainder is not None:
            return self._remainder[0]
        return None

    def busy(self) -> bool:
        return self.run is not None or self._remainder is not None or len(self.blocks) > 0

    def moving(self) -> bool:
        return self.run is not None or any(s.is_running() for s in self.host.steppers)

    def committed(self) -> bool:
        if self._remainder is not None or self._hold == HoldState.STOPPING:
            return False
        if self.run is None:
            return len(self.blocks) == 0
        return len(self.blocks) == 1 and self.run.emitted()

    def path_rate(self) -> float:
        run = self.run
        if run is None or not run.started:
            return 0.0
        t = (self.host.backend.now() - run.origin) / self.tps
        return run.law.state_at(t)[1] * run.length * 60

    def frontier(self) -> int:
        run = self.run
        now = self.host.backend.now()
        if run is None:
            return now
        return max([now] + [a.cur for a in run.axes])

    # ---------------------------------------------------------- requests
    def hold(self) -> None:
        if self._hold != HoldState.NONE:
            return
        run = self.run
        now = self.host.backend.now()
        if run is None:
            self._hold = HoldState.HELD  # nothing moves: the next block waits
            return
        self._hold = HoldState.STOPPING
        front = self.frontier()
        t = (front - run.origin) / self.tps
        s, v = run.law.state_at(t)
        self.holds.append(HoldRecord(now, front, s, v, run.accel, run.block))
        if t < run.law.end_t:
            run.law = run.law.replace_from(t, stop_from(t, s, v, run.accel))
            run.stopping = True

    def resume(self) -> None:
        if self._hold == HoldState.HELD:
            self._hold = HoldState.NONE
            self._resume = self._remainder is not None

    def discard(self) -> None:
        if self._remainder is not None:
            self._remainder = None
            if len(self.blocks):
                self.blocks.pop()
        self._resume = False

    def abort(self) -> None:
        for s in self.host.steppers:
            s.force_stop_and_new_position(s.get_current_position())
        self.run = None
        self._from = None
        self._remainder = None
        self._resume = False
        self._hold = HoldState.NONE

    def set_overrides(self, feed_percent: int, rapid_percent: int) -> None:
        self.feed_percent, self.rapid_percent = feed_percent, rapid_percent
        run = self.run
        if run is None or run.stopping or self._hold != HoldState.NONE or run.block.jog:
            return
        cruise = self._cruise(run.block, run.length)
        if math.isclose(cruise, run.cruise):
            return
        run.cruise = cruise
        front = self.frontier()
        t = (front - run.origin) / self.tps
        if t >= run.law.end_t:
            return
        s, v = run.law.state_at(t)
        run.law = run.law.replace_from(t, ramp_to_rest(t, s, v, cruise, run.accel))

    # ------------------------------------------------------------ driving
    def poll(self) -> None:
        now = self.host.backend.now()
        while True:
            run = self.run
            if run is not None:
                err = self._feed(run, now)
                if err is not None:
                    self.host.motion_failed(err)
                    return
                if not (run.emitted() and not any(a.stepper.is_running() for a in run.axes)):
                    return
                self._finish(run, now)
                continue
            if self._hold != HoldState.NONE:
                if self._hold == HoldState.STOPPING:
                    self._hold = HoldState.HELD
                return
            if self._resume and self._remainder is not None:
                block, s0, done = self._remainder
                self._remainder = None
                self._resume = False
                self._start(block, s0, done, now)
                continue
            block = self.blocks.peek()
            if block is None:
                return
            self._start(block, 0.0, [0] * len(block.target), now)

    def wake_tick(self) -> int | None:
        b = self.host.backend
        now = b.now()
        run = self.run
        if run is None:
            if self._hold == HoldState.NONE and (self.blocks.peek() is not None
                                                  or self._resume):
                return now
            return now if self._hold == HoldState.STOPPING else None
        times = []
        nxt = b.next_event_time()
        for a in run.axes:
            if a.pending or (not a.finished and a.cur >= now + self.ahead_ticks):
                # waits for queue room, or is fed far enough: a queue event or the
                # moment it is due again
                if nxt is not None:
                    times.append(nxt)
                if not a.pending:
                    times.append(a.cur - self.ahead_ticks // 2)
            elif not a.finished:
                times.append(now)
        if not times:  # every command written: the end comes with a machine event
            times.append(nxt if nxt is not None else now + self.host.backend.profile
                         .fill_period_ticks)
        return max(min(times), now)

    # -------------------------------------------------------------- runs
    def _cruise(self, block: Move, length: float) -> float:
        """The block's speed in path fractions/s (before the axes' limits)."""
        top = self._top_speed(block)
        if block.feed is None:
            return top * self.rapid_percent / 100
        feed = block.feed if block.jog else block.feed * self.feed_percent / 100
        return min(top, feed / 60 / length)

    def _path(self, block: Move) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
        """The block's path where it runs between steps - from the previous block's
        exact end (an arc's chord end) to its own - else None (steps to steps)."""
        x0: tuple[float, ...] = tuple(float(v) for v in block.start)
        prev = self._from
        if prev is not None and prev[0] == block.start and prev[1] is not None:
            x0 = prev[1]
        x1 = block.exact if block.exact is not None else tuple(float(v) for v in block.target)
        if x0 == tuple(block.start) and x1 == tuple(block.target):
            return None
        return x0, x1

    def _axis_figures(self, block: Move) -> tuple[list[float], list[float], list[float]]:
        st = self.host.settings
        path = self._path(block)
        deltas: list[float] = ([float(t - s) for t, s in zip(block.target, block.start,
                                                             strict=True)]
                               if path is None else
                               [b - a for a, b in zip(path[0], path[1], strict=True)])
        rates, accels = [], []
        for i, stepper in enumerate(self.host.steppers[:len(deltas)]):
            spu = st.steps_per_unit[i]
            top = self.tps / (stepper.get_max_speed_in_ticks() + 1)
            rates.append(min(st.max_rate[i] * spu / 60, top))
            accels.append(st.acceleration[i] * spu)
        return deltas, rates, accels

    def _top_speed(self, block: Move) -> float:
        deltas, rates, _ = self._axis_figures(block)
        return min(r / abs(d) for d, r in zip(deltas, rates, strict=True) if d)

    def _start(self, block: Move, s0: float, done: list[int], now: int) -> None:
        host = self.host
        st = host.settings
        deltas, rates, accels = self._axis_figures(block)
        accel = min(a / abs(d) for d, a in zip(deltas, accels, strict=True) if d)
        length = math.sqrt(sum((d / st.steps_per_unit[i]) ** 2 for i, d in enumerate(deltas)))
        cruise = self._cruise(block, length)
        steppers = host.steppers
        steps = [t - s for t, s in zip(block.target, block.start, strict=True)]
        moving = [i for i, d in enumerate(steps) if d and done[i] < abs(d)]
        path = self._path(block)
        lead = self.min_cmd
        drivers_off = not getattr(host, "drivers_on", True)
        for i in moving:
            if drivers_off:
                lead = max(lead, steppers[i].get_delay_to_enable_ticks())
            lead = max(lead, steppers[i].get_dir_change_delay_ticks())
        # the last step of every axis is followed by the same wait: the queues run dry
        # together (it must suit the slowest stepper's top speed)
        self.tail = max([self.min_cmd] + [steppers[i].get_max_speed_in_ticks()
                                          for i in moving])
        law = TimeLaw(ramp_to_rest(0.0, s0, 0.0, cruise, accel), s_start=s0)
        run = Run(block, law, now + lead, now, lead, length, accel, cruise)
        run.axes = [AxisFeed(i, steppers[i], abs(steps[i]), done[i], steps[i] > 0, now,
                             None if path is None else
                             (path[0][i], path[1][i], block.start[i]))
                    for i in moving]
        self.run = run
        self.runs.append((now, lead))
        host.enable_drivers()
        for a in run.axes:
            # after a force stop the queue ignores commands until a new motion is planned
            # (the ramp generator clears this; raw commands must do it themselves)
            a.stepper.queue.ignore_commands = False
        err = self._feed(run, now)
        for a in run.axes:
            a.stepper.add_queue_entry(None, start=True)
        run.started = True
        if err is not None:
            host.motion_failed(err)

    def _finish(self, run: Run, now: int) -> None:
        """Every command of the run is made and the queues ran dry."""
        self.run = None
        if self._hold == HoldState.STOPPING:
            rec = self.holds[-1]
            rec.stopped_at, rec.s_stop = now, run.law.end_s
        complete = all(a.done >= a.n for a in run.axes)
        if complete:
            self.blocks.pop()
            self._from = (run.block.target, run.block.exact)
        else:
            done = [0] * len(run.block.target)
            for a in run.axes:
                done[a.index] = a.done
            for i, (t, s) in enumerate(zip(run.block.target, run.block.start, strict=True)):
                if t != s and not any(a.index == i for a in run.axes):
                    done[i] = abs(t - s)  # finished in an earlier run
            self._remainder = (run.block, run.law.end_s, done)
        if self._hold == HoldState.STOPPING:
            self._hold = HoldState.HELD

    # ------------------------------------------------------------ feeding
    def _feed(self, run: Run, now: int) -> AqeResult | None:
        """Commands into every axis's queue up to ``ahead_ticks`` from now."""
        until = now + self.ahead_ticks
        for a in run.axes:
            while True:
                while a.pending:
                    if a.stepper.is_queue_full():
                        break
                    res = a.stepper.add_queue_entry(*a.pending[0], start=run.started)
                    if res != AqeResult.OK:
                        if res.retry:
                            break
                        return res
                    a.pending.popleft()
                if a.pending or a.finished or a.cur >= until:
                    break
                start = a.cur
                a.pending.extend(self._next(run, a))
                if self.speed_listener is not None:
                    self._tell_speed(run, a, start)
        return None

    def set_speed_listener(self, fn: SpeedListener | None, lasers_only: bool = False) -> bool:
        self.speed_listener = fn  # (told of every block)
        return True

    def _tell_speed(self, run: Run, a: AxisFeed, start: int) -> None:
        """The speed listener (laser mode): the path speed at each command of the
        dominant axis just computed (``a.pending`` from ``start``), 0 at its end."""
        if a is not max(run.axes, key=lambda x: x.n):
            return
        fn = self.speed_listener
        assert fn is not None
        tick = start
        for ticks, steps, _up in a.pending:  # (empty before _next: only the new ones)
            if steps:
                t = (tick - run.origin) / self.tps
                fn(tick, run.law.state_at(t)[1] * run.length * 60, run.block)
            tick += ticks * steps if steps > 1 else ticks
        if a.finished:
            fn(a.cur, 0.0, run.block)

    def _tick(self, run: Run, a: AxisFeed, j: int) -> int | None:
        """Tick of the axis's step ``j`` (1..n) under the run's law (None: not in it)."""
        if j > a.n:
            return None
        t = run.law.time_of(a.fraction(j))
        return None if t is None else run.origin + round(t * self.tps)

    def _next(self, run: Run, a: AxisFeed) -> list[Command]:
        """The next command(s) of axis ``a``; advances its state."""
        lim = self._limits(a.stepper)
        # no command (a pause neither) may be shorter than the stepper's step period
        min_cmd, up = max(self.min_cmd, lim.min_step_ticks), a.up
        j = a.done + 1
        due = self._tick(run, a, j)
        if due is None:
            a.finished = True
            return []
        wait = due - a.cur
        if wait >= min_cmd:  # a pause first, in pieces of at most ahead_ticks
            piece = wait if wait <= self.piece + min_cmd else self.piece
            piece = min(piece, MAX_TICKS - min_cmd)
            if 0 < wait - piece < min_cmd:
                piece = wait - min_cmd
            a.cur += piece
            return [(piece, 0, up)]
        # step j is due now (a wait shorter than a command: early by less than that)
        after = self._tick(run, a, j + 1)
        if after is None:  # the last step of this run: the common tail follows it
            d = max(self.tail, min_cmd, lim.min_step_ticks)
            a.cur += d
            a.done = j
            a.finished = True
            return [(d, 1, up)]
        span = after - a.cur
        if span > self.group_span:  # sparse: one short step command, pauses follow
            d = span if span <= self.group_span + min_cmd else max(min_cmd,
                                                                    lim.min_step_ticks)
            d = min(d, MAX_TICKS)
            a.cur += d
            a.done = j
            return [(d, 1, up)]
        m, end = 1, after
        while m < MAX_STEPS:  # steps j .. j+m-1, ending where step j+m is due
            nxt = self._tick(run, a, j + m + 1)
            if nxt is None or nxt - a.cur > self.group_span:
                break
            m, end = m + 1, nxt
        while end - a.cur < min_cmd and m < MAX_STEPS:  # too short for a command
            nxt = self._tick(run, a, j + m + 1)
            if nxt is None:
                break
            m, end = m + 1, nxt
        if end - a.cur < min_cmd:  # only the last step is left after these: take it in
            count = m + 1
            t = max(-(-min_cmd // count), lim.min_step_ticks, self.tail)
            a.cur += t * count
            a.done = j + m
            a.finished = True
            return [(t, count, up)]
        cmds = group_commands(end - a.cur, m, up, lim)
        a.cur += sum(t * n for t, n, _ in cmds)
        a.done = j + m - 1
        return cmds
