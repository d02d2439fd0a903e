"""A path group on a recording simulated chip, and what its pins say about the path.

Everything here is measured from the recorded step and direction edges: the position
of every axis at every instant at which one of them stepped (edges on one tick are
one instant), its distance from the commanded polyline, step rates and accelerations
per axis, the path speed at an instant.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

from fas import Engine
from fas.path import AxisLimits, PathGroup, PathResult, PathSettings
from fas.sim import SimBackend
from rigs.pins import steps_by_pins


def make_group(profile: str = "atmega328p", axes: int = 2, *,
               limits: AxisLimits | None = None, junction_deviation: float = 0.05,
               arc_tolerance: float = 0.002, queue_blocks: int = 32,
               record: bool = True, start_delay_ms: int = 50, corner_blends: bool = False,
               plain_corner_steps: float = 0.0):
    """(backend, engine, group, step pins, direction pins): ``axes`` steppers on the
    first step pin of the profile's first channels, joined into a path group
    (``corner_blends``, ``plain_corner_steps``: PathSettings', off - Grbl's junctions -
    by default)."""
    backend = SimBackend(profile, record=record)
    engine = Engine(backend)
    engine.init()
    p = backend.profile
    pins = step_pins(p, axes)
    dirs = dir_pins(p, axes)
    steppers = []
    for sp, dp in zip(pins, dirs, strict=True):
        s = engine.stepper_connect_to_pin(sp)
        assert s is not None
        s.set_direction_pin(dp)
        steppers.append(s)
    limits = limits or AxisLimits(80.0, 6000.0, 500.0)
    settings = PathSettings(axes=(limits,) * axes, junction_deviation=junction_deviation,
                            arc_tolerance=arc_tolerance, queue_blocks=queue_blocks,
                            start_delay_ms=start_delay_ms, corner_blends=corner_blends,
                            plain_corner_steps=plain_corner_steps)
    group = PathGroup(steppers, settings)
    assert group.attach() == PathResult.OK
    group.blend_log = group.executor.blends = []  # the blends: the path as run
    group.executor.plain_log = []  # ... and the corners taken plain among them
    return backend, engine, group, pins, dirs


def step_pins(profile, axes: int) -> list[int]:
    """A step pin for each of ``axes`` steppers: the first of each channel's pins, or
    successive pins of one group where any pin reaches any channel."""
    groups = profile.step_pin_groups
    if len(groups) >= axes:
        return [g[0] for g in groups[:axes]]
    return list(groups[0][:axes])


def dir_pins(profile, axes: int) -> list[int]:
    """Direction pins that are no step pin."""
    taken = {pin for g in profile.step_pin_groups for pin in g}
    return [pin for pin in range(20, 200) if pin not in taken][:axes]


class Stream:
    """A sender streaming targets into a group as its queue takes them (a G-code
    sender waiting for ``ok``): :meth:`run` lets time pass while it keeps feeding."""

    def __init__(self, backend, group: PathGroup, targets: Sequence[Sequence[int]],
                 feed: float | None) -> None:
        self.backend = backend
        self.group = group
        self.targets = list(targets)
        self.feed = feed
        self.sent = 0

    def pump(self) -> None:
        g = self.group
        while self.sent < len(self.targets):
            res = g.line(self.targets[self.sent], self.feed)
            if res == PathResult.QUEUE_FULL:
                return
            assert res in (PathResult.OK, PathResult.EMPTY_BLOCK), res
            self.sent += 1
        g.flush()

    def run(self, until=None, limit_s: float = 3600.0) -> bool:
        """Feed and let time pass until ``until()`` (default: every target sent and the
        group idle); False on timeout."""
        b = self.backend
        g = self.group
        if until is None:
            def until() -> bool:
                return self.sent == len(self.targets) and g.is_idle()
        deadline = b.now() + int(limit_s * b.profile.ticks_per_s)
        self.pump()
        while not until():
            if b.now() >= deadline:
                return False
            b.wait_until(lambda: until() or (self.sent < len(self.targets)
                                             and g.room() > 0), deadline - b.now())
            self.pump()
        return True


def feed_all(backend, group: PathGroup, targets: Sequence[Sequence[int]],
             feed: float | None, limit_s: float = 3600.0) -> None:
    """Queue every target (waiting for room as a sender would), flush, run to idle."""
    assert Stream(backend, group, targets, feed).run(limit_s=limit_s), "the path did not end"



def circles_of_chords(count: int, spu: float) -> list[tuple[int, int]]:
    """bench_path's circles in steps (``spu`` steps/mm): ``count`` circles of chords within
    0.002 mm, radius 4, 6, 8 .. mm, all from (0, 0) (centre to the right), the direction
    chosen by the number of chords so far - where it flips, the path turns back on itself."""
    from fas.path import Plane, arc_points

    pts: list[tuple[int, int]] = []
    for k in range(count):
        for p in arc_points((0.0, 0.0), (0.0, 0.0), (4.0 + 2 * k, 0.0), Plane.XY,
                            len(pts) % 2 == 0, 0.002):
            pts.append((round(p[0] * spu), round(p[1] * spu)))
    return pts


def random_path(rnd, count: int = 120) -> list[tuple[int, int]]:
    """``count`` random 2-axis targets in steps, moves of 2 to 400 steps each."""
    pos = [0, 0]
    pts = []
    for _ in range(count):
        scale = rnd.choice([2, 10, 60, 400])
        pos = [pos[0] + rnd.randint(-scale, scale), pos[1] + rnd.randint(-scale, scale)]
        pts.append((pos[0], pos[1]))
    return pts


def run_with_random_holds(backend, group: PathGroup, pts: Sequence[Sequence[int]], rnd,
                          feed: float = 3000.0) -> list[tuple[int, tuple[int, ...]]]:
    """Stream ``pts`` to ``group``, holding it at random moments (10-300 ms apart) and
    resuming it, some blocks queued while held; the (tick, position) of every hold's
    stop."""
    from fas.path import PathResult, PathState

    tps = backend.profile.ticks_per_s
    stream = Stream(backend, group, pts, feed)
    stops: list[tuple[int, tuple[int, ...]]] = []

    def finished() -> bool:
        return stream.sent == len(pts) and group.is_idle()

    while not finished():
        t = backend.now() + int(rnd.uniform(0.01, 0.3) * tps)
        assert stream.run(until=lambda t=t: backend.now() >= t or finished(), limit_s=60)
        if group.state == PathState.RUNNING:
            group.hold()
            assert stream.run(until=lambda: group.state == PathState.HELD, limit_s=5)
            stops.append((backend.now(), tuple(s.get_current_position()
                                               for s in group.steppers)))
            if rnd.random() < 0.3:
                stream.pump()  # blocks queued while held
            assert group.resume() == PathResult.OK
    return stops

def axis_steps(backend, pins: Sequence[int], dirs: Sequence[int]) -> list[list[tuple[int, int]]]:
    """Per axis: (tick, +1/-1) of every step."""
    edges = backend.recorder.pin_edges
    return [steps_by_pins(edges, sp, dp) for sp, dp in zip(pins, dirs, strict=True)]


def instants(steps: Sequence[Sequence[tuple[int, int]]],
             start: Sequence[int]) -> list[tuple[int, tuple[int, ...]]]:
    """(tick, position of every axis) after each instant with a step."""
    events = sorted((t, i, d) for i, ss in enumerate(steps) for t, d in ss)
    pos = list(start)
    out = []
    k = 0
    while k < len(events):
        t = events[k][0]
        while k < len(events) and events[k][0] == t:
            pos[events[k][1]] += events[k][2]
            k += 1
        out.append((t, tuple(pos)))
    return out


def cheb_to_segment(p: Sequence[float], a: Sequence[float], b: Sequence[float]) -> float:
    """The Chebyshev distance (the largest axis difference) from ``p`` to segment ab."""
    d = [bi - ai for ai, bi in zip(a, b, strict=True)]
    r = [pi - ai for pi, ai in zip(p, a, strict=True)]
    cands = [0.0, 1.0]
    n = len(d)
    for i in range(n):
        if d[i]:
            cands.append(r[i] / d[i])
        for j in range(i + 1, n):
            for sgn in (1.0, -1.0):
                den = d[i] - sgn * d[j]
                if den:
                    cands.append((r[i] - sgn * r[j]) / den)
    best = math.inf
    for s in cands:
        if 0.0 <= s <= 1.0:
            v = max(abs(r[i] - s * d[i]) for i in range(n))
            if v < best:
                best = v
    return best


def perp_to_segment(p: Sequence[float], a: Sequence[float], b: Sequence[float]) -> float:
    """The Euclidean distance from ``p`` to segment ab."""
    d = [bi - ai for ai, bi in zip(a, b, strict=True)]
    r = [pi - ai for pi, ai in zip(p, a, strict=True)]
    dd = sum(x * x for x in d)
    s = 0.0 if dd == 0 else max(0.0, min(1.0, sum(x * y for x, y in zip(r, d, strict=True)) / dd))
    return math.sqrt(sum((ri - s * di) ** 2 for ri, di in zip(r, d, strict=True)))


def path_deviation(points: Sequence[tuple[int, tuple[int, ...]]],
                   polyline: Sequence[Sequence[int]]) -> tuple[float, float]:
    """The largest Chebyshev and Euclidean distance (steps) of the instants' positions
    from the polyline (its vertices in steps: where the blocks end).  Every axis makes
    its last step of a block on one tick, so the path is at a vertex at one instant:
    the instants in between are measured against the segment between the vertex
    reached last and the next one."""
    verts = [tuple(polyline[0])]
    for v in polyline[1:]:
        if tuple(v) != verts[-1]:
            verts.append(tuple(v))
    worst_c = worst_e = 0.0
    b = 0
    last = len(verts) - 1
    for _, p in points:
        if b < last and p == verts[b + 1]:
            b += 1
            continue  # at the vertex: on the path
        if b == last:
            raise AssertionError(f"a step after the path's end: {p}")
        a, e = verts[b], verts[b + 1]
        worst_c = max(worst_c, cheb_to_segment(p, a, e))
        worst_e = max(worst_e, perp_to_segment(p, a, e))
    assert b == last, f"vertex {b + 1} of {last} was never reached exactly: {verts[b + 1]}"
    return worst_c, worst_e


def window_rates(ticks: Sequence[int], tps: int, window_s: float
                 ) -> list[tuple[float, float]]:
    """(time s, steps/s) of one axis's steps (one direction) over windows of about
    ``window_s``: steps between two step times divided by their distance."""
    out = []
    k = 0
    n = len(ticks)
    w = window_s * tps
    while k < n - 1:
        j = k + 1
        while j < n - 1 and ticks[j] - ticks[k] < w:
            j += 1
        span = ticks[j] - ticks[k]
        if span > 0:
            out.append(((ticks[k] + ticks[j]) / 2 / tps, (j - k) * tps / span))
        k = j
    return out


def position_at(ticks: Sequence[int], t: float) -> float:
    """An axis's position at tick ``t``, interpolated linearly between its steps (the
    count of steps up to a step's tick is exact there)."""
    import bisect
    k = bisect.bisect_right(ticks, t)
    if k == 0:
        return 0.0
    if k >= len(ticks):
        return float(len(ticks))
    t0, t1 = ticks[k - 1], ticks[k]
    return k + (t - t1) / (t1 - t0) if t1 > t0 else float(k)


