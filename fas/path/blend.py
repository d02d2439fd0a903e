"""Corner blends: a junction taken at constant acceleration (issue 25).

Junction deviation gives the speed ``v`` at the corner from direction ``u`` into
direction ``w`` (unit vectors in units); Grbl's stepper then changes each axis's
velocity at once by ``v (w_i - u_i)`` - an impulse no axis can follow.  A *blend*
takes the corner the way junction deviation's own model assumes: the velocity goes
from ``v u`` to ``v w`` at the constant acceleration ``a_j`` along ``w - u``, where
``a_j`` is the acceleration along that bisector that keeps every axis within its
limit - the one :meth:`fas.path.lookahead.Lookahead.junction_sqr` uses - so every
axis stays within its acceleration by construction.

Its figures (:func:`corner_blend`): it lasts ``T = v |w - u| / a_j``, begins
``reach = v T / 2`` before the corner on the block in and ends as far into the block
out, at speed ``v`` at both ends; outside it the motion is the blocks' own - at a
constant speed ``v`` over the reach on both sides, the blended position equals the
unblended one at both ends.  It passes inside the corner by ``v T |w - u| / 8``
(the distance of its middle from the corner point, the nearest it comes), which at
the junction-deviation speed is ``d sin(theta/2) (1 + sin(theta/2)) / 2 <= d``.

Per axis it is a constant acceleration, so the axis's steps are where a quadratic in
time crosses the integers (:func:`axis_crossings`): moving up, the step to ``p + 1``
comes when the position reaches ``p + 1``; moving down, the step to ``p - 1`` when it
reaches ``p - 1`` - the rule a straight block follows (its position rounds down
along the path), so the step grid of both blocks is unchanged, and an axis that
turns round inside the blend makes no step at the turn.

Written out, a blend step may come a little earlier (:func:`lead_to_polyline`):
where the commanded corner (the blend's control polygon at the blend's clock)
reaches its integer first, the step comes there, but at most 1/8 step (the
grouping's tolerance) before the blend reaches it - so that an axis the blend makes
lag the commanded path (floor rounding plus the blend's gap inside the corner) is
not more than a step from it (docs/path-planner.md, "Where the 1.038 came from").

The planner's side (:func:`exit_window`): with the blends, a block is a ramp between
two zones of constant speed whose lengths grow with the junction speeds squared
(``reach = k v^2``, :attr:`Blend.zone`), so what a block can reach is linear in the
squared speeds again.  docs/path-planner.md ("Corners: blends") says how the look-ahead
plans with it, the executor makes it final (:class:`fas.path.executor.BlendSegment`) and
the stepping writes its steps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import repeat
from operator import mul, sub, truediv

# (STRAIGHT: |w - u| below this is straight on, nothing to blend - any turn above it
# is blended: a velocity jump of v |w - u| would show in the acceleration from the pins)
from .lookahead import STRAIGHT, limit_along

#: an integer this close to a blend's exact end (steps) is reached at the end
END_EPS = 1e-9
#: exit_window's rounding: relative to the squared speeds (and to 1 for 1 - 2 a k)
WINDOW_EPS = 1e-9
#: a turn this close to either end of a motion (its share of the duration) is at it
TURN_EPS = 1e-9


@dataclass(frozen=True)
class Blend:
    """A corner taken at constant acceleration (see the module text).  Units, seconds.

    The velocity goes from ``speed * u`` to ``speed_out * w``: at one speed (a planned
    corner, :func:`corner_blend`) or slowing down (a feed hold's corner,
    :func:`slowing_blend`).  Either way its path is the quadratic Bezier from ``reach``
    before the corner on the block in to ``reach_out`` after it on the block out,
    with the corner point as its control point: ``reach = speed T / 2`` and
    ``reach_out = speed_out T / 2``."""

    u: tuple[float, ...]  # direction of the block in
    w: tuple[float, ...]  # direction of the block out
    speed: float  # v: the speed at the blend's start (units/s; a planned corner: the
    # junction speed, at both ends)
    accel: float  # |the acceleration| (units/s^2), along v_out w - v u
    duration: float  # T (s)
    reach: float  # along the block in from the blend's start to the corner (units)
    inside: float  # how far from the corner point it passes (units)
    zone: float  # k: reach = k v^2 at this corner and acceleration (s^2/unit)
    speed_out: float  # the speed at its end (units/s)
    reach_out: float  # along the block out from the corner to the blend's end (units)

    def axis_accel(self, i: int) -> float:
        """Axis ``i``'s acceleration in the blend (units/s^2, signed)."""
        return (self.speed_out * self.w[i] - self.speed * self.u[i]) / self.duration

    def position(self, t: float) -> tuple[float, ...]:
        """Where the blend is ``t`` seconds after it began, from the corner (units)."""
        v, vo, d, T = self.speed, self.speed_out, self.reach, self.duration
        return tuple(-d * a + v * a * t + 0.5 * (vo * b - v * a) / T * t * t
                     for a, b in zip(self.u, self.w, strict=True))

    def velocity(self, t: float) -> tuple[float, ...]:
        v, vo, T = self.speed, self.speed_out, self.duration
        return tuple(v * a + (vo * b - v * a) * t / T
                     for a, b in zip(self.u, self.w, strict=True))

    def turn_time(self, i: int) -> float | None:
        """When axis ``i`` turns round inside the blend (its velocity is 0), if it does."""
        a, b = self.speed * self.u[i], self.speed_out * self.w[i]
        if a * b >= 0.0:
            return None
        return self.duration * a / (a - b)


