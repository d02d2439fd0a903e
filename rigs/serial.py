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
