"""Inputs of the device's board (``firmware/inputs.c``, docs/serial-protocol.md section 18).

Watched digital pins are reported as soon as they change, analog ones (0..1023) when
their sample is due and shows a new value, each again with the slow refresh.  The
world outside the simulated board - switches and pots - is :meth:`DeviceInputs.set_input`
(the host may turn it with SetInput: Ident feature F_SIM_INPUTS).
"""

from __future__ import annotations

from ..serial.protocol import (
    F_SIM_INPUTS,
    S_ANALOG,
    W_ANALOG,
    W_OFF,
    W_PULLUP,
    Input,
    Message,
    SetInput,
    WatchInput,
)
from ..sim.machine import PRIO_PLAIN
from .board import Board
from .limits import DeviceLimits
from .queues import Handler

DEFAULT_ANALOG_MS = 50  # WatchInput period 0: sample analog inputs every 50 ms
ANALOG_DEFAULT = 512  # an analog input nobody has set reads mid-scale (a centred pot)


class DeviceInputs:
    """Watched inputs and the simulated world on the board's pins."""

    def __init__(self, board: Board, limits: DeviceLimits) -> None:
        self.board = board
        self.limits = limits  # a switch that changes may be a limit switch
        # watched inputs: pin -> [mode, sample period (ticks), next sample, value reported]
        self.watches: dict[int, list[int]] = {}
        self.analog: dict[int, int] = {}  # the analog inputs' values (set_input)

    def handlers(self) -> dict[type[Message], Handler]:
        return {WatchInput: self.watch, SetInput: self.set_input_message}

    def reset(self) -> None:
        """A new session: the new host asks for the inputs it wants."""
        self.watches.clear()

    def watch(self, m: WatchInput) -> None:
        board = self.board
        if m.mode == W_OFF:
            self.watches.pop(m.pin, None)
            return
        if m.mode > W_ANALOG:
            board.reject()
            return
        machine = board.machine
        pins = machine.pins
        if m.mode == W_PULLUP and m.pin not in pins.first_write:
            pins.set(m.pin, 1, machine.now)  # the pull-up holds an open input high
        period = board.ms_ticks(m.period_ms or DEFAULT_ANALOG_MS)
        value = self.value(m.pin, m.mode)
        self.watches[m.pin] = [m.mode, period, machine.now + period, value]
        board.send(Input(m.pin, value, machine.now & 0xFFFFFFFF))

    def value(self, pin: int, mode: int) -> int:
        """What input ``pin`` reads in ``mode``."""
        if mode == W_ANALOG:
            return self.analog.get(pin, ANALOG_DEFAULT)
        return self.board.machine.pins.get(pin)

    def sample(self) -> None:
        """Digital inputs are reported as soon as they change, analog ones when their
        sample is due and shows a new value."""
        board = self.board
        now = board.machine.now
        for pin, w in self.watches.items():
            mode = w[0]
            if mode == W_ANALOG:
                if now < w[2]:
                    continue
                w[2] += w[1] * ((now - w[2]) // w[1] + 1)
            value = self.value(pin, mode)
            if value != w[3]:
                w[3] = value
                board.send(Input(pin, value, now & 0xFFFFFFFF))

    def refresh(self) -> None:
        """The slow refresh: every watched input again (a lost report heals here)."""
        board = self.board
        now = board.machine.now
        for pin, w in self.watches.items():
            board.send(Input(pin, w[3], now & 0xFFFFFFFF))

    def wake_ticks(self) -> list[int]:
        """The samples due of analog inputs that changed (the loop must wake for them)."""
        return [w[2] for pin, w in self.watches.items()
                if w[0] == W_ANALOG and self.value(pin, w[0]) != w[3]]

    def set_input(self, pin: int, value: int, analog: bool | None = None) -> None:
        """The world outside the board: a switch pulls ``pin`` to ``value`` (0/1) or a
        pot turns analog input ``pin`` to ``value`` (0..1023).  ``analog`` None: as the
        host watches the pin (digital if it does not)."""
        board = self.board
        w = self.watches.get(pin)
        if analog is None:
            analog = (w is not None and w[0] == W_ANALOG) or (w is None and pin in self.analog)
        if analog:
            self.analog[pin] = min(max(int(value), 0), 1023)
        else:
            board.machine.pins.set(pin, 1 if value else 0, board.machine.now)
        if board.session_open and w is not None:
            self.sample()
        if not analog:
            self.limits.pin_changed(pin, 1 if value else 0)

    def set_input_message(self, m: SetInput) -> None:
        """SetInput: the host turns a pot or presses a switch of this simulated board."""
        if not self.board.features & F_SIM_INPUTS:
            self.board.reject()
            return
        self.set_input(m.pin, m.value, analog=bool(m.flags & S_ANALOG))

    def schedule_input(self, tick: int, pin: int, value: int,
                       analog: bool | None = None) -> None:
        """``set_input`` at device tick ``tick`` (a switch that closes at a known time)."""
        self.board.machine.schedule(tick, lambda: self.set_input(pin, value, analog),
                                    PRIO_PLAIN)
