"""Arcs (G2/G3) as straight segments within the arc tolerance, as Grbl's ``mc_arc``.

An arc lies in a plane (G17 XY, G18 ZX, G19 YZ: :class:`Plane`), turns clockwise or
counter-clockwise about a centre given as an offset from the start (I/J/K) or found
from a radius (R), and may move the plane's third axis (and any further axes) in
proportion: a helix.

* **Segments.**  The segment end points lie on the circle; a chord of angle ``phi``
  on radius ``r`` comes ``r (1 - cos(phi/2))`` inside it.  The count is the smallest
  that keeps this within the tolerance ``tol`` ($12):
  ``ceil(|theta| / (2 acos(1 - tol/r)))``.  Grbl counts
  ``floor(|theta r / 2| / sqrt(tol (2 r - tol)))`` - its chord of half length
  ``sqrt(tol (2 r - tol))`` comes exactly ``tol`` inside, but rounding the count
  down lengthens every chord a little (``tol`` exceeded by up to ``(n+1)^2/n^2``);
  ours is the same count or one more.  An arc whose radius is within ``tol / 2``
  is one straight line, as Grbl's.
* **Points.**  Every point is computed with exact trigonometry from the start's radius
  vector - not with Grbl's small-angle rotation and its correction every 12 segments,
  which saves an 8-bit CPU its ``sin``/``cos``; the host has them cheap, and there is
  no drift to correct.  The last segment ends on the target exactly.
* **End.**  A block ending on whole steps ends every axis moving in it on its end
  tick: just before it the axes stand on the target less each one's last step, a
  point the target and the directions fix.  Where that lies beyond the tolerance + one
  step (a target rounded to steps off the circle), :func:`arc_end_cut` gives a point on
  the last chord that makes the slower axis end before (a caller's extra chord end).
* **Full circle.**  A start equal to the target (in the plane) with I/J/K is a full
  turn (Grbl's rule: the angle ``0`` from ``atan2`` becomes ``2 pi``).
* **Errors** (Grbl's status codes, :class:`ArcError`): R with the target equal to the
  start - 33; R smaller than half the distance to the target - 34; I/J/K without an
  offset in the plane - 35; I/J/K whose radius to the target differs from the radius
  to the start by more than 0.005 and by 0.5 or by 0.1 % of the radius - 33.
  The thresholds are Grbl's in millimetres; a caller working in other units passes
  its own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from enum import IntEnum

from .settings import GROUP_TOLERANCE_STEPS

ARC_ANGULAR_TRAVEL_EPSILON = 5e-7  # rad (Grbl's config.h)
ARC_RADIUS_TOLERANCE = 0.005  # mm: a radius difference up to this is always fine
ARC_RADIUS_MAX_ERROR = 0.5  # mm: beyond this never
ARC_RADIUS_RELATIVE = 0.001  # in between: at most 0.1 % of the radius


class Plane(IntEnum):
    """The arc's plane, by its G-code (Grbl: G17 default)."""

    XY = 17
    ZX = 18
    YZ = 19

    @property
    def axes(self) -> tuple[int, int, int]:
        """(first in-plane axis, second, the linear axis) by index X=0, Y=1, Z=2 -
        the first turned towards the second is counter-clockwise."""
        return _PLANE_AXES[self]


_PLANE_AXES = {Plane.XY: (0, 1, 2), Plane.ZX: (2, 0, 1), Plane.YZ: (1, 2, 0)}


class ArcError(IntEnum):
    """Why an arc is refused; the values are Grbl's ``error:N`` codes."""

    OK = 0
    INVALID_TARGET = 33  # R: target = start; I/J/K: radii to start and target differ
    ARC_RADIUS_ERROR = 34  # R smaller than half the distance start - target
    NO_OFFSETS_IN_PLANE = 35  # I/J/K mode without an offset in the plane


