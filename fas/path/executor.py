"""Execution of the planned blocks: the speed along the path, made final piece by piece.

The executor works on the first block of the look-ahead queue.  From the point it has
reached (distance ``s``, speed ``v``) the rest of the block is a trapezoid: accelerate
towards the nominal speed, cruise, decelerate to the exit speed the plan asks for now
(the next block's entry).  Each run of the periodic task makes that profile final up
to a time *horizon* (the queues' forward planning), as constant-acceleration
:class:`Piece` s of a :class:`Segment`; the axes then turn the final pieces into
steps (:mod:`fas.path.stepping`).  What lies beyond the horizon is planned again on
the next run with the exit speed of that time - which only rises as blocks arrive
(Grbl's stepper does the same with its segment buffer).  A block whose last piece is
final leaves the queue; the next one enters at its exit speed.

A *feed hold* replaces the plan beyond the horizon by a deceleration at each block's
acceleration, through as many blocks as it takes, to a stop - the point where the
path stops (:attr:`Segment.end` of the segment it stops in).  The speeds of the hold
stay below the plan's (the plan could only be slower where it decelerated at the same
rate), so no junction limit is passed.

Time is in ticks (float, absolute), distance in units, speeds in units/tick.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

from .blend import (
    Blend,
    corner_blend,
    corner_steps,
    exit_window,
    hold_blend,
    plain_offsets,
    slowing_blend,
)
from .lookahead import Block, Lookahead
from .settings import GROUP_TOLERANCE_STEPS, TURN_EXACT_S

#: pieces shorter than this (ticks) are not cut off at the horizon: the next run
#: takes them with what follows
MIN_PIECE_TICKS = 1.0
#: plain corners kept before trim forgets the ones no axis can reach any more
PLAIN_KEEP = 64


class Piece:
    """Constant acceleration from ``(s0, t0, v0)`` to ``(s1, t1)`` (a segment's part)."""

    __slots__ = ("s0", "s1", "t0", "t1", "v0", "a")

    def __init__(self, s0: float, s1: float, t0: float, t1: float, v0: float,
                 a: float) -> None:
        self.s0 = s0
        self.s1 = s1
        self.t0 = t0
        self.t1 = t1
        self.v0 = v0  # units/tick
        self.a = a  # units/tick^2

    def time_at(self, s: float) -> float:
        d = s - self.s0
        if d <= 0.0:
            return self.t0
        v0 = self.v0
        root = v0 * v0 + 2.0 * self.a * d
        den = v0 + math.sqrt(root if root > 0.0 else 0.0)
        if den <= 0.0:
            return self.t1
        t = self.t0 + 2.0 * d / den
        return t if t < self.t1 else self.t1

    def dist_at(self, t: float) -> float:
        tau = t - self.t0
        if tau <= 0.0:
            return self.s0
        s = self.s0 + tau * (self.v0 + 0.5 * self.a * tau)
        return s if s < self.s1 else self.s1

    def speed_at(self, t: float) -> float:
        tau = t - self.t0  # (min(max(tau, 0.0), t1 - t0), written out)
        if tau < 0.0:
            tau = 0.0
        span = self.t1 - self.t0
        if span < tau:
            tau = span
        return self.v0 + self.a * tau

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"Piece(s {self.s0:.5g}..{self.s1:.5g}, t {self.t0:.1f}..{self.t1:.1f}, "
                f"v0={self.v0:.4g}, a={self.a:.4g})")


