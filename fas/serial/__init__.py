"""The serial backend, host side: the library on this computer, its queue commands on
a device behind a serial line (docs/serial-protocol.md).

* :mod:`.protocol` - frames, CRC-16, messages: the one definition of the wire format;
* :mod:`.link` - the host end: acknowledgement, retransmission;
* :mod:`.backend`, :mod:`.channel` - :class:`SerialBackend`, the library's backend;
* :mod:`.clock`, :mod:`.stream` - wall or virtual time; ports and ptys.

Nothing here imports :mod:`fas.sim`: the device side - the Python device, the
firmware in simavr, the fault-injecting relay, host and device on one virtual clock -
is :mod:`fas.device`.
"""

from .backend import SerialBackend, SerialError
from .clock import RealClock, VirtualClock
from .stream import LinkClosed, Pty, open_serial

__all__ = [
           "LinkClosed",
           "Pty",
           "RealClock",
           "SerialBackend",
           "SerialError",
           "VirtualClock",
           "open_serial",
]
