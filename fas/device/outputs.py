"""User outputs of the device (``firmware/outputs.c``, docs/serial-protocol.md section 16).

PWM timers, output changes made at once, at a device tick (timed: OutputAt, at most
``TIMED_SLOTS`` waiting) or - synchronized - once every queue has run dry, and the
cancel of those not made yet.  The chip's PWM units and its rule for
synchronized changes are the simulated machine's (:class:`fas.sim.SimBackend`).
"""

from __future__ import annotations

from ..arch import Profile
from ..backend import OutputChange
from ..output_figures import PwmTimer, output_figures
from ..pwm import PwmSetting
from ..serial.protocol import (
    F_TIMED_OUTPUTS,
    T_CANCEL,
    TIMED_SLOTS,
    Message,
    OutputAt,
    OutputCancel,
    OutputNext,
    OutputPwm,
    OutputSet,
    PwmGrid,
    tick_diff32,
)
from .board import Board
from .queues import Handler


def pwm_timer_for(profile: Profile, number: int, pin: int) -> PwmTimer | None:
    """The timer that makes analog output ``number`` on ``pin`` on this chip."""
    figures = output_figures(profile)
    unit = figures.pwm_pin(pin)
    if unit is not None:
        return figures.pwm_timer(unit.timer)
    if figures.pwm_any_pin and 0 <= number < len(figures.user_analog):
        return figures.pwm_timer(figures.user_analog[number].timer)
    return None


class DeviceOutputs:
    """The user outputs: OutputPwm, OutputSet, OutputCancel, OutputAt, OutputNext."""

    def __init__(self, board: Board) -> None:
        self.board = board
        self._timed_last: OutputAt | None = None  # the session's last timed change

    def handlers(self) -> dict[type[Message], Handler]:
        return {OutputPwm: self.message, OutputSet: self.message, OutputCancel: self.message,
                OutputAt: self.timed, OutputNext: self.timed}

    def new_session(self) -> None:
        """No timed change yet for an OutputNext to count from."""
        self._timed_last = None

    def timed(self, m: Message) -> None:
        """OutputAt / OutputNext: the change at device tick ``at`` by the chip's timer (a
        tick past: at once); more than ``TIMED_SLOTS`` waiting, an OutputNext with no
        timed change before it in the session, or a device without the family:
        rejected."""
        board = self.board
        sim = board.sim
        if not board.features & F_TIMED_OUTPUTS:
            board.reject()
            return
        if isinstance(m, OutputNext):
            last = self._timed_last
            if last is None:
                board.reject()
                return
            m = OutputAt(last.flags, last.number, last.pin, m.value,
                         (last.at + m.after) & 0xFFFFFFFF)
        assert isinstance(m, OutputAt)
        if m.flags & T_CANCEL:
            sim.cancel_timed_outputs()
            return
        self._timed_last = m  # (OutputNext counts from it, whatever becomes of it)
        if sim.timed_waiting() >= TIMED_SLOTS:
            board.reject()
            return
        now = board.machine.now
        at = now + tick_diff32(m.at, now & 0xFFFFFFFF)
        sim.timed_output(OutputChange(m.analog, m.number, m.pin, m.value if m.analog else
                                      (1 if m.value else 0)), at)

    def _report_grid(self, pin: int) -> None:
        """PwmGrid: where the PWM periods of ``pin`` begin on the device clock."""
        wave = self.board.sim.machine.outputs.waves.get(pin)
        if wave is None:  # pragma: no cover - configure_pwm made it
            return
        period = wave.pn if wave.pd == 1 else 0  # (a period of whole ticks, or no grid)
        self.board.send(PwmGrid(pin, wave.origin & 0xFFFFFFFF, period))

    def cancel(self) -> None:
        """Drop the synchronized and timed changes not made yet; outputs stay as they are."""
        self.board.sim.cancel_sync_outputs()
        self.board.sim.cancel_timed_outputs()

    def message(self, m: Message) -> None:
        """PWM timers, output changes at once or after every queue ran dry, cancel."""
        board = self.board
        sim = board.sim
        if isinstance(m, OutputCancel):
            self.cancel()
            return
        if isinstance(m, OutputPwm):
            timer = pwm_timer_for(board.profile, m.number, m.pin)
            if timer is None or m.counts < 2 or m.clock_div < 1:
                board.reject()
                return
            setting = PwmSetting(timer.name, timer.clock_hz, timer.divider_frac_bits,
                                 m.clock_div, m.counts, 0.0)
            sim.configure_pwm(m.number, m.pin, setting, min(m.count, m.counts))
            if board.features & F_TIMED_OUTPUTS:
                self._report_grid(m.pin)
            return
        assert isinstance(m, OutputSet)
        change = OutputChange(m.analog, m.number, m.pin, m.value if m.analog else
                              (1 if m.value else 0))
        if m.synchronized and not board.locked:
            sim.sync_output(change)
        elif m.synchronized:
            board.reject()
        else:
            sim.set_output(change)
