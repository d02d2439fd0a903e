"""The look-ahead queue: straight blocks and the speeds at their junctions.

Each block is a straight segment from where the previous one ends to a target in
steps.  When it is queued its figures are fixed (Grbl's ``plan_buffer_line``):

* its length ``L`` in units and unit vector ``u`` (each axis's steps divided by its
  steps per unit);
* its acceleration and top rate: the largest along ``u`` that keeps every axis within
  its own limit, ``min_i(limit_i / |u_i|)``; the nominal speed is the feed, at most
  that rate;
* the largest speed at the junction with the block before it, by *junction
  deviation* ``d``: a circle tangent to both segments whose edge stays ``d`` from the
  corner is taken at the centripetal acceleration the axes allow along the bisector,
  ``v^2 = a_j * d * sin(theta/2) / (1 - sin(theta/2))`` (theta: the angle between
  the segments, 180 degrees for a straight continuation); no more than either
  block's nominal speed.  A block queued with nothing before it starts from rest.

The entry speeds are then planned (Grbl's ``planner_recalculate``): a *reverse pass*
from the newest block, which must be able to stop at its end, back to the first
block whose plan cannot change any more, lets each block enter no faster than it can
still slow down to the next block's entry; a *forward pass* from there lowers every
entry that the block before cannot reach while accelerating.  Blocks up to the
*planned* pointer are final: their entries are at the junction limit or reached at
full acceleration, and no block queued later can raise them - the passes start there.

The first block is the one being executed: :class:`fas.path.executor.Executor`
shortens it (``remaining``) and sets its entry to the speed reached so far, and it
reads the exit speed it must reach - the next block's entry - as it goes; that exit
only rises as blocks are added, so what was executed stays feasible.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import repeat
from operator import mul, sub, truediv

from .settings import MINIMUM_FEED, AxisLimits

#: |w - u| below this: straight on, nothing to blend (fas.path.blend)
STRAIGHT = 1e-9

BIG = 1e30  # an unlimited speed squared (a straight continuation)
COS_STRAIGHT = -0.999999  # cos(angle) below this: a straight continuation
COS_REVERSAL = 0.999999  # above this: a full reversal (the junction speed is 0)


class Block:
    """One straight segment of the path (see the module text).  Speeds in units/s."""

    __slots__ = ("start", "delta", "origin", "span", "through", "unit", "length",
                 "remaining",
                 "acceleration", "rapid_rate", "nominal_speed", "entry_sqr",
                 "max_entry_sqr", "max_junction_sqr", "tag", "feed", "override",
                 "reserve_in", "reserve_out", "zone_out")

    def __init__(self, start: tuple[int, ...], delta: tuple[int, ...],
                 unit: tuple[float, ...], length: float, acceleration: float,
                 rapid_rate: float, nominal_speed: float, tag: object,
                 feed: float | None, override: bool = True,
                 origin: tuple[float, ...] | None = None,
                 span: tuple[float, ...] | None = None, through: bool = False) -> None:
        self.start = start  # steps, where the axes stand as the block begins
        self.delta = delta  # steps per axis (signed) the axes make in it
        #: the path itself (steps, not rounded) where it runs between steps (an
        #: arc's chord ends): it begins at ``origin`` and goes ``span``, each axis
        #: ending on the step nearest to the path's end (:func:`pin_after`); None:
        #: ``start``, ``delta``
        self.origin = origin
        self.span = span
        #: the path goes on through its end (an arc's chord end): every axis stands
        #: on the step nearest to the path all the way, its last step not on the end
        self.through = through
        self.unit = unit  # unit vector in units
        self.length = length  # units
        self.remaining = length  # units not executed yet (Grbl: block->millimeters)
        self.acceleration = acceleration  # units/s^2 along the block
        self.rapid_rate = rapid_rate  # units/s: every axis at its maximum rate or below
        self.nominal_speed = nominal_speed  # units/s: the feed, at most the rapid rate
        self.entry_sqr = 0.0  # planned entry speed squared
        self.max_entry_sqr = 0.0
        self.max_junction_sqr = 0.0
        self.tag = tag  # the caller's (a G-code line number, a laser power)
        self.feed = feed  # units/min as asked (None: rapid)
        self.override = override  # the feed/rapid override applies (not to a jog)
        # corner blends (fas.path.blend): the lengths kept for the blends at both
        # ends (the passes ramp over the rest) and the blend's k at the end
        self.reserve_in = 0.0
        self.reserve_out = 0.0
        self.zone_out = 0.0

    @property
    def end(self) -> tuple[int, ...]:
        return tuple(s + d for s, d in zip(self.start, self.delta, strict=True))

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"Block({self.delta}, L={self.length:.4g}, v={self.nominal_speed:.4g}, "
                f"entry={math.sqrt(self.entry_sqr):.4g}, "
                f"max={math.sqrt(self.max_entry_sqr):.4g})")


def pin_after(pin: int, x0: float, x1: float) -> int:
    """Where an axis stands once the path has gone from ``x0`` to ``x1`` (steps, along
    one axis) with the axis at ``pin`` (within a step of ``x0``): on the step nearest
    to ``x1`` - on ``x1`` itself where it is a whole step - unless that lies behind
    ``pin`` (a turn within half a step: the axis waits)."""
    if x1 > x0:
        k = math.floor(x1 + 0.5)
        return k if k > pin else pin
    if x1 < x0:
        k = math.ceil(x1 - 0.5)
        return k if k < pin else pin
    return pin


def on_steps(block: Block) -> bool:
    """Whether ``block`` ends in a corner a blend may take: on whole steps and not a
    point the path goes on through (an arc's chord end, kept exact)."""
    if block.through:
        return False
    if block.span is None:
        return True
    origin = block.origin
    assert origin is not None
    return all(abs(x0 + x - round(x0 + x)) < 1e-9
               for x0, x in zip(origin, block.span, strict=True))


def limit_along(limits: Sequence[float], unit: Sequence[float]) -> float:
    """The largest value along ``unit`` that keeps every axis within ``limits[i]``."""
    best = BIG
    for lim, u in zip(limits, unit, strict=True):
        if u != 0.0:
            v = lim / abs(u)
            if v < best:
                best = v
    return best


class Lookahead:
    """The queue of blocks and its speed planning (see the module text)."""

    def __init__(self, axes: Sequence[AxisLimits], junction_deviation: float,
                 size: int, top_rates: Sequence[float] | None = None,
                 blend_share: float = 0.0) -> None:
        """``top_rates``: the steppers' own top speeds in steps/s (their queues' limit),
        which cap each axis's ``max_rate`` too.  ``blend_share`` > 0: corners are
        blended (fas.path.blend), each blend within that share of either block."""
        from .blend import zone_coefficient  # (blend uses limit_along from here)

        self.size = size
        self.blend_share = blend_share
        #: with blends: a corner whose blend no axis's step tells from Grbl's corner
        #: by more than this (steps) is written as Grbl's (PathSettings.plain_corner_steps)
        self.plain_steps = 0.0
        self._zone_coefficient = zone_coefficient  # (_reserve's, imported once)
        #: junction_sqr's last corner: (unit in, unit out, |out - in|, the acceleration
        #: along out - in) - zone_coefficient's figures for the same corner
        self._bisector: tuple[Sequence[float], Sequence[float], float, float] | None = None
        self.blocks: list[Block] = []
        self.planned = 0  # blocks before this index (and its entry) are final
        self.configure(axes, junction_deviation, top_rates)
        self.prev_unit: tuple[float, ...] | None = None
        self.prev_nominal = 0.0
        self.recalculations = 0
        self.pass_steps = 0  # blocks visited by both passes (the work planning did)
        self.feed_scale = 1.0  # feed override (Grbl's 0x90..0x94), G1 blocks
        self.rapid_scale = 1.0  # rapid override (0x95..0x97), rapid blocks

    def configure(self, axes: Sequence[AxisLimits], junction_deviation: float,
                  top_rates: Sequence[float] | None = None) -> None:
        self.spu = tuple(a.steps_per_unit for a in axes)
        rates = [a.max_rate / 60.0 for a in axes]
        if top_rates is not None:
            rates = [min(r, top / a.steps_per_unit)
                     for r, top, a in zip(rates, top_rates, axes, strict=True)]
        self.max_rate = tuple(rates)  # units/s per axis
        self.accel = tuple(a.acceleration for a in axes)  # units/s^2 per axis
        self.junction_deviation = junction_deviation

    # ------------------------------------------------------------- queries
    def __len__(self) -> int:
        return len(self.blocks)

    def full(self) -> bool:
        return len(self.blocks) >= self.size

    def first(self) -> Block | None:
        return self.blocks[0] if self.blocks else None

    def exit_sqr(self) -> float:
        """The exit speed squared planned for the first block (the next one's entry)."""
        return self.blocks[1].entry_sqr if len(self.blocks) > 1 else 0.0

    def min_time(self) -> float:
        """Seconds the queued blocks take at least (each at its nominal speed)."""
        return sum(b.remaining / b.nominal_speed for b in self.blocks)

    # ---------------------------------------------------------------- adding
    def make_block(self, start: tuple[int, ...], delta: tuple[int, ...],
                   feed: float | None, tag: object, override: bool = True,
                   origin: tuple[float, ...] | None = None,
                   span: tuple[float, ...] | None = None,
                   through: bool = False) -> Block | None:
        """A block from ``start`` by ``delta`` steps at ``feed`` units/min (None: the
        rapid rate); None for a block of no length.  Not queued yet (:meth:`add`).
        ``override``: the overrides (:meth:`set_overrides`) scale its speed.
        ``origin``, ``span``: the path's own start and travel in steps where it runs
        between steps (:class:`Block`); its length and direction are theirs;
        ``through``: :attr:`Block.through`."""
        spu = self.spu
        # (map in place of zips with their keyword, which cost more; the same figures)
        d_units = list(map(truediv, delta if span is None else span, spu))
        length = math.sqrt(sum(map(mul, d_units, d_units)))
        if length == 0.0:
            return None
        unit = tuple(map(truediv, d_units, repeat(length)))
        acceleration = rapid = BIG  # (limit_along for both, written out)
        accel, max_rate = self.accel, self.max_rate
        for i, u in enumerate(unit):  # (by index: a zip with its keyword costs more)
            if u != 0.0:
                au = abs(u)
                v = accel[i] / au
                if v < acceleration:
                    acceleration = v
                v = max_rate[i] / au
                if v < rapid:
                    rapid = v
        block = Block(start, delta, unit, length, acceleration, rapid, rapid, tag, feed,
                      override, origin, span, through)
        block.nominal_speed = self.nominal(block)
        return block

    def nominal(self, block: Block) -> float:
        """The block's speed (units/s): its feed or the rapid rate, scaled by the
        override (Grbl's ``plan_compute_profile_nominal_speed``), at most the rapid rate."""
        rapid = block.rapid_rate
        if block.feed is None:
            return rapid * self.rapid_scale if block.override else rapid
        feed = block.feed * self.feed_scale if block.override else block.feed
        # (min(max(feed, MINIMUM_FEED) / 60.0, rapid) written out: a builtin's call costs
        # more than the comparison - here and below, the same operand on a tie)
        speed = (MINIMUM_FEED if feed < MINIMUM_FEED else feed) / 60.0
        return rapid if rapid < speed else speed

    def set_overrides(self, feed_scale: float, rapid_scale: float) -> None:
        """New override factors: every queued block's speed and junction limits are
        computed again and the whole queue is planned again (Grbl's
        ``plan_update_velocity_profile_parameters``).  The block in execution takes
        its new speed from the end of what is final on."""
        self.feed_scale, self.rapid_scale = feed_scale, rapid_scale
        prev = 0.0
        for i, b in enumerate(self.blocks):
            b.nominal_speed = self.nominal(b)
            if i:
                top = min(b.nominal_speed, prev)
                b.max_entry_sqr = min(top * top, b.max_junction_sqr)
                if b.entry_sqr > b.max_entry_sqr:
                    b.entry_sqr = b.max_entry_sqr
            prev = b.nominal_speed
        if self.blocks:
            self.prev_nominal = prev
        self.replan_from_first()

    def add(self, block: Block) -> None:
        """Queue ``block`` (there is room) and plan again."""
        blocks = self.blocks
        prev_unit = self.prev_unit
        if not blocks or prev_unit is None:
            block.max_junction_sqr = 0.0  # from rest
        else:
            block.max_junction_sqr = self.junction_sqr(prev_unit, block.unit)
        nominal = block.nominal_speed
        top = nominal
        if blocks and self.prev_nominal < nominal:  # (min(nominal, prev_nominal))
            top = self.prev_nominal
        top2, limit = top * top, block.max_junction_sqr
        block.max_entry_sqr = limit if limit < top2 else top2  # (min(top2, limit))
        share = self.blend_share
        if share > 0.0:
            self._reserve(block, share)
        block.entry_sqr = 0.0
        self.prev_nominal = nominal
        self.prev_unit = block.unit
        blocks.append(block)
        self.recalculate()

    def _reserve(self, block: Block, share: float) -> None:
        """Corner blends: the newest block keeps ``share`` of its length free at its
        end; the junction into ``block`` is capped so that its blend takes at most
        that share of either block, and the block before keeps the blend's largest
        length ``k m`` only - a length that grows, so what is final stays final.  The
        path goes on through an arc's chord ends (``through``) and points between
        steps exactly: no blend there, the junction as Grbl's (:func:`on_steps`)."""
        blocks = self.blocks
        k = 0.0
        prev_res = 0.0
        if (blocks and self.prev_unit is not None and block.max_junction_sqr > 0.0
                and on_steps(blocks[-1])):
            prev = blocks[-1]
            c = self._bisector
            if (c is not None and c[0] is prev.unit and c[1] is block.unit
                    and not c[2] < STRAIGHT):  # (zone_coefficient from junction_sqr's)
                k = c[2] / (2.0 * c[3])
            else:
                k = self._zone_coefficient(prev.unit, block.unit, self.accel)
            if k > 0.0:
                shorter = block.length if block.length < prev.length else prev.length
                fit = share * shorter / k
                if block.max_junction_sqr > fit:
                    block.max_junction_sqr = fit
                if block.max_entry_sqr > fit:
                    block.max_entry_sqr = fit
            top = block.nominal_speed  # (min(block's, prev's), written out)
            if prev.nominal_speed < top:
                top = prev.nominal_speed
            top2 = top * top
            m = block.max_junction_sqr  # (min(m, top2))
            if top2 < m:
                m = top2
            res = k * m  # (an override that raises the speeds: the executor's window)
            prev.remaining += prev.reserve_out - res
            prev.reserve_out = res
            prev.zone_out = k
            prev_res = res
        elif blocks:
            prev = blocks[-1]
            prev.remaining += prev.reserve_out
            prev.reserve_out = 0.0
            prev.zone_out = 0.0
        block.reserve_in = prev_res
        block.reserve_out = share * block.length
        block.remaining = block.length - block.reserve_in - block.reserve_out

    def junction_sqr(self, a: Sequence[float], b: Sequence[float]) -> float:
        """The largest speed squared at the corner from direction ``a`` to ``b``."""
        cos_theta = 0.0  # cosine of the angle between the segments (-1: straight on)
        for i, x in enumerate(a):  # (by index: a zip with its keyword costs more)
            cos_theta -= x * b[i]
        if cos_theta > COS_REVERSAL:
            return 0.0
        if cos_theta < COS_STRAIGHT:
            return BIG
        bisector = list(map(sub, b, a))  # (b - a; map: no zip with its keyword)
        norm = math.sqrt(sum(map(mul, bisector, bisector)))
        accel = BIG  # (limit_along(self.accel, bisector / norm), written out)
        limits = self.accel
        for i, v in enumerate(bisector):  # (by index, as above)
            u = v / norm
            if u != 0.0:
                x = limits[i] / abs(u)
                if x < accel:
                    accel = x
        self._bisector = (a, b, norm, accel)  # (_reserve's zone coefficient: the same)
        sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
        return accel * self.junction_deviation * sin_half / (1.0 - sin_half)

    # -------------------------------------------------------------- planning
    def recalculate(self) -> None:
        """The reverse and the forward pass from the planned pointer on."""
        blocks = self.blocks
        last = len(blocks) - 1
        planned = self.planned
        if last <= planned:
            return  # one block left to plan: the first stays as executed
        self.recalculations += 1
        cur = blocks[last]
        e = cur.max_entry_sqr  # (min(e, stop), written out)
        stop = 2.0 * cur.acceleration * cur.remaining
        if stop < e:
            e = stop
        cur.entry_sqr = e
        # reverse: as fast as each can still slow down to the next (``e``: the entry
        # of the block after ``cur``)
        for i in range(last - 1, planned, -1):
            cur = blocks[i]
            m = cur.max_entry_sqr
            if cur.entry_sqr != m:
                e = e + 2.0 * cur.acceleration * cur.remaining
                if e >= m:
                    e = m
                cur.entry_sqr = e
            else:
                e = m
        # forward: what acceleration reaches (``e``: the entry of ``cur``)
        cur = blocks[planned]
        e = cur.entry_sqr
        for i in range(planned + 1, last + 1):
            nxt = blocks[i]
            x = nxt.entry_sqr
            if e < x:
                r = e + 2.0 * cur.acceleration * cur.remaining
                if r < x:
                    nxt.entry_sqr = x = r
                    planned = i  # full acceleration: nothing before can improve
            if x == nxt.max_entry_sqr:
                planned = i  # at its junction's limit: the plan before it is final
            cur = nxt
            e = x
        self.pass_steps += 2 * (last - self.planned)
        self.planned = planned

    def replan_from_first(self) -> None:
        """Plan every block again from the first (its entry or length changed in a way
        the final plan did not foresee: a feed hold, a shortened exit)."""
        self.planned = 0
        self.recalculate()

    # ---------------------------------------------------------------- taking
    def pop_first(self) -> Block:
        """The first block was executed to its end: drop it."""
        block = self.blocks.pop(0)
        planned = self.planned - 1  # (max(0, planned), written out)
        self.planned = planned if planned > 0 else 0
        if not self.blocks:
            self.prev_unit = None  # a block queued now starts from rest
        return block

    def replace_first(self, block: Block) -> None:
        """A feed hold stopped in the first block: ``block`` (the rest of it, from where
        the axes stand) takes its place and everything is planned from rest."""
        block.max_junction_sqr = 0.0
        block.max_entry_sqr = 0.0
        block.entry_sqr = 0.0
        self.blocks[0] = block
        self.replan_from_first()

    def clear(self) -> None:
        self.blocks.clear()
        self.planned = 0
        self.prev_unit = None
        self.prev_nominal = 0.0
