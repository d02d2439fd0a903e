"""The user outputs' figures, per chip: their pins and the PWM timers behind them.

:data:`BY_PROFILE` holds one :class:`OutputFigures` per profile name that has a table
of user outputs (issue 12: Dout0..3 and Aout0..3, :mod:`fas.outputs`);
:func:`output_figures` answers for any profile, with :data:`NO_OUTPUTS` (no pin for
any output, until a program sets one) for the others.  The library's outputs, its
PWM computation (:mod:`fas.pwm`), the serial device and the console's views of the
outputs read these.
"""

from __future__ import annotations

from dataclasses import dataclass

from .arch import Profile
from .codes import PIN_UNDEFINED

PWM_RULE_COUNTS = "counts"  # AVR / SAM timers: a prescaler and a TOP (period = N*(TOP+1))
PWM_RULE_BITS = "bits"  # ESP32 LEDC: whole bits of resolution, fractional clock divider


@dataclass(frozen=True)
class PwmTimer:
    """A hardware timer that makes the PWM of user analog outputs (issue 12).

    ``rule`` says how a frequency becomes a timer setting (:mod:`fas.pwm`):

    * :data:`PWM_RULE_COUNTS` - the timer counts ``clock_hz / N`` with N one of
      ``prescalers`` up to TOP; a period is TOP+1 counts, at most ``2**width_bits``.
      ``fixed_top`` > 0: TOP cannot move (both compare units of the timer make PWM,
      or the timer also runs ``millis()``), only the prescaler is chosen.
    * :data:`PWM_RULE_BITS` - ESP32 LEDC: the resolution is the largest whole number
      of bits with ``2**bits <= clock_hz / f``, at most ``width_bits``; the clock
      divider has ``divider_frac_bits`` fractional bits and at most ``divider_max``
      as its integer part.
    """

    name: str
    clock_hz: int
    rule: str
    width_bits: int
    prescalers: tuple[int, ...] = (1,)
    fixed_top: int = 0
    divider_frac_bits: int = 0
    divider_max: int = 0


@dataclass(frozen=True)
class PwmPin:
    """A pin that a PWM timer drives (its compare unit, e.g. ``OC2B``)."""

    pin: int
    timer: str
    unit: str


@dataclass(frozen=True)
class OutputFigures:
    """The user outputs on one chip."""

    # pins of the four digital outputs (PIN_UNDEFINED: this chip has none free)
    user_digital_pins: tuple[int, ...] = ()
    # the four analog (PWM) outputs: pin and timer (pin PIN_UNDEFINED: none free)
    user_analog: tuple[PwmPin, ...] = ()
    # the PWM timers and every pin they can drive (overrides must pick one of these)
    pwm_timers: tuple[PwmTimer, ...] = ()
    pwm_pins: tuple[PwmPin, ...] = ()
    # the output's timer can be routed to any pin (ESP32 GPIO matrix)
    pwm_any_pin: bool = False
    pwm_default_hz: int = 5000  # seed 003: frequency of an analog output unless set

    def pwm_timer(self, name: str) -> PwmTimer | None:
        for t in self.pwm_timers:
            if t.name == name:
                return t
        return None

    def pwm_pin(self, pin: int) -> PwmPin | None:
        """The PWM unit that can drive ``pin`` (None: the pin has no PWM hardware)."""
        for p in (*self.user_analog, *self.pwm_pins):
            if p.pin == pin and pin != PIN_UNDEFINED:
                return p
        return None


NO_OUTPUTS = OutputFigures()

_AVR_PRESCALERS_T0_T1 = (1, 8, 64, 256, 1024)  # timers 0, 1, 3, 4, 5 (CS bits)
_AVR_PRESCALERS_T2 = (1, 8, 32, 64, 128, 256, 1024)  # timer 2 has two more
# timer 0 runs millis(): Arduino's fast PWM, prescaler 64, TOP 255 (976.5625 Hz) only
_AVR_TIMER0 = PwmTimer("timer 0", 16_000_000, PWM_RULE_COUNTS, 8, (64,), fixed_top=255)
_NO_PWM = PwmPin(PIN_UNDEFINED, "", "")

