"""StepperDemo's ``g`` mode: G-code on StepperDemo's own steppers (issue 12).

``g`` in normal mode enters it.  From then on a line is a G-code block, answered
``ok`` / ``error: <reason>``; ``x`` alone on a line leaves (after every queued block
is done) back to StepperDemo's normal mode.  Axes X, Y, Z ... are StepperDemo's
steppers M1, M2, M3 ...  While in the mode the drivers are switched by the G-code
machine (auto enable off); leaving restores each stepper's auto enable.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import messages as msg
from .machine import RESET, STATUS, GcodeMachine
from .settings import GcodeSettings

if TYPE_CHECKING:  # pragma: no cover
    from ..demo.app import StepperDemo

EXIT_LINE = "x"


class DemoGcode:
    """The G-code machine inside StepperDemo's loop."""

    def __init__(self, app: StepperDemo, settings: GcodeSettings | None = None) -> None:
        self.app = app
        steppers = [s for s in app.steppers if s is not None]
        self.auto_enable = [s.get_auto_enable() for s in steppers]
        self.machine = GcodeMachine(app.engine, steppers, self._write, settings)
        self._line = bytearray()
        self._last = 0
        self.leaving = False

    def _write(self, line: str) -> None:
        self.app.print(line + msg.CRLF)

    # --------------------------------------------------------------- input
    def can_take(self) -> bool:
        """May the loop hand over the next input character?"""
        return not self.leaving and self.machine.can_take_line()

    def char(self, c: int) -> None:
        """One input character (StepperDemo's loop takes one per pass)."""
        last, self._last = self._last, c
        ch = chr(c)
        if ch == STATUS or c == RESET:
            self.machine.realtime(ch)
            return
        if ch in "\r\n":
            if ch == "\n" and last == 0x0D:
                return  # CR LF ends one line
            text = self._line.decode("utf-8", "replace")
            self._line.clear()
            if text.strip() == EXIT_LINE:
                self.leaving = True
                self.poll()
                return
            self.machine.line(text)
            return
        if len(self._line) < 1024:
            self._line.append(c)

    # ---------------------------------------------------------------- time
    def poll(self) -> None:
        self.machine.poll()
        if self.leaving and self.machine.idle():
            self._leave()

    def wake_tick(self) -> int | None:
        return self.machine.wake_tick()

    def busy(self) -> bool:
        return self.leaving or not self.machine.idle()

    def _leave(self) -> None:
        self.leaving = False
        for s, auto in zip(self.machine.steppers, self.auto_enable, strict=True):
            # the ramp generator's target is where the G-code moves ended (R<n> is
            # relative to it): name the place where the stepper stands
            s.force_stop_and_new_position(s.get_current_position())
            s.set_auto_enable(auto)
            if auto:  # back in automatic mode: the driver is off while at rest
                s.disable_outputs()
        self.app.leave_gcode()
