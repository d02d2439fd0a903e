"""Electronic gearing: a follower stepper that steps with its leader at n:m.

The follower's queue commands are derived from the leader's queued commands, not from
a speed estimate.  A leader command is a run of pulses at ticks the backend knows
(:meth:`~fas.backend.QueueChannel.end_tick`), so the leader's step times are known
exactly as far ahead as its queue reaches - the forward-planning time, 20 ms.  Counted
from the moment of engagement, the follower's target after each leader pulse is

    y* = floor((n·x + h) / m)          x: leader steps, y: follower steps, n <= m

and a follower step is due where y* changes.  Those steps are written as follower
commands such that at every step edge of either stepper ``|y - (n/m)·x| <= 1``
(edges at the same tick count as one instant):

* a follower step may fall anywhere in its *window*: the ticks at which taking it
  keeps the error within one step before and after it (for the 1:3 of a helix
  winder about three leader steps wide).  Its exact place - on the leader pulse
  that changes y* - is always in the window;
* runs of follower steps are fitted on an evenly spaced grid inside their windows,
  so that one command of up to 255 steps carries them (a queue holds 16 commands);
  a gap longer than one command's 65535 ticks becomes a pulse plus pauses;
* an idle follower is started with a timed start on its first step's tick, so that
  it can join a leader that is already running.

The phase ``h`` keeps the error small on both sides: ``h = m // 2`` for ratios up
to 1/2 (|error| < 1/2 + n/m at the moment the leader stepped and the follower not
yet), ``h = n`` above.

While engaged, the gear is the follower's planner (:class:`GearFollower`, registered
as ``"gear"`` in :mod:`fas.planners`): its fill runs in every periodic task after the
fill of every other planner - so after the leader's own planning.  It wraps the
planner it replaced, which keeps answering the follower's own requests (a program
moves a geared follower only after ``disengage``); ``disengage`` gives that planner
back.

The follower must be idle when the gear engages, without auto enable (its driver
stays on: an enable delay would shift its steps) and without a direction-change
delay.  The leader is driven as usual (ramp generator, moves, runs, stops).  When
the application force-stops the leader it must call :meth:`Gear.force_stop` (both
stop at once).  On a device (serial backend) the guarantee holds as long as the
device's queues do not run dry (underruns shift the leader's timeline).
"""

from __future__ import annotations

from enum import IntEnum
from typing import TYPE_CHECKING, Callable

from .codes import MoveResult
from .planner import Planner, PlannerChange, PlannerHost

if TYPE_CHECKING:  # pragma: no cover
    from .engine import Engine
    from .stepper import Stepper

PLANNER_GEAR = "gear"  # the follower's planner while geared (fas.planners)

MAX_TICKS = 65535  # one queue command's period
MAX_STEPS = 255  # ... and its steps
TRIM_PULSES = 4096  # drop leader pulses already behind us in chunks of this size
LINK_PLANNING_MS = 40  # behind a link the leader plans this much further ahead


class GearResult(IntEnum):
    OK = 0
    ERR_RATIO = -1  # n and m must satisfy 1 <= n <= m
    ERR_FOLLOWER_BUSY = -2  # the follower moves: stop it first
    ERR_AUTO_ENABLE = -3  # the follower uses auto enable
    ERR_DIR_DELAY = -4  # the follower has a direction-change delay
    ERR_NO_TIMING = -5  # the backend cannot tell queue timing or start on a tick
    ERR_SAME_STEPPER = -6


class _Frame:
    """The ratio a follower step was derived with and its origin: the error at a step
    edge is ``m·(y - y_base) - n·(x - x_base)`` in m-ths of a step (x leader steps and
    y follower steps since the gear's origin; the bases move at a ratio change)."""

    __slots__ = ("n", "m", "tight_m", "x_base", "y_base")

    def __init__(self, n: int, m: int, tight_m: int, x_base: int, y_base: int) -> None:
        self.n = n
        self.m = m
        self.tight_m = tight_m  # the tight windows' tolerance (Gear._set_phase)
        self.x_base = x_base
        self.y_base = y_base