ATMEGA328P_OUTPUTS = OutputFigures(
    # free pins beside StepperDemo's wiring (5-10), the LED (13) and the UART (0, 1)
    user_digital_pins=(2, 4, 12, 14),
    # timer 1 steps the motors and timer 0 runs millis(): only timer 2 is left, and
    # with both its compare units as PWM its TOP is fixed at 255 (one prescaler for both)
    user_analog=(PwmPin(3, "timer 2", "OC2B"), PwmPin(11, "timer 2", "OC2A"),
                 _NO_PWM, _NO_PWM),
    pwm_timers=(PwmTimer("timer 2", 16_000_000, PWM_RULE_COUNTS, 8, _AVR_PRESCALERS_T2,
                         fixed_top=255), _AVR_TIMER0),
    pwm_pins=(PwmPin(5, "timer 0", "OC0B"), PwmPin(6, "timer 0", "OC0A")),
)

# the Arduino Mega as issue 12 laid it out for the timer-4 build (the default)
ATMEGA2560_OUTPUTS = OutputFigures(
    user_digital_pins=(22, 23, 24, 25),
    # one timer per output, so every output has its own frequency: the 16-bit timers
    # 1, 3, 5 with TOP in ICRn, and timer 2 (8 bit) with TOP in OCR2A (OC2A is lost)
    user_analog=(PwmPin(11, "timer 1", "OC1A"), PwmPin(5, "timer 3", "OC3A"),
                 PwmPin(46, "timer 5", "OC5A"), PwmPin(9, "timer 2", "OC2B")),
    pwm_timers=(
        PwmTimer("timer 1", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 3", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 5", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 2", 16_000_000, PWM_RULE_COUNTS, 8, _AVR_PRESCALERS_T2),
        _AVR_TIMER0,
    ),
    pwm_pins=(PwmPin(12, "timer 1", "OC1B"), PwmPin(2, "timer 3", "OC3B"),
              PwmPin(3, "timer 3", "OC3C"), PwmPin(45, "timer 5", "OC5B"),
              PwmPin(44, "timer 5", "OC5C"), PwmPin(4, "timer 0", "OC0B"),
              PwmPin(13, "timer 0", "OC0A")),
)

# the ESP32 (every ESP-IDF version; not the S2/S3/C3/... chips)
ESP32_OUTPUTS = OutputFigures(
    # with StepperDemo's six steppers wired only 0, 23, 32 and 33 stay free: the
    # outputs also use pins of steppers 4-6, and refuse them while those are connected
    user_digital_pins=(32, 33, 23, 25),
    user_analog=tuple(PwmPin(pin, f"LEDC timer {i}", f"LEDC channel {i}")
                      for i, pin in enumerate((5, 16, 4, 14))),
    # LEDC on the 80 MHz APB clock: whole bits of resolution, at most 13 (seed 003);
    # divider 1.0 .. 1023.996 in 1/256 steps (10.8 fixed point)
    pwm_timers=tuple(PwmTimer(f"LEDC timer {i}", 80_000_000, PWM_RULE_BITS, 13,
                              divider_frac_bits=8, divider_max=1023) for i in range(4)),
    pwm_any_pin=True,
)

SAM_DUE_OUTPUTS = OutputFigures(
    user_digital_pins=(50, 51, 52, 53),
    # timer-counter channels (TIOA), 32-bit, clocked from MCK/2, /8, /32, /128;
    # the PWM controller's pins 6-9 belong to the steppers
    user_analog=(PwmPin(2, "TC0 ch0", "TIOA0"), PwmPin(3, "TC2 ch1", "TIOA7"),
                 PwmPin(5, "TC2 ch0", "TIOA6"), PwmPin(11, "TC2 ch2", "TIOA8")),
    pwm_timers=tuple(PwmTimer(name, 84_000_000, PWM_RULE_COUNTS, 32, (2, 8, 32, 128))
                     for name in ("TC0 ch0", "TC2 ch1", "TC2 ch0", "TC2 ch2")),
    pwm_pins=(PwmPin(13, "TC0 ch0", "TIOB0"), PwmPin(10, "TC2 ch1", "TIOB7"),
              PwmPin(4, "TC2 ch0", "TIOB6"), PwmPin(12, "TC2 ch2", "TIOB8")),
)

BY_PROFILE: dict[str, OutputFigures] = {
    "atmega328p": ATMEGA328P_OUTPUTS,
    "atmega2560": ATMEGA2560_OUTPUTS,
    "esp32": ESP32_OUTPUTS,
    "esp32_idf5": ESP32_OUTPUTS,
    "esp32_idf6": ESP32_OUTPUTS,
    "sam_due": SAM_DUE_OUTPUTS,
    "pc_test": ESP32_OUTPUTS,  # upstream's test platform is the ESP32's figures
}


def output_figures(profile: Profile) -> OutputFigures:
    """The user outputs of ``profile`` (:data:`NO_OUTPUTS` where it has no table)."""
    return BY_PROFILE.get(profile.name, NO_OUTPUTS)