class Segment:
    """A block as the axes execute it: its geometry and the pieces made final so far.

    Per axis: ``steps[i]`` steps (``ups[i]``: upwards), ``pitch[i]`` units of path
    per step of the axis's travel; step ``j`` is due where the path reaches
    ``(j - phase[i]) * pitch[i]``.  A block between whole steps has ``phase`` 0 (step
    ``j`` at ``j * pitch``, the last at the end).  A path from or to a point between
    steps, or one the path goes on through (an arc's chord ends): each step where the
    path is half a step before it - the axis on the step nearest to the path; the
    phase holds the axis's offset from its start step along the travel - but where
    the block ends on a whole step of the axis, its last step comes on the end
    (``on_end[i]``: all axes' last steps on one tick there)."""

    __slots__ = ("seq", "block", "start", "steps", "ups", "pitch", "phase", "on_end",
                 "length", "accel",
                 "pieces", "s_done", "t_start", "t_done", "complete", "end", "end_tick",
                 "dominant", "tag", "first")

    blend = False  # a BlendSegment: steps of its own per axis

    def __init__(self, seq: int, block: Block, t_start: float, ticks_per_s: int) -> None:
        self.seq = seq
        self.block = block
        self.start = block.start
        delta = block.delta
        self.steps = steps = tuple([abs(d) for d in delta])
        self.ups = tuple([d > 0 for d in delta])
        self.length = block.length
        if block.span is None:  # from a step to a step
            length = block.length
            self.pitch = tuple([length / n if n else 0.0 for n in steps])
            self.phase: tuple[float, ...] = (0.0,) * len(steps)
            self.on_end: tuple[bool, ...] = (True,) * len(steps)
        else:
            origin = block.origin
            assert origin is not None
            self.pitch = tuple(block.length / abs(x) if n else 0.0
                               for n, x in zip(self.steps, block.span, strict=True))
            # each step where the path is half a step before it; an axis ending on a
            # whole step of a block that ends there makes its last on the end
            through = block.through
            self.on_end = tuple(not through and abs(x0 + x - p0 - d) < 1e-9
                                for x0, x, p0, d in zip(origin, block.span, block.start,
                                                        block.delta, strict=True))
            self.phase = tuple(((x0 - p0 if d > 0 else p0 - x0) + 0.5) if d else 0.0
                               for x0, p0, d in zip(origin, block.start, block.delta,
                                                    strict=True))
        self.accel = block.acceleration / (ticks_per_s * ticks_per_s)  # units/tick^2
        self.pieces: list[Piece] = []
        self.s_done = 0.0  # final up to this distance ...
        self.t_start = t_start
        self.t_done = t_start  # ... and this time
        self.complete = False  # every piece is final
        self.end = block.length  # where the path ends in it (a feed hold: earlier)
        self.end_tick = 0  # the tick of ``end`` once complete
        self.dominant = steps.index(max(steps))  # (the first of the largest)
        self.tag = block.tag
        #: per axis the steps a blend before it made already (the cursor starts there)
        self.first: tuple[int, ...] = (0,) * len(steps)

    def known(self, axis: int) -> int:
        """How many of ``axis``'s steps in this segment have a final time."""
        n = self.steps[axis]
        if not n or (self.complete and self.end == self.length):
            return n
        k = int(self.s_done / self.pitch[axis] + self.phase[axis])
        if self.on_end[axis] and self.block.span is not None:
            n -= 1  # the last step comes on the end, the others half a step before
        f = self.first[axis]
        if k < f:
            k = f
        return k if k < n else n

    def steps_by(self, axis: int, s: float) -> int:
        """The index of ``axis``'s last step due at or before distance ``s`` (may lie
        beyond the segment's steps)."""
        return int(s / self.pitch[axis] + self.phase[axis])

    def step_up(self, axis: int, j: int) -> bool:
        """The direction of ``axis``'s step ``j``."""
        return self.ups[axis]

    def time_at(self, s: float) -> float:
        """The time (ticks) at distance ``s`` (at most ``s_done``)."""
        for p in self.pieces:
            if s <= p.s1:
                return p.time_at(s)
        return self.t_done

    def dist_at(self, t: float) -> float:
        """The distance at time ``t`` (clamped to what is final)."""
        if t >= self.t_done:
            return self.s_done
        for p in self.pieces:
            if t <= p.t1:  # (Piece.dist_at written out)
                tau = t - p.t0
                if tau <= 0.0:
                    return p.s0
                s = p.s0 + tau * (p.v0 + 0.5 * p.a * tau)
                return s if s < p.s1 else p.s1
        return self.s_done

    def speed_at(self, t: float) -> float:
        """The path speed (units/tick) at time ``t`` within the final pieces."""
        for p in self.pieces:
            if t <= p.t1:
                return p.speed_at(t)
        return self.pieces[-1].speed_at(t) if self.pieces else 0.0

    def step_tick(self, axis: int, j: int) -> int:
        """The tick of ``axis``'s step ``j`` (0: the segment's start)."""
        if j == 0:
            return int(self.t_start + 0.5)
        if (j == self.steps[axis] and self.complete and self.end == self.length
                and self.on_end[axis]):
            return self.end_tick
        s = (j - self.phase[axis]) * self.pitch[axis]
        for p in self.pieces:  # (time_at and Piece.time_at written out)
            if s <= p.s1:
                d = s - p.s0
                if d <= 0.0:
                    return int(p.t0 + 0.5)
                v0 = p.v0
                root = v0 * v0 + 2.0 * p.a * d
                den = v0 + math.sqrt(root if root > 0.0 else 0.0)
                if den <= 0.0:
                    return int(p.t1 + 0.5)
                t = p.t0 + 2.0 * d / den
                return int((t if t < p.t1 else p.t1) + 0.5)
        return int(self.t_done + 0.5)

    def step_ticks(self, axis: int, j0: int, j1: int) -> list[int]:
        """The ticks of ``axis``'s steps ``j0`` to ``j1`` (>= 1), as :meth:`step_tick`."""
        pitch = self.pitch[axis]
        phase = self.phase[axis]
        pieces = self.pieces
        count = len(pieces)
        k = 0
        out: list[int] = []
        end = (j1 == self.steps[axis] and self.complete and self.end == self.length
               and self.on_end[axis])
        sqrt = math.sqrt
        t_done = self.t_done
        # the piece in use, its figures as locals (Piece.time_at written out); past
        # the last piece: none (s1 infinite)
        past = not count
        s0 = t0 = t1 = v0 = vv = a2 = 0.0
        s1 = math.inf
        if count:
            p = pieces[0]
            s0, s1, t0, t1, v0 = p.s0, p.s1, p.t0, p.t1, p.v0
            vv, a2 = v0 * v0, 2.0 * p.a
        keep = out.append
        for j in range(j0, j1 if end else j1 + 1):
            s = (j - phase) * pitch
            if s > s1:
                while k < count and s > pieces[k].s1:
                    k += 1
                if k < count:
                    p = pieces[k]
                    s0, s1, t0, t1, v0 = p.s0, p.s1, p.t0, p.t1, p.v0
                    vv, a2 = v0 * v0, 2.0 * p.a
                else:
                    past = True
                    s1 = math.inf
            if past:
                keep(int(t_done + 0.5))
                continue
            d = s - s0
            if d <= 0.0:
                keep(int(t0 + 0.5))
                continue
            root = vv + a2 * d
            den = v0 + sqrt(root if root > 0.0 else 0.0)
            t = t0 + 2.0 * d / den if den > 0.0 else t1
            keep(int((t1 if t > t1 else t) + 0.5))
        if end:
            out.append(self.end_tick)
        return out

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"Segment(#{self.seq} {self.block.delta}, done {self.s_done:.4g}/"
                f"{self.length:.4g}, t {self.t_start:.0f}..{self.t_done:.0f})")


