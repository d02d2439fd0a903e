"""The ramp task's cost per kind of task (build e, off by default; docs/timing-model.md,
"nineteenth pass" and "twentieth pass"): idle runs charged (``idle_task_ticks``) and a
decelerating command's own figure (``fill_dec_cmd_ticks``)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas import Engine
from fas.sim import SimBackend
from fas.sim import timing as sim_timing_module

from .task_cpu import run_task_cpu


def _with(monkeypatch: pytest.MonkeyPatch, **fields: object) -> None:
    table = {k: replace(v, **fields) for k, v in sim_timing_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)


def _idle_engine(seconds: int) -> SimBackend:
    backend = SimBackend("atmega328p", build="e")
    engine = Engine(backend)
    engine.init()
    engine.stepper_connect_to_pin(9)  # a stepper that never moves
    backend.run_for(seconds * backend.profile.ticks_per_s)
    return backend


def test_idle_runs_of_the_ramp_task_are_skipped_unless_charged(
        monkeypatch: pytest.MonkeyPatch) -> None:
    off = _idle_engine(1)
    assert off.task_runs <= 1  # the default: runs that do nothing are skipped
    _with(monkeypatch, idle_task_ticks=429)  # the replica's idle task (ATmega328P)
    on = _idle_engine(1)
    period = on.task_period_ticks
    slots = on.profile.ticks_per_s // period
    assert slots - 1 <= on.task_runs <= slots + 1  # every period runs
    entry = sim_timing_module.AVR_E_TIMING.fill_entry_ticks
    assert on.machine.stolen_ticks - off.machine.stolen_ticks == \
        429 * on.task_runs - (off.machine.stolen_ticks and off.task_runs * entry)


_run = run_task_cpu


def test_a_decelerating_command_can_cost_its_own_figure(
        monkeypatch: pytest.MonkeyPatch) -> None:
    steps, stolen = _run(monkeypatch)
    cmd = sim_timing_module.AVR_E_TIMING.fill_cmd_ticks
    _with(monkeypatch, fill_dec_cmd_ticks=cmd)  # the same figure: nothing moves
    assert _run(monkeypatch) == (steps, stolen)
    _with(monkeypatch, fill_dec_cmd_ticks=cmd + 1000)
    steps_dec, stolen_dec = _run(monkeypatch)
    assert steps_dec == steps  # no `e`: the task's CPU moves no step
    extra = stolen_dec - stolen
    assert extra > 0 and extra % 1000 == 0  # the ramp down's commands, 1 000 each
    _with(monkeypatch, fill_dec_cmd_ticks=0, fill_cmd_ticks=cmd + 1000)
    every = _run(monkeypatch)[1] - stolen  # every command that is not a coast one
    assert every > extra  # the ramp up's are not charged as decelerating


def test_a_queue_starts_tail_is_task_cpu_after_the_start(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``fill_start_tail_ticks`` (off in every build; docs/timing-model.md, "twenty-eighth
    pass"): the task goes on after it started a queue, so the start's first step stays
    where it was and only the task's CPU grows."""
    steps, stolen = _run(monkeypatch)
    _with(monkeypatch, fill_start_tail_ticks=416)
    steps_tail, stolen_tail = _run(monkeypatch)
    assert steps_tail[0] == steps[0]  # the first step: before the tail
    extra = stolen_tail - stolen
    assert extra > 0 and extra % 416 == 0  # one tail per queue start of a task
    _with(monkeypatch, fill_start_tail_ticks=0, fill_start_ticks=AVR_E_START + 416)
    later = _run(monkeypatch)
    assert later[0][0] > steps[0]  # charged before the start instead: the step moves
    assert later[1] == stolen_tail  # ... with the same CPU


AVR_E_START = sim_timing_module.AVR_E_TIMING.fill_start_ticks
