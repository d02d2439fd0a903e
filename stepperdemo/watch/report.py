"""The timing report: what a logic analyser on the step/dir/enable pins would tell.

(And on the user outputs, issue 12: per digital output its changes, per PWM output
its measured period and duty.)

Per stepper: pulses, step period (min/median/max), peak speed and acceleration, the
deviation of each step interval from the planned command timing, pulse high time,
gaps, queue underruns and missed compares, direction changes with the shortest
dir-to-step delay, driver enables with the delay to the first step.  Then the
interrupt-blocked windows (`e`) and the stray pin reads (`r`) of the run.
"""

from __future__ import annotations

from .. import messages as msg
from .motion import GAP_FACTOR, StepperMotion
from .observe import Observers


def fmt_us(ticks: float | None, ticks_per_s: int) -> str:
    """Ticks as microseconds, exact to 4 decimals, without trailing zeros."""
    if ticks is None:
        return msg.REPORT_NONE
    text = f"{ticks * 1_000_000 / ticks_per_s:.4f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def library_positions(app) -> list[int | None] | None:
    """The positions the library reports for StepperDemo's steppers (for comparison)."""
    if app is None:
        return None
    return [None if s is None else s.get_current_position() for s in app.steppers]


def _stepper_lines(m: StepperMotion, tps: int, library: int | None) -> list[str]:
    w = m.wiring

    def us(ticks: float | None) -> str:
        return fmt_us(ticks, tps)

    pins = [msg.REPORT_PIN.format(role=role, pin=pin)
            for role, pin in (("dir", w.direction), ("enable", w.enable_low),
                              ("enable high", w.enable_high)) if pin is not None]
    lines = [msg.REPORT_STEPPER.format(n=w.number, step=w.step, pins="".join(pins))]
    net = m.position - m.start_position
    lines.append(msg.REPORT_PULSES.format(pulses=m.pulses, counted=m.channel_count("pulses"),
                                          net=net, position=m.position))
    if library is not None and library != m.position:
        lines.append(msg.REPORT_POSITION_DIFFERS.format(library=library))
    if m.period_min is not None:
        lines.append(msg.REPORT_PERIOD.format(min=us(m.period_min), median=us(m.period_median()),
                                              max=us(m.period_max)))
        lines.append(msg.REPORT_SPEED.format(speed=tps / m.period_min, acc=_rate(m.acc_max),
                                             dec=_rate(m.dec_max)))
    if m.dev_compared and not m.dev_late and not m.dev_early:
        lines.append(msg.REPORT_DEVIATION_NONE.format(compared=m.dev_compared))
    elif m.dev_compared:
        ontime = m.dev_compared - m.dev_late - m.dev_early
        lines.append(msg.REPORT_DEVIATION.format(
            compared=m.dev_compared, ontime=ontime, late=m.dev_late,
            late_max=us(m.dev_max_late), early=m.dev_early, early_max=us(m.dev_max_early)))
    if m.high_min is not None:
        lines.append(msg.REPORT_HIGH.format(min=us(m.high_min), max=us(m.high_max)))
    if m.gaps:
        lines.append(msg.REPORT_GAPS.format(gaps=m.gaps, factor=GAP_FACTOR, longest=us(m.gap_max)))
    else:
        lines.append(msg.REPORT_GAPS_NONE.format(factor=GAP_FACTOR))
    lines.append(msg.REPORT_QUEUE.format(motions=m.motions, dry=m.channel_count("dry"),
                                         restarts=m.restarts,
                                         missed=m.channel_count("missed_compares")))
    lines.append(msg.REPORT_DIR.format(changes=m.dir_changes, delay=us(m.dir_to_step_min)))
    lines.extend(_quickstep_lines(m, tps))
    delays = m.enable_to_step
    lines.append(msg.REPORT_ENABLE.format(
        enables=m.enables, min=us(min(delays) if delays else None),
        max=us(max(delays) if delays else None), disabled=m.steps_disabled))
    return lines