class BlendSegment(Segment):
    """A corner blend (:mod:`fas.path.blend`) as the axes execute it: complete when
    made, each axis's steps at times of their own (and directions: an axis may turn
    round in it).  Its distance figures are the blend's (the path it takes)."""

    blend = True

    def __init__(self, seq: int, block: Block, blend: Blend,
                 per_axis: list[tuple[int, list[tuple[float, int]], int]],
                 t_start: float, ticks_per_s: int, dominant: int,
                 leads: list[list[float]] | None = None) -> None:
        # (Segment's figures set here: a blend has no distance of its own)
        self.seq = seq
        self.block = block  # the block out (the blend ends in it)
        self.start = block.start
        self.b = blend
        self.tps = ticks_per_s
        #: each step's time (ticks from ``t_start``) where the blend reaches it ...
        self.exact = [[t * ticks_per_s for t, _d in steps] for _m, steps, _f in per_axis]
        #: ... and where it is written: led towards the commanded corner (up to
        #: GROUP_TOLERANCE_STEPS early, fas.path.blend.lead_to_polyline)
        self.times = (self.exact if leads is None
                      else [[t * ticks_per_s for t in ts] for ts in leads])
        self.dirs = [[d > 0 for _t, d in steps] for _m, steps, _f in per_axis]
        self.steps = tuple([len(x) for x in self.times])
        self.ups = tuple([d[0] if d else block.delta[i] > 0 for i, d in enumerate(self.dirs)])
        n = len(self.steps)
        self.pitch = (0.0,) * n
        self.first = (0,) * n
        self.phase = (0.0,) * n
        self.on_end = (True,) * n
        self.length = self.end = self.s_done = blend.reach + blend.reach_out
        self.accel = 0.0
        self.pieces: list[Piece] = []
        self.t_start = t_start
        self.t_done = t_start + blend.duration * ticks_per_s
        self.complete = True
        self.end_tick = int(self.t_done + 0.5)
        self.dominant = dominant
        self.tag = block.tag
        self.saved: tuple[int, ...] = (0,) * n  # see Executor._blend
        #: (axis, led) -> (t_start, each step's tick): :meth:`ticks`' lists
        self._ticks: dict[tuple[int, bool], tuple[float, list[int]]] = {}

    def known(self, axis: int) -> int:
        return self.steps[axis]

    def step_tick(self, axis: int, j: int) -> int:
        if j == 0:
            return int(self.t_start + 0.5)
        return int(self.t_start + self.times[axis][j - 1] + 0.5)

    def exact_tick(self, axis: int, j: int) -> int:
        """Step ``j``'s tick where the blend reaches it (not led)."""
        if j == 0:
            return int(self.t_start + 0.5)
        return int(self.t_start + self.exact[axis][j - 1] + 0.5)

    def ticks(self, axis: int, led: bool) -> list[int]:
        """Every step's tick of ``axis`` (``led``: where it is written, else where
        the blend reaches it), as :meth:`step_tick` and :meth:`exact_tick` give
        them; made once (again after a :meth:`Executor.shift`)."""
        key = (axis, led)
        t_start = self.t_start
        made = self._ticks.get(key)
        if made is None or made[0] != t_start:
            t0 = t_start + 0.5
            made = (t_start, [int(t0 + t) for t in
                              (self.times if led else self.exact)[axis]])
            self._ticks[key] = made
        return made[1]

    def step_up(self, axis: int, j: int) -> bool:
        d = self.dirs[axis]
        return d[j - 1] if 0 < j <= len(d) else self.ups[axis]

    def speed_at(self, t: float) -> float:
        """Path speed (units/tick) at tick ``t``."""
        tau = min(max((t - self.t_start) / self.tps, 0.0), self.b.duration)
        return math.sqrt(sum(x * x for x in self.b.velocity(tau))) / self.tps

    def dist_at(self, t: float) -> float:  # pragma: no cover - not asked of a blend
        return self.s_done

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"BlendSegment(#{self.seq} v={self.b.speed:.4g} T={self.b.duration:.4g}, "
                f"steps {self.steps}, t {self.t_start:.0f}..{self.t_done:.0f})")