class _Event:
    """A follower step: where y* changes (the leader pulse ``k``) and its window."""

    __slots__ = ("tick", "k", "up", "y_before", "frame", "lo", "hi", "open_hi")

    def __init__(self, tick: int, k: int, up: bool, y_before: int, frame: _Frame) -> None:
        self.tick = tick
        self.k = k  # absolute index of the triggering leader pulse
        self.up = up
        self.y_before = y_before
        self.frame = frame  # the ratio and origin it was derived with
        self.lo = 0
        self.hi = 0
        self.open_hi = True  # the window's end was cut by the known horizon


class GearSpan:
    """A stretch of following: from ``start`` (tick; ``end`` None while it lasts) the
    follower's position minus ``y0`` is n/m of the leader's minus ``x0``."""

    __slots__ = ("start", "end", "x0", "y0", "n", "m")

    def __init__(self, start: int, x0: int, y0: int, n: int, m: int) -> None:
        self.start = start
        self.end: int | None = None
        self.x0 = x0
        self.y0 = y0
        self.n = n
        self.m = m


class GearStats:
    """What the gear did: follower steps and commands, and any step placed outside
    its window (``late``: the error bound could not be kept there)."""

    __slots__ = ("steps", "commands", "pauses", "starts", "late", "restarts", "resyncs",
                 "shifted_max")

    def __init__(self) -> None:
        self.steps = 0
        self.commands = 0
        self.pauses = 0
        self.starts = 0
        self.late = 0
        self.restarts = 0  # timed starts that came too late and were redone
        self.resyncs = 0  # the leader's timeline broke; a new origin was taken
        self.shifted_max = 0  # largest |placed tick - exact tick| of a follower step


