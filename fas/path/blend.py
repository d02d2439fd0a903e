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

from .lookahead import limit_along

#: |w - u| below this: straight on, nothing to blend (any turn above it is blended:
#: a velocity jump of v |w - u| would show in the acceleration from the pins)
STRAIGHT = 1e-9
#: an integer this close to a blend's exact end (steps) is reached at the end
END_EPS = 1e-9
#: exit_window's rounding: relative to the squared speeds (and to 1 for 1 - 2 a k)
WINDOW_EPS = 1e-9
#: a turn this close to either end of a motion (its share of the duration) is at it
TURN_EPS = 1e-9


@dataclass(frozen=True)
class Blend:
    """A corner taken at constant acceleration (see the module text).  Units, seconds."""

    u: tuple[float, ...]  # direction of the block in
    w: tuple[float, ...]  # direction of the block out
    speed: float  # v: the junction speed (units/s), at both ends of the blend
    accel: float  # a_j: along w - u (units/s^2)
    duration: float  # T (s)
    reach: float  # along each block from the corner to the blend's end (units)
    inside: float  # how far from the corner point it passes (units)
    zone: float  # k: reach = k v^2 at this corner and acceleration (s^2/unit)

    def axis_accel(self, i: int) -> float:
        """Axis ``i``'s acceleration in the blend (units/s^2, signed)."""
        return self.speed * (self.w[i] - self.u[i]) / self.duration

    def position(self, t: float) -> tuple[float, ...]:
        """Where the blend is ``t`` seconds after it began, from the corner (units)."""
        v, d, T = self.speed, self.reach, self.duration
        return tuple(-d * a + v * a * t + 0.5 * v * (b - a) / T * t * t
                     for a, b in zip(self.u, self.w, strict=True))

    def velocity(self, t: float) -> tuple[float, ...]:
        v, T = self.speed, self.duration
        return tuple(v * (a + (b - a) * t / T) for a, b in zip(self.u, self.w, strict=True))

    def turn_time(self, i: int) -> float | None:
        """When axis ``i`` turns round inside the blend (its velocity is 0), if it does."""
        a, b = self.u[i], self.w[i]
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
    return Blend(tuple(u), tuple(w), speed, a_j, duration, zone * speed * speed,
                 speed * duration * n / 8.0, zone)


def zone_coefficient(u: Sequence[float], w: Sequence[float],
                     axis_accel: Sequence[float]) -> float:
    """``k``: a blend at this corner at speed ``v`` takes ``k v^2`` of each block
    (units per (units/s)^2); 0 straight on."""
    diff = [b - a for a, b in zip(u, w, strict=True)]
    n = math.sqrt(sum(x * x for x in diff))
    if n < STRAIGHT:
        return 0.0
    return n / (2.0 * limit_along(axis_accel, [x / n for x in diff]))


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
        while True:
            gap = s * (p + s - xa)  # how far the next integer lies ahead
            if gap < 0.0:  # already past it (rounding at a piece's start)
                gap = 0.0
            root = w0 * w0 + 2.0 * b * gap
            den = w0 + math.sqrt(root) if root > 0.0 else w0
            tau = 2.0 * gap / den if den > 0.0 else math.inf
            if tau > span:
                if last and x_end is not None and s * (x_end - (p + s)) >= -END_EPS:
                    tau = span  # the end lies on that integer: rounding missed it
                else:
                    break
            p += s
            out.append((ta + tau, s))
    return out, p


def corner_steps(start_in: Sequence[int], delta_in: Sequence[int],
                 delta_out: Sequence[int], blend: Blend, spu: Sequence[float],
                 made_in: Sequence[int] | None = None,
                 origin_in: Sequence[float] | None = None,
                 span_in: Sequence[float] | None = None,
                 span_out: Sequence[float] | None = None
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
    corner on whole steps (the steps counted from ``start_in``, the axes' pins)."""
    path_in = delta_in if span_in is None else span_in
    path_out = delta_out if span_out is None else span_out
    len_in = math.sqrt(sum((d / k) ** 2 for d, k in zip(path_in, spu, strict=True)))
    len_out = math.sqrt(sum((d / k) ** 2 for d, k in zip(path_out, spu, strict=True)))
    from_in = start_in if origin_in is None else origin_in
    if not (blend.reach <= len_in and blend.reach <= len_out):
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
        x_end = corner + dp_out * blend.reach / len_out
        steps, p = axis_crossings(x0, blend.speed * blend.u[i] * k, blend.axis_accel(i) * k,
                                  blend.duration, p0, x_end)
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
    if zone > 0.0:
        hi = min(hi, rest / zone)  # the zone fits
    lo = 0.0
    slope = 1.0 - two_a * zone  # e (1 - 2 a k) >= v^2 - 2 a rest: it can slow down
    # (rounding: an executor on its way to an exit meets the bound with equality)
    need = v_sqr - two_a * rest - WINDOW_EPS * (v_sqr + two_a * rest)
    if slope > WINDOW_EPS:
        lo = max(0.0, need / slope)
    elif slope < -WINDOW_EPS:
        hi = min(hi, need / slope)
    elif need > 0.0:
        return None
    if lo > hi:
        return None
    return lo, hi