def arc_center_from_radius(start: Sequence[float], target: Sequence[float], radius: float,
                           plane: Plane, clockwise: bool
                           ) -> tuple[ArcError, tuple[float, float]]:
    """The centre of an R-form arc as offsets from ``start`` in the plane's two axes
    (Grbl: a negative R takes the arc of more than 180 degrees)."""
    a0, a1, _ = plane.axes
    x = target[a0] - start[a0]
    y = target[a1] - start[a1]
    if x == 0.0 and y == 0.0:
        return ArcError.INVALID_TARGET, (0.0, 0.0)  # R cannot name a full circle
    h4 = 4.0 * radius * radius - x * x - y * y
    if h4 < 0.0:
        return ArcError.ARC_RADIUS_ERROR, (0.0, 0.0)
    h_x2_div_d = -math.sqrt(h4) / math.hypot(x, y)  # -(2 h / d)
    if not clockwise:
        h_x2_div_d = -h_x2_div_d
    if radius < 0.0:
        h_x2_div_d = -h_x2_div_d
    return ArcError.OK, (0.5 * (x - y * h_x2_div_d), 0.5 * (y + x * h_x2_div_d))


def check_arc_offsets(start: Sequence[float], target: Sequence[float],
                      offset: tuple[float, float], plane: Plane, *,
                      offset_in_plane: bool = True,
                      tolerance: float = ARC_RADIUS_TOLERANCE,
                      max_error: float = ARC_RADIUS_MAX_ERROR,
                      relative: float = ARC_RADIUS_RELATIVE) -> ArcError:
    """Grbl's checks of an I/J/K arc: ``offset`` is the centre minus the start in the
    plane's two axes; ``offset_in_plane`` False when the block named none of them."""
    if not offset_in_plane:
        return ArcError.NO_OFFSETS_IN_PLANE
    a0, a1, _ = plane.axes
    r_start = math.hypot(offset[0], offset[1])
    r_target = math.hypot(target[a0] - start[a0] - offset[0],
                          target[a1] - start[a1] - offset[1])
    delta = abs(r_target - r_start)
    if delta > tolerance and (delta > max_error or delta > relative * r_start):
        return ArcError.INVALID_TARGET
    return ArcError.OK


def arc_travel(start: Sequence[float], target: Sequence[float],
               offset: tuple[float, float], plane: Plane, clockwise: bool) -> float:
    """The signed angle (rad) of the arc: negative clockwise; a full turn where the
    target lies on the start's radius in the turning direction's end."""
    a0, a1, _ = plane.axes
    r0, r1 = -offset[0], -offset[1]  # from the centre to the start
    c0, c1 = start[a0] + offset[0], start[a1] + offset[1]
    t0, t1 = target[a0] - c0, target[a1] - c1
    travel = math.atan2(r0 * t1 - r1 * t0, r0 * t0 + r1 * t1)
    if clockwise:
        if travel >= -ARC_ANGULAR_TRAVEL_EPSILON:
            travel -= 2.0 * math.pi
    elif travel <= ARC_ANGULAR_TRAVEL_EPSILON:
        travel += 2.0 * math.pi
    return travel


def arc_segments(radius: float, travel: float, tolerance: float) -> int:
    """The fewest segments whose chords stay within ``tolerance`` of the circle (0 or
    1: one straight line)."""
    if radius <= 0.0 or tolerance <= 0.0 or 2.0 * radius <= tolerance:
        return 0
    phi = 2.0 * math.acos(1.0 - tolerance / radius)  # the widest chord within tolerance
    return math.ceil(abs(travel) / phi - 1e-9)


def arc_points(start: Sequence[float], target: Sequence[float],
               offset: tuple[float, float], plane: Plane, clockwise: bool,
               tolerance: float) -> list[tuple[float, ...]]:
    """The end points of the arc's segments (every axis of ``start``; the last is
    ``target`` exactly).  The axes outside the plane move in proportion to the angle."""
    a0, a1, _ = plane.axes
    n_axes = len(start)
    travel = arc_travel(start, target, offset, plane, clockwise)
    radius = math.hypot(offset[0], offset[1])
    segments = arc_segments(radius, travel, tolerance)
    points: list[tuple[float, ...]] = []
    if segments > 1:
        c0, c1 = start[a0] + offset[0], start[a1] + offset[1]
        r0, r1 = -offset[0], -offset[1]
        step = travel / segments
        for k in range(1, segments):
            cos_k = math.cos(k * step)
            sin_k = math.sin(k * step)
            p = [start[i] + (target[i] - start[i]) * k / segments for i in range(n_axes)]
            p[a0] = c0 + r0 * cos_k - r1 * sin_k
            p[a1] = c1 + r0 * sin_k + r1 * cos_k
            points.append(tuple(p))
    points.append(tuple(float(v) for v in target))
    return points


