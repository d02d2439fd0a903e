"""The conformance build's ramp task lies 144 ticks after the local build's, and the
task's fitted entry cost gives those ticks back (docs/timing-model.md, "twenty-third
pass"): a move started on a quiet console keeps its first step, and a move the loop
starts within those 144 ticks after the local build's task is planned by that task.  Since
the fortieth pass build d's default reads its task from its replica (entry, exit, idle run
apart, and its phase): the fitted relation is tested on the figures fitted before (the
variant FIT of ``bench/d_corpus.py``)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

from fas.sim import timing as sim_timing_module
from stepperdemo.scenarios.evaluate import step_times_us

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import d_corpus  # noqa: E402
import e_fidelity  # noqa: E402
import slot_jumps  # noqa: E402

from stepperdemo.demo import build as demo_build_module  # noqa: E402

LAG = sim_timing_module.CONFORMANCE_TASK_LAG_TICKS


def _fitted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Build d's 328P as fitted before the fortieth pass."""
    for table, key in ((sim_timing_module.BY_FAMILY, "avr"),
                       (sim_timing_module.BY_BUILD["d_time_measurement"], "atmega328p"),
                       (demo_build_module.BY_PROFILE, "atmega328p")):
        monkeypatch.setitem(table, key, table[key])
    d_corpus.set_build_d(d_corpus.VARIANTS["FIT"])


def _local_build_task(monkeypatch: pytest.MonkeyPatch) -> None:
    """Build d's timing as before this pass: the local build's task, the fitted entry."""
    _fitted(monkeypatch)
    t = sim_timing_module.BY_FAMILY["avr"]
    monkeypatch.setitem(sim_timing_module.BY_FAMILY, "avr", replace(
        t, task_phase_ticks=t.task_phase_ticks - LAG, fill_entry_ticks=t.fill_entry_ticks + LAG))


def test_the_builds_task_and_entry(monkeypatch: pytest.MonkeyPatch) -> None:
    d = sim_timing_module.AVR_TIMING
    assert d.task_phase_ticks == sim_timing_module.LOCAL_BUILD_TASK_PHASE_TICKS + 144
    assert d.fill_entry_ticks + 144 == 2436  # the fit on the conformance runs' first steps
    # the other builds keep the task their own figures were read with; the 2560's and
    # the 32U4's default builds are the 328P's in this
    for t in (sim_timing_module.AVR_E_TIMING, sim_timing_module.AVR_UPSTREAM_TM_TIMING):
        assert t.task_phase_ticks == sim_timing_module.LOCAL_BUILD_TASK_PHASE_TICKS
    for t in (sim_timing_module.AVR_MEGA_TIMING, sim_timing_module.AVR_USB_TIMING):
        assert (t.task_phase_ticks, t.fill_entry_ticks) == (d.task_phase_ticks,
                                                            d.fill_entry_ticks)


def test_a_start_on_a_quiet_console_keeps_its_first_step(
        monkeypatch: pytest.MonkeyPatch) -> None:
    line = "M1 A1000 V100 R100 W"
    _fitted(monkeypatch)
    now = step_times_us(e_fidelity.run_model(line, "atmega328p", "d"), 9)
    _local_build_task(monkeypatch)
    before = step_times_us(e_fidelity.run_model(line, "atmega328p", "d"), 9)
    assert len(now) == len(before) == 100
    assert now[0] == before[0]
    assert now == before  # nothing else of a lone move depends on where the task lies


def test_test_sequence_02_plans_its_move_at_44_77_s_in_the_earlier_task(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The conformance run test_seq_sd_02_328p: the loop starts its 57th move 825 ticks
    after the previous move's stop (952 before build d's loop passes were read from its
    replica, thirty-first pass); the firmware's first step comes from the task 1 009
    ticks after that stop (the local build's task, 865, was too early for the call before).
    With build d's figures read (fortieth pass: the task's phase 217 ticks later,
    its steps as the replica's) the task comes 1 136 ticks after the model's stop, the call still
    825: the same task plans the move."""
    line = "t M1 02 I R W"
    rows, backend = slot_jumps.model_calls(line, "atmega328p", "d")
    stop, call, task = rows[55]
    assert (call - stop, task - stop) == (825, 1136)
    _fitted(monkeypatch)
    rows, backend = slot_jumps.model_calls(line, "atmega328p", "d")
    stop, call, task = rows[55]
    assert (call - stop, task - stop) == (825, 865 + LAG)
    _local_build_task(monkeypatch)
    rows, _ = slot_jumps.model_calls(line, "atmega328p", "d")
    stop, call, task = rows[55]
    # with build d's loop passes (thirty-first pass) the call comes 40 ticks before even
    # the local build's task (with the passes before: 952, after it, the loop lost the
    # task's entry of 2 436 ticks before its call and the move took the next slot)
    assert (call - stop, task - stop) == (825, 865)
