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