def bisector_accel(u: Sequence[float], w: Sequence[float],
                   axis_accel: Sequence[float]) -> float:
    """The largest acceleration along ``w - u`` that keeps every axis within
    ``axis_accel`` (units/s^2); 0 straight on."""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    n = math.sqrt(sum(x * x for x in diff))
    if n < STRAIGHT:
        return 0.0
    return limit_along(axis_accel, [x / n for x in diff])


def corner_blend(u: Sequence[float], w: Sequence[float], speed: float,
                 axis_accel: Sequence[float]) -> Blend | None:
    """The blend at the corner from ``u`` into ``w`` at ``speed`` (units/s), every
    axis within ``axis_accel`` (units/s^2); None straight on or at a stop."""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    n = math.sqrt(sum(x * x for x in diff))
    if n < STRAIGHT or speed <= 0.0:
        return None
    a_j = limit_along(axis_accel, [x / n for x in diff])
    duration = speed * n / a_j
    zone = n / (2.0 * a_j)
    reach = zone * speed * speed
    return Blend(tuple(u), tuple(w), speed, a_j, duration, reach,
                 speed * duration * n / 8.0, zone, speed, reach)


def plain_offsets(u: Sequence[float], w: Sequence[float], zone: float, speed_sqr: float,
                  spu: Sequence[float], threshold: float) -> tuple[float, ...] | None:
    """Each axis's largest offset (steps) between the blend at the corner from ``u``
    into ``w`` (``zone``: :func:`zone_coefficient`, at speed squared ``speed_sqr``)
    and Grbl's corner at the blend's clock, where every one is at most ``threshold``
    steps; else None.

    At the blend's clock the commanded corner (the block in at ``v`` up to the
    corner, then the block out) and the blend differ in axis ``i`` by ``v (w_i -
    u_i) t^2 / (2 T)`` over the first half and symmetrically after: one sign, largest
    at the middle, ``v T |w_i - u_i| / 8`` units there - the blend's ``inside``
    times ``|w_i - u_i| / |w - u|``, and with ``T = 2 k v`` that is ``k v^2 |w_i -
    u_i| / 4``.  Both end at the same place and time, so where that is below
    ``threshold`` in every axis, no step of Grbl's corner comes more than
    ``threshold`` steps from where the blend reaches it (docs/path-planner.md,
    "Corners no step can tell apart")."""
    scale = 0.25 * zone * speed_sqr
    out = tuple([scale * abs(w[i] - a) * spu[i] for i, a in enumerate(u)])  # (no zip
    # with its keyword: that costs more than the comprehension)
    for d in out:
        if d > threshold:
            return None
    return out