def trapezoid(v0: float, nominal: float, v_exit: float, accel: float,
              dist: float) -> list[tuple[float, float, float]]:
    """The phases ``(speed at its start, acceleration, length)`` from speed ``v0`` over
    ``dist`` to ``v_exit`` (which the caller made reachable), at most ``nominal``."""
    if dist <= 0.0:
        return []
    v02, vx2 = v0 * v0, v_exit * v_exit
    peak2 = 0.5 * (v02 + vx2) + accel * dist
    if peak2 < v02:  # cannot slow down enough: decelerate all the way
        return [(v0, -accel, dist)]
    top2 = nominal * nominal
    if peak2 < top2:  # (min(nominal^2, peak2))
        top2 = peak2
    if top2 < vx2:
        top2 = vx2
    if abs(top2 - v02) <= 1e-9 * top2:  # at the top already (rounding): no phase of
        top2 = v02  # a millionth of a unit that would break a cruise in two
    phases: list[tuple[float, float, float]] = []
    if top2 > v02:
        d1 = (top2 - v02) / (2.0 * accel)
        a1 = accel
    else:
        d1 = (v02 - top2) / (2.0 * accel)
        a1 = -accel
    d3 = (top2 - vx2) / (2.0 * accel)
    if d1 + d3 > dist:  # rounding: share the excess
        scale = dist / (d1 + d3)
        d1 *= scale
        d3 = dist - d1
    d2 = dist - d1 - d3
    top = math.sqrt(top2)
    if d1 > 0.0:
        phases.append((v0, a1, d1))
    if d2 > 0.0:
        phases.append((top, 0.0, d2))
    if d3 > 0.0:
        phases.append((top, -accel, d3))
    return phases


