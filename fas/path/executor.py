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

import math
from collections.abc import Sequence

from .lookahead import Block, Lookahead

#: pieces shorter than this (ticks) are not cut off at the horizon: the next run
#: takes them with what follows
MIN_PIECE_TICKS = 1.0


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
                 "dominant", "tag")

    def __init__(self, seq: int, block: Block, t_start: float, ticks_per_s: int) -> None:
        self.seq = seq
        self.block = block
        self.start = block.start
        delta = block.delta
        self.steps = steps = tuple([abs(d) for d in delta])
        self.ups = tuple([d > 0 for d in delta])
        self.length = block.length
        if block.span is None:  # from a step to a step
            self.pitch = tuple(block.length / n if n else 0.0 for n in self.steps)
            self.phase: tuple[float, ...] = (0.0,) * len(self.steps)
            self.on_end: tuple[bool, ...] = (True,) * len(self.steps)
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

    def known(self, axis: int) -> int:
        """How many of ``axis``'s steps in this segment have a final time."""
        n = self.steps[axis]
        if self.complete and self.end == self.length:
            return n
        k = int(self.s_done / self.pitch[axis] + self.phase[axis]) if n else 0
        if self.on_end[axis] and self.block.span is not None:
            n -= 1  # the last step comes on the end, the others half a step before
        return k if k < n else n

    def steps_by(self, axis: int, s: float) -> int:
        """The index of ``axis``'s last step due at or before distance ``s`` (may lie
        beyond the segment's steps)."""
        return int(s / self.pitch[axis] + self.phase[axis])

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
            if t <= p.t1:
                return p.dist_at(t)
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
        return int(self.time_at((j - self.phase[axis]) * self.pitch[axis]) + 0.5)

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"Segment(#{self.seq} {self.block.delta}, done {self.s_done:.4g}/"
                f"{self.length:.4g}, t {self.t_start:.0f}..{self.t_done:.0f})")


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
    top2 = min(nominal * nominal, peak2)
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

    # ------------------------------------------------------------ making final
    def commit(self, horizon: float) -> None:
        """Make the motion final up to tick ``horizon`` (or to the end of the path)."""
        la = self.lookahead
        tps = self.tps
        while not self.final and self.t < horizon:
            seg = self.cur
            if seg is None:
                block = la.first()
                if block is None:
                    self.final = True  # nothing queued: the path ends (at rest)
                    break
                seg = Segment(self.next_seq, block, self.t, tps)
                self.next_seq += 1
                self.segments.append(seg)
                self.cur = seg
            block = seg.block
            rest = seg.length - seg.s_done
            v = self.v * tps  # units/s
            accel = block.acceleration
            if self.holding:
                phases, stop = self._hold_phases(v, accel, rest)
                exit2 = max(0.0, v * v - 2.0 * accel * rest) if not stop else 0.0
            else:
                stop = False
                vx2 = la.exit_sqr()
                reach2 = v * v + 2.0 * accel * rest
                if vx2 > reach2:  # the exit rose beyond what this block still reaches
                    vx2 = reach2
                    la.blocks[1].entry_sqr = reach2
                    la.replan_from_first()
                phases = trapezoid(v, block.nominal_speed, math.sqrt(vx2), accel, rest)
                exit2 = max(vx2, v * v - 2.0 * accel * rest)
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
            seg.s_done = seg.end = seg.length
            la.pop_first()
            nxt = la.first()
            if nxt is not None:
                nxt.entry_sqr = exit2
        # the block being executed: what is left of it, entered at the speed reached
        seg = self.cur
        if seg is not None and not seg.complete:
            block = seg.block
            block.remaining = seg.length - seg.s_done
            block.entry_sqr = (self.v * tps) ** 2

    def _take(self, seg: Segment, phases: Sequence[tuple[float, float, float]],
              horizon: float) -> bool:
        """Make ``phases`` (units, seconds) final up to ``horizon``; True if all are."""
        tps = self.tps
        for v_s, a_s, d in phases:
            v = v_s / tps
            a = a_s / (tps * tps)
            dur, v1 = phase_ticks(v, a, d)
            t0 = self.t
            if t0 + dur > horizon:
                tau = horizon - t0
                if tau < MIN_PIECE_TICKS:
                    return False
                dd = tau * (v + 0.5 * a * tau)
                if dd <= 0.0 or dd >= d:
                    return False
                self._piece(seg, dd, horizon, v, a)
                self.v = v + a * tau
                return False
            self._piece(seg, d, t0 + dur, v, a)
            self.v = v1
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
            if seg.t_start <= t <= seg.t_done and seg.pieces:
                return seg.speed_at(t) * self.tps
        return 0.0
