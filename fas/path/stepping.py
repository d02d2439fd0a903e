"""One axis of a path: its step times as FastAccelStepper queue commands.

Axis ``i`` makes step ``j`` of a segment at distance ``(j - phase) * pitch``
(:class:`fas.path.executor.Segment`): where the path reaches the step's position, or
half a step before it in a segment from or to a point between steps (an arc's
chords), at the tick the segment's final pieces give for that distance, rounded.  So
at every instant each axis has made exactly the steps the path has passed (the
position rounds down along the path: less than one step behind it; to the nearest
step in an arc's chords), and every axis makes the last step of a segment that ends
on a step at the segment's end tick - all on one tick.  A corner blend
(:class:`fas.path.executor.BlendSegment`) has each axis's step ticks of its own: the
last steps before it, its own and the first of the segment after it are grouped at
one whole period with the last step waiting for the rest, as far as every step stays
at or before its tick and within ``tol`` (:meth:`AxisWriter._blend_group`,
:meth:`AxisWriter._longest`), and the segment after it begins at the step the blend
left each axis at.

The steps become commands ``(ticks, steps, count_up)`` that run back to back from the
run's common start tick, so that each step falls on its tick:

* a *group* of steps at an even period, from a step at the command's start to the
  tick of the step after the group (two commands when the span does not divide:
  periods ``P`` and ``P + 1``, the longer last).  The group lasts at most
  ``sqrt(8 * tol / a_axis)`` where the axis accelerates (its chord then stays within
  ``tol`` steps of the exact times: :data:`fas.path.settings.GROUP_TOLERANCE_STEPS`),
  at most 255 steps, and at least the profile's minimum command time;
* a segment's last step only *begins* a group: the group goes on in the next segment
  if the axis moves on in the same direction, else it is one step and a wait up to
  the axis's next step (pauses where a wait exceeds 65535 ticks);
* where the next step is not final yet (beyond the executor's horizon) the step gets
  a *provisional* wait that ends at least one minimum command time before the
  horizon; pauses fill the rest once the next step is known.  An axis that does not
  move writes pauses, so that every queue of the group keeps its place in time.

Grouped steps come early along the motion, so across an axis's turn their errors
change sign; for :data:`fas.path.settings.TURN_EXACT_S` after its last step before a
turn the axis's steps come on their own ticks (``tol`` 0), so that its acceleration
measured from the pins over step edges >= W apart stays within the limit + ``2 tol /
W^2`` (W up to that time) at the turn too.  Near a corner the executor took plain
(``PathSettings.plain_corner_steps``: Grbl's corner where its blend would differ by
at most that much) a group keeps within ``tol`` less the corner's offset in this axis
(:meth:`fas.path.executor.Executor.tolerance_near`), so that the offset and the
grouping together stay within ``tol`` of the blend.

A step that cannot be placed on its tick (a command would be shorter than the minimum
command time, or a period not a whole number where the two-command split is too
short) is moved to the nearest tick a command allows; :class:`AxisStats` counts those
(``shifted``, ``shift_max``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntEnum
from typing import TYPE_CHECKING, cast

from ..codes import AqeResult
from .executor import BlendSegment, Executor, Segment
from .settings import GROUP_TOLERANCE_STEPS, TURN_EXACT_S

if TYPE_CHECKING:  # pragma: no cover
    from ..planner import PlannerHost

MAX_STEPS = 255  # a command's steps
MAX_TICKS = 65535  # a command's ticks
#: a segment's last steps before a blend, up to this many, group with the blend's
BLEND_LEAD = 32
#: ... and a group through a blend goes on into up to this many steps after it
BLEND_RUN = 32

#: ``listener(tick, speed, tag)``: the path speed (units/min) of a command of a
#: segment's dominant axis beginning at ``tick``; speed 0 where the path stops
SpeedListener = Callable[[int, float, object], None]


class Found(IntEnum):
    STEP = 0  # the next step is final: (seq, j, tick)
    UNKNOWN = 1  # the next step is not final yet
    END = 2  # no more steps in this run


class Wrote(IntEnum):
    OK = 0  # commands written; go on
    WAIT = 1  # nothing to write until more of the path is final
    FULL = 2  # no room in the queue
    ERROR = 3  # the queue refused a command for good


# the members as module constants (the same objects; a class attribute look-up of an
# enum member costs more, and these are compared for every command written)
_OK, _WAIT, _FULL, _ERROR = Wrote.OK, Wrote.WAIT, Wrote.FULL, Wrote.ERROR
_STEP, _UNKNOWN, _END = Found.STEP, Found.UNKNOWN, Found.END
_QUEUED = AqeResult.OK  # (the queue's answer to a command written, as above)


class AxisStats:
    """What one axis wrote."""

    __slots__ = ("commands", "pauses", "steps", "shifted", "shift_max", "errors",
                 "early_ends", "early_max")

    def __init__(self) -> None:
        self.commands = 0
        self.pauses = 0
        self.steps = 0
        self.shifted = 0  # steps placed off their tick
        self.shift_max = 0  # the largest distance from its tick (ticks)
        self.errors = 0
        self.early_ends = 0  # segments' last steps inside a group across segments ...
        self.early_max = 0  # ... and the most ticks one came before its tick


def split_ticks(ticks: int) -> list[int]:
    """``ticks`` as command lengths of at most 65535 each (equal parts)."""
    n = -(-ticks // MAX_TICKS)
    base, extra = divmod(ticks, n)
    return [base + 1] * extra + [base] * (n - extra)


class AxisWriter:
    """Writes one axis's commands for the path the executor made final."""

    def __init__(self, axis: int, host: PlannerHost, executor: Executor) -> None:
        self.axis = axis
        self.host = host
        self.queue = host.queue
        self.ex = executor
        p = host.profile
        self.tps = p.ticks_per_s
        self.min_cmd = p.min_cmd_ticks
        #: a command at least this long keeps two task periods in the queue: a group
        #: shorter than that may go on past a segment's last step (:meth:`_across`)
        self.min_span = 4 * host.backend.task_period_ticks // host.queue.queue_len
        self.tol = GROUP_TOLERANCE_STEPS
        #: steps before this tick are placed on their ticks: the axis turned round
        #: less than TURN_EXACT_S ago (:meth:`_step`)
        self.exact_until = 0
        self.turn_ticks = round(TURN_EXACT_S * self.tps)
        #: the first of the executor's plain corners that may lie near this axis's
        #: next group (Executor.plain_ends; its steps only go on in time)
        self.plain_k = 0
        self.step_dir: bool | None = None  # the direction of the last step written
        self.step_last = 0  # ... and its tick
        self.stats = AxisStats()
        self.listener: SpeedListener | None = None
        self.seq = 0  # the segment of the cursor ...
        self.j = 0  # ... and its step (0: the segment's start)
        self.pending = False  # step (seq, j) is final but not written yet
        self.t_pend = 0  # ... its tick
        self.w_end = 0  # the tick at which the written commands end
        self.done = True  # nothing more to write in this run
        self.up = True  # direction of the queue's end
        self._deep = 0  # an entry taken up after this tick keeps the queue deep enough
        #: the tick at which the channel takes up the last entry written (a pause at
        #: its start, steps at their last): it must come after the next task run
        self.last_start = 0
        self.free = 0  # entries the queue takes (counted down while writing)

    # ----------------------------------------------------------------- a run
    def begin(self, start_tick: int, last_start: int) -> None:
        """A run: the axis's commands go on from ``start_tick``; the entry queued last
        is taken up by the channel at ``last_start``."""
        self.seq = self.ex.first_seq
        self.j = 0
        self.plain_k = 0
        self.pending = False
        self.w_end = start_tick
        self.last_start = last_start
        self.done = False
        self.up = self.queue.queue_end_count_up

    def shift(self, ticks: int) -> None:
        """The run starts ``ticks`` later: the written commands end that much later."""
        self.w_end += ticks
        self.last_start += ticks
        self.step_last += ticks
        self.exact_until += ticks
        if self.pending:
            self.t_pend += ticks

    def cursor_seq(self) -> int:
        return self.seq

    @property
    def min_wait(self) -> int:
        """The shortest command: a step and its wait, or a pause."""
        least = self.min_cmd  # (max(least, fastest) written out: a builtin's call
        fastest = self.queue.max_speed_in_ticks  # costs more than the comparison)
        return fastest if fastest > least else least

    # ---------------------------------------------------------------- writing
    def fill(self, now: int, low_water: int) -> Wrote:
        """Write what is final, while the queue has room.  A group that the horizon
        cuts short, a provisional wait and pauses ahead wait for the next run while
        the channel takes up the last entry more than ``low_water`` ticks after ``now``
        (the next runs make more of the path final: longer commands); a channel that
        takes up its last entry before more is written runs dry."""
        if self.done:
            return _OK
        self._deep = now + low_water
        q = self.queue
        q.channel.sync()  # (q.queue_entries() written out: every task)
        self.free = q.queue_len - ((q.next_write_idx - q.read_idx) & 0xFF)
        while True:
            free = self.free
            if free < 2:
                return _FULL
            if not self.pending:
                found, seq, j, tick = self._next()
                self.seq, self.j = seq, j
                if found == _END:
                    self.done = True
                    return _OK
                if found == _UNKNOWN:
                    return self._pause_ahead(free)
                self.t_pend = tick
                self.pending = True
            gap = self.t_pend - self.w_end
            if gap:
                if gap >= self.min_wait:  # (a pause is refused below the top speed)
                    seg = self.ex.segment(self.seq)
                    assert seg is not None
                    res = self._pauses(gap, seg.step_up(self.axis, self.j), free)
                    if res != _OK:
                        return res
                    continue
                self._shift(gap)  # too close for a pause (or late): the step moves
                self.t_pend = self.w_end
            res = self._step()
            if res != _OK:
                return res

    def _next(self) -> tuple[Found, int, int, int]:
        """The axis's next step after the cursor: ``(STEP, seq, j, tick)``; else
        ``(UNKNOWN or END, seq, j, 0)`` with the place the cursor may move on to (past
        the segments whose steps it has all made)."""
        ex = self.ex
        i = self.axis
        seq, j = self.seq, self.j
        segs = ex.segments  # (ex.segment written out)
        at = seq - ex.first_seq
        seg = segs[at] if 0 <= at < len(segs) else None
        while seg is not None:
            n = seg.steps[i]
            if j < n:
                if j < seg.known(i):
                    if seg.blend and self.tol == 0.0:  # exact: a blend's own ticks
                        return (_STEP, seq, j + 1,
                                cast(BlendSegment, seg).exact_tick(i, j + 1))
                    return _STEP, seq, j + 1, seg.step_tick(i, j + 1)
                if not seg.complete:
                    return _UNKNOWN, seq, j, 0
            elif not seg.complete:
                return _UNKNOWN, seq, j, 0
            at += 1
            nxt = segs[at] if at < len(segs) else None
            if nxt is None:  # not made yet: stay at this one's end (a blend before
                j = n  # the next may have made its first steps)
                break
            seq += 1
            seg = nxt
            j = seg.first[i]
        return (_END if ex.final else _UNKNOWN), seq, j, 0

    def _step(self) -> Wrote:
        """Write the pending step (due at ``w_end``) with the steps it groups with."""
        ex = self.ex
        i = self.axis
        segs = ex.segments
        at = self.seq - ex.first_seq  # (ex.segment written out)
        seg = segs[at] if 0 <= at < len(segs) else None
        assert seg is not None
        # shortly after a turn no step early (TURN_EXACT_S): one step a command
        up = seg.step_up(i, self.j) if seg.blend else seg.ups[i]
        if up != self.step_dir:
            if self.step_dir is not None:
                self.exact_until = self.step_last + self.turn_ticks
            self.step_dir = up
        # (with corner blends only: at Grbl's junctions the velocity jumps at a turn)
        self.tol = (0.0 if self.w_end < self.exact_until and ex.lookahead.blend_share
                    else GROUP_TOLERANCE_STEPS)
        if seg.blend:  # a corner blend: its steps grouped as far as they allow
            return self._blend_group(seg)
        # (Segment.known written out)
        known = seg.steps[i]
        complete = seg.complete
        if known and not (complete and seg.end == seg.length):
            k = int(seg.s_done / seg.pitch[i] + seg.phase[i])
            if seg.on_end[i] and seg.block.span is not None:
                known -= 1
            f = seg.first[i]
            if k < f:
                k = f
            if k < known:
                known = k
        if complete and self.j >= known:  # the segment's last step
            at += 1
            nxt = segs[at] if at < len(segs) else None
            if nxt is not None and nxt.blend:  # it goes on into the blend's steps
                return self._blend_group(seg)
            kn = 0  # (nxt.known(i), asked once)
            if (nxt is not None and seg.end == seg.length and nxt.steps[i]
                    and nxt.ups[i] == seg.ups[i]):
                kn = nxt.known(i)
            if (nxt is not None and kn >= 1
                    and (seg.on_end[i]
                         or nxt.step_tick(i, 1) - self.w_end < self.min_wait)):
                # the same step is the start of the next segment (where the path
                # goes on between steps: its first step is too close for a command
                # of its own, and the pitches differ only by the turn at the joint)
                self.seq += 1
                self.j = 0
                seg = nxt
                known = kn
            else:
                # a joint between steps: the step and a wait up to the next segment's
                # first step, whose steps then follow their own spacing
                return self._single(seg)
        j0 = self.j
        if known <= j0:
            return self._provisional(seg)
        if seg.complete and seg.end != seg.length and known - j0 <= BLEND_LEAD:
            nxt = ex.segment(self.seq + 1)
            if nxt is not None and nxt.blend:
                return self._blend_group(seg)  # the last steps with the blend's
        min_cmd = self.min_cmd
        complete = seg.complete
        pitch = seg.pitch[i]
        phase = seg.phase[i]
        if not complete:  # the steps end a command's time before the horizon
            tb = ex.t - min_cmd
            sb = seg.s_done
            if tb < seg.t_done:
                for p in seg.pieces:  # (Segment.dist_at written out)
                    if tb <= p.t1:
                        tau = tb - p.t0
                        if tau <= 0.0:
                            sb = p.s0
                        else:
                            sb = p.s0 + tau * (p.v0 + 0.5 * p.a * tau)
                            if sb >= p.s1:
                                sb = p.s1
                        break
            back = int(sb / pitch + phase)  # (steps_by)
            if self.last_start > self._deep:
                if back <= j0:
                    return _WAIT  # (cut at j0 + 1 below: the queue is deep)
                last = seg.pieces[-1] if seg.pieces else None
                if (last is not None and last.a == 0.0 and last.t0 <= self.w_end < last.t1
                        and self._cruise_cut(seg, j0, known, back, pitch, phase)):
                    return _WAIT  # (the same as below, found sooner)
        t0 = self.w_end
        # The tick ``t_lim`` up to which a group from ``t0`` may go, ``slowing``:
        # whether the path slows down there.  Grouped steps stay within ``tol`` steps
        # of the exact positions: where the path speeds up, their chord is off by
        # ``a_axis tau^2 / 8`` at most; where it slows down, steps at the first
        # interval's period by ``a_axis tau^2 / 2``; over a cruise they are exact, and
        # the group may go on into a change of speed after it as far as
        # ``a_axis tau^2 / 2`` allows.  A group does not reach from a part that slows
        # down into one that does not, nor back: its steps are placed early on one
        # side and that side differs (:meth:`_group`).
        a = seg.accel / pitch  # steps/tick^2
        pieces = seg.pieces
        count = len(pieces)
        k = 0
        while k < count and pieces[k].t1 <= t0:
            k += 1
        if k == count:  # (past the final pieces: as slowing down, 2 tol / a)
            cruise_end = None
            slowing = False
            factor = 2.0
            boundary = math.inf
        else:
            first = pieces[k]
            slowing = first.a < 0.0
            cruise_end = None
            boundary = math.inf
            while k < count:
                p = pieces[k]
                k += 1
                pa = p.a
                if (pa < 0.0) != slowing:
                    boundary = p.t0
                    break
                if pa == 0.0 and (cruise_end is not None or p is first):
                    cruise_end = p.t1
                elif pa != 0.0 and cruise_end is not None:
                    break
            factor = 2.0 if slowing else 8.0
        jmax = j0 + MAX_STEPS
        if known < jmax:
            jmax = known
        deep = self.last_start > self._deep
        tol = self.tol
        # (_limit written out)
        if cruise_end is not None:
            t_lim = cruise_end + math.sqrt(2.0 * tol / a)
        else:
            t_lim = t0 + math.sqrt(factor * tol / a)
        if t_lim >= boundary:
            t_lim = boundary
        plain = ex.plain
        if plain:  # near a plain corner the tolerance shrinks by its offset
            ends = ex.plain_ends
            n = len(ends)
            base = ex.plain_base
            k = self.plain_k - base  # (the cursor counts the forgotten ones too)
            if k < 0 or k > n:  # (a new run)
                k = 0
            while k < n and ends[k] < t0:
                k += 1
            self.plain_k = k + base
            widen = ex.plain_widen
            if k < n and plain[k][0] - widen <= t_lim:
                # (Executor.tolerance_near from k, written out)
                near = tol
                while k < n:
                    pk = plain[k]
                    if pk[0] - widen > t_lim:
                        break
                    x = tol - pk[2][i]
                    if x < near:
                        near = x
                    k += 1
                if not near > 0.0:  # (at least 0.0)
                    near = 0.0
                if near < tol:
                    self.tol = tol = near
                    if cruise_end is not None:
                        t_lim = cruise_end + math.sqrt(2.0 * tol / a)
                    else:
                        t_lim = t0 + math.sqrt(factor * tol / a)
                    if t_lim >= boundary:
                        t_lim = boundary
        if t_lim >= seg.t_done:
            jh = int(seg.s_done / pitch + phase)  # (steps_by)
        else:
            jh = int(seg.dist_at(t_lim) / pitch + phase)
        if jh > jmax:
            jh = jmax
        elif jh <= j0:
            jh = j0 + 1
        # the horizon, not the group's own limits, ends it
        cut = jh >= known and not complete
        # end a command's time before the horizon: what follows the group must not
        # come out shorter than a command
        if not complete and back < jh:
            cut = True
            jh = back if back > j0 else j0 + 1
        if cut and deep:
            return _WAIT  # the queue is deep: the next run makes it longer
        if jh == seg.steps[i] and complete and seg.end == seg.length and seg.on_end[i]:
            th = seg.end_tick
        else:  # (Segment.step_tick written out: jh >= 1)
            s = (jh - phase) * pitch
            th = int(seg.t_done + 0.5)
            for p in pieces:
                if s <= p.s1:
                    d = s - p.s0
                    if d <= 0.0:
                        th = int(p.t0 + 0.5)
                        break
                    v0 = p.v0
                    root = v0 * v0 + 2.0 * p.a * d
                    den = v0 + math.sqrt(root if root > 0.0 else 0.0)
                    if den <= 0.0:
                        th = int(p.t1 + 0.5)
                        break
                    t = p.t0 + 2.0 * d / den
                    th = int((t if t < p.t1 else p.t1) + 0.5)
                    break
        if th - t0 < min_cmd:  # too short for a command: take more steps
            ahead = seg.steps_by(i, seg.dist_at(t0 + min_cmd))
            if ahead > jh:
                jh = ahead if ahead < jmax else jmax
                th = seg.step_tick(i, jh)
            while th - t0 < min_cmd and jh < jmax:
                jh += 1
                th = seg.step_tick(i, jh)
            if th - t0 < min_cmd and not seg.complete:
                return _WAIT  # the steps that make it long enough are not final
        n = seg.steps[i]
        if seg.complete and jh < n and seg.end == seg.length:
            tn = seg.step_tick(i, n)
            if tn - th < min_cmd:  # the rest up to the last step would be too short
                if n - j0 <= MAX_STEPS:
                    jh, th = n, tn
                else:
                    back = seg.steps_by(i, seg.dist_at(tn - min_cmd))
                    if j0 < back < jh:
                        jh, th = back, seg.step_tick(i, back)
        if jh == n and th - t0 < self.min_span and seg.complete and seg.end == seg.length:
            res = self._across(seg, j0, t0)
            if res is not None:
                return res
        return self._group(seg, jh - j0, th - t0, jh, th, slowing)

    def _cruise_cut(self, seg: Segment, j0: int, known: int, back: int, pitch: float,
                    phase: float) -> bool:
        """Whether the group :meth:`_step` makes from ``w_end`` in ``seg`` (not complete)
        is cut by the horizon where the path cruises from ``w_end`` to the end of what
        is final: its limit ``t_lim`` (a cruise's end plus ``sqrt(2 tol / a)``) then lies
        at or past ``seg.t_done`` whatever the tolerance near a plain corner, so the
        group reaches the last known step - the figures :meth:`_step` finds, without
        its look through the pieces and the plain corners.  (The tolerance is left as
        set: where the queue is deep and the group cut, the next :meth:`_step` sets it
        again; only :meth:`_next` reads it between, after a new run's ``begin``, and
        only whether it is 0 - which no plain corner makes it here, every offset being
        below it.)  False: not found this way (:meth:`_step` goes on)."""
        pieces = seg.pieces  # (the caller found w_end in the last piece, a cruise)
        if pieces[-1].t1 < seg.t_done or (len(pieces) > 1 and pieces[-2].t1 > self.w_end):
            return False  # (w_end not in a cruise that is the last piece)
        tol = self.tol
        if tol != 0.0 and self.ex.plain and not self.ex.plain_most < tol:
            return False  # (a plain corner might shrink the tolerance to 0)
        jh = int(seg.s_done / pitch + phase)  # (steps_by)
        jmax = j0 + MAX_STEPS
        if known < jmax:
            jmax = known
        if jh > jmax:
            jh = jmax
        elif jh <= j0:
            jh = j0 + 1
        return jh >= known or back < jh

    def _limit(self, t0: int, a: float, cruise_end: float | None, factor: float,
               boundary: float) -> float:
        """The tick up to which a group from ``t0`` stays within ``tol`` steps (see
        :meth:`_step`): ``a`` the axis's acceleration (steps/tick^2), ``cruise_end``
        where a cruise from ``t0`` ends (None: none; then ``sqrt(factor tol / a)``
        from ``t0``), ``boundary`` where the path turns from slowing down to not or
        back."""
        if cruise_end is not None:
            t_lim = cruise_end + math.sqrt(2.0 * self.tol / a)
        else:
            t_lim = t0 + math.sqrt(factor * self.tol / a)
        return boundary if t_lim >= boundary else t_lim

    def _near_plain(self, t0: int, t1: int) -> None:
        """The tolerance for steps from ``t0`` to ``t1``, near a plain corner."""
        ex = self.ex
        if ex.plain:
            self.tol = ex.tolerance_near(self.axis, t0, t1, self.tol)

    def _across(self, seg: Segment, j0: int, t0: int) -> Wrote | None:
        """A group that would end at its segment's last step, too short to keep the
        queue deep (tiny segments): it goes on into the segments after it while the
        axis keeps its direction, and its steps are placed so that none comes after
        its tick, nor more than ``tol`` steps before it (checked step by step).  The
        segments' last steps inside it then come up to that much early - not on the
        tick of the other axes' (counted in ``early_ends``).  None: no longer group."""
        ex = self.ex
        i = self.axis
        up = seg.ups[i]
        exact: list[int] = []  # ticks of the steps after the pending one ...
        where: list[tuple[int, int]] = []  # ... and their (segment, step)
        cur = seg
        for j in range(j0 + 1, seg.steps[i] + 1):
            exact.append(seg.step_tick(i, j))
            where.append((seg.seq, j))
        while exact[-1] - t0 < self.min_span and len(exact) < MAX_STEPS:
            nxt = ex.segment(cur.seq + 1)
            if (nxt is None or nxt.blend or not nxt.steps[i] or nxt.ups[i] != up
                    or not (cur.complete and cur.end == cur.length)):
                break
            known = nxt.known(i)
            j = 0
            while j < known and len(exact) < MAX_STEPS and exact[-1] - t0 < self.min_span:
                j += 1
                exact.append(nxt.step_tick(i, j))
                where.append((nxt.seq, j))
            if j < nxt.steps[i]:
                break
            cur = nxt
        first_end = seg.steps[i] - j0  # steps up to this segment's last
        self._near_plain(t0, exact[-1])
        while len(exact) > first_end:
            cmds, placed = self._placement(t0, exact)
            if cmds is not None:
                break
            exact.pop()
            where.pop()
        else:
            return None
        if self.free < len(cmds):
            return _FULL
        res = self._write_all(cmds, up, seg)
        if res != _OK:
            return res
        st = self.stats
        for k in range(len(exact) - 1):  # the segments' last steps inside the group
            s_k, j_k = where[k]
            end = ex.segment(s_k)
            if end is not None and j_k == end.steps[i]:
                st.early_ends += 1
                st.early_max = max(st.early_max, exact[k] - placed[k])
        self.seq, self.j = where[-1]
        self.t_pend = exact[-1]
        self.pending = True
        return _OK

    def _blend_group(self, seg: Segment) -> Wrote:
        """The pending step is in a corner blend or among the last ``BLEND_LEAD``
        before one: it and the next steps the same way - through the blend's and on
        into up to ``BLEND_RUN`` steps of the segment after it - up to the first step
        that does not fit (which starts the next command), placed at or before their
        ticks and within ``tol`` steps (:meth:`_placement`, the longest run that
        fits); one step and its wait where no group fits.  An axis that speeds up
        through the corner takes the blend's steps into the even spread of the steps
        after it; one that slows down, into the period of the steps before it."""
        ex = self.ex
        i = self.axis
        j0 = self.j
        up = seg.step_up(i, j0)
        chain = [seg]
        segs = ex.segments  # (ex.segment written out)
        first_seq = ex.first_seq
        if not seg.blend:
            at = self.seq + 1 - first_seq
            nxt = segs[at] if 0 <= at < len(segs) else None
            assert nxt is not None and nxt.blend
            chain.append(nxt)
        at = chain[-1].seq + 1 - first_seq
        out = segs[at] if 0 <= at < len(segs) else None  # the segment after the blend
        if out is None:
            cut = not ex.final
        else:
            chain.append(out)
            cut = not out.complete and out.known(i) - out.first[i] < BLEND_RUN
        if cut and self.last_start > self._deep:
            return _WAIT  # the queue is deep: the next run makes the group longer
        exact: list[int] = []
        #: the blends' own ticks where their steps are led (``exact``: the led ones,
        #: the latest placement; ``reach``: where the blend reaches them, from which
        #: the earliest is counted); None where none is led
        reach: list[int] | None = None
        #: where each segment's steps begin in ``exact``: (index, seq, its step there)
        spans: list[tuple[int, int, int]] = []
        tol = self.tol
        for cur in chain:
            j = j0 if cur is seg else cur.first[i]
            kn = cur.steps[i] if cur.blend else cur.known(i)  # (BlendSegment.known)
            if cur is out and kn > j + BLEND_RUN:
                kn = j + BLEND_RUN
            if j >= kn:
                if not cur.complete:
                    break  # the steps after are not final yet
                continue
            spans.append((len(exact), cur.seq, j + 1))
            if cur.blend:
                bl = cast(BlendSegment, cur)
                # the first step the other way ends it (looked for without raising:
                # most blends have none)
                ahead = bl.dirs[i][j:kn]
                turn = (not up) in ahead
                n = ahead.index(not up) + 1 if turn else kn - j
                if tol > 0.0 and bl.times is not bl.exact:
                    if reach is None:
                        reach = list(exact)
                    exact.extend(bl.ticks(i, True)[j:j + n])
                    reach.extend(bl.ticks(i, False)[j:j + n])
                else:  # (an axis's exact steps after a turn: the blend's own)
                    exact.extend(bl.ticks(i, False)[j:j + n])
                    if reach is not None:
                        reach.extend(exact[len(reach):])
                if turn:
                    break
            else:
                if cur.ups[i] != up:
                    kn = j + 1  # the first step the other way ends it
                exact.extend(cur.step_ticks(i, j + 1, kn))
                if reach is not None:
                    reach.extend(exact[len(reach):])
                if cur.ups[i] != up or not cur.complete:
                    break
            if len(exact) >= MAX_STEPS:
                del exact[MAX_STEPS:]
                break
        if not exact:
            return self._single(seg)
        t0 = self.w_end
        self._near_plain(t0, exact[-1])
        m, period = self._longest(t0, exact, reach)
        if m < 2:
            return self._single(seg)
        cmds = [(period, m - 1), (exact[m - 1] - t0 - (m - 1) * period, 1)]
        del exact[m:]
        if self.free < len(cmds):
            return _FULL
        res = self._write_all(cmds, up, seg)
        if res != _OK:
            return res
        last = len(exact) - 1
        for at, sq, jf in reversed(spans):
            if at <= last:
                self.seq, self.j = sq, jf + last - at
                break
        self.t_pend = exact[-1]
        self.pending = True
        return _OK

    def _longest(self, t0: int, exact: list[int], reach: list[int] | None = None
                 ) -> tuple[int, int]:
        """How many of ``exact`` a group from a step at ``t0`` reaches (its last one
        starting the next command) with its steps at a whole period ``P``, the last
        waiting for the rest: ``(m, P)``, ``m`` 1 where none.  Step ``k`` at ``t0 +
        k P`` is at or before its tick and at most ``tol`` steps early where ``(e_k -
        tol (e_k - e_(k-1)) - t0) / k <= P <= (e_k - t0) / k``: one pass narrows that
        range step by step; ``P`` is its top, the latest placement.  ``reach``: where
        a blend's led steps (``exact``, each at most ``tol`` steps before it) are
        reached - the ``tol`` counts from there, so a led step comes at most ``tol``
        early in all."""
        tol = self.tol
        lo = -math.inf
        hi = math.inf
        n = len(exact)
        fastest = self.queue.max_speed_in_ticks
        prev = t0
        #: the period at step k (periods[k - 1]) while the range holds
        periods: list[int] = []
        keep = periods.append
        if reach is None:  # (the loop below with f = e: most groups)
            # ``int(hi)`` as whole numbers: the least ``(e_k - t0) // k`` (ticks are
            # integers below 2^53, so the quotient's float never rounds up to the
            # next integer; where it is negative both break at once: below fastest)
            period = 1 << 62
            for k, e in enumerate(exact, 1):
                if k >= n:
                    break
                d = e - t0
                h = d // k
                if h < period:
                    period = h
                low = (d - tol * (e - prev)) / k
                if low > lo:
                    lo = low
                if period < lo or period < fastest:
                    break
                prev = e
                keep(period)
        else:
            # (``reach`` may go on past ``exact``'s cut at MAX_STEPS)
            for k, (e, f) in enumerate(zip(exact, reach, strict=False), 1):
                if k >= n:
                    break
                hf = (e - t0) / k
                if hf < hi:
                    hi = hf
                # (``f``: the earliest counts from where the blend reaches the step)
                d = f - t0
                low = (d - tol * (f - prev)) / k
                if low > lo:
                    lo = low
                period = int(hi)
                if period < lo or period < fastest:
                    break
                prev = f
                keep(period)
        # the most steps whose commands are legal: steps 0..k-1 at the period of
        # step k-1, then the wait up to step k's tick (step k begins the next command)
        min_cmd = self.min_cmd
        min_wait = fastest if fastest > min_cmd else min_cmd  # (self.min_wait written out)
        k = len(periods)
        while k:
            period = periods[k - 1]
            rest = exact[k] - t0 - k * period
            if (min_wait <= rest <= MAX_TICKS and period <= MAX_TICKS
                    and (period * k >= min_cmd if k > 1 else period >= min_cmd)):
                return k + 1, period
            k -= 1
        return 1, 0

    def _placement(self, t0: int, exact: list[int], m: int = 0
                   ) -> tuple[list[tuple[int, int]] | None, list[int]]:
        """Commands for a step at ``t0`` and the steps up to the last of ``exact``
        (which starts the next command; ``m``: of its first ``m`` only), each placed
        at or before its exact tick and at most ``tol`` steps early; (None, []) where
        neither the even spread nor the first interval's period does that."""
        if not m:
            m = len(exact)
        span = exact[m - 1] - t0
        period, r = divmod(span, m)
        tol = self.tol
        fastest = self.queue.max_speed_in_ticks
        if fastest <= period < MAX_TICKS:
            a = m - r
            if r == 0 or (self._legal(period, a) and self._legal(period + 1, r)):
                # step k (1..m-1) at t0 + k period + max(0, k - a)
                prev = t0
                t = t0
                k = 1
                while k < m:
                    t += period if k <= a else period + 1
                    e = exact[k - 1]
                    if t > e or e - t > tol * (e - prev):
                        break
                    prev = e
                    k += 1
                else:
                    return ([(period, a)] + ([(period + 1, r)] if r else []),
                            [t0 + k * period + max(0, k - a) for k in range(1, m)])
        first = exact[0] - t0
        rest = span - (m - 1) * first
        if (m > 1 and fastest <= first <= MAX_TICKS
                and self._legal(first, m - 1) and self.min_wait <= rest <= MAX_TICKS):
            prev = t0
            t = t0
            for k in range(m - 1):
                t += first
                e = exact[k]
                if t > e or e - t > tol * (e - prev):
                    return None, []
                prev = e
            return [(first, m - 1), (rest, 1)], [t0 + k * first for k in range(1, m)]
        return None, []

    def _group(self, seg: Segment, m: int, span: int, jh: int, th: int,
               slowing: bool) -> Wrote:
        """``m`` steps from ``w_end`` over ``span`` ticks; step ``jh`` at ``th``.

        Each step of the group comes at its exact tick or before it, never after - so
        an axis is never a whole step behind the path (its position rounds down along
        the path).  While the path keeps its speed or speeds up, the step times are
        concave and their chord lies before them: the steps are spread evenly (two
        periods ``P``, ``P + 1`` where the span does not divide, the shorter first).
        Where it slows down the chord would lie after them: the steps come at the
        period of the group's first interval, the shortest, and the last waits for
        the rest."""
        i = self.axis
        up = seg.ups[i]
        cmds = None
        if slowing and m > 1:
            first = seg.step_tick(i, self.j + 1) - self.w_end
            rest = span - (m - 1) * first
            fastest = self.queue.max_speed_in_ticks
            least = self.min_cmd  # (self.min_wait written out below)
            if (first >= fastest and first <= MAX_TICKS and self._legal(first, m - 1)
                    and (fastest if fastest > least else least) <= rest <= MAX_TICKS):
                cmds = [(first, m - 1), (rest, 1)]
        if cmds is None:
            cmds = self._commands(span, m)
        if cmds is None:  # slower than a command's period: one step and a wait
            jh = self.j + 1
            th = seg.step_tick(i, jh)
            wait = max(th - self.w_end, self.min_wait)
            cmds = [(t, 1 if k == 0 else 0) for k, t in enumerate(split_ticks(wait))]
        if self.free < len(cmds):
            return _FULL
        res = self._write_all(cmds, up, seg)
        if res != _OK:
            return res
        self.j = jh
        self.t_pend = th
        self.pending = True
        return _OK

    def _commands(self, span: int, m: int) -> list[tuple[int, int]] | None:
        """Commands ``(ticks, steps)`` for ``m`` steps over ``span`` ticks (None: a
        period beyond 65535 ticks)."""
        if m == 1:
            lo = self.min_cmd  # (self.min_wait written out)
            fastest = self.queue.max_speed_in_ticks
            if fastest > lo:
                lo = fastest
            if span > MAX_TICKS:
                return None
            if span < lo:
                return [(lo, 1)]
            return [(span, 1)]
        period, r = divmod(span, m)
        if period > MAX_TICKS or (period == MAX_TICKS and r):
            return None
        min_cmd = self.min_cmd
        floor = self.queue.max_speed_in_ticks
        least = -(-min_cmd // m)
        if least > floor:
            floor = least
        if period < floor:
            return [(floor, m)]
        if r == 0:
            return [(period, m)]
        a, b = m - r, r
        # (both _legal: a command's duration at least min_cmd, its ticks at most
        # MAX_TICKS - period + 1 is, as period < MAX_TICKS here)
        if ((period * a if a > 1 else period) >= min_cmd
                and ((period + 1) * b if b > 1 else period + 1) >= min_cmd):
            return [(period, a), (period + 1, b)]
        return [(period + (1 if 2 * r >= m else 0), m)]

    def _legal(self, ticks: int, steps: int) -> bool:
        duration = ticks * steps if steps > 1 else ticks
        return duration >= self.min_cmd and ticks <= MAX_TICKS

    def _single(self, seg: Segment) -> Wrote:
        """The pending step is its segment's last and the axis does not go on in the
        next segment the same way: one step, then wait for the next step."""
        found, seq, j, tick = self._next()
        if found == _UNKNOWN:
            return self._provisional(seg)
        i = self.axis
        up = seg.step_up(i, self.j)
        if found == _END:
            cmds = [(self.min_wait, 1)]  # the last step of the run: the queue runs out
        else:
            wait = tick - self.w_end
            if wait < self.min_wait:
                wait = self.min_wait
            parts = split_ticks(wait)
            cmds = [(t, 1 if k == 0 else 0) for k, t in enumerate(parts)]
        if self.free < len(cmds):
            return _FULL
        if found == _END:
            res = self._write_all(cmds, up, seg)
            if res == _OK:
                self.pending = False
                self.done = True
                if self.listener is not None and i == seg.dominant:
                    self.listener(self.w_end, 0.0, seg.tag)
            return res
        nseg = self.ex.segment(seq)
        assert nseg is not None
        res = self._write_all(cmds[:1], up, seg)
        if res == _OK and len(cmds) > 1:
            res = self._write_all(cmds[1:], nseg.step_up(i, j), seg)
        if res != _OK:
            return res
        self.seq, self.j, self.t_pend = seq, j, tick
        self.pending = True
        return _OK

    def _provisional(self, seg: Segment) -> Wrote:
        """The pending step's successor is beyond the horizon: a wait that ends at least
        one minimum command time before the horizon (pauses extend it later)."""
        if self.last_start > self._deep:
            return _WAIT  # the queue is deep: the next step may be final then
        wait = int(self.ex.t) - self.min_cmd - self.w_end
        if wait > MAX_TICKS:
            wait = MAX_TICKS
        if wait < self.min_wait:
            return _WAIT
        res = self._write_all([(wait, 1)], seg.step_up(self.axis, self.j), seg)
        if res == _OK:
            self.pending = False
        return res

    def _pause_ahead(self, free: int) -> Wrote:
        """No step is final: pauses up to one minimum command time before the horizon."""
        least = self.min_cmd
        gap = int(self.ex.t) - least - self.w_end
        fastest = self.queue.max_speed_in_ticks  # (self.min_wait written out)
        if gap < (fastest if fastest > least else least) or self.last_start > self._deep:
            return _WAIT
        parts = split_ticks(gap)[:free - 1]
        return self._write_all([(t, 0) for t in parts], self.up, None)

    def _pauses(self, gap: int, up: bool, free: int) -> Wrote:
        """Pauses up to the pending step: as many as the queue takes now (a step final
        further ahead than the queue holds in pauses - a device's long link lead - gets
        the rest on the next runs; every part is at least half a longest command)."""
        parts = split_ticks(gap)
        if free < 2:
            return _FULL
        return self._write_all([(t, 0) for t in parts[:free - 1]], up, None)

    def _shift(self, by: int) -> None:
        st = self.stats
        st.shifted += 1
        if abs(by) > st.shift_max:
            st.shift_max = abs(by)

    def _write_all(self, cmds: list[tuple[int, int]], up: bool,
                   seg: Segment | None) -> Wrote:
        """Write ``cmds`` in direction ``up``; a command that makes steps of the
        dominant axis of ``seg`` tells the speed listener."""
        write = self.host.write
        st = self.stats
        listener = self.listener if seg is not None and seg.dominant == self.axis else None
        ok = _QUEUED
        w_end = self.w_end
        for ticks, steps in cmds:
            res = write(ticks, steps, up, False)
            if res != ok:
                if res.retry:
                    return _FULL  # pragma: no cover - room was checked
                st.errors += 1
                self.host.report_abort(res, (ticks, steps, up))
                return _ERROR
            if listener is not None and steps and seg is not None:
                listener(w_end, seg.speed_at(w_end) * self.tps * 60.0, seg.tag)
            self.free -= 1
            if steps > 1:
                last_start = w_end + (steps - 1) * ticks
                w_end += ticks * steps
            else:
                last_start = w_end
                w_end += ticks
            self.last_start = last_start
            self.w_end = w_end
            self.up = up
            if steps:
                st.commands += 1
                st.steps += steps
                if up != self.step_dir:  # a turn (a step not through _step)
                    if self.step_dir is not None:
                        self.exact_until = self.step_last + self.turn_ticks
                    self.step_dir = up
                self.step_last = last_start
            else:
                st.pauses += 1
        return _OK
