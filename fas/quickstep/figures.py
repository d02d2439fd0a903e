"""QuickStep's figures, per chip: the timers it may run on and what its interrupts cost.

:data:`BY_PROFILE` holds one :class:`QuickStepFigures` per profile name that offers
QuickStep (issue 14); :func:`quickstep_figures` answers for any profile, with
:data:`NO_QUICKSTEP` (no timer: QuickStep is not available) for the others.  The
planner (its clock and time base) reads the timers and the RAM for its FIFOs; the
simulated chip (:mod:`fas.sim.quickstep`) reads the interrupt costs.

QuickStep (seed 004) on AVR: timer 2 (8 bit, prescalers 1..1024) by default, so that
the 16-bit timers stay free; base time 12 us .. 16.384 ms there, up to 4.19 s on a
16-bit timer.  No QuickStep build was available to measure the interrupt costs: they
are estimates from the instruction counts of such routines (register saves ~40
cycles, a countdown per motor, a port write and the next compare per step), chosen
so that at the 12 us minimum five motors leave no CPU (the seed's limit).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..arch import Profile


@dataclass(frozen=True)
class QsTimer:
    """A hardware timer the QuickStep planner can run on (its periodic base time)."""

    number: int  # timer 2, timer 3 ...
    bits: int  # 8 or 16: the counter width, so the longest base time
    prescalers: tuple[int, ...]  # clock dividers the timer offers


@dataclass(frozen=True)
class QuickStepFigures:
    """QuickStep on one chip (ticks of its profile)."""

    # timers QuickStep may use, the default first; empty: QuickStep is not available
    timers: tuple[QsTimer, ...] = ()
    ram_bytes: int = 0  # RAM left for the order FIFOs (4 bytes per order)
    order_bytes: int = 4  # one order: int16 steps (sign = direction), uint16 interval
    min_base_ticks: int = 0  # shortest base time (below it the ISR eats the CPU)
    period_isr_ticks: int = 0  # CPU of the base-period interrupt (entry, exit, timer)
    motor_isr_ticks: int = 0  # ... plus this per running QuickStep motor
    step_isr_ticks: int = 0  # CPU of the compare interrupt that makes one step
    pulse_ticks: int = 0  # step pin high time (the compare ISR writes it high, then low)
    start_ticks: int = 0  # order pushed to an idle motor -> its first step

    def timer(self, number: int | None = None) -> QsTimer | None:
        """The QuickStep timer ``number`` (None: the default one), or None."""
        for t in self.timers:
            if number is None or t.number == number:
                return t
        return None


NO_QUICKSTEP = QuickStepFigures()

_TIMER2 = QsTimer(2, 8, (1, 8, 32, 64, 128, 256, 1024))


def _timer16(number: int) -> QsTimer:
    return QsTimer(number, 16, (1, 8, 64, 256, 1024))


# ATmega328P: timer 1, the only 16-bit timer, belongs to FastAccelStepper (steps and
# ramp task).  2048 bytes of RAM; StepperDemo with FastAccelStepper keeps ~1 KB (input
# buffer 256, serial buffers 128, queues, steppers, stack): the FIFOs get the other half
AVR_QUICKSTEP = QuickStepFigures(
    timers=(_TIMER2,),
    ram_bytes=1024,
    min_base_ticks=12 * 16,
    period_isr_ticks=72,
    motor_isr_ticks=24,
    step_isr_ticks=96,
    pulse_ticks=48,
    start_ticks=80,
)

# ATmega2560: timer 2, or a 16-bit timer FastAccelStepper does not use (the default
# build, steps on timer 4, leaves timer 1 to the user outputs); 8 KB, ~1.5 KB for the
# program
_MEGA_QUICKSTEP = replace(AVR_QUICKSTEP, timers=(_TIMER2, _timer16(3), _timer16(5)),
                          ram_bytes=8192 - 1536)


def _mega_timer(step_timer: int) -> QuickStepFigures:
    """The Mega built with ``step_timer`` for the steps: the other 16-bit timers."""
    return replace(_MEGA_QUICKSTEP, timers=(_TIMER2,) + tuple(
        _timer16(t) for t in (1, 3, 4, 5) if t != step_timer))


BY_PROFILE: dict[str, QuickStepFigures] = {
    "atmega328p": AVR_QUICKSTEP,
    "atmega2560": _MEGA_QUICKSTEP,
    "atmega2560_timer1": _mega_timer(1),
    "atmega2560_timer3": _mega_timer(3),
    "atmega2560_timer5": _mega_timer(5),
}


def quickstep_figures(profile: Profile) -> QuickStepFigures:
    """QuickStep's figures on ``profile`` (:data:`NO_QUICKSTEP` where it has none)."""
    return BY_PROFILE.get(profile.name, NO_QUICKSTEP)
