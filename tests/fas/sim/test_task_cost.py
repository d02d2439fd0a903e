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


MULTI_START = "M1 A70000 V42 R25000 W"  # e05 without `e`: its start task ends in 2-3 steps


def test_a_starting_ramps_longer_commands_can_cost_their_own_figure(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``fill_unstarted_multi_cmd_ticks`` (off in every build; docs/timing-model.md,
    "thirty-second pass"): a command of several steps written before its queue starts
    costs this, all in; the commands of a running ramp keep theirs."""
    singles = _run(monkeypatch)  # a start through one-step commands only
    steps, stolen = _run(monkeypatch, MULTI_START)
    cmd = sim_timing_module.AVR_E_TIMING.fill_cmd_ticks
    _with(monkeypatch, fill_unstarted_multi_cmd_ticks=cmd)  # the same figure: nothing moves
    assert _run(monkeypatch, MULTI_START) == (steps, stolen)
    _with(monkeypatch, fill_unstarted_multi_cmd_ticks=cmd + 1000)
    later, stolen_later = _run(monkeypatch, MULTI_START)
    extra = stolen_later - stolen
    commands = extra // 1000
    assert commands >= 2 and extra == 1000 * commands  # the start task's, 1 000 each
    assert later[0] > steps[0]  # charged before the start: the first step moves
    assert later[1] - later[0] == steps[1] - steps[0]  # and nothing else
    assert _run(monkeypatch) == singles  # ... has none of them


def test_a_start_after_a_longer_command_can_cost_its_own_figure(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``fill_start_after_cmd_ticks`` (off; "thirty-second pass"): the queue start that
    follows a command of several steps, instead of ``fill_start_ticks``."""
    singles = _run(monkeypatch)
    steps, stolen = _run(monkeypatch, MULTI_START)
    _with(monkeypatch, fill_start_after_cmd_ticks=AVR_E_START)  # the same: nothing moves
    assert _run(monkeypatch, MULTI_START) == (steps, stolen)
    _with(monkeypatch, fill_start_after_cmd_ticks=AVR_E_START + 1000)
    later, stolen_later = _run(monkeypatch, MULTI_START)
    assert stolen_later - stolen == 1000  # one queue start
    assert round((later[0] - steps[0]) * 16) >= 1000  # its first step moves (+ interrupts)
    assert _run(monkeypatch) == singles  # after a one-step command: fill_start_ticks

