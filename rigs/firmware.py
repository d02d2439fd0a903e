"""The device firmware in simavr: behind the serial backend (:func:`run_firmware`) or
driven frame by frame (:class:`Host`); the toolchain check that skips a test - or, on
CI, fails it - without simavr and the AVR toolchain (:func:`need_firmware`)."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.device.simavr import SimavrDevice, Trace, toolchain_problem
from fas.serial.protocol import (
    UNSEQUENCED,
    DeviceStatus,
    FrameDecoder,
    Message,
    Status,
    StatusRequest,
    decode_messages,
    encode_frame,
)
from rigs.pins import position_by_pins
from rigs.serial import TPS, Outcome
from stepperdemo.demo.app import StepperDemo

STEP_PINS = (9, 10)


@dataclass
class FirmwareOutcome(Outcome):
    pin_pulses: list[int] = field(default_factory=list)  # rising edges on pins 9, 10
    pin_positions: list[int] = field(default_factory=list)  # counted with the dir pins
    status_pulses: list[int] = field(default_factory=list)  # the device's own count
    trace: Trace | None = None
    rx_log: list[tuple[int, bytes]] = field(default_factory=list)  # what the chip received
    busy: float = 0.0  # share of the chip's cycles not asleep
    stack_bytes: int = 0  # the deepest the chip's stack went
    rx_overruns: int = 0  # bytes the chip's UART receive path lost


def need_firmware() -> None:
    """Skip (with the reason) where the AVR toolchain or simavr is missing - except on
    CI, where the firmware tests must run: there a missing toolchain fails them."""
    import pytest  # only the tests ask: a bench script says why itself

    problem = toolchain_problem()
    if problem is None:
        return
    if os.environ.get("CI"):
        pytest.fail(f"CI: the firmware tests need the AVR toolchain and simavr: {problem}")
    pytest.skip(f"firmware tests need the AVR toolchain and simavr ({problem}); "
                "see README, 'Device firmware'")


def run_firmware(line: str, faults: Faults | None = None, baud: int = 115200,
                 **options: Any) -> FirmwareOutcome:
    """``line`` through the serial backend against the firmware in simavr (lockstep)."""
    with Loopback("atmega328p", faults=faults, device="simavr", baud=baud, **options) as lb:
        dev = lb.device
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        reason = app.run_script(line, max_ticks=600 * TPS)
        assert backend.settle(), "the device did not come to rest"
        assert backend.request_status() is not None
        steppers = [s for s in app.steppers if s is not None]
        trace = dev.trace()
        pins = dev.pins()
        info = dev.info()
        return FirmwareOutcome(
            [s.get_current_position() for s in steppers],
            [backend.statuses[i].pulses for i in sorted(backend.statuses)], reason,
            device_positions=[backend.statuses[i].position for i in sorted(backend.statuses)],
            counters=backend.device_counters(), link=backend.link_stats(),
            transcript=app.transcript.decode(),
            pin_pulses=[pins[p].rising for p in STEP_PINS[:len(steppers)]],
            pin_positions=[position_by_pins(trace.edges, STEP_PINS[i], s.get_direction_pin(),
                                            s.direction_pin_high_counts_up())
                           for i, s in enumerate(steppers)],
            status_pulses=[backend.statuses[i].pulses for i in sorted(backend.statuses)],
            trace=trace, rx_log=dev.rx_log, busy=1 - info.sleep_cycles / info.cycle,
            stack_bytes=dev.stack_used(), rx_overruns=dev.rx_overruns())


# ---------------------------------------- frame by frame (test_firmware_protocol)
MS = 16_000  # cycles
CHAR = 11 * 8 * 17  # simavr's character time at 115200 baud (11 bits of 136 cycles)


class Host:
    """Just enough of a host: frames into the chip's UART, its frames decoded (the
    firmware's side of the protocol, frame by frame, without the serial backend)."""

    def __init__(self, elf: str | Path, trace: str | Path) -> None:
        self.dev = SimavrDevice(elf=elf, trace=trace)
        self.dev.run_to_cycle(20 * MS)  # boot
        self.decoder = FrameDecoder()

    def send(self, seq: int, *msgs: Message, payload: bytes | None = None,
             ms: float = 15) -> list[tuple[int, Any]]:
        """One frame; then the chip runs for its line time and ``ms`` (its answers take
        their line time too: 40 bytes are 3.7 ms at 115200 baud); what it sent."""
        if payload is None:
            payload = b"".join(m.encode() for m in msgs)
        frame = encode_frame(seq, payload)
        self.frame_end = self.dev.cycle + len(frame) * CHAR  # its last byte in the UART
        out = self.dev.run_to_cycle(self.dev.cycle, frame)
        out += self.dev.run_to_cycle(self.dev.cycle + len(frame) * CHAR + int(ms * MS))
        return self._decode(out)

    def run(self, ms: float) -> list[tuple[int, Any]]:
        return self._decode(self.dev.run_to_cycle(self.dev.cycle + int(ms * MS)))

    def _decode(self, data: bytes) -> list[tuple[int, Any]]:
        """(acknowledgement, message) of every message; (ack, None) for a bare frame."""
        got = []
        for seq, payload in self.decoder.feed(data):
            got += [(seq, m) for m in decode_messages(payload)] or [(seq, None)]
        return got

    def status(self) -> tuple[DeviceStatus, dict[int, Status]]:
        got = self.send(UNSEQUENCED, StatusRequest(), ms=10)
        device = [m for _, m in got if isinstance(m, DeviceStatus)][-1]
        return device, {m.stepper: m for _, m in got if isinstance(m, Status)}

    def counters(self) -> dict[str, int]:
        return self.status()[0].counters()

    def pulses(self, pin: int = 9) -> int:
        return self.dev.pins()[pin].rising