def arc_end_cut(last: Sequence[float], target: Sequence[int], centre: tuple[float, float],
                radius: float, band: float, plane: Plane) -> tuple[float, ...] | None:
    """A point on an arc's last chord where to end the block before the last, so that
    the chord's slower in-plane axis makes its last step where the path is half a step
    before it (as inside the arc) rather than on the end tick - or None: no cut.

    Everything in steps: ``last`` the last chord's start (a chord end as it is),
    ``target`` its end in whole steps, the circle's ``centre`` and ``radius`` in the
    plane (equal steps per unit on its two axes), ``band`` the distance from the circle
    the steps are to keep (``$12`` + one step).  A block that ends on whole steps ends
    every axis moving in it on its end tick, so just before that tick the axes stand
    on the target less each one's last step - a point set by the target and the
    directions the arc ends in.  Where the target lies off the circle (its rounding to
    steps) that point can lie beyond ``band``, whatever the placement of the steps
    before it.  The cut is made there only, and only where it helps: both in-plane axes
    move in the last chord, the point without the slower axis's last step lies
    nearer the circle, and the slower axis passes its last half step before the faster
    one passes its own - the cut comes between the two, so that the slower axis stands
    on its target from the cut on (no step in the last block) and the faster has its
    last step still ahead (the last block is not empty).  The cut lies on the chord:
    the path is the same, the look-ahead keeps the feed through it."""
    a0, a1, _ = plane.axes
    plane_axes = (a0, a1)

    def off(p: Sequence[float]) -> float:
        return abs(math.hypot(p[0] - centre[0], p[1] - centre[1]) - radius)

    span = {a: target[a] - last[a] for a in plane_axes}
    if any(math.floor(last[a] + 0.5) == target[a] for a in plane_axes):
        return None  # an axis without a step in the last chord: nothing forced by it
    d = {a: 1 if span[a] > 0 else -1 for a in plane_axes}
    # before the end tick: the target less both last steps; on it, between the two
    # steps (one tick, in either order): the target less one of them
    forced = max(off([target[a] - d[a] * (b & (1 << n) != 0) for n, a in
                      enumerate(plane_axes)]) for b in (1, 2, 3))
    if forced <= band:
        return None
    minor, major = sorted(plane_axes, key=lambda a: abs(span[a]))
    kept = [target[a] - (d[a] if a == major else 0) for a in plane_axes]
    if off(kept) >= forced:
        return None
    u_minor = (target[minor] - 0.5 * d[minor] - last[minor]) / span[minor]
    u_major = (target[major] - 0.5 * d[major] - last[major]) / span[major]
    if not 0.0 < u_minor < u_major < 1.0:
        return None
    u = 0.5 * (u_minor + u_major)
    return tuple(x0 + u * (x1 - x0) for x0, x1 in zip(last, target, strict=True))



#: a step grouped with others comes at most this many steps early
EARLY_STEPS = GROUP_TOLERANCE_STEPS


def block_pins(start: Sequence[float], end: Sequence[float]) -> list[tuple[int, int]]:
    """Where the axes of a plane stand during a block of an arc's end (steps, the
    plane's two axes) from the chord end ``start`` (between steps) to ``end`` (the
    target on whole steps, or a point between), by
    :class:`fas.path.executor.Segment`'s rule: each axis stands on the step nearest to
    its path (from the step nearest to ``start``) - each step where the path is half a
    step before it, or up to ``EARLY_STEPS`` earlier where steps are grouped - but
    where the block ends on a whole step of the axis its last step comes on the end
    tick (not listed: the next block's, or the end rule's).  Every position where two
    steps may come in either order (their windows overlap) is listed."""
    pins = [math.floor(x + 0.5) for x in start]
    events: list[tuple[float, float, int, int]] = []  # (u, u early, axis, direction)
    for i in range(2):
        stop = math.floor(end[i] + 0.5)
        n = abs(stop - pins[i])
        span = end[i] - start[i]
        if float(stop) == end[i]:
            n -= 1  # the last on the end tick
        if n < 1 or span == 0.0:
            continue
        d = 1 if stop > pins[i] else -1
        early = EARLY_STEPS / abs(span)
        for k in range(1, n + 1):
            u = (pins[i] + k * d - 0.5 * d - start[i]) / span
            events.append((u, u - early, i, d))
    events.sort()
    out = [(pins[0], pins[1])]
    pos = list(pins)
    for k, (u, _e, i, d) in enumerate(events):
        if k + 1 < len(events):  # the next one may come first
            _u1, e1, j, dj = events[k + 1]
            if j != i and e1 <= u:
                alt = list(pos)
                alt[j] += dj
                out.append((alt[0], alt[1]))
        pos[i] += d
        out.append((pos[0], pos[1]))
    return out