def _nearest(p0: Sequence[float], p2: Sequence[float]) -> float:
    """The least distance from the origin of the quadratic Bezier from ``p0`` to
    ``p2`` with the origin as its control point: ``|(1 - s)^2 p0 + s^2 p2|`` over
    ``0 <= s <= 1`` (sampled, then narrowed by golden sections)."""
    def dist(s: float) -> float:
        a, b = (1.0 - s) ** 2, s * s
        return math.sqrt(sum((a * x + b * y) ** 2 for x, y in zip(p0, p2, strict=True)))

    n = 64
    k = min(range(n + 1), key=lambda j: dist(j / n))
    lo, hi = max(0.0, (k - 1) / n), min(1.0, (k + 1) / n)
    g = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(60):
        m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
        if dist(m1) <= dist(m2):
            hi = m2
        else:
            lo = m1
    return dist(0.5 * (lo + hi))


def slowing_blend(u: Sequence[float], w: Sequence[float], speed_in: float,
                  speed_out: float, axis_accel: Sequence[float]) -> Blend | None:
    """The blend from velocity ``speed_in * u`` to ``speed_out * w`` (units/s) in the
    shortest time every axis's acceleration allows: ``T = max_i |v_out w_i - v_in
    u_i| / a_i``, the axes that set it at their limit.  None straight on or from a
    stop.  (At ``speed_out == speed_in`` it is :func:`corner_blend`'s blend.)"""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    if math.sqrt(sum(x * x for x in diff)) < STRAIGHT or speed_in <= 0.0:
        return None
    dv = [speed_out * b - speed_in * a for a, b in zip(u, w, strict=True)]
    duration = max(abs(x) / acc for x, acc in zip(dv, axis_accel, strict=True))
    if duration <= 0.0:
        return None
    reach, reach_out = 0.5 * speed_in * duration, 0.5 * speed_out * duration
    inside = _nearest([-reach * a for a in u], [reach_out * b for b in w])
    return Blend(tuple(u), tuple(w), speed_in, math.sqrt(sum(x * x for x in dv)) / duration,
                 duration, reach, inside, zone_coefficient(u, w, axis_accel), speed_out,
                 reach_out)


