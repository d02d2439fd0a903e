"""Motion counted from pin edges: the steps, the position, a follower's error.

``edges`` is a function giving one pin's edges as (times, levels) in time order:
``recorder.pin_edges`` of a :class:`fas.sim.pins.EdgeRecorder` (the simulated chip,
the Python device) or ``trace.edges`` of a :class:`fas.device.simavr.Trace` (the
firmware in simavr).  A step is a rising edge of the step pin; it counts up while the
direction pin is at its up level (high unless ``high_counts_up`` is false), and the
direction pin is low before its first edge.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable, Sequence

from fas.codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED

Edges = Callable[[int], tuple[Sequence[int], Sequence[int]]]


def steps_by_pins(edges: Edges, step_pin: int, dir_pin: int,
                  high_counts_up: bool = True) -> list[tuple[int, int]]:
    """(tick, +1 or -1) of every step; a stepper without a direction pin of its own
    (undefined, or on an external driver) counts every step up."""
    times, levels = edges(step_pin)
    if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
        return [(t, 1) for t, lv in zip(times, levels, strict=True) if lv]
    dtimes, dlevels = edges(dir_pin)
    out = []
    for t, lv in zip(times, levels, strict=True):
        if lv:
            i = bisect_right(dtimes, t) - 1
            level = dlevels[i] if i >= 0 else 0
            out.append((t, 1 if (level == 1) == high_counts_up else -1))
    return out


def position_by_pins(edges: Edges, step_pin: int, dir_pin: int,
                     high_counts_up: bool = True) -> int:
    """The position the step and direction pins say (0 before the first step)."""
    return sum(d for _, d in steps_by_pins(edges, step_pin, dir_pin, high_counts_up))


def ratio_error(edges: Edges, leader: tuple[int, int], follower: tuple[int, int],
                n: int, m: int, x0: int = 0, y0: int = 0,
                since: int = 0) -> tuple[float, int, int]:
    """Largest |(y - y0) - n/m (x - x0)| at the instants with a step from ``since`` on
    (steps of both at one tick are one instant), x the leader's position and y the
    follower's by their (step, dir) pins; and both end positions."""
    events = [(t, 0, d) for t, d in steps_by_pins(edges, *leader)]
    events += [(t, 1, d) for t, d in steps_by_pins(edges, *follower)]
    events.sort()
    pos = [0, 0]
    worst = 0.0
    i = 0
    while i < len(events):
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            pos[events[i][1]] += events[i][2]
            i += 1
        if t >= since:
            worst = max(worst, abs((pos[1] - y0) - n * (pos[0] - x0) / m))
    return worst, pos[0], pos[1]


def periods(times: Sequence[int]) -> list[int]:
    """The intervals between successive times."""
    return [b - a for a, b in zip(times, times[1:], strict=False)]
