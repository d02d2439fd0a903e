"""The board under the Python device, and what every part of its firmware shares.

The chip is the simulated machine of :mod:`fas.sim` (its pins, timers and PWM units);
no engine runs on it - the host plans, the device's parts execute.  What the parts
share is what the C firmware keeps in globals (``firmware/device.h``): the counters of
DeviceStatus, the session's motion lock (a watchdog trip or an emergency stop), and
the messages waiting to be sent.
"""

from __future__ import annotations

from ..arch import Profile
from ..serial.protocol import DEVICE_COUNTERS, Message
from ..sim.backend import SimBackend
from ..sim.machine import Machine
from ..sim.pins import EdgeRecorder

FRAME_BREAK = b""  # in the outbox: start a new frame (small frames survive noise)


class Board:
    """The simulated chip and the device state its parts share (see module text)."""

    def __init__(self, profile: Profile, record: bool = False) -> None:
        self.profile = profile
        self.tps = profile.ticks_per_s
        self.sim = SimBackend(profile)  # the machine and its pins; no engine runs here
        self.machine: Machine = self.sim.machine
        self.recorder: EdgeRecorder | None = None
        if record:
            self.recorder = EdgeRecorder()
            self.machine.pins.sinks.append(self.recorder)
        self.counters: dict[str, int] = dict.fromkeys(DEVICE_COUNTERS, 0)
        self.out: list[bytes] = []  # encoded messages (and FRAME_BREAKs) to send
        self.session_open = False
        self.watchdog_tripped = False  # the host was silent: motion stopped
        self.estopped = False  # an emergency stop: motion stopped
        self.features = 0  # Ident's optional message families (set by the device)

    @property
    def now(self) -> int:
        return self.machine.now

    @property
    def locked(self) -> bool:
        """No entry, start or synchronized output is taken until the next Hello."""
        return self.watchdog_tripped or self.estopped

    def ms_ticks(self, ms: int) -> int:
        return ms * self.tps // 1000

    def send(self, message: Message) -> None:
        """Queue ``message`` for the next frame."""
        self.out.append(message.encode())

    def frame_break(self) -> None:
        """What follows goes in a frame of its own."""
        self.out.append(FRAME_BREAK)

    def reject(self) -> None:
        """A message the device cannot act on (counted as ``rejected``)."""
        self.counters["rejected"] += 1

    def reset_counters(self) -> None:
        counters = self.counters
        for name in counters:
            counters[name] = 0