def hold_blend(u: Sequence[float], w: Sequence[float], v_sqr: float, rest: float,
               accel_in: float, accel_out: float, axis_accel: Sequence[float],
               room_out: float, deviation: float = math.inf
               ) -> tuple[float, float] | None:
    """A feed hold's corner it cannot stop before: ``(v_in^2, v_out)`` of the
    :func:`slowing_blend` that leaves the least to run after it, or None where none
    fits (straight on, or no blend can begin on the rest of the block in).

    The hold is at speed squared ``v_sqr`` with ``rest`` units to the corner, and
    decelerates at ``accel_in`` on the block in and at ``accel_out`` on the block out.
    A blend slowing to ``v_out = r v_in`` takes ``T = v_in tau(r)``, ``tau(r) = max_i
    |r w_i - u_i| / a_i``, and begins ``c v_in^2`` before the corner (``c = tau /
    2``), where the deceleration reaches ``v_in^2 = (v^2 - 2 a_in rest) / (1 - 2 a_in
    c)`` (it must: ``v_in^2 <= v^2``).  It ends ``r c v_in^2`` into the block out (at
    most ``room_out``) at ``v_out``, from where a stop takes ``v_out^2 / (2 a_out)``
    more: ``Q(r) = v_in^2 (r c + r^2 / (2 a_out))``, the stop's distance from the
    corner along the block out.  The hold takes the least ``Q`` (the largest ``r``
    among equals: the shortest blend), over ``r`` in ``(0, 1]``: every breakpoint of
    ``tau``, where the blend would begin at the hold's point, ``Q``'s stationary
    points on each axis's piece of ``tau``, and a grid of 1/1024 besides.  ``r = 1``
    is :func:`corner_blend` at the slowest exit :func:`exit_window` allows, so it
    never stops later than that.
    Where the blend slows along the polyline at ``a_in`` (``1 - 2 a_in c = r``: the
    axes that set ``tau`` keep their share of the block's acceleration) the stop lies
    ``v^2 / (2 a_in)`` along the polyline, as without the corner.  Every blend passes
    inside the corner by at most ``deviation`` (``$11``, as a planned blend at the
    junction speed): the least ``Q`` among those that do."""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    if math.sqrt(sum(x * x for x in diff)) < STRAIGHT:
        return None
    need = v_sqr - 2.0 * accel_in * rest
    if need <= 0.0:
        return None
    axes = list(zip(u, w, axis_accel, strict=True))

    def tau(r: float) -> float:
        return max(abs(r * b - a) / acc for a, b, acc in axes)

    grid = 1024
    cands = {j / grid for j in range(1, grid + 1)}
    edge = (1.0 - need / v_sqr) / accel_in  # tau where the blend begins at the hold's point
    for i, (a, b, acc) in enumerate(axes):
        if b != 0.0:
            cands.add(a / b)  # the axis's term is 0 there
            for sg in (1.0, -1.0):
                cands.add((a + sg * edge * acc) / b)
        for sg in (1.0, -1.0):  # where the axis sets tau = al + be r: Q's stationary
            al, be = -sg * a / acc, sg * b / acc  # points, A2 D1 r^2 - 2 A2 D0 r - A1 D0 = 0
            a1, a2 = 0.5 * al, 0.5 * be + 0.5 / accel_out
            d0, d1 = 1.0 - accel_in * al, accel_in * be
            qa, qb, qc = a2 * d1, -2.0 * a2 * d0, -a1 * d0
            if qa != 0.0:
                disc = qb * qb - 4.0 * qa * qc
                if disc >= 0.0:
                    root = math.sqrt(disc)
                    cands.update(((-qb + root) / (2.0 * qa), (-qb - root) / (2.0 * qa)))
            elif qb != 0.0:
                cands.add(-qc / qb)
        for a2, b2, acc2 in axes[i + 1:]:
            for sg in (1.0, -1.0):  # the two axes' terms equal
                den = b / acc - sg * b2 / acc2
                if den != 0.0:
                    cands.add((a / acc - sg * a2 / acc2) / den)
    found: list[tuple[float, float, float, float]] = []  # (Q, r, v_in^2, c)
    for r in cands:
        if not 0.0 < r <= 1.0:
            continue
        c = 0.5 * tau(r)
        den = 1.0 - 2.0 * accel_in * c
        if den <= WINDOW_EPS:
            continue
        vin2 = need / den
        if vin2 > v_sqr:
            if vin2 > v_sqr * (1.0 + WINDOW_EPS):
                continue  # it would begin before the hold's point
            vin2 = v_sqr
        if r * c * vin2 > room_out:
            continue
        found.append((vin2 * (r * c + r * r / (2.0 * accel_out)), r, vin2, c))
    found.sort()
    k = 0
    while k < len(found):  # by Q; among equals the largest r first
        top = found[k][0] * (1.0 + WINDOW_EPS)
        j = k
        while j < len(found) and found[j][0] <= top:
            j += 1
        for _q, r, vin2, c in sorted(found[k:j], key=lambda f: -f[1]):
            if deviation == math.inf or _within(u, w, r, c * vin2, deviation):
                return vin2, r * math.sqrt(vin2)
        k = j
    return None


