"""The serial backend: the library on the host, its queue commands on a device.

* :mod:`.protocol` - frames, CRC-16, messages (docs/serial-protocol.md);
* :mod:`.link` - the host end: acknowledgement, retransmission;
* :mod:`.backend`, :mod:`.channel` - :class:`SerialBackend`, the library's backend;
* :mod:`.device` - a device on the simulated machine (``stepperdemo device``);
* :mod:`.relay` - a fault-injecting relay (``stepperdemo relay``);
* :mod:`.clock`, :mod:`.stream` - wall or virtual time; ports and ptys;
* :mod:`.loopback` - host, device (and relay) on one virtual clock over real ptys.
"""

from .backend import SerialBackend, SerialError
from .clock import RealClock, VirtualClock
from .device import Device
from .relay import Faults, Relay
from .stream import LinkClosed, Pty, open_serial

__all__ = [
           "Device",
           "Faults",
           "LinkClosed",
           "Pty",
           "RealClock",
           "Relay",
           "SerialBackend",
           "SerialError",
           "VirtualClock",
           "open_serial",
]
