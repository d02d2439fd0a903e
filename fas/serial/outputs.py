"""What the host drives on the device: pin levels and user outputs (issue 12).

The host remembers the last level it wrote to each pin, each PWM configuration and
each output's state, and builds the messages that set them - now, and again in every
new session (:meth:`OutputState.replay`), so that a device that lost its session, or
was reset, drives what the application last asked for.
"""

from __future__ import annotations

from ..backend import OutputChange
from ..pwm import PwmSetting
from .protocol import (
    O_ANALOG,
    O_SYNCHRONIZED,
    T_CANCEL,
    Message,
    OutputAt,
    OutputCancel,
    OutputNext,
    OutputPwm,
    OutputSet,
    Pin,
)


class OutputState:
    """Pin levels and user outputs the host has set (replayed on reconnect)."""

    def __init__(self) -> None:
        self.pins: dict[int, int] = {}  # levels the host wrote, in the order written
        self.pwm: dict[int, OutputPwm] = {}  # by output number
        self.outputs: dict[tuple[bool, int], OutputSet] = {}  # by (analog, number)
        # the session's last timed change sent (flags, number, pin, at): OutputNext
        # counts from it (section 16)
        self._timed_last: tuple[int, int, int, int] | None = None

    def pin(self, pin: int, level: int) -> Pin:
        level = 1 if level else 0
        self.pins.pop(pin, None)
        self.pins[pin] = level
        return Pin(pin, level)

    def level(self, pin: int) -> int:
        return self.pins.get(pin, 0)

    def configure_pwm(self, number: int, pin: int, setting: PwmSetting, count: int) -> OutputPwm:
        message = OutputPwm(number, pin, setting.clock_div, setting.counts, count)
        self.pwm[number] = message
        self.outputs.pop((True, number), None)
        return message

    def output(self, change: OutputChange, synchronized: bool = False) -> OutputSet:
        """The change; its state is what a new session makes at once."""
        self.outputs[(change.analog, change.number)] = self._message(change, 0)
        return self._message(change, O_SYNCHRONIZED if synchronized else 0)

    def timed(self, change: OutputChange, device_tick: int) -> OutputAt | OutputNext:
        """The change at ``device_tick``; its state is what a new session makes at once.
        OutputNext (5 bytes) when the session's last timed change was of the same
        output and at most 65 535 ticks before, else OutputAt (12 bytes)."""
        self.outputs[(change.analog, change.number)] = self._message(change, 0)
        flags = O_ANALOG if change.analog else 0
        at = device_tick & 0xFFFFFFFF
        last, self._timed_last = self._timed_last, (flags, change.number, change.pin, at)
        if last is not None and last[:3] == (flags, change.number, change.pin):
            after = (at - last[3]) & 0xFFFFFFFF
            if after <= 0xFFFF and 0 <= change.value <= 0xFFFF:
                return OutputNext(change.value, after)
        return OutputAt(flags, change.number, change.pin, change.value, at)

    @staticmethod
    def timed_cancel() -> OutputAt:
        return OutputAt(T_CANCEL, 0, 0, 0, 0)

    @staticmethod
    def _message(change: OutputChange, flags: int) -> OutputSet:
        return OutputSet(flags | (O_ANALOG if change.analog else 0), change.number, change.pin,
                         change.value)

    @staticmethod
    def cancel() -> OutputCancel:
        return OutputCancel()

    def replay(self) -> list[Message]:
        """The messages a new session needs: pins, then PWM timers, then outputs (and
        the session has no timed change yet for an OutputNext to count from)."""
        self._timed_last = None
        return [*(Pin(pin, level) for pin, level in self.pins.items()), *self.pwm.values(),
                *self.outputs.values()]
