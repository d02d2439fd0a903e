"""StepperDemo on virtual time: a scripted line on the simulated chip and its transcript
(:func:`run`), the queue commands a line makes (:func:`command_stamps`), and steppers
set going on any backend (:func:`moving`, :func:`two_at_25khz`)."""

from __future__ import annotations

from fas.arch import Profile
from fas.backend import Backend
from fas.sim import SimBackend
from stepperdemo.demo.app import StepperDemo
from stepperdemo.program import EndReason

CRUISE_US = 40  # 25 kHz
CRUISE_TICKS = CRUISE_US * 16  # on a 16 MHz chip


def run(line: str, arch: str = "atmega328p", *, firmware_end: bool = False,
        max_s: float = 600, record: bool = False, test_mode_wait: bool = False):
    """(app, end reason) of ``line`` scripted on ``arch``'s simulated chip."""
    backend = SimBackend(arch, record=record)
    app = StepperDemo(backend, scripted=True, test_mode_wait=test_mode_wait)
    reason = app.run_script(line, firmware_end=firmware_end,
                            max_ticks=int(max_s * backend.profile.ticks_per_s))
    return app, reason


def text(app) -> str:
    return app.transcript.decode("utf-8")


def after_setup(app) -> str:
    """The transcript after the start banner, usage and first stepper table."""
    t = text(app)
    first_table_end = t.index("   M2: ") if "   M2: " in t else 0
    return t[t.index("\n", first_table_end) + 1:]


def lines(app) -> list[str]:
    return [ln.rstrip("\r") for ln in text(app).split("\n")]


def command_stamps(line: str, arch: str = "atmega328p") -> tuple[list[int], Profile]:
    """The tick of every queue command the ramp generator writes while ``line`` runs on
    the simulated chip (what a serial link would have to carry), and the profile."""
    backend = SimBackend(arch)
    stamps: list[int] = []
    allocate = backend.allocate_channel

    def counting(queue):
        ch = allocate(queue)
        plain = ch.entry_added

        def entry_added():
            stamps.append(backend.now())
            plain()

        ch.entry_added = entry_added
        return ch

    backend.allocate_channel = counting
    StepperDemo(backend, scripted=True).run_script(line)
    return stamps, backend.profile


def moving(backend: Backend, *, steps: int = 1_000_000, speed_us: int = CRUISE_US,
           accel: int = 100_000, after_ms: int = 500):
    """(app, M1): StepperDemo's first stepper sent ``steps`` at ``speed_us`` and
    ``accel``, ``after_ms`` into the move; by default cruising at 25 kHz."""
    app = StepperDemo(backend, scripted=True)
    app.setup()
    s = app.steppers[0]
    s.set_speed_in_us(speed_us)
    s.set_acceleration(accel)
    s.move(steps)
    backend.app_spend(after_ms * backend.profile.ticks_per_ms)
    return app, s


def decel_start(rising: list[int], t_call: int, cruise_ticks: int = CRUISE_TICKS) -> int | None:
    """Ticks from ``t_call`` to the first step of a deceleration from the cruise (the
    first period more than 1 % longer), None if the steps never slow down."""
    after = [t for t in rising if t >= t_call]
    for a, b in zip(after, after[1:], strict=False):
        if b - a > cruise_ticks * 101 // 100:
            return a - t_call
    return None


def two_at_25khz(backend: Backend) -> tuple[StepperDemo, list[int]]:
    """(app, targets): M1 and M2 sent 20 000 steps apart at 25 kHz (the issue's
    two-stepper line) - started, not waited for."""
    app = StepperDemo(backend, scripted=True)
    app.setup()
    moves = (20_000, -20_000)
    for s, d in zip(app.steppers, moves, strict=True):
        s.set_speed_in_us(CRUISE_US)
        s.set_acceleration(100_000)
        s.move(d)
    return app, list(moves)


__all__ = ["CRUISE_TICKS", "CRUISE_US", "EndReason", "after_setup", "command_stamps",
           "decel_start", "moving", "lines", "run", "text", "two_at_25khz"]