def fit_speed(times: Sequence[float], xs: Sequence[float], at: float) -> float:
    """The slope at ``at`` of the least-squares parabola through (times, xs)."""
    n = len(times)
    ts = [t - at for t in times]
    s = [sum(t ** k for t in ts) for k in range(5)]
    b = [sum(x * t ** k for x, t in zip(xs, ts, strict=True)) for k in range(3)]
    m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]]
    assert n >= 3
    # solve m c = b (Cramer); the slope at ``at`` is c[1]
    def det(a):
        return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
                - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    d = det(m)
    m1 = [[m[r][0], b[r], m[r][2]] for r in range(3)]
    return det(m1) / d


def axis_motion(steps: Sequence[tuple[int, int]]) -> tuple[list[int], list[int]]:
    """(ticks, position after the step) of one axis's steps."""
    pos = 0
    ticks, xs = [], []
    for t, d in steps:
        pos += d
        ticks.append(t)
        xs.append(pos)
    return ticks, xs


def interp(ticks: Sequence[int], xs: Sequence[int], t: float) -> float:
    """Position at tick ``t``, linear between the steps around it."""
    import bisect
    k = bisect.bisect_right(ticks, t)
    if k == 0:
        return float(xs[0] - (xs[1] - xs[0] if len(xs) > 1 else 1))
    if k >= len(ticks):
        return float(xs[-1])
    t0, t1 = ticks[k - 1], ticks[k]
    x0, x1 = xs[k - 1], xs[k]
    return x0 + (x1 - x0) * (t - t0) / (t1 - t0)