def _within(u: Sequence[float], w: Sequence[float], r: float, reach: float,
            deviation: float) -> bool:
    """Does the Bezier from ``-reach u`` to ``r reach w`` (corner at the origin) pass
    the corner at ``deviation`` or nearer?  Its middle ``(p0 + p2) / 4`` is a point of
    it (nearer: yes); every point is ``(1 - s)^2 + s^2 >= 1/2`` times a point of the
    chord ``p0 p2`` (half its distance beyond: no); else :func:`_nearest`."""
    p0 = [-reach * a for a in u]
    p2 = [r * reach * b for b in w]
    if math.sqrt(sum((a + b) ** 2 for a, b in zip(p0, p2, strict=True))) / 4.0 <= deviation:
        return True
    d = [b - a for a, b in zip(p0, p2, strict=True)]
    n2 = sum(x * x for x in d)
    t = min(1.0, max(0.0, -sum(a * x for a, x in zip(p0, d, strict=True)) / n2)) if n2 else 0.0
    chord = math.sqrt(sum((a + t * x) ** 2 for a, x in zip(p0, d, strict=True)))
    if 0.5 * chord > deviation:
        return False
    return _nearest(p0, p2) <= deviation


def zone_coefficient(u: Sequence[float], w: Sequence[float],
                     axis_accel: Sequence[float]) -> float:
    """``k``: a blend at this corner at speed ``v`` takes ``k v^2`` of each block
    (units per (units/s)^2); 0 straight on."""
    diff = list(map(sub, w, u))  # (w - u; map: no zip with its keyword, which costs more)
    n = math.sqrt(sum(map(mul, diff, diff)))
    if n < STRAIGHT:
        return 0.0
    return n / (2.0 * limit_along(axis_accel, list(map(truediv, diff, repeat(n)))))


def fit_sqr(u: Sequence[float], w: Sequence[float], axis_accel: Sequence[float],
            len_in: float, len_out: float, share: float = 0.5) -> float:
    """The largest junction speed squared whose blend takes at most ``share`` of the
    block in (``len_in``) and of the block out (units); unlimited straight on."""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    n = math.sqrt(sum(x * x for x in diff))
    if n < STRAIGHT:
        return math.inf
    a_j = limit_along(axis_accel, [x / n for x in diff])
    return 2.0 * share * a_j * min(len_in, len_out) / n


def axis_crossings(x0: float, v0: float, a: float, duration: float, p0: int,
                   x_end: float | None = None) -> tuple[list[tuple[float, int]], int]:
    """Axis steps of the motion ``x(t) = x0 + v0 t + a t^2 / 2`` (steps, seconds)
    over ``[0, duration]``, from the position ``p0`` (``|x0 - p0| < 1``, and
    ``p0 <= x0`` where it moves up, ``p0 >= x0`` where it moves down - the blocks'
    rounding): ``([(t, +1 or -1), ...], p)`` - each step at the time the position
    reaches the next integer in the direction of motion, and the position at the
    end.  Where the velocity changes sign inside, the motion is split there: the
    turn itself makes no step.  ``x_end``: the exact position at the end where the
    caller knows it (a block's integer end): an integer reached there within
    rounding is stepped on at the end."""
    out: list[tuple[float, int]] = []
    p = p0
    bounds = [0.0]
    if a != 0.0:
        t_turn = -v0 / a
        # a turn at an end (an axis that stops at the corner, or starts there) is
        # no turn inside: rounding must not cut a piece of no length off
        if TURN_EPS * duration < t_turn < (1.0 - TURN_EPS) * duration:
            bounds.append(t_turn)
    bounds.append(duration)
    for k in range(len(bounds) - 1):
        ta, tb = bounds[k], bounds[k + 1]
        xa = x0 + v0 * ta + 0.5 * a * ta * ta
        va = v0 + a * ta
        vb = v0 + a * tb
        mid = va + vb  # the direction over the piece (velocity keeps its sign)
        if mid == 0.0:
            continue
        s = 1 if mid > 0.0 else -1
        # in the frame of the motion: y = s (x - xa) grows from 0, at w0 + b t
        w0 = max(s * va, 0.0)
        b = s * a
        span = tb - ta
        last = k == len(bounds) - 2
        ww = w0 * w0  # (the same products as in the loop, made once)
        b2 = 2.0 * b
        sqrt = math.sqrt
        keep = out.append
        while True:
            gap = s * (p + s - xa)  # how far the next integer lies ahead
            if gap < 0.0:  # already past it (rounding at a piece's start)
                gap = 0.0
            root = ww + b2 * gap
            den = w0 + sqrt(root) if root > 0.0 else w0
            tau = 2.0 * gap / den if den > 0.0 else math.inf
            if tau > span:
                if last and x_end is not None and s * (x_end - (p + s)) >= -END_EPS:
                    tau = span  # the end lies on that integer: rounding missed it
                else:
                    break
            p += s
            keep((ta + tau, s))
    return out, p


