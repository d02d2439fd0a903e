"""User outputs (seed 003): four digital and four analog (PWM) outputs per engine.

``engine.outputs`` numbers them independently, Dout0..3 and Aout0..3, on the pins of
the outputs' table (``OutputFigures.user_digital_pins`` / ``.user_analog``), which
:meth:`UserOutputs.set_digital_pin` / :meth:`UserOutputs.set_analog_pin` override.

* **Synchronized** changes (``synchronized=True``, G-code M62/M63/M67) take effect
  after all motion commanded before them has completed and before any motion
  commanded after them (:mod:`fas.sync` holds that motion back until then).
* **Immediate** changes (M64/M65/M68) take effect at once.
* **Timed** analog changes (``analog(..., at=tick)``, the laser's power at a queue
  command's tick) are made at that tick where the outputs are - by the backend's timed
  output (:meth:`fas.backend.Backend.timed_output`: a compare on the simulated chip, the
  device's clock behind a serial link) when it offers one, else by
  :meth:`UserOutputs.poll_timed` when the application polls after the tick.  What
  :meth:`UserOutputs.analog_applied` reports follows at the poll either way.

Analog values are a duty in percent, clamped to 0..100; each output has a frequency
(default 5000 Hz, ``OutputFigures.pwm_default_hz``) that its timer turns into a setting
(:mod:`fas.pwm`); the duty produced is the nearest count, and
:meth:`UserOutputs.analog_state` reports it.

Power-on and :meth:`UserOutputs.reset`: every output off.  A pin is left untouched
until its output is first used (it is low - off - from power-on).  Nothing else
changes an output: an emergency stop, an error or the end of a program leave them
as they are (:meth:`UserOutputs.cancel_pending` drops synchronized changes that have
not happened yet, as an alarm flushes its queue).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING

from .backend import OutputChange
from .codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED
from .output_figures import output_figures
from .pwm import PwmFrequencyError, PwmSetting, count_percent, duty_count, pwm_setting

if TYPE_CHECKING:  # pragma: no cover
    from .engine import Engine

OUTPUTS = 4  # per kind, seed 003
TIMER_USER = "pwm"  # the outputs' name in the allocator's book of timers


class OutputResult(IntEnum):
    OK = 0
    ERR_NO_SUCH_OUTPUT = -1  # the number is not 0..3
    ERR_NO_PIN = -2  # this profile has no pin for that output (override it)
    ERR_PIN_IN_USE = -3  # a stepper or another output uses the pin
    ERR_NOT_PWM_PIN = -4  # no PWM timer drives that pin
    ERR_FREQUENCY = -5  # the timer cannot make that frequency
    ERR_BUSY = -6  # a synchronized change on this timer waits: change the frequency later
    ERR_NOT_A_NUMBER = -7  # NaN duty or frequency
    ERR_TIMER_IN_USE = -8  # another user of the timer has it (QuickStep, fas.allocate)


@dataclass(frozen=True)
class AnalogState:
    """What an analog output does (after every change commanded so far)."""

    number: int
    pin: int
    setting: PwmSetting | None  # None: never used (off)
    requested_percent: float
    count: int

    @property
    def duty_percent(self) -> float:
        return count_percent(self.count, self.setting.counts) if self.setting else 0.0


def output_name(analog: bool, number: int) -> str:
    return f"{'Aout' if analog else 'Dout'}{number}"


class UserOutputs:
    """The engine's user outputs (see the module text)."""

    def __init__(self, engine: Engine) -> None:
        self._engine = engine
        p = output_figures(engine.profile)
        self.figures = p
        self._digital_pins = [_pin_of(p.user_digital_pins, i) for i in range(OUTPUTS)]
        self._analog_pins = [p.user_analog[i].pin if i < len(p.user_analog) else PIN_UNDEFINED
                             for i in range(OUTPUTS)]
        self._digital_used = [False] * OUTPUTS
        self._digital_level = [0] * OUTPUTS  # after every commanded change
        self._analog_hz: list[float] = [float(p.pwm_default_hz)] * OUTPUTS
        self._analog_setting: list[PwmSetting | None] = [None] * OUTPUTS
        self._analog_percent = [0.0] * OUTPUTS
        self._analog_count = [0] * OUTPUTS
        # what the outputs show: immediate changes at once, synchronized ones when made
        self._digital_applied = [0] * OUTPUTS
        self._analog_applied: list[tuple[float, int]] = [(0.0, 0)] * OUTPUTS
        self.changes = 0
        # timed changes (at tick, change, made by the backend's timed output), by tick
        self._timed: list[tuple[int, OutputChange, bool]] = []
        # fn(change) when a change is made (issued or applied)
        self.listeners: list[Callable[[OutputChange], None]] = []

    # ------------------------------------------------------------------ pins
    def digital_pin(self, number: int) -> int:
        return self._digital_pins[number] if 0 <= number < OUTPUTS else PIN_UNDEFINED

    def analog_pin(self, number: int) -> int:
        return self._analog_pins[number] if 0 <= number < OUTPUTS else PIN_UNDEFINED

    def set_digital_pin(self, number: int, pin: int) -> OutputResult:
        """Put Dout ``number`` on another pin (before its first use)."""
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        if pin == PIN_UNDEFINED or pin & PIN_EXTERNAL_FLAG:
            return OutputResult.ERR_NO_PIN
        if self._pin_user(pin, skip=(False, number)) is not None:
            return OutputResult.ERR_PIN_IN_USE
        self._digital_pins[number] = pin
        self._digital_used[number] = False
        return OutputResult.OK

    def set_analog_pin(self, number: int, pin: int) -> OutputResult:
        """Put Aout ``number`` on another PWM pin (before its first use)."""
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        if pin == PIN_UNDEFINED or pin & PIN_EXTERNAL_FLAG:
            return OutputResult.ERR_NO_PIN
        if self._timer_of_pin(number, pin) is None:
            return OutputResult.ERR_NOT_PWM_PIN
        if self._pin_user(pin, skip=(True, number)) is not None:
            return OutputResult.ERR_PIN_IN_USE
        self._analog_pins[number] = pin
        old = self._analog_setting[number]
        if old is not None:
            self._engine.allocator.release_timer(old.timer, TIMER_USER, number)
        self._analog_setting[number] = None
        return OutputResult.OK

    def pin_user(self, pin: int) -> str | None:
        """Who else drives ``pin``: "stepper 2 step", "Dout1" ... (None: free)."""
        return self._pin_user(pin, skip=None)

    def _pin_user(self, pin: int, skip: tuple[bool, int] | None) -> str | None:
        for s in self._engine.steppers:
            for role, p in (("step", s.get_step_pin()), ("direction", s.get_direction_pin()),
                            ("enable", s.get_enable_pin_low_active()),
                            ("enable", s.get_enable_pin_high_active())):
                if p == pin:
                    return f"stepper {s.index + 1} {role}"
        for analog, pins in ((False, self._digital_pins), (True, self._analog_pins)):
            for i, p in enumerate(pins):
                if p == pin and (analog, i) != skip:
                    return output_name(analog, i)
        return None

    def _timer_of_pin(self, number: int, pin: int) -> str | None:
        p = self.figures
        unit = p.pwm_pin(pin)
        if unit is not None:
            return unit.timer
        if p.pwm_any_pin and number < len(p.user_analog) and p.user_analog[number].timer:
            return p.user_analog[number].timer
        return None

    def pwm_uses_timer(self, timer: str) -> bool:
        """Does a started analog output run on ``timer``?"""
        return TIMER_USER in self._engine.allocator.timer_users(timer)

    def _timer_taken(self, timer: str) -> bool:
        """Something else runs on ``timer`` (the QuickStep planner: AVR "timer 2")."""
        return self._engine.allocator.timer_used_by_other(timer, TIMER_USER)

    def timer_name(self, number: int) -> str | None:
        """The PWM timer of Aout ``number`` on its current pin."""
        pin = self.analog_pin(number)
        return None if pin == PIN_UNDEFINED else self._timer_of_pin(number, pin)

    # ------------------------------------------------------------- frequency
    def frequency_hz(self, number: int) -> float:
        return self._analog_hz[number]

    def set_frequency(self, number: int, frequency_hz: float) -> OutputResult:
        """The PWM frequency of Aout ``number`` (at once; outputs sharing its timer follow).

        A timer shared with another output (ATmega328P timer 2) has one frequency:
        both outputs get it.  Refused while a synchronized change of an output on
        that timer waits (its count belongs to the old setting).
        """
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        if not isinstance(frequency_hz, (int, float)) or math.isnan(frequency_hz):
            return OutputResult.ERR_NOT_A_NUMBER
        pin = self._analog_pins[number]
        if pin == PIN_UNDEFINED:
            return OutputResult.ERR_NO_PIN
        timer = self.figures.pwm_timer(self._timer_of_pin(number, pin) or "")
        if timer is None:
            return OutputResult.ERR_NOT_PWM_PIN
        if self._timer_taken(timer.name):
            return OutputResult.ERR_TIMER_IN_USE
        try:
            setting = pwm_setting(timer, frequency_hz)
        except PwmFrequencyError:
            return OutputResult.ERR_FREQUENCY
        sharing = self._sharing(timer.name)
        if self._engine.sync.pending_analog(sharing):
            return OutputResult.ERR_BUSY
        for n in sharing:
            self._analog_hz[n] = frequency_hz
            if self._analog_setting[n] is not None:
                self._configure(n, setting)
        return OutputResult.OK

    def frequency_setting(self, number: int) -> PwmSetting | OutputResult:
        """The setting Aout ``number``'s timer makes of its frequency (or why none)."""
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        current = self._analog_setting[number]
        if current is not None:
            return current
        pin = self._analog_pins[number]
        if pin == PIN_UNDEFINED:
            return OutputResult.ERR_NO_PIN
        timer = self.figures.pwm_timer(self._timer_of_pin(number, pin) or "")
        if timer is None:
            return OutputResult.ERR_NOT_PWM_PIN
        try:
            return pwm_setting(timer, self._analog_hz[number])
        except PwmFrequencyError:
            return OutputResult.ERR_FREQUENCY

    def _sharing(self, timer: str) -> list[int]:
        return [n for n in range(OUTPUTS) if self._analog_pins[n] != PIN_UNDEFINED
                and self._timer_of_pin(n, self._analog_pins[n]) == timer]

    def _configure(self, number: int, setting: PwmSetting) -> None:
        # a started output books its timer (fas.allocate) until it moves to another pin
        self._engine.allocator.hold_timer(setting.timer, TIMER_USER, number)
        self._analog_setting[number] = setting
        self._analog_count[number] = duty_count(setting.counts, self._analog_percent[number])
        self._engine.backend.configure_pwm(number, self._analog_pins[number], setting,
                                           self._analog_count[number])

    # --------------------------------------------------------------- changes
    def digital(self, number: int, on: bool, synchronized: bool = True) -> OutputResult:
        """Switch Dout ``number`` on or off (M62/M63 synchronized, M64/M65 immediate)."""
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        pin = self._digital_pins[number]
        if pin == PIN_UNDEFINED:
            return OutputResult.ERR_NO_PIN
        if not self._digital_used[number]:
            user = self._pin_user(pin, skip=(False, number))
            if user is not None:
                return OutputResult.ERR_PIN_IN_USE
            self._digital_used[number] = True
        level = 1 if on else 0
        self._digital_level[number] = level
        self._issue(OutputChange(False, number, pin, level, None, synchronized))
        return OutputResult.OK

    def analog(self, number: int, duty_percent: float,
               synchronized: bool = True, at: int | None = None) -> OutputResult:
        """Set Aout ``number`` to ``duty_percent`` (clamped 0..100; M67 sync, M68 immediate).

        ``at``: a timed change - made at that tick (of ``backend.now()``) where the
        outputs are, by the backend's timed output when it offers one, else by
        :meth:`poll_timed` when the tick has come (see the module text)."""
        if not 0 <= number < OUTPUTS:
            return OutputResult.ERR_NO_SUCH_OUTPUT
        if not isinstance(duty_percent, (int, float)) or math.isnan(duty_percent):
            return OutputResult.ERR_NOT_A_NUMBER
        pin = self._analog_pins[number]
        if pin == PIN_UNDEFINED:
            return OutputResult.ERR_NO_PIN
        setting = self._analog_setting[number]
        if setting is None:
            user = self._pin_user(pin, skip=(True, number))
            if user is not None:
                return OutputResult.ERR_PIN_IN_USE
            found = self.frequency_setting(number)
            if not isinstance(found, PwmSetting):
                return found
            if self._timer_taken(found.timer):
                return OutputResult.ERR_TIMER_IN_USE
            # a shared timer already running for another output keeps its setting
            for n in self._sharing(found.timer):
                running = self._analog_setting[n]
                if running is not None:
                    found = running
                    self._analog_hz[number] = self._analog_hz[n]
                    break
            self._analog_percent[number] = 0.0
            self._configure(number, found)  # the timer starts, output off
            setting = found
        duty = min(100.0, max(0.0, float(duty_percent)))
        count = duty_count(setting.counts, duty)
        self._analog_percent[number] = duty
        self._analog_count[number] = count
        change = OutputChange(True, number, pin, count, setting, synchronized and at is None,
                              duty)
        if at is None:
            self._issue(change)
        else:
            self._issue_at(change, at)
        return OutputResult.OK

    def _issue_at(self, change: OutputChange, at: int) -> None:
        self.changes += 1
        made = self._engine.backend.timed_output(change, at)
        i = len(self._timed)
        while i and self._timed[i - 1][0] > at:
            i -= 1
        self._timed.insert(i, (at, change, made))

    def poll_timed(self, now: int) -> int:
        """The timed changes whose tick has come: made now where the backend has no timed
        output, and shown as applied (:meth:`analog_applied`, the listeners) either way.
        Returns how many."""
        k = 0
        timed = self._timed
        while k < len(timed) and timed[k][0] <= now:
            k += 1
        due, self._timed = timed[:k], timed[k:]
        backend = self._engine.backend
        for _at, change, made in due:
            if not made:
                backend.set_output(change)
            self.applied(change)
        return k

    def next_timed_tick(self) -> int | None:
        """The tick of the next timed change not yet shown as applied (None: none)."""
        return self._timed[0][0] if self._timed else None

    def cancel_timed(self) -> int:
        """Drop the timed changes whose tick has not come (after :meth:`poll_timed`):
        what is commanded is again what the outputs show.  Returns how many."""
        dropped = len(self._timed)
        if dropped:
            self._engine.backend.cancel_timed_outputs()
            self._timed.clear()
            for n in range(OUTPUTS):
                self._analog_percent[n], self._analog_count[n] = self._analog_applied[n]
        return dropped

    def _issue(self, change: OutputChange) -> None:
        self.changes += 1
        if change.synchronized:
            self._engine.sync.add_barrier(change)
        else:
            self._engine.backend.set_output(change)
            self.applied(change)

    def applied(self, change: OutputChange) -> None:
        """A change has been made (the sync barrier calls this for synchronized ones)."""
        if change.analog:
            self._analog_applied[change.number] = (change.percent, change.value)
        else:
            self._digital_applied[change.number] = change.value
        for fn in self.listeners:
            fn(change)

    # ----------------------------------------------------------------- state
    def digital_level(self, number: int) -> int:
        """The level after every change commanded so far (synchronized ones included)."""
        return self._digital_level[number]

    def digital_applied(self, number: int) -> int:
        """The level the output has now (synchronized changes still waiting excluded)."""
        return self._digital_applied[number]

    def analog_applied(self, number: int) -> tuple[float, int]:
        """(requested percent, count) the output runs with now."""
        return self._analog_applied[number]

    def analog_state(self, number: int) -> AnalogState:
        return AnalogState(number, self._analog_pins[number], self._analog_setting[number],
                           self._analog_percent[number], self._analog_count[number])

    def pending(self) -> int:
        """Synchronized changes that have not happened yet."""
        return self._engine.sync.pending_changes()

    def cancel_pending(self, drop_motion: bool = True) -> int:
        """Alarm: drop synchronized changes not yet made (and the motion held behind
        them); the outputs keep their present state.  Returns the changes dropped."""
        dropped = self._engine.sync.cancel(drop_motion)
        for n in range(OUTPUTS):  # what is commanded is again what the outputs show
            self._digital_level[n] = self._digital_applied[n]
            self._analog_percent[n], self._analog_count[n] = self._analog_applied[n]
        return dropped

    def reset(self) -> None:
        """Reset: drop pending changes, every output off at once."""
        self._engine.sync.cancel(drop_motion=True)
        self.cancel_timed()
        for n in range(OUTPUTS):
            if self._digital_used[n]:
                self._digital_level[n] = 0
                self._issue(OutputChange(False, n, self._digital_pins[n], 0))
            if self._analog_setting[n] is not None:
                self._analog_percent[n] = 0.0
                self._analog_count[n] = 0
                self._issue(OutputChange(True, n, self._analog_pins[n], 0,
                                         self._analog_setting[n]))


def _pin_of(pins: tuple[int, ...], i: int) -> int:
    return pins[i] if i < len(pins) else PIN_UNDEFINED