def max_accel(ticks: Sequence[int], xs: Sequence[int], t_from: int, t_to: int, tps: int,
              window_s: float) -> tuple[float, float]:
    """(largest |acceleration| in steps/s^2, largest |speed| in steps/s) of one axis
    inside [t_from, t_to], from three of its steps about ``window_s`` apart: at a
    step's tick its position is exact, so (with steps at ticks a < b < c)
    ``2 ((x_c - x_b) / (t_c - t_b) - (x_b - x_a) / (t_b - t_a)) / (t_c - t_a)``
    is off by at most ``4 e / W^2`` when each step is within ``e`` steps of its
    exact time's position (and the speed ``(x_c - x_b) / (t_c - t_b)`` by ``2 e / W``).
    The axis's own steps only: before its first step in the span it stood, or moved
    as the block before."""
    import bisect
    w = int(window_s * tps)
    worst_a = worst_v = 0.0
    k0 = bisect.bisect_right(ticks, t_from)
    k1 = bisect.bisect_left(ticks, t_to)
    a = k0
    while a < k1:
        b = bisect.bisect_left(ticks, ticks[a] + w, a + 1, k1)
        if b >= k1:
            break
        c = bisect.bisect_left(ticks, ticks[b] + w, b + 1, k1)
        if c >= k1:
            break
        ta, tb, tc = (ticks[a] / tps, ticks[b] / tps, ticks[c] / tps)
        v1 = (xs[b] - xs[a]) / (tb - ta)
        v2 = (xs[c] - xs[b]) / (tc - tb)
        worst_a = max(worst_a, abs(2 * (v2 - v1) / (tc - ta)))
        worst_v = max(worst_v, abs(v1), abs(v2))
        a = max(a + 1, bisect.bisect_left(ticks, ticks[a] + w // 4, a + 1, k1))
    return worst_a, worst_v


def edge_accels(ticks: Sequence[int], xs: Sequence[int], tps: int, window_s: float
                ) -> Iterator[tuple[int, int, int, float]]:
    """For every step b of one axis: (t_a, t_b, t_c, |acceleration| in steps/s^2) with
    a = the last step at least ``window_s`` before it, c = the first at least
    ``window_s`` after it, and the divided difference ``2 ((x_c - x_b)/(t_c - t_b) -
    (x_b - x_a)/(t_b - t_a)) / (t_c - t_a)``.  The position at a step's tick is exact,
    so for a motion with a continuous velocity this is a weighted mean of its
    acceleration (never above the largest); a velocity jump Dv between a and c adds
    up to 2 Dv / (t_c - t_a).  Steps up to ``e`` steps early make it off by at most
    2 e / W^2."""
    import bisect
    w = round(window_s * tps)
    n = len(ticks)
    scale = tps * tps
    for b in range(n):
        a = bisect.bisect_right(ticks, ticks[b] - w) - 1
        c = bisect.bisect_left(ticks, ticks[b] + w)
        if a < 0 or c >= n:
            continue
        ta, tb, tc = ticks[a], ticks[b], ticks[c]
        v = abs(2 * ((xs[c] - xs[b]) / (tc - tb) - (xs[b] - xs[a]) / (tb - ta)) / (tc - ta))
        yield ta, tb, tc, v * scale


def edge_accel(ticks: Sequence[int], xs: Sequence[int], tps: int,
               window_s: float) -> tuple[float, int]:
    """(largest |acceleration| in steps/s^2, the tick of its middle step) of one axis
    over its whole motion, corners included (:func:`edge_accels`)."""
    worst, at = 0.0, 0
    for _ta, tb, _tc, v in edge_accels(ticks, xs, tps, window_s):
        if v > worst:
            worst, at = v, tb
    return worst, at


def axes_edge_accel(steps: Sequence[Sequence[tuple[int, int]]], tps: int,
                    window_s: float) -> list[tuple[float, int]]:
    """:func:`edge_accel` of every axis of a run (``steps``: each axis's (tick, +1/-1)):
    per axis, its largest |acceleration| in steps/s^2 and the tick of its middle step."""
    out = []
    for axis in steps:
        tk, xs = axis_motion(axis)
        out.append(edge_accel(tk, xs, tps, window_s))
    return out


def first_within_a_step(ins: Sequence[tuple[int, tuple[int, ...]]], i: int,
                        v: Sequence[float]) -> int:
    """The index of the first instant from ``i`` on within one step (Chebyshev) of the
    point ``v`` - a vertex between steps, such as an arc's chord end."""
    j = i
    while j < len(ins) and max(abs(a - c) for a, c in zip(ins[j][1], v, strict=True)) > 1.0:
        j += 1
    assert j < len(ins), f"vertex {v} never passed within a step"
    return j


def reached(ins: Sequence[tuple[int, tuple[int, ...]]], i: int, v: tuple[int, ...]) -> int:
    """The index of the instant from ``i`` on that reaches the vertex ``v`` (on whole
    steps): the first at ``v`` while the path is within a step of it, else (a tiny
    block's last step a little early in one axis, so that the axes are never at ``v``
    together - Grbl's corners, plain ones with blends) the first within a step."""
    j = first_within_a_step(ins, i, v)
    k = j
    while k < len(ins) and max(abs(a - c) for a, c in zip(ins[k][1], v, strict=True)) <= 1:
        if ins[k][1] == v:
            return k
        k += 1
    return j


def _same_block(a, b) -> bool:
    """Two blend records whose block out is the same move (planned again after a hold)."""
    return a.block.start == b.block.start and a.block.delta == b.block.delta


def _plain_next(plain: Sequence[tuple], q: int, v: tuple[int, ...],
                blends: Sequence[tuple], k: int) -> bool:
    """Is the next corner record at ``v`` the plain corner ``plain[q]`` (the
    executor's ``plain_log``: (corner, tick)) rather than the blend ``blends[k]`` - a
    vertex visited more than once, taken plain at one visit and blended at another?"""
    return (q < len(plain) and tuple(plain[q][0]) == v
            and (k >= len(blends) or plain[q][1] < blends[k][1].t_start))


def path_as_run(vertices: Sequence[Sequence[int]], blends: Sequence[tuple],
                ins: Sequence[tuple[int, tuple[int, ...]]], spu: Sequence[float],
                samples: int = 8, plain: Sequence[tuple] = ()
                ) -> list[tuple[float, tuple[float, ...]]]:
    """The path as executed, with times: ``(tick, point)`` for each vertex - where the
    executor blended it (``blends``: its record, in order) the blend's curve in
    ``samples`` chords (off it by ``T^2 |a| / (8 samples^2)``, far below a step) at
    their ticks, else the instant the axes reach it (the first vertex at the first
    instant; ``plain``: the executor's plain corners, in order)."""
    out: list[tuple[float, tuple[float, ...]]] = []
    k = 0  # blends
    q = 0  # plain corners
    i = 0  # instants
    for n, v in enumerate(vertices):
        v = tuple(v)
        # a corner can have several records (of one block out, planned again): a feed
        # hold that stops near a corner it was blending blends it again when it resumes
        # (each is run)
        blended = False
        if n and _plain_next(plain, q, v, blends, k):
            q += 1
            i = reached(ins, i, v)
            out.append((ins[i][0], tuple(float(c) for c in v)))
            i += 1
            continue
        while n and k < len(blends) and tuple(blends[k][0]) == v and (
                not blended or _same_block(blends[k][1], blends[k - 1][1])):
            blended = True
            seg = blends[k][1]
            b = seg.b
            for m in range(samples + 1):
                tau = b.duration * m / samples
                pos = b.position(tau)
                out.append((seg.t_start + tau * seg.tps,
                            tuple(c + x * f for c, x, f in zip(v, pos, spu, strict=True))))
            t_mid = (seg.t_start + seg.t_done) / 2
            while i < len(ins) and ins[i][0] <= t_mid:
                i += 1
            k += 1
        if blended:
            continue
        if n == 0:
            out.append((ins[0][0] - 1 if ins else 0, tuple(float(c) for c in v)))
            continue
        if any(c != round(c) for c in v):  # between steps (an arc's chord end): the
            j = first_within_a_step(ins, i, v)  # first instant near it
            out.append((ins[j][0], tuple(float(c) for c in v)))
            i = j
            continue
        i = reached(ins, i, v)
        out.append((ins[i][0], tuple(float(c) for c in v)))
        i += 1
    assert k == len(blends), f"blend {k} not on the path"
    return out


def timed_deviation(ins: Sequence[tuple[int, tuple[int, ...]]],
                    path: Sequence[tuple[float, tuple[float, ...]]], slack: int) -> float:
    """The largest Chebyshev distance (steps) of the instants from the path as run
    (:func:`path_as_run`), each against the path's pieces within ``slack`` ticks of
    its time."""
    worst = 0.0
    j0 = 0
    n = len(path) - 1
    for t, p in ins:
        while j0 < n - 1 and path[j0 + 1][0] < t - slack:
            j0 += 1
        best = math.inf
        j = j0
        while j < n and path[j][0] <= t + slack:
            d = cheb_to_segment(p, path[j][1], path[j + 1][1])
            if d < best:
                best = d
            j += 1
        if best == math.inf:
            best = cheb_to_segment(p, path[min(j0, n - 1)][1], path[min(j0, n - 1) + 1][1])
        worst = max(worst, best)
    return worst


def blended_ticks(vertices: Sequence[Sequence[int]], blends: Sequence[tuple],
                  ins: Sequence[tuple[int, tuple[int, ...]]],
                  plain: Sequence[tuple] = ()) -> list[int]:
    """The tick of each vertex: the instant it is reached, or where a blend takes the
    corner, the middle of the blend.  ``plain``: the executor's plain corners
    (PathSettings.plain_corner_steps), in order - a vertex the path visits more than
    once may be blended at one visit and not at another."""
    out = []
    k = 0
    q = 0
    i = 0
    for v in vertices:
        v = tuple(v)
        if _plain_next(plain, q, v, blends, k):
            q += 1
        elif k < len(blends) and tuple(blends[k][0]) == v:
            # (several records of one corner, path_as_run: the last one takes it)
            while (k + 1 < len(blends) and tuple(blends[k + 1][0]) == v
                   and _same_block(blends[k + 1][1], blends[k][1])):
                k += 1
            seg = blends[k][1]
            t = int((seg.t_start + seg.t_done) / 2)
            out.append(t)
            while i < len(ins) and ins[i][0] <= t:
                i += 1
            k += 1
            continue
        if any(c != round(c) for c in v):  # between steps (an arc's chord end): the
            j = first_within_a_step(ins, i, v)  # first instant near it
            out.append(ins[j][0])
            i = j
            continue
        i = reached(ins, i, v)
        out.append(ins[i][0])
        i += 1
    return out


def commanded_deviation(ins: Sequence[tuple[int, tuple[int, ...]]],
                        vertices: Sequence[Sequence[int]], blends: Sequence[tuple],
                        slack: int, plain: Sequence[tuple] = ()) -> float:
    """With corner blends: the largest Chebyshev distance (steps) of the instants from
    the *commanded* polyline (its corners not blended), each against the segments
    within ``slack`` ticks of its time - a vertex's time the instant it is reached,
    or the middle of the blend that takes it (:func:`blended_ticks`; ``plain``: the
    executor's plain corners)."""
    ticks = blended_ticks(vertices[1:], blends, ins, plain)
    path = [(float(ins[0][0] - 1), tuple(float(c) for c in vertices[0]))]
    path += [(float(t), tuple(float(c) for c in v))
             for t, v in zip(ticks, vertices[1:], strict=True)]
    return timed_deviation(ins, path, slack)


def tracked_deviation(points: Sequence[tuple[int, tuple[int, ...]]],
                      polyline: Sequence[Sequence[int]], window: int = 3) -> float:
    """The largest Chebyshev distance (steps) of the instants' positions from the
    polyline, each measured against the segments from the one the previous instant was
    nearest to and ``window`` after it (the path is followed forward; no vertex needs
    to be reached exactly - tiny blocks' last steps may come a little early)."""
    verts = [tuple(polyline[0])]
    for v in polyline[1:]:
        if tuple(v) != verts[-1]:
            verts.append(tuple(v))
    worst = 0.0
    k = 0
    n = len(verts) - 1
    for _, p in points:
        best, best_j = math.inf, k
        for j in range(k, min(k + window + 1, n)):
            d = cheb_to_segment(p, verts[j], verts[j + 1])
            if d < best - 1e-12:
                best, best_j = d, j
        k = best_j
        worst = max(worst, best)
    return worst
