"""Run StepperDemo lines on virtual time for the console tests."""

from __future__ import annotations

from fas.sim import SimBackend
from stepperdemo.demo.app import StepperDemo
from stepperdemo.program import EndReason


def run(line: str, arch: str = "atmega328p", *, firmware_end: bool = False,
        max_s: float = 600, record: bool = False, test_mode_wait: bool = False):
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


__all__ = ["run", "text", "after_setup", "lines", "EndReason"]
