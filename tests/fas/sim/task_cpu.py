"""A run of the model with the ramp tasks' CPU summed (build e unless told): shared by the
tests of the task's cost figures (test_task_cost.py, test_ramp_cost.py,
test_coast_tails_d.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from fas.sim import SimBackend

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import e_fidelity  # noqa: E402

_TASK = SimBackend._task  # noqa: SLF001
RUN = "M1 A30000 V45 f w300 S W"  # a ramp up, a coast, a stop (a ramp down)


def run_task_cpu(monkeypatch: pytest.MonkeyPatch, run: str = RUN,
                 build: str = "e") -> tuple[list[float], int]:
    """The step times (us) and the ramp tasks' CPU (ticks) summed over the run."""
    spent = [0]

    def counted(self: SimBackend, index: int) -> None:
        before = self.machine.stolen_ticks
        _TASK(self, index)
        spent[0] += self.machine.stolen_ticks - before

    monkeypatch.setattr(SimBackend, "_task", counted)
    backend = e_fidelity.run_model(run, "atmega328p", build)
    return e_fidelity.step_times_us(backend, 9), spent[0]