def phase_ticks(v: float, a: float, d: float) -> tuple[float, float]:
    """(duration, end speed) of a phase in ticks and units/tick."""
    if a == 0.0:
        return d / v, v
    root = v * v + 2.0 * a * d
    v1 = math.sqrt(root) if root > 0.0 else 0.0
    den = v + v1
    return (2.0 * d / den if den > 0.0 else 0.0), v1


class Executor:
    """Makes the plan final up to a horizon, block after block (see the module text)."""

    def __init__(self, lookahead: Lookahead, ticks_per_s: int) -> None:
        self.lookahead = lookahead
        self.tps = ticks_per_s
        self.segments: list[Segment] = []  # not yet stepped through by every axis
        self.first_seq = 0  # seq of segments[0]
        self.next_seq = 0
        self.cur: Segment | None = None  # the segment being made final
        self.v = 0.0  # speed reached (units/tick)
        self.t = 0.0  # time reached (ticks)
        self.final = False  # the path ends at self.t: a stop with nothing after it
        self.holding = False
        self.stop_segment: Segment | None = None  # where a feed hold stopped
        #: when a list: every corner blend made final, (corner in steps, its segment)
        self.blends: list[tuple[tuple[int, ...], BlendSegment]] | None = None
        #: when a list: every plain corner made final, (corner in steps, its tick)
        self.plain_log: list[tuple[tuple[int, ...], float]] | None = None
        #: a blend ended inside the next block: (where, each axis's first step)
        self._enter: tuple[float, tuple[int, ...]] | None = None
        #: a plain corner (PathSettings.plain_corner_steps) before the next block:
        #: (its blend's reach into it, units; the speed, units/tick)
        self._cruise: tuple[float, float] | None = None
        #: the plain corners made final: (the tick its blend would begin, end, each
        #: axis's largest offset from that blend, steps) - the grouping's tolerance
        #: near one shrinks by its offset (:meth:`tolerance_near`)
        self.plain: list[tuple[float, float, tuple[float, ...]]] = []
        #: each one's end + TURN_EXACT_S (sorted: the writers' cursors walk it)
        self.plain_ends: list[float] = []
        self.plain_widen = TURN_EXACT_S * ticks_per_s  # (ticks)
        self.plain_base = 0  # plain corners forgotten before plain[0] (trim)
        #: the largest offset any plain corner ever noted has (steps; never lowered):
        #: below an axis's tolerance, no plain corner shrinks it to 0
        self.plain_most = 0.0

    # ------------------------------------------------------------ a run
    def begin(self, t0: float) -> None:
        """A run starts at rest at tick ``t0``."""
        self.segments.clear()
        self.first_seq = self.next_seq
        self.cur = None
        self.v = 0.0
        self.t = t0
        self.final = False
        self.stop_segment = None
        self._enter = None
        self._cruise = None
        self.plain.clear()
        self.plain_ends.clear()
        self.plain_base = 0

    def shift(self, ticks: int) -> None:
        """Move everything made final so far ``ticks`` later (a start that came later)."""
        self.t += ticks
        for seg in self.segments:
            seg.t_start += ticks
            seg.t_done += ticks
            if seg.complete:
                seg.end_tick += ticks
            for piece in seg.pieces:
                piece.t0 += ticks
                piece.t1 += ticks
        self.plain = [(a + ticks, b + ticks, d) for a, b, d in self.plain]
        self.plain_ends = [e + ticks for e in self.plain_ends]

    def segment(self, seq: int) -> Segment | None:
        i = seq - self.first_seq
        segs = self.segments
        return segs[i] if 0 <= i < len(segs) else None

    def trim(self, keep_from: int) -> None:
        """Forget the segments before seq ``keep_from`` (every axis is past them)."""
        drop = keep_from - self.first_seq
        if drop > 0:
            del self.segments[:drop]
            self.first_seq = keep_from
        if len(self.plain_ends) > PLAIN_KEEP and self.segments:
            # plain corners no axis's group can reach any more (a group begins at or
            # before its first step's tick, less than a window early)
            gone = bisect.bisect_left(self.plain_ends,
                                      self.segments[0].t_start - self.plain_widen)
            if gone:
                del self.plain[:gone]
                del self.plain_ends[:gone]
                self.plain_base += gone

    # ------------------------------------------------------------ making final
    def commit(self, horizon: float) -> None:
        """Make the motion final up to tick ``horizon`` (or to the end of the path)."""
        la = self.lookahead
        tps = self.tps
        while not self.final and self.t < horizon:
            seg = self.cur
            if seg is None:
                block = la.blocks[0] if la.blocks else None  # (la.first())
                if block is None:
                    self.final = True  # nothing queued: the path ends (at rest)
                    break
                seg = Segment(self.next_seq, block, self.t, tps)
                if self._enter is not None:  # a blend before it: from its end on
                    seg.s_done, seg.first = self._enter
                    self._enter = None
                elif self._cruise is not None:  # a plain corner before it: at the
                    reach_out, v_c = self._cruise  # blend's clock up to where it ends
                    self._cruise = None
                    self._piece(seg, reach_out, self.t + reach_out / v_c, v_c, 0.0)
                    self.v = v_c
                self.next_seq += 1
                self.segments.append(seg)
                self.cur = seg
            block = seg.block
            rest = seg.length - seg.s_done
            v = self.v * tps  # units/s
            accel = block.acceleration
            # the blend at the block's end takes k e of it (e: the exit squared)
            more = len(la.blocks) > 1
            k = block.zone_out if more else 0.0
            slowing: Blend | None = None
            if self.holding:
                phases, stop = self._hold_phases(v, accel, rest)
                exit2 = max(0.0, v * v - 2.0 * accel * rest) if not stop else 0.0
                if not stop and k > 0.0:  # the corner as a blend that slows down
                    out = la.blocks[1]
                    hb = hold_blend(block.unit, out.unit, v * v, rest, accel,
                                    out.acceleration, la.accel, out.length,
                                    la.junction_deviation)
                    if hb is not None:
                        slowing = slowing_blend(block.unit, out.unit, math.sqrt(hb[0]),
                                                hb[1], la.accel)
                    if slowing is not None:
                        exit2 = slowing.speed * slowing.speed  # (the blend's entry)
                        ramp = rest - slowing.reach
                        phases = [(v, -accel, ramp)] if ramp > 0.0 else []
                    else:
                        k = 0.0
            else:
                stop = False
                vx2 = la.blocks[1].entry_sqr if more else 0.0  # (la.exit_sqr())
                win = exit_window(v * v, rest, accel, k) if k > 0.0 else None
                if win is not None and k * max(win[0], min(vx2, win[1])) > la.blocks[1].length:
                    win = None  # its blend would not fit in the block out (an override)
                if win is None:
                    k = 0.0  # (none: go on as without a blend)
                if k > 0.0 and win is not None:
                    lo, hi = win
                    if vx2 > hi:  # the exit rose beyond what this block still reaches
                        vx2 = hi
                        la.blocks[1].entry_sqr = hi
                        la.replan_from_first()
                    if vx2 < lo:
                        vx2 = lo
                    dist = rest - k * vx2
                    phases = trapezoid(v, block.nominal_speed, math.sqrt(vx2), accel, dist)
                    exit2 = vx2
                else:
                    reach2 = v * v + 2.0 * accel * rest
                    if vx2 > reach2:  # the exit rose beyond what this block still reaches
                        vx2 = reach2
                        la.blocks[1].entry_sqr = reach2
                        la.replan_from_first()
                    phases = trapezoid(v, block.nominal_speed, math.sqrt(vx2), accel, rest)
                    exit2 = v * v - 2.0 * accel * rest
                    if vx2 >= exit2:  # (max(vx2, exit2))
                        exit2 = vx2
            done = self._take(seg, phases, horizon)
            if not done:
                break
            self.v = math.sqrt(exit2) / tps  # exactly the exit planned (no rounding)
            # the segment is final to its end (or to the hold's stop)
            seg.complete = True
            seg.end_tick = int(self.t + 0.5)
            self.cur = None
            if stop:
                seg.end = seg.s_done
                self.final = True
                self.stop_segment = seg
                self.v = 0.0
                break
            blend = slowing
            plain = None
            if blend is None and k > 0.0 and exit2 > 0.0:
                out_unit = la.blocks[1].unit
                if la.plain_steps > 0.0:
                    plain = plain_offsets(block.unit, out_unit, k, exit2, la.spu,
                                          la.plain_steps)
                if plain is not None:  # no step tells its blend from Grbl's corner
                    self._plain(seg, math.sqrt(exit2), k * exit2, plain)
                else:
                    blend = corner_blend(block.unit, out_unit, math.sqrt(exit2), la.accel)
            if blend is None:
                if plain is None:
                    seg.s_done = seg.end = seg.length
            else:
                seg.end = seg.s_done  # the blend goes on from here
                if blend.speed_out != blend.speed:  # (a hold's: it leaves slower)
                    exit2 = blend.speed_out * blend.speed_out
                    self.v = blend.speed_out / tps
            la.pop_first()
            nxt = la.blocks[0] if la.blocks else None  # (la.first())
            if nxt is not None:
                nxt.entry_sqr = exit2
            if blend is not None and nxt is not None:
                self._blend(seg, nxt, blend)
        # the block being executed: what is left of it, entered at the speed reached
        seg = self.cur
        if seg is not None and not seg.complete:
            block = seg.block
            left = seg.length - seg.s_done - block.reserve_out
            block.remaining = left if left > 0.0 else 0.0
            block.entry_sqr = (self.v * tps) ** 2

    def _blend(self, seg: Segment, nxt: Block, blend: Blend) -> None:
        """The corner after ``seg`` as a blend into ``nxt``, final as a whole (the
        block out final up to where the blend ends in it)."""
        axes = range(len(seg.steps))
        made = [seg.known(i) for i in axes]
        block = seg.block
        leads: list[list[float]] = []
        per = corner_steps(block.start, block.delta, nxt.delta, blend, self.lookahead.spu,
                           made, block.origin, block.span, nxt.span, leads,
                           GROUP_TOLERANCE_STEPS)
        bseg = BlendSegment(self.next_seq, nxt, blend, per, self.t, self.tps, seg.dominant,
                            leads)
        bseg.tag = block.tag  # the corner ends the block in
        # the steps each axis's blocks would have made in the blend and did not
        bseg.saved = tuple([abs(d) - m + f - len(st)
                            for d, (m, st, f) in zip(block.delta, per, strict=True)])
        if self.blends is not None:
            self.blends.append((nxt.start, bseg))
        self.next_seq += 1
        self.segments.append(bseg)
        self.t = bseg.t_done
        self._enter = (blend.reach_out, tuple(f for _m, _s, f in per))

    def _plain(self, seg: Segment, speed: float, reach: float,
               offsets: tuple[float, ...]) -> None:
        """The corner after ``seg`` as Grbl's corner at the clock of its blend (at
        ``speed`` units/s, ``reach`` units along either block): the block in at that
        speed up to the corner, the block out as far as the blend would reach into it
        (:attr:`_cruise`); each axis's own steps."""
        tps = self.tps
        v = speed / tps  # units/tick
        t_begin = self.t
        rest = seg.length - seg.s_done
        if rest > 0.0:
            self._piece(seg, rest, self.t + rest / v, v, 0.0)
        seg.s_done = seg.end = seg.length
        seg.end_tick = int(self.t + 0.5)
        if self.plain_log is not None:
            block = seg.block
            self.plain_log.append((tuple([s + d for s, d in zip(block.start, block.delta,
                                                                 strict=True)]), self.t))
        t_end = self.t + reach / v
        self._cruise = (reach, v)
        self.note_plain(t_begin, t_end, offsets)

    def note_plain(self, t_begin: float, t_end: float, offsets: tuple[float, ...]) -> None:
        """A plain corner whose blend would last from tick ``t_begin`` to ``t_end``,
        each axis's offset from it (steps): the grouping near it keeps within the
        tolerance less that offset (:meth:`tolerance_near`)."""
        self.plain.append((t_begin, t_end, offsets))
        self.plain_ends.append(t_end + self.plain_widen)
        for d in offsets:
            if d > self.plain_most:
                self.plain_most = d

    def tolerance_near(self, axis: int, t0: float, t1: float, tol: float,
                       k: int | None = None) -> float:
        """The grouping tolerance ``tol`` (steps) of ``axis`` for steps between ticks
        ``t0`` and ``t1``: less by the largest offset of a plain corner whose blend's
        time, widened by TURN_EXACT_S on both sides, meets them (docs/path-planner.md,
        "Corners no step can tell apart").  ``k``: the first plain corner that can
        (``plain_ends[k] >= t0``, an index into :attr:`plain`), where the caller
        knows it."""
        ends = self.plain_ends
        if not ends:
            return tol
        if k is None:
            k = bisect.bisect_left(ends, t0)
        plain = self.plain
        widen = self.plain_widen
        out = tol
        while k < len(plain):
            a, _b, d = plain[k]
            if a - widen > t1:
                break
            if tol - d[axis] < out:
                out = tol - d[axis]
            k += 1
        return out if out > 0.0 else 0.0

    def _take(self, seg: Segment, phases: Sequence[tuple[float, float, float]],
              horizon: float) -> bool:
        """Make ``phases`` (units, seconds) final up to ``horizon``; True if all are."""
        tps = self.tps
        pieces = seg.pieces
        for v_s, a_s, d in phases:
            v = v_s / tps
            a = a_s / (tps * tps)
            if a == 0.0:  # (phase_ticks written out)
                dur, v1 = d / v, v
            else:
                root = v * v + 2.0 * a * d
                v1 = math.sqrt(root) if root > 0.0 else 0.0
                den = v + v1
                dur = 2.0 * d / den if den > 0.0 else 0.0
            t0 = self.t
            t1 = t0 + dur
            cut = t1 > horizon
            if cut:
                tau = horizon - t0
                if tau < MIN_PIECE_TICKS:
                    return False
                dd = tau * (v + 0.5 * a * tau)
                if dd <= 0.0 or dd >= d:
                    return False
                d = dd
                t1 = horizon
                v1 = v + a * tau
            # (_piece written out)
            s0 = seg.s_done
            last = pieces[-1] if pieces else None
            if (last is not None and last.a == a and last.t1 == t0
                    and abs(last.v0 + a * (last.t1 - last.t0) - v) <= 1e-9 * (abs(v) + 1e-12)):
                last.s1 = s0 + d
                last.t1 = t1
            else:
                pieces.append(Piece(s0, s0 + d, t0, t1, v, a))
            seg.s_done = s0 + d
            seg.t_done = self.t = t1
            self.v = v1
            if cut:
                return False
        return True

    def _piece(self, seg: Segment, d: float, t1: float, v: float, a: float) -> None:
        """Append the motion over ``d`` units up to tick ``t1`` from speed ``v`` at
        acceleration ``a``: a continuation of the last piece (the same acceleration,
        cut at the horizon before) lengthens it."""
        pieces = seg.pieces
        s0 = seg.s_done
        last = pieces[-1] if pieces else None
        if (last is not None and last.a == a and last.t1 == self.t
                and abs(last.v0 + a * (last.t1 - last.t0) - v) <= 1e-9 * (abs(v) + 1e-12)):
            last.s1 = s0 + d
            last.t1 = t1
        else:
            pieces.append(Piece(s0, s0 + d, self.t, t1, v, a))
        seg.s_done = s0 + d
        seg.t_done = self.t = t1

    def _hold_phases(self, v: float, accel: float,
                     rest: float) -> tuple[list[tuple[float, float, float]], bool]:
        """Decelerate from ``v`` (units/s): over the whole rest, or to a stop in it."""
        if v <= 0.0:
            return [], True
        d_stop = v * v / (2.0 * accel)
        if d_stop >= rest:
            return [(v, -accel, rest)], False
        return [(v, -accel, d_stop)], True

    # ------------------------------------------------------------ feed hold
    def hold(self) -> None:
        """Decelerate to a stop from the end of what is final."""
        self.holding = True

    def speed_at(self, t: float) -> float:
        """Path speed (units/s) at tick ``t``, by the final pieces (0 outside them)."""
        for seg in self.segments:
            if seg.t_start <= t <= seg.t_done and (seg.pieces or seg.blend):
                return seg.speed_at(t) * self.tps
        return 0.0
