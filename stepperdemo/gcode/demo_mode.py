"""StepperDemo's ``g`` mode: the G-code machine on StepperDemo's own steppers.

``g`` in normal mode enters it; from then on the input is the Grbl 1.1 controller's
(the same :class:`~.machine.GcodeMachine` as ``stepperdemo gcode`` and its
``--pty``/``--tcp`` endpoint): bytes go to its receive path as they arrive -
real-time bytes (``?`` ``!`` ``~`` Ctrl-X ...) act at once, the rest waits in its
128-byte ring, and a block ends at a line end (LF or CR; nothing else ends it).
``x`` alone on a line leaves (after every queued block is done) back to
StepperDemo's normal mode.  Axes X, Y, Z ... are StepperDemo's steppers M1, M2,
M3 ... (at most six).  While in the mode the drivers are switched by the G-code
machine (auto enable off); leaving restores each stepper's auto enable.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from .. import messages as msg
from .machine import GcodeMachine
from .parser import AXES
from .settings import GcodeSettings

if TYPE_CHECKING:  # pragma: no cover
    from fas import Engine, Stepper
    from fas.backend import Backend


class GcodeHost(Protocol):
    """What the ``g`` mode uses of the program that hosts it (StepperDemo's app): its
    steppers and engine, its printing, its failure count and the way back to its own
    mode - the seam that keeps this module from importing the app."""

    steppers: list[Stepper | None]
    engine: Engine
    backend: Backend
    gcode_failures: int

    def print(self, text: str | bytes) -> None: ...
    def leave_gcode(self) -> None: ...

EXIT_LINE = "X"  # "x" alone on a line, as the receive path hands it over


class DemoGcode:
    """The G-code machine inside StepperDemo's loop."""

    def __init__(self, app: GcodeHost, settings: GcodeSettings | None = None) -> None:
        self.app = app
        steppers = [s for s in app.steppers if s is not None][:len(AXES)]
        self.auto_enable = [s.get_auto_enable() for s in steppers]
        self.machine = GcodeMachine(app.engine, steppers, self._write, settings)
        self.machine.intercept = self._intercept
        self.leaving = False
        self._noted_partial = False
        self.machine.power_on()

    def _write(self, line: str) -> None:
        self.app.print(line + msg.CRLF)

    def _intercept(self, text: str) -> bool:
        if text != EXIT_LINE:
            return False
        self.leaving = True
        self.machine.input_held = True  # what follows the x is StepperDemo's again
        return True

    # --------------------------------------------------------------- input
    def room(self) -> bool:
        """May a script hand over its next character?  Only while the controller would
        read it (a sender waiting for each ``ok``): the input after an ``x`` line must
        stay StepperDemo's."""
        m = self.machine
        return not self.leaving and m.pending is None and m.can_read()

    def receive(self, data: bytes) -> None:
        """Bytes as they arrive on the serial line."""
        self.machine.receive(data)

    # ---------------------------------------------------------------- time
    def poll(self) -> None:
        self.machine.poll()
        if self.leaving and self.machine.idle():
            self._leave()

    def script_ended(self) -> None:
        """The scripted input is all taken: a line without its line end is never
        executed (Grbl's rule) - say so once instead of doing nothing silently."""
        partial = self.machine.rx.partial
        if partial and not self._noted_partial:
            self._noted_partial = True
            self.app.gcode_failures += 1
            self._write(msg.GRBL_MSG.format(text=msg.GCODE_UNENDED_LINE.format(text=partial)))

    def wake_tick(self) -> int | None:
        if self.leaving and self.machine.idle():
            return self.app.backend.now()
        return self.machine.wake_tick()

    def busy(self) -> bool:
        return self.leaving or not self.machine.idle()

    def _leave(self) -> None:
        self.leaving = False
        m = self.machine
        self.app.gcode_failures += m.errors
        for s, auto in zip(m.steppers, self.auto_enable, strict=True):
            # the ramp generator's target is where the G-code moves ended (R<n> is
            # relative to it): name the place where the stepper stands
            s.force_stop_and_new_position(s.get_current_position())
            s.set_auto_enable(auto)
            if auto:  # back in automatic mode: the driver is off while at rest
                s.disable_outputs()
        self.app.leave_gcode()