def last_block_pins(start: Sequence[float], target: Sequence[int],
                    cut: Sequence[float] | None = None) -> list[tuple[int, int]]:
    """:func:`block_pins` of an arc's end from the last chord end ``start`` to the
    ``target`` (both in the plane), through ``cut`` where :func:`arc_end_cut` cuts the
    last chord - less the positions within a step of the target on both axes: the end
    rule's, which :func:`arc_end_cut` deals with."""
    if cut is None:
        pins = block_pins(start, target)
    else:
        pins = block_pins(start, cut) + block_pins(cut, target)
    return [p for p in pins if not all(abs(target[i] - p[i]) <= 1 for i in range(2))]


def _approach_ok(last: Sequence[float], target: Sequence[int], centre: tuple[float, float],
                 radius: float, band: float, plane: Plane) -> bool:
    """Do the steps from the last chord end ``last`` to ``target`` (all axes), with
    :func:`arc_end_cut`'s cut where it makes one, keep ``band``?"""
    a0, a1, _ = plane.axes
    cut = arc_end_cut(last, target, centre, radius, band, plane)
    pins = last_block_pins((last[a0], last[a1]), (target[a0], target[a1]),
                           None if cut is None else (cut[a0], cut[a1]))
    return all(abs(math.hypot(x - centre[0], y - centre[1]) - radius) <= band
               for x, y in pins)


#: arc_end_approach's candidates: the last chord's angle times k / APPROACH_TRIES
APPROACH_TRIES = 64


def arc_end_approach(last: Sequence[float], target: Sequence[int],
                     centre: tuple[float, float], radius: float, band: float,
                     plane: Plane, clockwise: bool) -> tuple[float, ...] | None:
    """A point on the circle where the arc's last chord should begin instead, so that
    the last block's steps keep ``band`` (``$12`` + one step) - or None: they do from
    ``last`` already (or no point helps).

    Everything in steps, as :func:`arc_end_cut`: ``last`` the last chord's start (on
    the circle), ``target`` the arc's end rounded to whole steps - off the circle by up
    to 0.71 step.  A chord from the circle to a target rounded inside it comes up to
    ``s + |delta| / 2`` inside in its middle (``s`` its sagitta, up to ``$12``;
    ``delta`` the target's offset), where the steps may stand up to 0.71 step further
    in (the axes on the steps nearest to the path): beyond the band by up to 0.002 step
    on bench/bench_arcs.py's random arcs.  Where the steps from the last chord end
    (:func:`last_block_pins`, through :func:`arc_end_cut`'s cut where it makes one;
    the end rule's points left to it) would leave the band, the last chord begins
    later on the circle: at the smallest share of its angle (k / 64, then halving
    towards the end) from which they keep it.  The
    chord before it is a shorter chord of the circle, within ``$12`` as every chord.
    Other axes (a helix) in proportion to the angle."""
    a0, a1, _ = plane.axes
    c = centre
    tgt = (target[a0], target[a1])
    p_last = (last[a0], last[a1])
    if _approach_ok(last, target, c, radius, band, plane):
        return None
    th0 = math.atan2(p_last[1] - c[1], p_last[0] - c[0])
    th1 = math.atan2(tgt[1] - c[1], tgt[0] - c[0])
    turn = 2.0 * math.pi  # the last chord's angle, in the arc's direction:
    span = -((th0 - th1) % turn) if clockwise else (th1 - th0) % turn
    if not 0.0 < abs(span) < math.pi:
        return None

    def point(share: float) -> tuple[float, ...]:
        th = th0 + span * share
        out = [x0 + share * (x1 - x0) for x0, x1 in zip(last, target, strict=False)]
        out[a0] = c[0] + radius * math.cos(th)
        out[a1] = c[1] + radius * math.sin(th)
        return tuple(out)

    shares = [k / APPROACH_TRIES for k in range(1, APPROACH_TRIES)]
    shares += [1.0 - 0.5 ** j / APPROACH_TRIES for j in range(1, 30)]
    for share in shares:
        p = point(share)
        if _approach_ok(p, target, c, radius, band, plane):
            return p
    return None
