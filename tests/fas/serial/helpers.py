"""Run StepperDemo lines on the simulated backend and through the serial backend."""

from __future__ import annotations

from dataclasses import dataclass, field

from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.sim import SimBackend
from stepperdemo.demo.app import StepperDemo
from stepperdemo.program import EndReason

TPS = 16_000_000

# scenario-like command lines of the issue (acceptance)
LINES = [
    "M1 A1000 V100 R3200 W",
    "M1 A2000 V150 R6000 W",
    "M1 A15000 V40 P-5000 W P2500 W",
    "M1 A2000 V400 J100 R3000 W",
    "M1 A2000 V400 j30 R3000 W",
    "M1 A6000 V90 R5000 M2 A5000 V110 R-4000 W M1 W",
    "M1 h2500000 A4000 R2500 W",
    "M1 A700 V900 R-500 W R500 W",
    "M1 A2000 V200 + + + - W",
    "M1 A3000 V250 R2000 W @500 P0 W",
    "M1 A1000000 V40 R20000 W",
]

NOISY = Faults(corrupt=0.01, drop=0.005, dup=0.005, latency_ms=1.0, seed=1)


@dataclass
class Outcome:
    positions: list[int]
    pulses: list[int]
    reason: EndReason
    device_positions: list[int] = field(default_factory=list)
    counters: dict = field(default_factory=dict)
    link: dict = field(default_factory=dict)
    transcript: str = ""


def run_sim(line: str, arch: str = "atmega328p") -> Outcome:
    backend = SimBackend(arch)
    app = StepperDemo(backend, scripted=True)
    reason = app.run_script(line, max_ticks=600 * TPS)
    return Outcome([s.get_current_position() for s in app.steppers if s is not None],
                   [ch.pulses for ch in backend.channels], reason)


def run_serial(line: str, arch: str = "atmega328p", faults: Faults | None = None,
               **options) -> Outcome:
    with Loopback(arch, faults=faults, **options) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        reason = app.run_script(line, max_ticks=600 * TPS)
        assert backend.settle(), "the device did not come to rest"
        assert backend.request_status() is not None
        dev = lb.device
        idx = sorted(dev.queues)
        return Outcome([s.get_current_position() for s in app.steppers if s is not None],
                       [dev.pulses(i) for i in idx], reason,
                       device_positions=[dev.position(i) for i in idx],
                       counters=backend.device_counters(), link=backend.link_stats(),
                       transcript=app.transcript.decode())


# ------------------------------------------------ the firmware in simavr (issue 11)
STEP_PINS = (9, 10)


@dataclass
class FirmwareOutcome(Outcome):
    pin_pulses: list[int] = field(default_factory=list)  # rising edges on pins 9, 10
    pin_positions: list[int] = field(default_factory=list)  # counted with the dir pins
    status_pulses: list[int] = field(default_factory=list)  # the device's own count
    trace: object = None  # fas.device.simavr.Trace
    rx_log: list = field(default_factory=list)  # (cycle, bytes) the chip received
    busy: float = 0.0  # share of the chip's cycles not asleep
    stack_bytes: int = 0  # the deepest the chip's stack went
    rx_overruns: int = 0  # bytes the chip's UART receive path lost


def need_firmware() -> None:
    """Skip (with the reason) where the AVR toolchain or simavr is missing - except on
    CI, where the firmware tests must run: there a missing toolchain fails them."""
    import os

    import pytest

    from fas.device.simavr import toolchain_problem

    problem = toolchain_problem()
    if problem is None:
        return
    if os.environ.get("CI"):
        pytest.fail(f"CI: the firmware tests need the AVR toolchain and simavr: {problem}")
    pytest.skip(f"firmware tests need the AVR toolchain and simavr ({problem}); "
                "see README, 'Device firmware'")


def pin_position(trace, step_pin: int, dir_pin: int, high_counts_up: bool = True) -> int:
    """Steps counted from the pins: up while the direction pin is at its up level."""
    import bisect

    from fas.codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED

    rising = trace.rising(step_pin)
    if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
        return len(rising)
    dtimes, dlevels = trace.edges(dir_pin)
    pos = 0
    for t in rising:
        i = bisect.bisect_right(dtimes, t) - 1
        level = dlevels[i] if i >= 0 else 0
        pos += 1 if (level == 1) == high_counts_up else -1
    return pos


def run_firmware(line: str, faults: Faults | None = None, baud: int = 115200,
                 **options) -> FirmwareOutcome:
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
            pin_positions=[pin_position(trace, STEP_PINS[i], s.get_direction_pin(),
                                        s.direction_pin_high_counts_up())
                           for i, s in enumerate(steppers)],
            status_pulses=[backend.statuses[i].pulses for i in sorted(backend.statuses)],
            trace=trace, rx_log=dev.rx_log, busy=1 - info.sleep_cycles / info.cycle,
            stack_bytes=dev.stack_used(), rx_overruns=dev.rx_overruns())