def _reach_time(x0: float, v0: float, a: float, target: float, s: int) -> float:
    """When ``x0 + v0 t + a t^2 / 2`` (moving the way ``s``, no turn) reaches ``target``."""
    gap = s * (target - x0)
    if gap <= 0.0:
        return 0.0
    w0 = s * v0
    root = w0 * w0 + 2.0 * s * a * gap
    den = w0 + math.sqrt(root) if root > 0.0 else w0
    return 2.0 * gap / den if den > 0.0 else math.inf


def lead_to_polyline(steps: list[tuple[float, int]], x0: float, p0: int, blend: Blend,
                     i: int,
                     k: float, lead: float) -> list[tuple[float, int]]:
    """Axis ``i``'s blend steps, each moved to where the control polygon (the
    commanded corner at the blend's clock: the block in at ``speed`` up to ``T/2``,
    the block out at ``speed_out`` after) reaches its integer, where that is earlier,
    but never more than ``lead`` steps before the blend reaches it.  An axis that
    turns round (in the blend or at the corner) keeps its steps, and so does one at
    rest at either end (a step next to rest keeps its tick, as a group's first and
    last do: there 1/8 step is a large share of the time between steps)."""
    vi = blend.speed * blend.u[i] * k
    vo = blend.speed_out * blend.w[i] * k
    if vi * vo <= 0.0 or not steps:
        return steps
    s = steps[0][1]
    for _t, d in steps:
        if d != s:  # (an axis that turns round keeps its steps)
            return steps
    a = blend.axis_accel(i) * k
    half = blend.duration / 2
    corner = x0 + vi * half
    out = []
    p = p0
    for t, d in steps:
        p += s  # the integer this step reaches
        if s * (p - corner) <= 0.0:
            tu = (p - x0) / vi if vi else math.inf
        else:
            tu = half + (p - corner) / vo if vo else math.inf
        if tu < t:
            tu = max(tu, _reach_time(x0, vi, a, p - s * lead, s))
            if tu < t:
                t = tu
        out.append((t, d))
    return out


