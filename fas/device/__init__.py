"""The device side of the serial protocol (docs/serial-protocol.md), on this computer.

* :mod:`.device` - :class:`Device`, the Python device: the firmware's work on the
  simulated machine, split as ``firmware/`` is - :mod:`.session` (session and link
  layer), :mod:`.queues` (the queues and their messages), :mod:`.stepgen` (the step
  generator), :mod:`.limits`, :mod:`.inputs`, :mod:`.outputs`, on :mod:`.board`;
* :mod:`.simavr` - the C firmware (``firmware/``) built and run in simavr;
* :mod:`.proto_check` - does the firmware's ``proto.h`` say what :mod:`fas.serial.protocol`
  says?
* :mod:`.relay` - a fault-injecting relay (``stepperdemo relay``);
* :mod:`.loopback` - host, device (and relay) on one virtual clock over real ptys.

The host side (:mod:`fas.serial`) never imports this package; this one uses the host's
protocol definition, clocks and streams, and the simulated chip of :mod:`fas.sim`.
"""

from .device import Device
from .relay import Faults, Relay

__all__ = ["Device", "Faults", "Relay"]
