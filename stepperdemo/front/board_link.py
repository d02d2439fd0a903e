"""The line to a board running StepperDemo: a serial port, or a simulated board.

A :class:`BoardLink` moves bytes and tells the time; the board console
(:mod:`.board_session`) does the rest.  Two kinds:

* :class:`SerialBoardLink` - a real serial port (or a pty) through pyserial, on the
  wall clock.  :meth:`~SerialBoardLink.reset` pulses DTR, which restarts an Arduino
  (its auto-reset); where the port has no modem lines (a pty), it closes the port and
  opens it again, which drops and raises DTR on a real port and is what
  ``stepperdemo device --pty --console`` takes as the reset.
* :class:`SimBoardLink` - :class:`~stepperdemo.demo.serial_board.SimulatedBoard` on
  virtual time: the same firmware and line, deterministic and as fast as it computes
  (the twin check of ``stepperdemo run --board``, and tests).
"""

from __future__ import annotations

import math
import select
import time
from abc import ABC, abstractmethod

from fas.arch import Profile, get_profile
from fas.serial.stream import LinkClosed, SerialStream, open_serial

from ..demo.serial_board import SimulatedBoard

#: DTR held low this long to reset an Arduino (as avrdude does), and the time the
#: port stays closed when a pty has no DTR
DTR_PULSE_S = 0.25


class BoardLink(ABC):
    """Bytes to and from a board, and the time on the link's clock (seconds)."""

    name: str = ""

    @abstractmethod
    def now(self) -> float:
        """Seconds on the link's clock (monotonic)."""

    @abstractmethod
    def write(self, data: bytes) -> None:
        """Send bytes (raises :class:`LinkClosed` when the board is gone)."""

    @abstractmethod
    def read(self, timeout_s: float) -> bytes:
        """What arrived, waiting up to ``timeout_s`` for something (b"": nothing)."""

    @abstractmethod
    def reset(self) -> None:
        """Restart the board (DTR)."""

    @abstractmethod
    def reopen(self, port: str | None = None) -> None:
        """Open the line again (after the board was lost), optionally another port."""

    @abstractmethod
    def close(self) -> None:
        """End the session."""


class SerialBoardLink(BoardLink):
    """A serial port or pty (see the module text)."""

    def __init__(self, port: str, baud: int = 115200) -> None:
        self.port = port
        self.baud = baud
        self.name = port
        self._t0 = time.monotonic()
        self.stream: SerialStream | None = None
        self.dtr_resets = 0
        self.reopen_resets = 0
        self._open()

    def _open(self) -> None:
        self.stream = open_serial(self.port, self.baud)

    def now(self) -> float:
        return time.monotonic() - self._t0

    def _stream(self) -> SerialStream:
        if self.stream is None:
            raise LinkClosed(f"{self.port}: not open")
        return self.stream

    def write(self, data: bytes) -> None:
        self._stream().write(data)

    def read(self, timeout_s: float) -> bytes:
        stream = self._stream()
        data = stream.read_available()
        if data or timeout_s <= 0:
            return data
        try:
            select.select([stream.fileno()], [], [], timeout_s)
        except (OSError, ValueError) as exc:
            raise LinkClosed(f"{self.port}: {exc}") from exc
        return stream.read_available()

    def reset(self) -> None:
        import serial

        port = self._stream().port
        try:
            port.dtr = False
            time.sleep(DTR_PULSE_S)
            port.dtr = True
            self.dtr_resets += 1
        except (OSError, serial.SerialException):  # no modem lines (a pty)
            self.close()
            time.sleep(DTR_PULSE_S)
            self._open()
            self.reopen_resets += 1

    def reopen(self, port: str | None = None) -> None:
        self.close()
        if port:
            self.port = self.name = port
        self._open()

    def close(self) -> None:
        if self.stream is not None:
            self.stream.close()
            self.stream = None


class SimBoardLink(BoardLink):
    """The simulated board on virtual time (see the module text)."""

    def __init__(self, profile: Profile | str | None = None) -> None:
        self.profile = get_profile(profile)
        self.board = SimulatedBoard(self.profile)
        self.name = f"simulated {self.profile.name}"
        self._tps = self.profile.ticks_per_s
        self._base_s = 0.0  # session time at the board's last reset

    def now(self) -> float:
        return self._base_s + self.board.now() / self._tps

    def write(self, data: bytes) -> None:
        self.board.receive(data)

    def read(self, timeout_s: float) -> bytes:
        board = self.board
        deadline = board.now() + max(0, math.ceil(timeout_s * self._tps))
        while True:
            out = board.take_output()
            if out or board.now() >= deadline:
                return out
            wake = board.next_wake_tick()
            step = deadline if wake is None else min(max(wake, board.now() + 1), deadline)
            board.run_until(step)

    def reset(self) -> None:
        self._base_s = self.now()
        self.board.reset()

    def reopen(self, port: str | None = None) -> None:
        self.reset()  # opening the port restarts it, as it does an Arduino Uno

    def close(self) -> None:
        """Nothing to release."""
