"""A simulated board running StepperDemo, seen from its serial port.

What a host sees of a board flashed with the original StepperDemo sketch: the
interactive firmware (:class:`~stepperdemo.demo.app.StepperDemo` with
``scripted=False``) on the simulated chip, with its serial line:

* characters sent to the board arrive one per character time of the line
  (``SimTiming.uart_byte_ticks``) in the serial driver's receive buffer
  (``SimTiming.uart_rx_buffer`` characters); what arrives while the buffer is full
  is lost, as on the chip (StepperDemo takes one character per loop pass, and none
  while a ``W`` spins);
* everything the firmware prints comes out byte for byte (CR LF where it prints
  ``println``, a bare LF after its message-table texts), each print at the tick it
  was handed to the serial driver (a long print, which blocks the firmware until
  the driver has taken it, comes out when its last character was taken);
* :meth:`reset` is the reset pin: the chip starts again from power-on (banner, usage,
  stepper table), as an Arduino does when the host toggles DTR.

Time is the simulated chip's tick counter; a driver decides how it relates to the
wall clock (``stepperdemo device --pty --console``) or runs it on virtual time (the
twin check of ``stepperdemo run --board``).
"""

from __future__ import annotations

from collections import deque

from fas.arch import Profile, get_profile
from fas.sim import SimBackend
from fas.sim.timing import sim_timing

from .app import StepperDemo


class SimulatedBoard:
    """StepperDemo on a simulated chip behind its serial line (see the module text)."""

    def __init__(self, profile: Profile | str | None = None) -> None:
        self.profile = get_profile(profile)
        self.resets = 0
        self.rx_bytes = 0
        self.rx_dropped = 0
        self.tx_bytes = 0
        self._out: deque[tuple[int, bytes]] = deque()  # (tick handed over, bytes)
        self._arrivals: deque[tuple[int, int]] = deque()  # (tick, byte) on the line
        self._line_free = 0  # tick at which the line can carry the next character
        self.backend: SimBackend
        self.app: StepperDemo
        self._power_on()

    def _power_on(self) -> None:
        self.backend = SimBackend(self.profile)
        self.app = StepperDemo(self.backend, scripted=False, output=self._collect)
        self._arrivals.clear()
        self._line_free = 0

    # ------------------------------------------------------------ the line
    def _collect(self, data: bytes) -> None:
        self._out.append((self.backend.now(), data))
        self.tx_bytes += len(data)

    def reset(self) -> None:
        """The reset pin: everything starts again (the clock too, from tick 0)."""
        self.resets += 1
        self._out.clear()
        self._power_on()

    def now(self) -> int:
        return self.backend.now()

    def receive(self, data: bytes) -> None:
        """Characters the host sent, starting on the line now."""
        byte_ticks = sim_timing(self.profile).uart_byte_ticks
        t = max(self.backend.now(), self._line_free)
        for byte in data:
            t += byte_ticks  # a character is there once its stop bit has arrived
            self._arrivals.append((t, byte))
        self._line_free = t
        self.rx_bytes += len(data)

    def take_output(self, upto_tick: int | None = None) -> bytes:
        """What the board printed since the last call, up to ``upto_tick`` (the
        firmware may have run ahead of the wall clock in a long print or ``T``)."""
        out = self._out
        parts = []
        while out and (upto_tick is None or out[0][0] <= upto_tick):
            parts.append(out.popleft()[1])
        return b"".join(parts)

    # -------------------------------------------------------------- running
    def _deliver(self, byte: int) -> None:
        gcode = self.app.gcode
        if gcode is not None and not gcode.leaving:  # the g mode: Grbl's receive path
            gcode.receive(bytes((byte,)))
            return
        rx = self.app.rx
        if len(rx) < sim_timing(self.profile).uart_rx_buffer:
            rx.append(byte)
        else:
            self.rx_dropped += 1

    def run_until(self, tick: int) -> None:
        """Run the firmware up to ``tick``, taking the characters due on the way."""
        arrivals = self._arrivals
        while arrivals and arrivals[0][0] <= tick:
            at, byte = arrivals.popleft()
            self.app.run_until(at)
            self._deliver(byte)
        self.app.run_until(tick)

    def next_wake_tick(self) -> int | None:
        """When the board next has something to do (None: only input wakes it)."""
        wake = self.app.next_wake_tick()
        for due in (self._arrivals[0][0] if self._arrivals else None,
                    self._out[0][0] if self._out else None):
            if due is not None:
                wake = due if wake is None else min(wake, due)
        return wake

    def positions(self) -> list[int | None]:
        return [None if s is None else s.get_current_position() for s in self.app.steppers]