def corner_steps(start_in: Sequence[int], delta_in: Sequence[int],
                 delta_out: Sequence[int], blend: Blend, spu: Sequence[float],
                 made_in: Sequence[int] | None = None,
                 origin_in: Sequence[float] | None = None,
                 span_in: Sequence[float] | None = None,
                 span_out: Sequence[float] | None = None,
                 leads: list[list[float]] | None = None, lead: float = 0.0
                 ) -> list[tuple[int, list[tuple[float, int]], int]]:
    """Each axis's steps around one blended corner, on the blocks' own step grid.

    The block in goes from ``start_in`` by ``delta_in`` steps to the corner, the block
    out on by ``delta_out``; each axis ``i`` (``spu[i]`` steps per unit) makes its
    steps of the block in up to the blend's start, the blend's (times from the
    blend's start, :func:`axis_crossings`), then those of the block out after the
    first ones.  Per axis: ``(made_in, blend_steps, first_out)`` - how many of its
    steps in the block in come before the blend (the block's rounding: the steps
    whose point ``j * pitch`` the path has reached), the blend's steps, and how many
    of its steps in the block out the blend has made (the block out's next step is
    number ``first_out + 1``).  Needs the blend within both blocks.  A block whose
    path runs between steps (:class:`fas.path.lookahead.Block`'s ``origin``,
    ``span``): the path is ``origin_in`` + ``span_in`` in, ``span_out`` out, the
    corner on whole steps (the steps counted from ``start_in``, the axes' pins).
    ``leads``: a list that receives, per axis, its blend steps' times led towards the
    commanded corner by up to ``lead`` steps (:func:`lead_to_polyline`)."""
    path_in = delta_in if span_in is None else span_in
    path_out = delta_out if span_out is None else span_out
    len_in = math.sqrt(sum([(d / k) ** 2 for d, k in zip(path_in, spu, strict=True)]))
    len_out = math.sqrt(sum([(d / k) ** 2 for d, k in zip(path_out, spu, strict=True)]))
    from_in = start_in if origin_in is None else origin_in
    if not (blend.reach <= len_in and blend.reach_out <= len_out):
        raise ValueError("the blend is longer than a block")
    s_in = len_in - blend.reach  # where the blend begins on the block in
    out: list[tuple[int, list[tuple[float, int]], int]] = []
    for i, (x_s, d_in, d_out, k) in enumerate(
            zip(start_in, delta_in, delta_out, spu, strict=True)):
        x_p = from_in[i]  # the path's start, its travel in and out
        dp_in = path_in[i]
        dp_out = path_out[i]
        n_in = abs(d_in)
        if made_in is not None:
            made = made_in[i]  # the block in's rounding where its execution ended
        else:
            made = min(n_in, int(s_in * n_in / len_in + 1e-12)) if n_in else 0
        up_in = d_in > 0
        p0 = x_s + (made if up_in else -made)
        x0 = x_p + dp_in * s_in / len_in
        corner = x_s + d_in
        x_end = corner + dp_out * blend.reach_out / len_out
        steps, p = axis_crossings(x0, blend.speed * blend.u[i] * k, blend.axis_accel(i) * k,
                                  blend.duration, p0, x_end)
        if leads is not None:
            leads.append([t for t, _d in lead_to_polyline(steps, x0, p0, blend, i, k, lead)])
        if d_out == 0:
            first = 0 if p == corner else -1
        else:
            first = (p - corner) if d_out > 0 else (corner - p)
        if first < 0 or first > abs(d_out):
            raise ValueError("the blend ends off the block out's step grid")
        out.append((made, steps, first))
    return out


def exit_window(v_sqr: float, rest: float, accel: float, zone: float
                ) -> tuple[float, float] | None:
    """The exit speeds squared ``e`` a block can take from speed squared ``v_sqr``
    with ``rest`` units left before its corner, at ``accel`` along it, when the
    blend at that corner takes ``zone * e`` of it: the ramp over ``rest - zone e``
    must reach ``e`` and must be able to slow down to it, and the zone must fit.
    ``(lo, hi)``, or None where no exit is possible (not even a stop)."""
    two_a = 2.0 * accel
    hi = (v_sqr + two_a * rest) / (1.0 + two_a * zone)  # acceleration reaches it
    # (min and max below written out: a builtin's call costs more than the comparison;
    # the first operand on a tie, as theirs)
    if zone > 0.0:
        fits = rest / zone  # the zone fits
        if fits < hi:
            hi = fits
    lo = 0.0
    slope = 1.0 - two_a * zone  # e (1 - 2 a k) >= v^2 - 2 a rest: it can slow down
    # (rounding: an executor on its way to an exit meets the bound with equality)
    need = v_sqr - two_a * rest - WINDOW_EPS * (v_sqr + two_a * rest)
    if slope > WINDOW_EPS:
        low = need / slope
        if low > lo:
            lo = low
    elif slope < -WINDOW_EPS:
        high = need / slope
        if high < hi:
            hi = high
    elif need > 0.0:
        return None
    if lo > hi:
        return None
    return lo, hi
