"""The ramp task's time line on the AVR (build e, off by default): a running stepper's
fill reads its queue when the library's code gets there (``fill_reads_queue_live``),
that moment counted with the interrupts nested in the task (``task_nested_isrs``), and
the commands of a starting ramp (``fill_unstarted_cmd_extra_ticks``)
(docs/timing-model.md, "fourteenth pass"); the start-up's data copy
(``boot_data_bytes``, ``boot_data_align``) and the task's cost after its fill
(``fill_exit_ticks``) ("fifteenth pass")."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

from fas.arch import ATMEGA328P
from fas.sim import timing as sim_timing_module
from fas.sim.backend import SimBackend
from fas.sim.machine import Machine
from stepperdemo.scenarios.evaluate import position_from_pins

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import e_fidelity  # noqa: E402

E09 = "M1 A20000 V50 e f M2 A20000 V65 b w1200 M1 S M2 S W M1 W"
E09_B_FIRMWARE = -16352  # ../shared/conformance/e09: B's pin-derived end position


def test_the_tasks_code_is_stretched_by_timer_0_and_the_step_interrupts() -> None:
    m = Machine(ATMEGA328P, "e")
    t = m.timing
    ov, ms = t.millis_overflow_ticks, t.millis_isr_ticks
    m.start_millis()  # at tick 0: overflows at ov, 2 ov, ...
    m.run_until(ov - 100)
    assert m.nested_stretched(50) == 50  # before the overflow
    assert m.nested_stretched(1000) == 1000 + ms
    steps = [ov + 950]  # a step interrupt that the stretch reaches only with timer 0's
    m.step_isrs_between = lambda lo, hi: sum(120 for c in steps if lo <= c < hi)
    assert m.nested_stretched(1000) == 1000 + ms + 120
    assert m.nested_stretched(960) == 960 + ms + 120  # timer 0's brings it to ov + 956
    assert m.nested_stretched(950) == 950 + ms  # ends at ov + 946
    assert m.stretched(1000) == 1000  # the UART's stretch alone: nothing printed


def _b_end(monkeypatch: pytest.MonkeyPatch, **fields: object) -> int:
    table = {k: replace(v, **fields) for k, v in sim_timing_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)
    backend = e_fidelity.run_model(E09, "atmega328p", "e")
    sp = [p for p in e_fidelity.stepper_pins(backend.profile) if p.letter == "B"][0]
    return position_from_pins(backend, sp.step, sp.direction)


def test_a_fill_that_reads_its_queue_after_the_nested_interrupts_plans_the_firmwares_stop(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # e09's task at 1 458.5 ms: the firmware's M2 fill reads the queue ~10 000 ticks into
    # the task, when M2's running entry has ended, and plans a third coast command of 30
    # steps; read at the task's entry (the default) the model plans two, and M2's stop
    # finds its plan 30 steps short
    assert _b_end(monkeypatch) == E09_B_FIRMWARE + 30
    assert _b_end(monkeypatch, fill_reads_queue_live=True,
                  task_nested_isrs=1) == E09_B_FIRMWARE


def test_commands_written_before_the_queue_starts_can_cost_more(
        monkeypatch: pytest.MonkeyPatch) -> None:
    def first_rise(**fields: object) -> float:
        table = {k: replace(v, **fields) for k, v in sim_timing_module.BY_BUILD["e"].items()}
        monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)
        backend = e_fidelity.run_model("M1 A30000 V45 f w100 S W", "atmega328p", "e")
        return e_fidelity.step_times_us(backend, 9)[0]

    plain = first_rise()
    later = round((first_rise(fill_unstarted_cmd_extra_ticks=1000) - plain) * 16)
    commands = later // 1000  # the start task's commands (each 1 000 ticks more)
    assert commands >= 2 and later - 1000 * commands < 1000  # + the UART's interrupts


def _with(monkeypatch: pytest.MonkeyPatch, **fields: object) -> None:
    table = {k: replace(v, **fields) for k, v in sim_timing_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)


def _timer0_start(inp: str) -> int:
    backend = e_fidelity.run_model(inp, "atmega328p", "e")
    return backend.machine.tick_at_millis(0)


def test_the_start_up_copies_the_input_line_with_the_data_section_rounded_up_to_even(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # the replica's ELF: .data holds 407 bytes besides the line (input + " " + NUL) on the
    # ATmega328P and ends on an even address; timer 0 starts after the copy
    # (docs/timing-model.md, "fifteenth pass")
    short, mid, long = "M1 A30000 V45 f w10 S W", "M1 A30000 V45 f w100 S W", \
        "M1 A30000 V45 f w1000 S W"
    per_byte = sim_timing_module.AVR_E_TIMING.boot_script_byte_ticks
    assert _timer0_start(mid) - _timer0_start(short) == per_byte  # the default: as it is
    _with(monkeypatch, boot_data_bytes=408, boot_data_align=2)
    assert _timer0_start(mid) - _timer0_start(short) == 2 * per_byte  # 433 -> 434
    assert _timer0_start(long) == _timer0_start(mid)  # 434 stays 434


def test_the_tasks_cost_after_its_fill_moves_no_write(monkeypatch: pytest.MonkeyPatch) -> None:
    def run() -> tuple[float, int]:
        backend = e_fidelity.run_model("M1 A30000 V45 f w100 S W", "atmega328p", "e")
        return e_fidelity.step_times_us(backend, 9)[0], backend.machine.stolen_ticks

    rise, stolen = run()
    entry = sim_timing_module.AVR_E_TIMING.fill_entry_ticks
    _with(monkeypatch, fill_entry_ticks=entry - 100, fill_exit_ticks=100)
    rise_split, stolen_split = run()
    # the first step comes 100 ticks sooner, and every task costs what it did
    assert round((rise_split - rise) * 16) == -100
    assert stolen_split == stolen


def test_an_idle_loop_woken_by_millis_takes_the_deadline_up_half_a_pass_later(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from stepperdemo.demo import build as demo_build_module

    def window_starts() -> list[int]:
        blocks: list[tuple[int, int]] = []
        e_fidelity.run_model("M1 A30000 V45 e f w600 S W", "atmega328p", "e", blocks)
        return [a for i, (a, _) in enumerate(blocks)
                if i == 0 or a - blocks[i - 1][0] > 100_000]

    at_once = window_starts()
    table = {k: replace(v, wake_mid_pass=True)
             for k, v in demo_build_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(demo_build_module.BY_BUILD, "e", table)
    later = [b - a for a, b in zip(at_once, window_starts(), strict=True)]
    # during w600 a pass is 220 + 10 (M1 running) + 40 (M2 idle); once W holds the
    # input its character and command passes (+5, +106) alternate
    assert later == [(220 + 10 + 40) // 2] * 3 + [(220 + 50 + (5 + 106) // 2) // 2] * 2


def test_e_every_pass_runs_the_passes_between_the_windows(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from stepperdemo.demo import build as demo_build_module
    from stepperdemo.program import make_program

    def passes_and_reads(**fields: object) -> tuple[int, list[int]]:
        table = {k: replace(v, **fields) for k, v in demo_build_module.BY_BUILD["e"].items()}
        monkeypatch.setitem(demo_build_module.BY_BUILD, "e", table)
        backend = SimBackend("atmega328p", record=True, build="e")
        reads: list[int] = []
        millis = backend.millis

        def read() -> int:
            reads.append(backend.machine.now)
            return millis()

        monkeypatch.setattr(backend, "millis", read)
        app = make_program("demo", backend, scripted=True)
        app.run_script("M1 A30000 V45 e f w400 S W", firmware_end=True)
        return app.passes, reads

    skipped, _ = passes_and_reads()
    every, reads = passes_and_reads(e_every_pass=True)
    # between the windows (from 64 ms of millis on) the passes are run, not skipped
    assert every > 2 * skipped
    # a pause pass outside a window: two reads of millis() (the pause's and the `e`
    # check's) at one tick, the pass 220 + 10 (M1 running) + 40 (M2 idle) long without
    # interrupts; shorter by e_outside_saved_ticks
    def shortest_pitch(reads: list[int]) -> int:
        ticks = sorted(set(reads))
        return min(b - a for a, b in zip(ticks, ticks[1:], strict=False))

    assert shortest_pitch(reads) == 270
    _, reads_saved = passes_and_reads(e_every_pass=True, e_outside_saved_ticks=3)
    assert shortest_pitch(reads_saved) == 267
