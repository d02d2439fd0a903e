"""The spindle (or laser) and the coolant on the user outputs: which output is what
per profile - in this one place - and how M3/M4/M5 S and M7/M8/M9 drive them.

**The map** (:data:`TOOL_MAPS`, documented in ``docs/gcode.md``): the spindle's PWM is
an analog user output (its duty is the spindle speed, its frequency the output's
``$140+n`` setting), mist (M7) and flood (M8) coolant are digital user outputs.  The
outputs follow their pin settings (``$150-$163``); an output without a pin is not
there - the words are still accepted and kept in the modal state (``$G``), nothing
is driven, and laser mode (``$32=1``) is refused with Grbl's error 17.  M62-M68 may
still drive an output the map gives to the spindle or coolant (the last change wins):
programs written for the user outputs keep working; Dout0, Dout1 and Aout0 are
never in the map.

**Spindle speed -> duty** as Grbl 1.1's ``spindle_compute_pwm_value``: S times the
spindle override, S0 off, S at or above ``$30`` full duty, S at or below ``$31`` (but
not 0) the smallest duty the timer makes above 0, linear in between
(``$31`` -> 0 %, ``$30`` -> 100 %).

**Laser mode** (``$32=1``, Grbl 1.1's ``laser_mode.md``): each move carries its power
(:class:`~.interp.Laser`: 0 for G0 moves); the executor tells the path speed at every
queue command it writes (``MotionExecutor.speed_listener``) and the duty is scheduled
for that command's tick: M3 keeps S, M4 scales S by speed / programmed feed (0 when
the path stops).  The change is a *timed output* at that tick
(:meth:`fas.outputs.UserOutputs.analog` with ``at``): the backend makes it at the tick
where the outputs are - a timer compare on the simulated chip, the device's clock
behind ``--port`` - however busy the main loop is then, so the duty follows each queue
command within one PWM period (the timer takes a new duty at its next period); a
backend without timed outputs has them made by :meth:`Tooling.poll` as their ticks
come.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from fas.codes import PIN_UNDEFINED
from fas.pwm import PwmSetting

from .interp import SPINDLE_CCW, SPINDLE_OFF, Laser, Move

if TYPE_CHECKING:  # pragma: no cover
    from .machine import GcodeMachine

RPM_MAX, RPM_MIN = 30, 31  # the settings


@dataclass(frozen=True)
class ToolMap:
    """Which user output is what on one profile (None: not there)."""

    spindle_pwm: int | None  # Aout number: M3/M4 S -> duty; the laser
    mist: int | None  # Dout number: M7
    flood: int | None  # Dout number: M8
    probe: int | None = None  # input pin (pulled low on contact): G38.2-G38.5


#: the map, per profile (profiles not named have no user outputs: no spindle, no coolant).
#: ATmega328p: Aout1 is pin 11, Grbl's own spindle PWM pin (D11, timer 2); Dout2 is
#: pin 12 and Dout3 pin 14 (A0).  The others take the same numbers, so that Dout0,
#: Dout1 and Aout0 stay free for M62-M68 everywhere.  The probe is Grbl's probe pin:
#: A5 (pin 19) on the ATmega328p, A15 (pin 69) on the ATmega2560.
_USUAL = ToolMap(spindle_pwm=1, mist=2, flood=3)
TOOL_MAPS: dict[str, ToolMap] = {
    "atmega328p": ToolMap(spindle_pwm=1, mist=2, flood=3, probe=19),
    "atmega2560": ToolMap(spindle_pwm=1, mist=2, flood=3, probe=69),
    **{name: _USUAL for name in ("esp32", "esp32_idf5", "esp32_idf6", "sam_due")},
}
NO_TOOLS = ToolMap(None, None, None)


def tool_map(profile_name: str) -> ToolMap:
    return TOOL_MAPS.get(profile_name, NO_TOOLS)


def spindle_duty(rpm: float, rpm_max: float, rpm_min: float, step_percent: float) -> float:
    """Grbl's speed -> PWM rule (see the module text); ``step_percent`` is the smallest
    duty above 0 the timer makes."""
    if rpm <= 0.0:
        return 0.0
    if rpm_min >= rpm_max or rpm >= rpm_max:
        return 100.0
    if rpm <= rpm_min:
        return step_percent
    return max(step_percent, 100.0 * (rpm - rpm_min) / (rpm_max - rpm_min))


class Tooling:
    """The spindle/laser and coolant outputs of one G-code machine."""

    def __init__(self, machine: GcodeMachine) -> None:
        self.m = machine
        self.map = tool_map(machine.backend.profile.name)
        self.state = SPINDLE_OFF
        self.speed = 0.0  # S the spindle runs with (before the override)
        self.mist = self.flood = False
        self._scheduled = 0  # laser duty changes given to the outputs, tick not yet polled
        self.last_scheduled: float | None = None
        self.changes = 0  # duty changes made for the laser (figures, tests)
        # outputs this has switched on: only those does it switch off (M5, M9, M2,
        # an alarm), so a program driving them with M62-M68 alone keeps its values
        self._driven: set[tuple[bool, int]] = set()

    # ----------------------------------------------------------------- facts
    def _outputs(self):
        return self.m.engine.outputs

    def spindle_output(self) -> int | None:
        """The Aout number of the spindle PWM when it has a pin, else None."""
        n = self.map.spindle_pwm
        if n is None or self._outputs().analog_pin(n) == PIN_UNDEFINED:
            return None
        return n

    def _coolant_output(self, n: int | None) -> int | None:
        if n is None or self._outputs().digital_pin(n) == PIN_UNDEFINED:
            return None
        return n

    def role(self, analog: bool, number: int) -> str | None:
        """What the map makes of a user output (None: it is free for M62-M68)."""
        if analog:
            return "spindle PWM (M3/M4 S)" if number == self.spindle_output() else None
        if number == self._coolant_output(self.map.mist):
            return "mist coolant (M7)"
        if number == self._coolant_output(self.map.flood):
            return "flood coolant (M8)"
        return None

    def duty_for(self, speed: float) -> float:
        """The duty (percent) of spindle speed ``speed`` with the spindle override."""
        st = self.m.settings
        rpm = speed * self.m.spindle_override / 100.0
        step = 100.0
        n = self.spindle_output()
        if n is not None:
            setting = self._outputs().frequency_setting(n)
            if isinstance(setting, PwmSetting):
                step = 100.0 / setting.counts
        return spindle_duty(rpm, float(st.kept.get(RPM_MAX, 1000.0)),
                            float(st.kept.get(RPM_MIN, 0.0)), step)

    def reported_speed(self) -> float:
        """The spindle speed for the status report's ``FS:`` (Grbl's ``sys.spindle_speed``):
        S with the override, within ``$31``..``$30``, while the output is on; else 0."""
        if self.state == SPINDLE_OFF or self.applied_duty() <= 0.0:
            return 0.0
        st = self.m.settings
        rpm = self.speed * self.m.spindle_override / 100.0
        return min(max(rpm, float(st.kept.get(RPM_MIN, 0.0))),
                   float(st.kept.get(RPM_MAX, 1000.0)))

    def applied_duty(self) -> float:
        n = self.spindle_output()
        return 0.0 if n is None else self._outputs().analog_applied(n)[0]

    # --------------------------------------------------------------- changes
    def _set_duty(self, duty: float) -> None:
        n = self.spindle_output()
        if n is None or (duty == 0.0 and (True, n) not in self._driven):
            return
        if duty > 0.0:
            self._driven.add((True, n))
        else:
            self._driven.discard((True, n))
        if self._outputs().analog_applied(n)[0] != duty:
            self._outputs().analog(n, duty, synchronized=False)

    def set_spindle(self, state: int, speed: float) -> None:
        """M3/M4/M5 or a new S, now (the machine waits for the motion before it).  In
        laser mode M4 is off while nothing moves (Grbl)."""
        self.state, self.speed = state, speed
        self.clear_schedule()
        if state == SPINDLE_OFF or (state == SPINDLE_CCW and self.m.interp.laser_mode):
            self._set_duty(0.0)
        else:
            self._set_duty(self.duty_for(speed))

    def override_changed(self) -> None:
        """The spindle override changed: a running spindle (not the laser in motion,
        whose next command takes it) follows at once."""
        if self.state != SPINDLE_OFF and not self.m.interp.laser_mode:
            self._set_duty(self.duty_for(self.speed))

    def hold_off(self) -> None:
        """Laser mode, a feed hold has stopped the machine: the laser off until the
        motion goes on (Grbl's ``DISABLE_LASER_DURING_HOLD``, on by default); the next
        queue command of a powered move sets its power again."""
        if self.m.interp.laser_mode and self.state != SPINDLE_OFF:
            self.clear_schedule()
            self._set_duty(0.0)

    def set_coolant(self, mist: bool, flood: bool) -> None:
        self.mist, self.flood = mist, flood
        outputs = self._outputs()
        for n, on in ((self._coolant_output(self.map.mist), mist),
                      (self._coolant_output(self.map.flood), flood)):
            if n is None or (not on and (False, n) not in self._driven):
                continue
            if on:
                self._driven.add((False, n))
            else:
                self._driven.discard((False, n))
            if outputs.digital_applied(n) != int(on):
                outputs.digital(n, on, synchronized=False)

    def all_off(self) -> None:
        """Program end, alarm, abort: spindle and coolant off at once (Grbl's
        ``spindle_stop``/``coolant_stop``)."""
        self.set_spindle(SPINDLE_OFF, self.speed)
        self.set_coolant(False, False)

    def forget(self) -> None:
        """A reset has switched every output off already."""
        self.clear_schedule()
        self.state, self.mist, self.flood = SPINDLE_OFF, False, False
        self._driven.clear()

    # ---------------------------------------------------------- laser timing
    def on_speed(self, tick: int, rate: float, block: Move | None) -> None:
        """The executor's speed listener: from ``tick`` on the path runs at ``rate``
        units/min in ``block``."""
        if not isinstance(block, Move):
            return
        laser: Laser | None = block.laser
        if laser is None or self.spindle_output() is None:
            return
        if laser.dynamic:
            speed = laser.speed * rate / laser.feed if laser.feed > 0 else 0.0
        else:
            speed = laser.speed
        duty = self.duty_for(speed)
        if duty == self.last_scheduled:
            return
        self.last_scheduled = duty
        n = self.spindle_output()
        assert n is not None  # (checked above)
        if duty == 0.0 and (True, n) not in self._driven:
            return
        if duty > 0.0:
            self._driven.add((True, n))
        else:
            self._driven.discard((True, n))
        self._scheduled += 1
        self._outputs().analog(n, duty, synchronized=False, at=tick)

    def clear_schedule(self) -> None:
        """Drop the laser's changes whose tick has not come."""
        self._outputs().cancel_timed()
        self._scheduled = 0
        self.last_scheduled = None

    def poll(self, now: int) -> None:
        """The laser's changes whose tick has come are made (the backend's timed output
        made them at their tick already; see the module text)."""
        if self._scheduled:
            made = self._outputs().poll_timed(now)
            self._scheduled -= made
            self.changes += made

    def wake_tick(self) -> int | None:
        return self._outputs().next_timed_tick() if self._scheduled else None