def _rate(value: float | None) -> str:
    """steps/s^2, or "-" where the pulses did not show it (one step, a constant rate)."""
    return msg.REPORT_NONE if value is None else f"{value:.0f}"


def _output_lines(obs: Observers, tps: int) -> list[str]:
    """One line per user output that changed (issue 12)."""
    if obs.outputs is None:
        return []
    lines = []
    for tr in obs.outputs.outputs:
        if not tr.used:
            continue
        o = tr.out
        level = msg.REPORT_LEVEL_HIGH if tr.level else msg.REPORT_LEVEL_LOW
        if o.analog and tr.periods:
            period = tr.mean_period()
            lines.append(msg.REPORT_OUTPUT_PWM.format(
                name=o.name, pin=o.pin, periods=tr.periods, period=fmt_us(period, tps),
                hz=tps / period, pmin=fmt_us(tr.period_min, tps), pmax=fmt_us(tr.period_max, tps),
                duty=tr.mean_duty(), dmin=tr.duty_min, dmax=tr.duty_max, last=tr.last_duty))
        elif o.analog:
            lines.append(msg.REPORT_OUTPUT_PWM_FEW.format(name=o.name, pin=o.pin, rises=tr.rises,
                                                          falls=tr.falls, level=level))
        else:
            lines.append(msg.REPORT_OUTPUT_DIGITAL.format(
                name=o.name, pin=o.pin, rises=tr.rises, falls=tr.falls,
                high_ms=tr.high_total * 1000 / tps, first=f"{tr.first_edge / tps:.6f}",
                level=level))
    return lines


PLATEAUS_LISTED = 16  # periods listed in the plateau line (the slowest first)


def _quickstep_lines(m: StepperMotion, tps: int) -> list[str]:
    """QuickStep steppers: the plateaus (orders by period) and the timer."""
    ch = m.channel
    if ch is None or not hasattr(ch, "lost_periods"):
        return []
    items = sorted(m.entry_steps.items(), reverse=True)
    shown = [msg.REPORT_PLATEAU_ITEM.format(steps=steps, us=fmt_us(ticks, tps))
             for ticks, steps in items[:PLATEAUS_LISTED]]
    if len(items) > PLATEAUS_LISTED:
        shown.append("...")
    tb = ch.clock.current
    lines = [msg.REPORT_PLATEAUS.format(n=m.entries_taken, periods=len(items),
                                        list=" ".join(shown) or msg.REPORT_NONE)]
    if tb is not None:
        lines.append(msg.REPORT_QS_TIMER.format(timer=tb.timer.number,
                                                base=fmt_us(tb.base_ticks, tps),
                                                lost=ch.lost_periods,
                                                starts=m.channel_count("starts")))
    return lines


def report_lines(obs: Observers, positions: list[int | None] | None = None) -> list[str]:
    """The report as text lines; ``positions``: the library's view, to compare with."""
    obs.flush()
    an = obs.analysis
    tps = obs.profile.ticks_per_s
    if an is None:
        return [msg.REPORT_NOT_RECORDED]
    start, end = obs.stream.start_tick, obs.now_tick()
    lines = [msg.REPORT_TITLE.format(profile=obs.profile.name, start=start / tps,
                                     end=end / tps)]
    shown = 0
    for i, m in enumerate(an.steppers):
        if not m.pulses and not m.enables:
            continue
        shown += 1
        library = positions[i] if positions is not None and i < len(positions) else None
        lines.extend(_stepper_lines(m, tps, library))
    outputs = _output_lines(obs, tps)
    if not shown and not outputs:
        lines.append(msg.REPORT_NO_STEPS)
    lines.extend(outputs)
    lines.append(msg.REPORT_IRQ.format(windows=an.irq_windows, ms=an.irq_ticks * 1000 / tps))
    reads, during = an.stray_reads
    lines.append(msg.REPORT_STRAY.format(reads=reads, during=during))
    if obs.stream.late_edges:
        lines.append(msg.REPORT_LATE_EDGES.format(n=obs.stream.late_edges))
    return lines
