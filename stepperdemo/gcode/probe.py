"""G38.2-G38.5: probing against the profile's probe input (Grbl 1.1's ``mc_probe_cycle``).

The probe input is in the profile's map (:data:`.tooling.TOOL_MAPS`, ``probe``): an
input with a pull-up that the probe pulls low on contact (Grbl's probe pin, ``$6=0``).
A profile without one - or a backend without inputs and limit stops - refuses G38.x
with ``error:20`` after Grbl's checks.

A cycle, once the motion before it is done:

* the probe must not be triggered already (G38.2/G38.3: touching; G38.4/G38.5: not
  touching) - else ``ALARM:4``;
* the move starts towards the target with every moving axis's queue watched by the
  backend's limit stop on the probe pin (``Backend.set_limit``): on contact every axis
  stops at once, where its pulses are made - no further step;
* contact: the position is the probe position (``[PRB:x,y,z:1]``, ``$#``), the rest of
  the move is dropped, the parser is where the machine stopped; no contact by the
  target: G38.2/G38.4 ``ALARM:5``, G38.3/G38.5 ``[PRB:...:0]``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fas.backend import Backend

from .. import messages as msg
from . import reports
from .codes import Alarm
from .interp import Probe

if TYPE_CHECKING:  # pragma: no cover
    from .machine import GcodeMachine

CONTACT = 0  # the probe pulls its input low


def _limits_supported(backend: Backend) -> bool:
    return type(backend).set_limit is not Backend.set_limit


class ProbeCycle:
    """The probe input of one G-code machine and the cycle in progress."""

    def __init__(self, machine: GcodeMachine, pin: int | None) -> None:
        self.m = machine
        self.pin: int | None = None
        self._pin = pin if pin is not None and _limits_supported(machine.backend) else None
        self.position = [0] * machine.axes  # steps, the last probe's (machine)
        self.succeeded = False
        self.active: Probe | None = None
        self._limits: list[tuple[int, bool]] = []
        self._stops: dict[int, int] = {}  # queue index -> position where it stopped

    def available(self) -> bool:
        """The profile has a probe input and the backend watches it (from the first
        G38.x on: a program that never probes leaves the pin alone)."""
        if self.pin is None and self._pin is not None:
            backend = self.m.backend
            if backend.watch_input(self._pin):
                self.pin = self._pin
                backend.limit_listeners.append(self._stopped)
            else:
                self._pin = None
        return self.pin is not None

    def touching(self) -> bool:
        return self.pin is not None and self.m.backend.read_input(self.pin) == CONTACT

    # ---------------------------------------------------------------- cycle
    def execute(self, action: Probe) -> bool:
        """Called for the line's Probe action while it is in execution; True when done."""
        m = self.m
        ex = m.executor
        if self.active is None:
            if ex.busy() or ex.moving():
                return False  # after the motion before it (Grbl's buffer sync)
            if self.touching() == action.toward:
                m.probe_alarm(Alarm.PROBE_FAIL_INITIAL, msg.GCODE_PROBE_INITIAL)
                return True
            self._start(action)
            return False
        if self._stops:
            self._contact()
            return True
        if ex.busy() or ex.moving():
            return False
        self._finish(False)
        return True

    def _start(self, action: Probe) -> None:
        m = self.m
        move = action.move
        level = CONTACT if action.toward else 1 - CONTACT
        moving = [(m.steppers[i].index, t > s)
                  for i, (t, s) in enumerate(zip(move.target, move.start, strict=True))
                  if t != s]
        indices = tuple(i for i, _up in moving)
        assert self.pin is not None
        for index, up in moving:
            m.backend.set_limit(index, self.pin, level, up,
                                stop=tuple(i for i in indices if i != index))
        self._limits = moving
        self._stops = {}
        self.active = action
        m.blocks.push(move)
        m.executor.poll()

    def _stopped(self, index: int, pin: int, position: int, tick: int) -> None:
        """The backend stopped a queue at the probe (limit listener)."""
        if self.active is not None and pin == self.pin:
            self._stops[index] = position

    def _contact(self) -> None:
        m = self.m
        m.executor.abort()  # the rest of the move is dropped, every axis at rest
        m.blocks.clear()
        for s in m.steppers:
            if s.index in self._stops:
                s.force_stop_and_new_position(self._stops[s.index])
        self._finish(True)

    def _finish(self, contact: bool) -> None:
        m = self.m
        action = self.active
        assert action is not None
        for index, up in self._limits:
            m.backend.clear_limit(index, up)
        self._limits = []
        self._stops = {}
        self.active = None
        self.position = m.positions()
        self.succeeded = contact
        m.interp.sync_position(self.position)
        if not contact and action.fail_is_error:
            m.probe_alarm(Alarm.PROBE_FAIL_CONTACT, msg.GCODE_PROBE_NO_CONTACT)
            return
        m.write(self.report())

    def report(self) -> str:
        """``[PRB:x,y,z:1]`` - machine units, success."""
        st = self.m.settings
        units = [p / st.steps_per_unit[i] for i, p in enumerate(self.position)]
        return f"[PRB:{reports.axis_values(units)}:{int(self.succeeded)}]"

    def cancel(self) -> None:
        """Reset, abort: drop the cycle and its limit stops."""
        for index, up in self._limits:
            self.m.backend.clear_limit(index, up)
        self._limits = []
        self._stops = {}
        self.active = None