class Gear:
    """Follower ``follower`` steps n per m steps of ``leader`` (see module text)."""

    def __init__(self, engine: Engine, leader: Stepper, follower: Stepper, *,
                 guard: Callable[[bool], bool] | None = None,
                 on_blocked: Callable[[bool], None] | None = None) -> None:
        self.engine = engine
        self.leader = leader
        self.follower = follower
        p = engine.profile
        self.min_cmd_ticks = p.min_cmd_ticks
        self.urgent_ticks = 3 * p.fill_period_ticks  # commit what starts within this
        self._urgent = self.urgent_ticks  # ... plus the way to the step timer (per task)
        self._tail = self.urgent_ticks
        self.start_margin = p.ticks_per_ms  # timed start: room for the task's own work
        self.tight_run_ticks = 2 * p.ticks_per_ms  # a tight run this long keeps the rate low
        self.guard = guard  # may the follower step up (True) / down (False)?
        self.on_blocked = on_blocked  # called when the guard refused a step
        self.n = 1
        self.m = 1
        self._set_phase()
        self.engaged = False
        self.stats = GearStats()
        self.spans: list[GearSpan] = []  # every stretch of following, for measurements
        self._leader_planning: int | None = None
        self._follower_planner: GearFollower | None = None
        self._reset_tracking()

    # ----------------------------------------------------------------- control
    def check_ratio(self, n: int, m: int) -> bool:
        return 1 <= n <= m

    def engage(self, n: int | None = None, m: int | None = None) -> GearResult:
        """Start following from now on (origin: both positions now)."""
        if n is not None and m is not None:
            if not self.check_ratio(n, m):
                return GearResult.ERR_RATIO
            self.n, self.m = n, m
        if self.leader is self.follower:
            return GearResult.ERR_SAME_STEPPER
        f = self.follower
        if f.is_running():
            return GearResult.ERR_FOLLOWER_BUSY
        if f.get_auto_enable():
            return GearResult.ERR_AUTO_ENABLE
        if f.get_dir_change_delay_ticks():
            return GearResult.ERR_DIR_DELAY
        earliest = f.queue.channel.earliest_start_tick()
        if earliest is None:
            return GearResult.ERR_NO_TIMING
        self._set_phase()
        self._reset_tracking()
        # behind a link (a device) the leader plans further ahead, so that the follower's
        # commands derived from its plan still reach the step timer in time
        lead = max(0, earliest - self.engine.backend.now())
        p = self.engine.profile
        self._leader_planning = self.leader.get_forward_planning_ticks()
        if lead > p.ticks_per_ms:
            base_ms = self._leader_planning // p.ticks_per_ms
            self.leader.set_forward_planning_time_in_ms(min(255, base_ms + LINK_PLANNING_MS))
        self.engaged = True
        self.leader.queue.channel.hold_cuts(True)  # its queued steps must all be made
        self._ingest(initial=True)
        self._open_span(self._origin_tick)
        if not isinstance(f.planner, GearFollower) or f.planner.gear is not self:
            f.set_planner(PLANNER_GEAR, self)  # its fill: after the leader's planning
            planner = f.planner
            assert isinstance(planner, GearFollower)
            self._follower_planner = planner
        self.engine.kick()
        self._commit()  # the leader may be under way: its first steps come soon
        return GearResult.OK

    def _open_span(self, start: int) -> None:
        now = self.engine.backend.now()
        if self.spans and self.spans[-1].end is None:
            self.spans[-1].end = now
        self.spans.append(GearSpan(start, self.x0 + self._x_off + self._x_base,
                                   self.y0 + self._y_base, self.n, self.m))

    def set_ratio(self, n: int, m: int) -> GearResult:
        """A new ratio; while engaged it applies from the leader steps not yet seen."""
        if not self.check_ratio(n, m):
            return GearResult.ERR_RATIO
        self.n, self.m = n, m
        self._set_phase()
        if self.engaged:  # a new origin where the known leader pulses end
            self._x_base = self._x
            self._y_base = self._ystar
            self._open_span(self._pt[-1] + 1 if self._pt else self.engine.backend.now())
        self._new_frame()
        return GearResult.OK

    def disengage(self) -> None:
        """Stop deriving follower steps; the steps already queued still run."""
        if self.engaged and self._leader_planning is not None:
            self.leader.set_forward_planning_ticks(self._leader_planning)
        self.leader.queue.channel.hold_cuts(False)
        self.engaged = False
        gf = self._follower_planner
        if gf is not None and self.follower.planner is gf:
            self.follower.use_planner(gf.base)  # the planner it replaced (steps queued run)
        self._follower_planner = None
        self._events.clear()
        if self.spans and self.spans[-1].end is None:
            self.spans[-1].end = self.engine.backend.now()

    def force_stop(self) -> None:
        """Stop leader and follower at once (positions stay where the pulses stopped)."""
        for s in (self.leader, self.follower):
            s.force_stop_and_new_position(s.get_current_position())
        self.disengage()

    def error_now(self) -> float:
        """Follower minus ratio times leader, in steps from the origin, with the
        positions the library reports now (0 while not engaged)."""
        if not self.engaged:
            return 0.0
        x = self.leader.get_current_position() - self.x0 - self._x_off - self._x_base
        y = self.follower.get_current_position() - self.y0 - self._y_base
        return y - self.n * x / self.m

    def _set_phase(self) -> None:
        n, m = self.n, self.m
        self.h = m // 2 if 2 * n <= m else min(n, m - 1)
        # the tight windows: half way between the error of exact placement and 1 step
        exact = max(self.h, m - self.h, n)
        self.tight_m = (exact + m) // 2 if exact < m else m

    # ----------------------------------------------- periodic task (GearFollower)
    def needs_task(self) -> bool:
        return self.engaged and (bool(self._events) or self.leader.is_running())

    def run_task(self) -> None:
        if not self.engaged:
            return
        if self._resync_pending and not self.follower.queue.channel.is_running():
            self._restart_tracking()
        self._ingest()
        self._commit()
        self._trim()

    # ---------------------------------------------------------- leader pulses
    def _reset_tracking(self) -> None:
        self._pt: list[int] = []  # leader pulse ticks ...
        self._px: list[int] = []  # ... and x after each
        self._p0: int = 0  # absolute index of _pt[0]
        self._seen: int = self.leader.queue.entries_added
        self._last_pos: int | None = None  # leader position after the last pulse seen
        self._horizon: int = 0  # leader queue end: no unknown leader pulse before it
        self._x: int = 0  # leader steps since the origin, after the last pulse seen
        self._x_base = 0
        self._y_base = 0
        self._x_off: int = 0
        self._ystar: int = 0  # follower target after the last pulse seen
        self._events: list[_Event] = []
        self._f_end: int | None = None  # tick where the follower's commands end
        self._bound: bool = False  # ... and the first pending event must fall exactly there
        self._y: int = 0  # follower steps committed
        self._t_last: int | None = None  # tick of the last follower step committed
        self._resync_pending: bool = False
        self._unresolved: list[tuple[int, int, bool, int]] = []  # commands not yet timed
        self._expect_end: int | None = None  # the leader's end tick as last seen
        self._origin_tick: int = self.engine.backend.now()
        self.x0: int = self.leader.get_current_position()
        self.y0: int = self.follower.get_current_position()
        self._new_frame()

    def _new_frame(self) -> None:
        """Follower steps derived from now on: the ratio and origin of now."""
        self._frame = _Frame(self.n, self.m, self.tight_m, self._x_base, self._y_base)

    def _ingest(self, initial: bool = False) -> None:
        """Read the leader commands queued since the last look; derive follower steps.

        The commands are copied at once (the ring slot is reused once executed); their
        ticks are resolved backwards from the queue's end tick as soon as the backend
        knows it (a device confirms a start a round trip later)."""
        q = self.leader.queue
        added = q.entries_added
        queued = (q.next_write_idx - q.read_idx) & 0xFF
        new = queued if initial else added - self._seen
        self._seen = added
        if new > queued:
            self._resync()  # commands ran before the gear saw them
            return
        idx = (q.next_write_idx - new) & 0xFF
        for _ in range(new):
            e = q.entries[idx % q.queue_len]
            self._unresolved.append((e.ticks, e.total_steps, e.count_up, e.end_pos))
            idx = (idx + 1) & 0xFF
        end = q.channel.end_tick()
        if end is None:  # not known (yet): resolve at a later task
            if not q.is_running():
                self._horizon = 0
                self._expect_end = None
                self._unresolved.clear()  # it stopped: those commands are history
            return
        expect = self._expect_end
        if expect is not None:
            expect += sum(t * max(st, 1) for t, st, _up, _pos in self._unresolved[-new:]) \
                if new else 0
            if end != expect and not self._resync_pending:
                # the leader's timeline moved (a late start a device reported): the
                # follower's queued steps no longer fit it
                self._expect_end = None
                self._unresolved.clear()
                self._resync()
                return
        self._expect_end = end
        self._horizon = end
        if not self._unresolved or self._resync_pending:
            self._unresolved.clear()
            return
        spans = []
        t = end
        for ticks, steps, up, end_pos in reversed(self._unresolved):
            t -= ticks * max(steps, 1)
            spans.append((t, ticks, steps, up, end_pos))
        self._unresolved.clear()
        spans.reverse()
        skip_before = None
        if initial:  # join the leader from a little ahead: the follower must start
            skip_before = self._earliest_start() + self.start_margin
            self._origin_tick = skip_before
        for begin, ticks, steps, up, end_pos in spans:
            if steps == 0:
                continue
            d = 1 if up else -1
            first = end_pos - d * steps  # position before the command
            if self._last_pos is not None and first != self._last_pos:
                self._x_off += first - self._last_pos  # positions renamed: not a motion
            self._pulses(begin, ticks, steps, d, first, skip_before)
            self._last_pos = end_pos

    def _pulses(self, begin: int, ticks: int, steps: int, d: int, first: int,
                skip_before: int | None) -> None:
        pt, px, events = self._pt, self._px, self._events
        n, m, h = self.n, self.m, self.h
        frame = self._frame
        x_base, y_base = self._x_base, self._y_base
        x = self._x
        ystar = self._ystar
        pos = first
        t = begin
        for _ in range(steps):
            pos += d
            if skip_before is not None and t < skip_before:
                # already made (or too soon to follow): part of the origin
                self.x0 = pos
                t += ticks
                continue
            x = pos - self.x0 - self._x_off
            target = y_base + (n * (x - x_base) + h) // m
            k = self._p0 + len(pt)
            pt.append(t)
            px.append(x)
            if target != ystar:
                up = target > ystar
                events.append(_Event(t, k, up, ystar, frame))
                ystar += 1 if up else -1
                while ystar != target:  # cannot happen for n <= m; kept for safety
                    events.append(_Event(t, k, up, ystar, frame))
                    ystar += 1 if up else -1
            t += ticks
        self._x = x
        self._ystar = ystar

    def _resync(self) -> None:
        """The leader's timeline broke (its queue ran dry under it): once the follower's
        queued steps have run, start again from where both are then."""
        self.stats.resyncs += 1
        self._resync_pending = True
        self._events.clear()

    def _restart_tracking(self) -> None:
        self._reset_tracking()
        self._ingest(initial=True)
        self._open_span(self._origin_tick)

    def _trim(self) -> None:
        """Forget leader pulses before the last committed follower step."""
        if self._t_last is None or len(self._pt) < 2 * TRIM_PULSES:
            return
        pt = self._pt
        keep = 0
        limit = min(len(pt) - 1, TRIM_PULSES)
        while keep < limit and pt[keep] < self._t_last:
            keep += 1
        if self._events:
            keep = min(keep, self._events[0].k - self._p0)
        if keep > 0:
            del pt[:keep]
            del self._px[:keep]
            self._p0 += keep

    # ----------------------------------------------------------------- windows
    def _earliest_start(self) -> int:
        """The follower channel's earliest timed start (engage() refused a channel
        without timed starts)."""
        earliest = self.follower.queue.channel.earliest_start_tick()
        assert earliest is not None
        return earliest

    def _window(self, ev: _Event, tight: bool = False) -> tuple[int, int]:
        """Ticks at which the follower may take step ``ev`` (both ends included) with
        |m·y - n·x| <= one step (``tight``: the tight tolerance) at every edge, x and
        y counted from the origin of the ratio the step was derived with."""
        fr = ev.frame
        m, n = fr.m, fr.n
        tol = fr.tight_m if tight else m
        full = not tight
        yb = ev.y_before - fr.y_base
        ya = yb + (1 if ev.up else -1)
        # n·x_base taken into the y terms: the loops below compare with n·px[j] as is
        myb, mya = m * yb + n * fr.x_base, m * ya + n * fr.x_base
        pt, px = self._pt, self._px
        i = ev.k - self._p0
        # later than its leader pulse: the leader pulses passed meanwhile see y_before,
        # and the follower edge sees y_after with the leader where it then is
        j = i
        last = len(pt) - 1
        hi = None
        if full and not ev.open_hi:
            hi = ev.hi
            j = last + 1
        while j <= last:
            x = px[j]
            if abs(myb - n * x) > tol or abs(mya - n * x) > tol:
                hi = pt[j] - 1 if j > i else pt[i]
                break
            j += 1
        open_hi = hi is None
        if hi is None:  # no known leader pulse ends it: the unknown ones come from here
            hi = max(pt[i], self._horizon - 1)
        # earlier: the leader pulses from the follower edge on see y_after
        lo = pt[i]
        j = i - 1
        floor_t = self._t_last if self._t_last is not None else -1
        while j >= 0:
            if abs(mya - n * px[j]) > tol:
                break
            lo = pt[j]  # the follower edge after leader pulse j sees x = px[j]
            if lo <= floor_t:
                break
            j -= 1
        if lo <= floor_t:
            lo = floor_t + 1
        if full:
            ev.lo, ev.hi, ev.open_hi = lo, hi, open_hi
        return lo, hi

    # ---------------------------------------------------------------- commands
    def _commit(self) -> None:
        f = self.follower
        q = f.queue
        q.ignore_commands = False  # the gear plans this queue (as the ramp task's fill)
        ch = q.channel
        events = self._events
        final = not self.leader.is_ramp_generator_active()
        while events:
            if q.is_queue_full():
                return
            if ch.is_running() and q.is_queue_empty():
                return  # its last command runs out: a timed start follows
            now = self.engine.backend.now()
            # what must be written now: the next tasks' time plus the way to the step
            # timer (a device: the link's lead)
            earliest_start = ch.earliest_start_tick()
            assert earliest_start is not None  # engage() refused channels without one
            lead = max(0, earliest_start - now)
            self._urgent = self.urgent_ticks + lead
            # a step with no known successor is written only when the follower would
            # otherwise run dry before the next task
            self._tail = 2 * self.engine.profile.fill_period_ticks + lead
            ev0 = events[0]
            lo0 = self._window(ev0)[0]
            if not ch.is_running():
                if self._resync_pending:
                    self._restart_tracking()  # a new origin; the next task goes on
                    return
                earliest = earliest_start + self.start_margin
                t0 = max(ev0.tick, lo0, earliest)
                if t0 - now > self._urgent and len(events) < 2 and not final:
                    return  # not yet: the next step decides the first command
                saved = (list(events), self._y, self._t_last)
                self._f_end = t0
                self._bound = True
                if self.guard is not None and not self.guard(ev0.up):
                    self._blocked(ev0.up)
                    return
                if not self._fit_and_queue(t0, now, final):
                    self._f_end = None
                    return
                if not self._timed_start(t0):
                    events[:], self._y, self._t_last = saved
                    return
                continue
            if self._resync_pending:
                return  # the queued commands run out first
            if self._bound:
                bound_end = self._f_end
                assert bound_end is not None  # bound: set with the commands' end
                t0 = bound_end
            else:
                placed = self._place_after_gap(ev0, lo0, now, final)
                if placed is None:
                    return
                t0 = placed
            if self.guard is not None and not self.guard(ev0.up):
                self._blocked(ev0.up)
                return
            if not self._fit_and_queue(t0, now, final):
                return

    def _place_after_gap(self, ev0: _Event, lo0: int, now: int,
                         final: bool) -> int | None:
        """The follower's commands end at a free tick: pause up to the next step."""
        f_end = self._f_end
        assert f_end is not None  # the follower runs: its commands end there
        target = max(ev0.tick, lo0)
        gap = target - f_end
        if gap < 0 or (gap < self.min_cmd_ticks and f_end >= lo0):
            t0 = f_end  # as soon as the commands allow (inside the window or late)
        else:
            if gap < self.min_cmd_ticks:
                target = f_end + self.min_cmd_ticks
                gap = self.min_cmd_ticks
            if target - now > self._urgent and not final:
                # far ahead: pause only as far as needed now
                if f_end - now > self._urgent:
                    return None
                chunk = min(MAX_TICKS, target - f_end - self.min_cmd_ticks)
                if chunk < self.min_cmd_ticks or not self._room(1):
                    return None
                self._pause(chunk)
                return None
            if not self._room(len(split_ticks(gap)) + 1):
                return None
            self._pause_chain(gap)
            t0 = target
        self._bound = True
        self._f_end = t0
        return t0

    def _room(self, entries: int) -> bool:
        q = self.follower.queue
        return q.queue_len - q.queue_entries() >= entries

    def _fit(self, t0: int, tight: bool) -> tuple[tuple[int, int, int] | None, bool]:
        """The longest run from the first event at ``t0`` on an even grid inside the
        windows (``tight``: of the tight tolerance): ((steps, lowest period, highest
        period) or None, whether the known events ran out before the run had to end)."""
        events = self._events
        ev0 = events[0]
        p = self.follower.queue.max_speed_in_ticks
        min_cmd = self.min_cmd_ticks
        dlo, dhi = 1, MAX_TICKS
        best: tuple[int, int, int] | None = None
        for k in range(1, MAX_STEPS + 1):
            if k >= len(events):
                return best, True
            if events[k - 1].up != ev0.up:
                return best, False
            lo, hi = self._window(events[k], tight)
            dlo = max(dlo, -(-(lo - t0) // k))
            dhi = min(dhi, (hi - t0) // k)
            if dlo > dhi:
                return best, False
            need = max(p, -(-min_cmd // k)) if k >= 2 else max(p, min_cmd)
            if max(dlo, need) <= dhi:
                best = (k, max(dlo, need), dhi)
        return best, False

    def _fit_and_queue(self, t0: int, now: int, final: bool) -> bool:
        """Queue the run of steps that starts with the first event at ``t0``.

        A run inside tight windows (the error well below one step) is taken if it
        is long enough to keep the command rate low; otherwise the run inside the
        full one-step windows."""
        events = self._events
        ev0 = events[0]
        urgent = t0 - now <= self._urgent
        best, ran_out = self._fit(t0, True)
        good = best is not None and (ran_out or best[0] == MAX_STEPS
                                     or best[0] * best[1] >= self.tight_run_ticks)
        far = False
        if not good and len(events) >= 2:
            # the next step is further than one command reaches: a pulse and pauses
            # keep the steps on their leader pulses
            far = self._window(events[1], True)[0] - t0 > MAX_TICKS
        if not good and not far:
            best, ran_out = self._fit(t0, False)
        p = self.follower.queue.max_speed_in_ticks
        min_cmd = self.min_cmd_ticks
        if best is not None and not far:
            k, lo, hi = best
            if ran_out and not urgent and not final and events[k].open_hi:
                return False  # more leader pulses may lengthen this run: wait
            if not self._room(1):
                return False
            ideal = (events[k].tick - t0) / k
            d = min(max(round(ideal), lo), hi)
            self._queue_steps(d, k, ev0.up)
            for i in range(k):
                self._shifted(t0 + i * d, events[i])
            del events[:k]
            self._f_end = t0 + k * d
            self._bound = True
            self._t_last = t0 + (k - 1) * d
            return True
        if len(events) >= 2:  # the next step cannot be reached by one command
            lo1, hi1 = self._window(events[1], far)
            t1 = min(max(events[1].tick, lo1), hi1)
            dmin1 = max(p, min_cmd)
            if t1 - t0 < dmin1:
                t1 = t0 + dmin1
            if not self._room(len(split_ticks(t1 - t0))):
                return False
            self._shifted(t0, ev0)
            self._single(t0, t1 - t0, ev0.up)
            del events[:1]
            self._f_end = t1
            self._bound = True
            return True
        # only this step is known
        if not (t0 - now <= self._tail or final):
            return False
        if final and self._horizon <= t0 + 2 * min_cmd:
            wait = max(p, min_cmd)  # the leader stops: so does the follower
        else:
            wait = min(MAX_TICKS, max(max(p, min_cmd), self._horizon - t0 - min_cmd))
        if not self._room(1):
            return False
        self._shifted(t0, ev0)
        self._single(t0, wait, ev0.up)
        del events[:1]
        self._f_end = t0 + wait
        self._bound = False
        return True

    def _shifted(self, t: int, ev: _Event) -> None:
        shift = abs(t - ev.tick)
        if not shift:
            return  # on its leader pulse: always inside the window
        if shift > self.stats.shifted_max:
            self.stats.shifted_max = shift
        lo, hi = self._window(ev)
        if not lo <= t <= hi:
            self.stats.late += 1

    def _single(self, t0: int, gap: int, up: bool) -> None:
        """One step at ``t0``, the next thing ``gap`` ticks later."""
        if gap <= MAX_TICKS:
            self._queue_steps(gap, 1, up)
        else:
            parts = split_ticks(gap)
            self._queue_steps(parts[0], 1, up)
            for part in parts[1:]:
                self._pause(part)
        self._t_last = t0

    def _pause_chain(self, gap: int) -> None:
        for part in split_ticks(gap):
            self._pause(part)

    def _pause(self, ticks: int) -> None:
        f = self.follower
        f.add_queue_entry(ticks, 0, f.queue.queue_end_count_up, start=False)
        self.stats.pauses += 1
        if self._f_end is not None:
            self._f_end += ticks

    def _queue_steps(self, ticks: int, steps: int, up: bool) -> None:
        self.follower.add_queue_entry(ticks, steps, up, start=False)
        self.stats.commands += 1
        self.stats.steps += steps
        self._y += steps if up else -steps

    def _timed_start(self, t0: int) -> bool:
        ch = self.follower.queue.channel
        begin = ch.start_at(t0)
        self.stats.starts += 1
        if begin == t0:
            return True
        # too late (the task took longer than allowed for): drop, try again next task
        self.stats.restarts += 1
        self.start_margin *= 2
        f = self.follower
        f.force_stop_and_new_position(f.get_current_position())
        self._f_end = None
        self._bound = False
        return False

    def _blocked(self, up: bool) -> None:
        if self.on_blocked is not None:
            self.on_blocked(up)
        self.disengage()


def split_ticks(gap: int) -> list[int]:
    """``gap`` ticks as command lengths of at most 65535 each (the first the longest)."""
    n = -(-gap // MAX_TICKS)
    base, extra = divmod(gap, n)
    return [base + 1] * extra + [base] * (n - extra)


class GearFollower(Planner):
    """The follower's planner while geared (see the module text): the gear writes its
    queue after every other planner's fill; the planner it replaced (``base``) answers
    the follower's own requests and state, and is given back by ``disengage``."""

    fills_late = True

    def __init__(self, host: PlannerHost, base: Planner, gear: Gear) -> None:
        super().__init__(host)
        self.base = base
        self.gear = gear
        self.queue = base.queue

    # --- the follower's own requests: its planner before the gear
    def check_move(self, delta: int) -> MoveResult:
        return self.base.check_move(delta)

    def check_held(self) -> MoveResult:
        return self.base.check_held()

    def move(self, delta: int) -> MoveResult:
        return self.base.move(delta)

    def move_to(self, position: int) -> MoveResult:
        return self.base.move_to(position)

    def run(self, count_up: bool) -> MoveResult:
        return self.base.run(count_up)

    def keep_running(self) -> None:
        self.base.keep_running()

    def keep_speed(self) -> None:
        self.base.keep_speed()

    def apply_settings(self) -> None:
        self.base.apply_settings()

    def stop(self) -> None:
        self.base.stop()

    def force_stop(self) -> None:
        self.base.force_stop()

    def force_stop_at(self, position: int) -> None:
        self.base.force_stop_at(position)

    def single_step(self, count_up: bool) -> None:
        self.base.single_step(count_up)

    def positions_shifted(self, delta: int) -> None:
        self.base.positions_shifted(delta)

    # --- the periodic task: the follower's planner, then the gear
    def fill(self) -> int:
        generated = self.base.fill()
        self.gear.run_task()
        return generated

    def needs_task(self) -> bool:
        return self.base.needs_task() or self.gear.needs_task()

    # --- state: the follower's planner's
    def is_running(self) -> bool:
        return self.base.is_running()

    def is_active(self) -> bool:
        return self.base.is_active()

    def is_running_continuously(self) -> bool:
        return self.base.is_running_continuously()

    def is_stopping(self) -> bool:
        return self.base.is_stopping()

    def ramp_state(self) -> int:
        return self.base.ramp_state()

    def target_pos(self) -> int:
        return self.base.target_pos()

    def steps_to_stop(self) -> int:
        return self.base.steps_to_stop()

    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        return self.base.current_speed(realtime)

    def planned_period_ticks(self) -> int:
        return self.base.planned_period_ticks()

    def current_acceleration(self) -> int:
        return self.base.current_acceleration()

    def fastest_period_ticks(self) -> int:
        return self.base.fastest_period_ticks()


def make_follower(host: PlannerHost, current: Planner, kept: Planner | None,
                  gear: Gear) -> tuple[PlannerChange, Planner | None]:
    """The registry's factory: ``stepper.set_planner("gear", gear)`` (what
    :meth:`Gear.engage` does)."""
    if isinstance(current, GearFollower) and current.gear is gear:
        return PlannerChange.OK, None
    return PlannerChange.OK, GearFollower(host, current, gear)
