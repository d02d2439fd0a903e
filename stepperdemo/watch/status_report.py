"""Plots and a report from StepperDemo's status lines (a board shows nothing else).

On the simulation ``/plot`` and ``/report`` read the pins; a board running the
original firmware only prints a status line every 100 ms while a stepper runs.
These are the same plots (position and the planned speed ``v=`` over time) and a
report of what the lines can tell: how long each stepper ran, its positions, peak
speed, acceleration, the ramp states seen, and the pauses in which the board
printed nothing (a ``W`` spinning, ``T``, a long print).

Acceleration is the least-squares slope of ``v=`` against the time the lines
arrived, over each stretch of lines in one ramp state (``ACC`` up, ``RED`` down):
a line reaches the host late or early by its USB adapter's latency and the board's
prints, and the slope over a stretch averages that out, where the change between
two successive lines (as before) took a line that came 50 ms early as twice the
acceleration.
"""

from __future__ import annotations

from collections import Counter
from itertools import pairwise

from .. import messages as msg
from .plots import Series
from .status_lines import STOP_STATE, Sample, StatusTrace

GAP_S = 0.25  # between status lines while running: the board was busy
MIN_FIT_LINES = 3  # lines of one ramp state a slope needs
RAMP_UP, RAMP_DOWN = "ACC", "RED"  # the firmware's ramp states (messages.RAMP_STATE_TEXT)


def series_of(trace: StatusTrace, t0_s: float = 0.0) -> list[Series]:
    """Plot data per stepper, times from ``t0_s``."""
    out = []
    for number, st in sorted(trace.steppers.items()):
        samples = list(st.samples)
        if not samples:
            continue
        out.append(Series(number, [s.t_s - t0_s for s in samples],
                          [s.position for s in samples], [s.speed_sps for s in samples]))
    return out


def _runs(samples: list[Sample]) -> list[list[Sample]]:
    runs: list[list[Sample]] = [[]]
    for s in samples:
        runs[-1].append(s)
        if s.state == STOP_STATE:
            runs.append([])
    return [r for r in runs if r]


def _acceleration(run: list[Sample]) -> tuple[float | None, float | None]:
    """(acceleration, deceleration) of a run: the steepest slope of an ACC stretch and
    of a RED stretch (None: no stretch long enough)."""
    acc: float | None = None
    dec: float | None = None
    stretch: list[Sample] = []
    for s in [*run, None]:
        if (s is not None and stretch and s.speed_known and s.state == stretch[-1].state
                and s.t_s - stretch[-1].t_s <= GAP_S):
            stretch.append(s)
            continue
        if len(stretch) >= MIN_FIT_LINES and stretch[0].state in (RAMP_UP, RAMP_DOWN):
            slope = _slope([(x.t_s, abs(x.speed_sps)) for x in stretch])
            if stretch[0].state == RAMP_UP and slope > 0:
                acc = slope if acc is None else max(acc, slope)
            elif stretch[0].state == RAMP_DOWN and slope < 0:
                dec = -slope if dec is None else max(dec, -slope)
        stretch = [s] if s is not None and s.speed_known else []
    return acc, dec


def _slope(points: list[tuple[float, float]]) -> float:
    n = len(points)
    mt = sum(t for t, _ in points) / n
    mv = sum(v for _, v in points) / n
    stt = sum((t - mt) ** 2 for t, _ in points)
    return sum((t - mt) * (v - mv) for t, v in points) / stt if stt else 0.0


def _most(values: list[float | None]) -> str:
    known = [v for v in values if v is not None]
    return f"{max(known):.0f}" if known else msg.REPORT_NONE


def report_lines(trace: StatusTrace, source: str) -> list[str]:
    """The report as text lines."""
    times = [s.t_s for st in trace.steppers.values() for s in st.samples]
    start, end = (min(times), max(times)) if times else (0.0, 0.0)
    lines = [msg.STATUS_REPORT_TITLE.format(source=source, start=start, end=end,
                                            lines=trace.lines)]
    shown = 0
    for number, st in sorted(trace.steppers.items()):
        samples = list(st.samples)
        status = [s for s in samples if s.state != STOP_STATE]
        if not status:
            continue
        shown += 1
        lines.append(msg.STATUS_REPORT_STEPPER.format(n=number, lines=st.status_lines,
                                                      first=status[0].t_s,
                                                      last=status[-1].t_s))
        first, last = samples[0].position, samples[-1].position
        final = ("" if st.final_position is None
                 else msg.STATUS_REPORT_FINAL.format(final=st.final_position))
        lines.append(msg.STATUS_REPORT_POSITION.format(start=first, end=last,
                                                       net=last - first, final=final))
        runs = _runs(samples)
        rates = [_acceleration(run) for run in runs]
        gaps = sum(1 for run in runs for x, y in pairwise(run) if y.t_s - x.t_s > GAP_S)
        peak = max(abs(s.speed_sps) for s in status)
        lines.append(msg.STATUS_REPORT_SPEED.format(
            speed=peak, acc=_most([a for a, _ in rates]), dec=_most([d for _, d in rates])))
        states = Counter(s.state for s in status)
        lines.append(msg.STATUS_REPORT_RAMP.format(
            states=", ".join(f"{name} {n}" for name, n in states.most_common())))
        lines.append(msg.STATUS_REPORT_RUNS.format(runs=len(runs), gaps=gaps,
                                                   gap_ms=int(GAP_S * 1000)))
    if not shown:
        lines.append(msg.STATUS_REPORT_NONE)
    return lines
