"""PWM arithmetic of the user analog outputs: frequency -> timer setting -> duty count.

Pure computation on the figures of :class:`fas.output_figures.PwmTimer` (no I/O, no clock).

* :func:`pwm_setting` turns a requested frequency into what the timer can do: a clock
  divider and the number of counts per period (the duty resolution), and the
  frequency that really comes out.
* :func:`duty_count` turns a duty in percent into the nearest count (clamped to
  0..100 %, seed 003); the count, not the percentage, is what the timer produces.

The two rules (``PwmTimer.rule``):

``bits`` (ESP32 LEDC, seed 003)
    ``bits`` = the largest whole number with ``2**bits <= clock / f``, at most the
    timer's ``width_bits`` (13): 10 kHz -> 12 bits, 5 kHz -> 13 bits.  The divider
    ``clock * 2**frac / (f * 2**bits)`` is truncated to its fixed-point steps (as the
    ESP-IDF driver does); it must lie in ``1 .. divider_max + (2**frac - 1) / 2**frac``.

``counts`` (AVR timers, SAM timer-counters)
    The counter runs at ``clock / N`` for a prescaler N and wraps after TOP+1 counts.
    Variable TOP: the smallest N for which ``round(clock / (N * f))`` counts fit the
    counter (best resolution), TOP+1 = that count.  Fixed TOP (``fixed_top``): only N
    is chosen, the one whose frequency is nearest to the request.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import log2
from typing import TYPE_CHECKING

from .output_figures import PWM_RULE_BITS, PwmTimer

if TYPE_CHECKING:  # pragma: no cover
    from fractions import Fraction

# (fractions, with decimal, takes milliseconds to import: only the functions that
# work out a PWM setting import it, not every start of the program)


class PwmFrequencyError(ValueError):
    """The timer cannot make this frequency; ``lowest_hz``/``highest_hz`` is what it can."""

    def __init__(self, timer: PwmTimer, requested_hz: float, lowest_hz: float,
                 highest_hz: float) -> None:
        self.timer = timer
        self.requested_hz = requested_hz
        self.lowest_hz = lowest_hz
        self.highest_hz = highest_hz
        super().__init__(f"{timer.name} makes {lowest_hz:.4g} .. {highest_hz:.4g} Hz, "
                         f"not {requested_hz:g} Hz")

    @property
    def too_low(self) -> bool:
        return self.requested_hz < self.lowest_hz


@dataclass(frozen=True)
class PwmSetting:
    """One timer configuration: ``counts`` per period of ``clock_div`` timer clocks each.

    ``clock_div`` is the prescaler N (``counts`` rule) or the divider in units of
    ``2**-frac_bits`` (``bits`` rule).  A period lasts
    ``clock_div * counts / (clock_hz * 2**frac_bits)`` seconds.
    """

    timer: str
    clock_hz: int
    frac_bits: int
    clock_div: int
    counts: int
    requested_hz: float

    @property
    def frequency(self) -> Fraction:
        from fractions import Fraction
        return Fraction(self.clock_hz << self.frac_bits, self.clock_div * self.counts)

    @property
    def frequency_hz(self) -> float:
        return float(self.frequency)

    @property
    def bits(self) -> float:
        """Resolution in bits, log2 of the counts (a whole number on ESP32)."""
        return log2(self.counts)

    @property
    def step_percent(self) -> float:
        """Duty resolution: one count in percent of the period."""
        return 100.0 / self.counts

    def period_ticks(self, ticks_per_s: int) -> Fraction:
        """The period in ticks of a machine clock of ``ticks_per_s`` (exact)."""
        from fractions import Fraction
        return Fraction(ticks_per_s * self.clock_div * self.counts,
                        self.clock_hz << self.frac_bits)


def clamp_percent(duty_percent: float) -> float:
    """Seed 003: above 100 % is 100 %, below 0 % is 0 % (NaN is refused by callers)."""
    return min(100.0, max(0.0, float(duty_percent)))


def duty_count(counts: int, duty_percent: float) -> int:
    """The count nearest to ``duty_percent`` of ``counts`` (clamped; halves round up)."""
    from fractions import Fraction
    exact = Fraction(clamp_percent(duty_percent)) * counts / 100
    return int(exact + Fraction(1, 2))


def count_percent(count: int, counts: int) -> float:
    """The duty a count really produces, in percent."""
    return 100.0 * count / counts if counts else 0.0


def pwm_setting(timer: PwmTimer, frequency_hz: float) -> PwmSetting:
    """What ``timer`` makes of ``frequency_hz`` (raises :class:`PwmFrequencyError`)."""
    from fractions import Fraction
    f = Fraction(frequency_hz) if frequency_hz == frequency_hz else Fraction(0)
    if timer.rule == PWM_RULE_BITS:
        return _bits_setting(timer, f, frequency_hz)
    return _counts_setting(timer, f, frequency_hz)


def frequency_range(timer: PwmTimer) -> tuple[float, float]:
    """Lowest and highest frequency the timer makes (Hz)."""
    clock = timer.clock_hz
    if timer.rule == PWM_RULE_BITS:
        one = 1 << timer.divider_frac_bits
        max_div = timer.divider_max * one + one - 1
        return (clock * one / (max_div * (1 << timer.width_bits)), clock / 2)
    if timer.fixed_top:
        counts = timer.fixed_top + 1
        return (clock / (max(timer.prescalers) * counts), clock / (min(timer.prescalers) * counts))
    # a variable TOP needs at least two counts (one bit)
    return (clock / (max(timer.prescalers) * (1 << timer.width_bits)),
            clock / (min(timer.prescalers) * 2))


def _bits_setting(timer: PwmTimer, f: Fraction, requested: float) -> PwmSetting:
    from fractions import Fraction
    clock = timer.clock_hz
    low, high = frequency_range(timer)
    if f <= 0 or f > clock / 2:
        raise PwmFrequencyError(timer, requested, low, high)
    bits = 0
    while bits < timer.width_bits and (1 << (bits + 1)) * f <= clock:
        bits += 1
    one = 1 << timer.divider_frac_bits
    div = int(Fraction(clock * one) / (f * (1 << bits)))  # truncated, as ESP-IDF does
    if div < one or div > timer.divider_max * one + one - 1:
        raise PwmFrequencyError(timer, requested, low, high)
    return PwmSetting(timer.name, clock, timer.divider_frac_bits, div, 1 << bits, requested)


def _counts_setting(timer: PwmTimer, f: Fraction, requested: float) -> PwmSetting:
    from fractions import Fraction
    clock = timer.clock_hz
    low, high = frequency_range(timer)
    if f <= 0:
        raise PwmFrequencyError(timer, requested, low, high)
    if timer.fixed_top:
        counts = timer.fixed_top + 1
        best = min(timer.prescalers,
                   key=lambda n: (abs(Fraction(clock, n * counts) - f), n))
        return PwmSetting(timer.name, clock, 0, best, counts, requested)
    limit = 1 << timer.width_bits
    for n in sorted(timer.prescalers):
        counts = int(Fraction(clock, n) / f + Fraction(1, 2))
        if counts <= limit:
            if counts < 2:
                raise PwmFrequencyError(timer, requested, low, high)
            return PwmSetting(timer.name, clock, 0, n, counts, requested)
    raise PwmFrequencyError(timer, requested, low, high)
