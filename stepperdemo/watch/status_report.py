"""Plots and a report from StepperDemo's status lines (a board shows nothing else).

On the simulation ``/plot`` and ``/report`` read the pins; a board running the
original firmware only prints a status line every 100 ms while a stepper runs.
These are the same plots (position and the planned speed ``v=`` over time) and a
report of what the lines can tell: how long each stepper ran, its positions, peak
speed, acceleration between lines, the ramp states seen, and the pauses in which
the board printed nothing (a ``W`` spinning, ``T``, a long print).
"""

from __future__ import annotations

from collections import Counter
from itertools import pairwise

from .. import messages as msg
from .plots import Series
from .status_lines import STOP_STATE, Sample, StatusTrace

GAP_S = 0.25  # between status lines while running: the board was busy
MIN_DT_S = 0.05  # acceleration only from lines at least this far apart


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


def _acceleration(run: list[Sample]) -> tuple[float, float]:
    acc = dec = 0.0
    known = [s for s in run if s.speed_known]
    for a, b in pairwise(known):
        dt = b.t_s - a.t_s
        if dt < MIN_DT_S or dt > GAP_S:
            continue
        change = (abs(b.speed_sps) - abs(a.speed_sps)) / dt
        acc = max(acc, change)
        dec = max(dec, -change)
    return acc, dec


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
        acc = dec = 0.0
        gaps = 0
        for run in runs:
            a, d = _acceleration(run)
            acc, dec = max(acc, a), max(dec, d)
            gaps += sum(1 for x, y in pairwise(run) if y.t_s - x.t_s > GAP_S)
        peak = max(abs(s.speed_sps) for s in status)
        lines.append(msg.STATUS_REPORT_SPEED.format(speed=peak, acc=acc, dec=dec))
        states = Counter(s.state for s in status)
        lines.append(msg.STATUS_REPORT_RAMP.format(
            states=", ".join(f"{name} {n}" for name, n in states.most_common())))
        lines.append(msg.STATUS_REPORT_RUNS.format(runs=len(runs), gaps=gaps,
                                                   gap_ms=int(GAP_S * 1000)))
    if not shown:
        lines.append(msg.STATUS_REPORT_NONE)
    return lines
