"""Acceleration and deceleration of a short motion, from the times of its steps.

The timing report measures acceleration as the change of the mean step rate between
windows of >= 10 ms (:mod:`.motion`), which is blind to the tick rounding of single
commands.  A motion of a few milliseconds (53 steps at 1 000 000 steps/s^2 take 14
ms) has no two such windows: for it, the rate of each step interval is taken at the
interval's middle, and acceleration and deceleration are the least-squares slopes
of that rate against time over the rise to the peak and over the fall from it (the
peak: the intervals within 1 % or 2 ticks of the shortest, whichever is more).  On
the staircase of an AVR ramp at a high acceleration that is the mean slope of the
stairs - the same figure for the original firmware's step times and for ours.
"""

from __future__ import annotations

from collections.abc import Sequence

PEAK_SHARE = 0.01  # intervals this close to the shortest are the peak ...
PEAK_TICKS = 2  # ... or this many ticks, whichever is more
MIN_POINTS = 3  # intervals a phase needs for a slope


def phase_rates(rises: Sequence[float], ticks_per_s: int) -> tuple[float | None, float | None]:
    """(acceleration, deceleration) in steps/s^2 of one motion from the ticks of its
    rising step edges (both positive; None where a phase has fewer than
    :data:`MIN_POINTS` intervals or one rate only)."""
    points = [((a + b) / 2, b - a) for a, b in zip(rises, rises[1:], strict=False)
              if b > a]
    if len(points) < MIN_POINTS:
        return None, None
    shortest = min(iv for _, iv in points)
    near = max(shortest * (1 + PEAK_SHARE), shortest + PEAK_TICKS)
    peak = [i for i, (_, iv) in enumerate(points) if iv <= near]
    first, last = peak[0], peak[-1]
    rates = [(t / ticks_per_s, ticks_per_s / iv) for t, iv in points]
    acc = _slope(rates[:first + 1])
    dec = _slope(rates[last:])
    return (acc if acc is not None and acc > 0 else None,
            -dec if dec is not None and dec < 0 else None)


def _slope(points: Sequence[tuple[float, float]]) -> float | None:
    """Least-squares slope of (t, v); None for too few points or one value."""
    if len(points) < MIN_POINTS:
        return None
    n = len(points)
    mt = sum(t for t, _ in points) / n
    mv = sum(v for _, v in points) / n
    stt = sum((t - mt) ** 2 for t, _ in points)
    if stt == 0 or all(v == points[0][1] for _, v in points):
        return None
    return sum((t - mt) * (v - mv) for t, v in points) / stt
