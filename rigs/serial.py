"""StepperDemo lines through the serial backend to a simulated device (:func:`run_serial`)
beside the same line on the simulated chip (:func:`run_sim`); the issue's acceptance
lines; the link's capacity (:func:`stream_minimal`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from fas.device.loopback import Loopback
from fas.device.relay import Faults
from rigs.demo import run
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
    """``line`` on the simulated chip: positions, pulses per channel, end reason."""
    app, reason = run(line, arch)
    backend = app.backend
    return Outcome([s.get_current_position() for s in app.steppers if s is not None],
                   [ch.pulses for ch in backend.channels], reason)


def run_serial(line: str, arch: str = "atmega328p", faults: Faults | None = None,
               **options) -> Outcome:
    """``line`` through the serial backend to a simulated device on the virtual-clock
    loopback (``faults`` on its line, ``options`` to :class:`Loopback`), settled."""
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


def stream_minimal(lb: Loopback, steppers: int, seconds: float) -> tuple[float, float, int]:
    """(commands/s, frames/s, retransmissions): the host streams the shortest legal
    commands (one step each) into the queues of ``steppers`` steppers with direction
    pins of their own, as fast as the queues take them, for ``seconds`` of virtual
    time after 0.2 s of warm-up; the link is the limit."""
    backend = lb.backend
    app = StepperDemo(backend, scripted=True)
    app.setup()
    used, dir_pins = [], set()
    for s in app.steppers:
        if s is not None and s.get_direction_pin() not in dir_pins:
            dir_pins.add(s.get_direction_pin())
            used.append(s)
    used = used[:steppers]
    for s in used:
        s.set_auto_enable(False)
    p = backend.profile
    ticks = max(p.min_cmd_ticks, used[0].get_max_speed_in_ticks())
    warm_end = backend.now() + p.ticks_per_s // 5
    t0 = f0 = e0 = None
    end = None
    sent = 0
    while end is None or backend.now() < end:
        added = 0
        for s in used:
            if not s.is_queue_full() and s.add_queue_entry(ticks, 1, True) == 0:
                added += 1
        sent += added
        if added:
            continue
        backend.app_spend(p.ticks_per_s // 10000)
        if t0 is None and backend.now() >= warm_end:
            t0, f0, e0 = backend.now(), backend.link.stats.frames_sent, sent
            end = t0 + int(seconds * p.ticks_per_s)
    dt = (backend.now() - t0) / p.ticks_per_s
    frames = backend.link.stats.frames_sent - f0
    return (sent - e0) / dt, frames / dt, backend.link.stats.retransmissions
