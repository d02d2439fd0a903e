"""What the user-output pins show (issue 12): digital levels and PWM period and duty.

A consumer of :class:`fas.sim.trace.EdgeStream`, like :mod:`.motion`.  The pins are
those of the outputs' table (``OutputFigures.user_digital_pins``, ``.user_analog``);
VCD names ``Dout0..3`` and ``Aout0..3``.  For a PWM pin every complete period (rise to
rise) gives one period and one duty; the figures are exact (integer ticks summed),
the plot samples are thinned as they grow.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fas.arch import Profile
from fas.codes import PIN_UNDEFINED
from fas.output_figures import output_figures

from .thinning import PlotSamples

PLOT_POINTS = 2000  # samples kept per output for plots (.thinning: per time bucket)


@dataclass(frozen=True)
class OutputPin:
    name: str  # Dout0 .. Aout3
    pin: int
    analog: bool


def output_pins(profile: Profile) -> list[OutputPin]:
    """The user outputs that have a pin in the profile table."""
    figures = output_figures(profile)
    out = [OutputPin(f"Dout{i}", pin, False) for i, pin in enumerate(figures.user_digital_pins)
           if pin != PIN_UNDEFINED]
    out += [OutputPin(f"Aout{i}", a.pin, True) for i, a in enumerate(figures.user_analog)
            if a.pin != PIN_UNDEFINED]
    return out


class OutputTrace:
    """Figures of one output pin, fed edge by edge in time order."""

    def __init__(self, out: OutputPin, level: int) -> None:
        self.out = out
        self.level = level
        self.initial = level
        self.rises = 0
        self.falls = 0
        self.first_edge: int | None = None
        self.last_edge: int | None = None
        self.high_total = 0
        self._high_since: int | None = None
        # PWM: complete periods (rise to rise)
        self._rise: int | None = None
        self._fall: int | None = None
        self.periods = 0
        self.period_sum = 0
        self.high_sum = 0
        self.period_min: int | None = None
        self.period_max: int | None = None
        self.duty_min: float | None = None
        self.duty_max: float | None = None
        self.last_period: int | None = None
        self.last_duty: float | None = None
        # (tick, level 0/1 or duty %) for plots, thinned per time bucket
        self.plot = PlotSamples(PLOT_POINTS, key=1)

    def edges(self, times: Sequence[int], levels: bytes) -> None:
        for t, lv in zip(times, levels, strict=True):
            if lv == self.level:
                continue
            if self.first_edge is None:
                self.first_edge = t
                self.plot.add((t, self._value()))
            self.last_edge = t
            self.level = lv
            if lv:
                self.rises += 1
                self._high_since = t
                if self._rise is not None and self._fall is not None and self._fall > self._rise:
                    self._period(self._rise, self._fall, t)
                self._rise = t
                self._fall = None
            else:
                self.falls += 1
                if self._high_since is not None:
                    self.high_total += t - self._high_since
                self._high_since = None
                self._fall = t
            if not self.out.analog:
                self.plot.add((t, float(lv)))

    def _value(self) -> float:
        return float(self.level) * (100.0 if self.out.analog else 1.0)

    def _period(self, rise: int, fall: int, next_rise: int) -> None:
        period = next_rise - rise
        high = fall - rise
        duty = 100.0 * high / period
        self.periods += 1
        self.period_sum += period
        self.high_sum += high
        self.last_period = period
        self.last_duty = duty
        if self.period_min is None or period < self.period_min:
            self.period_min = period
        if self.period_max is None or period > self.period_max:
            self.period_max = period
        if self.duty_min is None or duty < self.duty_min:
            self.duty_min = duty
        if self.duty_max is None or duty > self.duty_max:
            self.duty_max = duty
        self.plot.add((rise, duty))

    @property
    def samples(self) -> list[tuple[int, float]]:
        """The plot samples (tick, level or duty %), in time order."""
        return self.plot.samples()

    def finish(self, end_tick: int) -> None:
        if self._high_since is not None:
            self.high_total += end_tick - self._high_since
            self._high_since = end_tick
        if self.first_edge is not None:
            if self.out.analog and self.periods and (self.last_edge or 0) < end_tick - (
                    self.period_max or 0):
                value = self._value()  # stopped pulsing: constant since the last edge
            elif self.out.analog:
                value = self.last_duty if self.last_duty is not None else self._value()
            else:
                value = float(self.level)
            self.plot.add((end_tick, value))

    @property
    def used(self) -> bool:
        return self.first_edge is not None

    def mean_duty(self) -> float | None:
        return 100.0 * self.high_sum / self.period_sum if self.period_sum else None

    def mean_period(self) -> float | None:
        return self.period_sum / self.periods if self.periods else None


class OutputAnalysis:
    """Consumer of the ordered edge stream for the user outputs of a profile."""

    def __init__(self, profile: Profile, initial: dict[int, int] | None = None) -> None:
        self.profile = profile
        initial = initial or {}
        self.outputs = [OutputTrace(o, initial.get(o.pin, 0)) for o in output_pins(profile)]
        self._by_pin: dict[int, list[OutputTrace]] = {}
        for tr in self.outputs:
            self._by_pin.setdefault(tr.out.pin, []).append(tr)

    def pins(self) -> set[int]:
        return set(self._by_pin)

    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        for tr in self._by_pin.get(pin, ()):
            tr.edges(times, levels)

    def finish(self, end_tick: int) -> None:
        for tr in self.outputs:
            tr.finish(end_tick)


def duty_steps(times: Sequence[int], levels: bytes, end_tick: int,
               close: float = 0.1) -> list[tuple[float, int, int]]:
    """A PWM pin's waveform as steps of one duty: ``(mean duty %, periods, ticks)`` per
    run of consecutive periods whose duties are within ``close`` percentage points of
    the run's first (a high time between two whole ticks alternates).  A period is
    rise to rise; the last one before the output stops (stays low longer than a
    period) counts with the length of the one before it."""
    rises = [t for t, lv in zip(times, levels, strict=True) if lv]
    falls = [t for t, lv in zip(times, levels, strict=True) if not lv]
    periods: list[tuple[int, int]] = []  # (period, high)
    fi = 0
    for i, rise in enumerate(rises):
        while fi < len(falls) and falls[fi] <= rise:
            fi += 1
        fall = falls[fi] if fi < len(falls) else None
        if i + 1 < len(rises):
            nxt = rises[i + 1]
        elif periods and fall is not None and end_tick - rise > periods[-1][0]:
            nxt = rise + periods[-1][0]  # stopped after this period
        else:
            break
        if fall is None or fall > nxt:
            break
        periods.append((nxt - rise, fall - rise))
    steps: list[tuple[float, int, int]] = []
    first = high_sum = length = count = 0
    for period, high in periods:
        duty = 100.0 * high / period
        if count and abs(duty - first) > close:
            steps.append((100.0 * high_sum / length, count, length))
            high_sum = length = count = 0
        if not count:
            first = duty
        high_sum += high
        length += period
        count += 1
    if count:
        steps.append((100.0 * high_sum / length, count, length))
    return steps
