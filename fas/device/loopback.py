"""Host, simulated device and optionally a relay on one virtual clock, over real ptys.

The device serves a new pty; the host opens it (or the relay's pty) with pyserial,
exactly as ``stepperdemo --port`` does.  A symbolic link in a private folder names
the device's current pty, so a device that is unplugged and plugged in again (a new
pty) is found under the same name by :meth:`SerialBackend.reconnect`.  Every byte is
counted on its :class:`~fas.serial.clock.Wire`, so the run is deterministic.
"""

from __future__ import annotations

import os
import tempfile
from typing import TYPE_CHECKING, Any

from ..serial.backend import SerialBackend
from ..serial.clock import VirtualClock, Wire
from ..serial.stream import ByteStream, Pty, open_serial, set_link
from .device import Device
from .relay import Faults, Relay

if TYPE_CHECKING:  # pragma: no cover
    from typing_extensions import Self  # typing.Self is Python 3.11+

    from .simavr import SimavrDevice


class Loopback:
    """``device="python"``: the simulated device (:class:`Device`); ``"simavr"``: the
    firmware in simavr (:class:`~fas.device.simavr.SimavrDevice`, ATmega328P only;
    ``firmware`` names its ELF, else it is built for the backend's baud rate)."""

    def __init__(self, arch: str = "atmega328p", *, faults: Faults | None = None,
                 watchdog_ms: int = 500, record: bool = False, connect: bool = True,
                 device: str = "python", firmware: str | None = None,
                 trace: str | None = None, device_options: dict[str, Any] | None = None,
                 **backend_options: Any) -> None:
        self.clock = VirtualClock()
        self._dir = tempfile.mkdtemp(prefix="fas-loopback-")
        self.port_path = os.path.join(self._dir, "device")
        self.faults = faults
        self.relay: Relay | None = None
        self._relay_pty: Pty | None = None
        self._device_pty = Pty("device")
        self.device: Device | SimavrDevice
        if device == "simavr":
            from .simavr import SimavrDevice

            if arch != "atmega328p":
                raise ValueError("the firmware is for the atmega328p")
            self.device = SimavrDevice(None, self.clock, elf=firmware, trace=trace,
                                       baud=backend_options.get("baud", 115200))
        elif device == "python":
            self.device = Device(None, arch, self.clock, watchdog_ms=watchdog_ms,
                                 record=record, **(device_options or {}))
        else:
            raise ValueError(f"unknown device kind {device!r}")
        self.clock.add_peer(self.device)
        self._plug_device()
        self.backend: SerialBackend | None = None
        if connect:
            self.backend = self.open_backend(**backend_options)

    # ------------------------------------------------------------- wiring
    def _plug_device(self) -> None:
        dev_stream = self._device_pty.stream
        dev_stream.rx_wire = Wire(self.device, "to device")
        dev_stream.tx_wire = Wire(None, "from device")
        self.device.attach(dev_stream)
        if self.faults is None:
            set_link(self.port_path, self._device_pty.path)
            return
        self._relay_pty = Pty("relay")
        relay_host = self._relay_pty.stream
        relay_dev = open_serial(self._device_pty.path)
        relay_host.rx_wire = Wire(None, "host to relay")
        relay_host.tx_wire = Wire(None, "relay to host")
        relay_dev.tx_wire = dev_stream.rx_wire
        relay_dev.rx_wire = dev_stream.tx_wire
        self.relay = Relay(relay_host, relay_dev, self.faults, self.clock)
        relay_host.rx_wire.reader = self.relay
        relay_dev.rx_wire.reader = self.relay
        self.relay.in_wires = [relay_host.rx_wire, relay_dev.rx_wire]
        self.clock.add_peer(self.relay)
        set_link(self.port_path, self._relay_pty.path)

    def _host_wires(self) -> tuple[Wire | None, Wire | None]:
        if self.relay is not None:
            return self.relay.host.rx_wire, self.relay.host.tx_wire
        s = self._device_pty.stream
        return s.rx_wire, s.tx_wire

    def open_stream(self, path: str, baud: int = 115200) -> ByteStream:
        """The host's opener: pyserial on the pty, with the wire counters attached."""
        stream = open_serial(path, baud)
        stream.tx_wire, stream.rx_wire = self._host_wires()
        return stream

    def open_backend(self, **options: Any) -> SerialBackend:
        options.setdefault("watchdog_ms", self.device.default_watchdog_ms)
        return SerialBackend(self.port_path, clock=self.clock, opener=self.open_stream,
                             **options)

    # ------------------------------------------------------ plugging
    def unplug(self) -> None:
        """Pull the device's cable: its pty disappears (the machine keeps its state)."""
        if self.relay is not None:
            raise RuntimeError("unplug is not modelled behind a relay")
        for w in (self._device_pty.stream.rx_wire, self._device_pty.stream.tx_wire):
            if w is not None:
                w.drain()
        self.device.unplug()

    def replug(self) -> None:
        """Plug the same device in again: a new pty under the same name."""
        self._device_pty = Pty("device")
        self._plug_device()

    def close(self) -> None:
        if self.backend is not None:
            self.backend.close()
        self.device.unplug()
        if hasattr(self.device, "close"):
            self.device.close()
        if self.relay is not None:
            self.relay.device.close()
        if self._relay_pty is not None:
            self._relay_pty.close()
        try:
            os.unlink(self.port_path)
            os.rmdir(self._dir)
        except OSError:
            pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
