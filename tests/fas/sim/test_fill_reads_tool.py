"""The ramp task's fill reads of its queues, model beside replica
(``bench/replica/fill_reads.py``, the replica's ``Q`` lines; docs/timing-model.md,
"twenty-fourth pass"), and ``SimTiming.fill_entry_after_reads``."""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from fas.sim import timing as sim_timing_module

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import compare  # noqa: E402
import fill_reads  # noqa: E402
import replica  # noqa: E402

E09 = "M1 A20000 V50 e f M2 A20000 V65 b w1200 M1 S M2 S W M1 W"


def test_the_replicas_reads_and_the_librarys_sum(tmp_path: Path) -> None:
    lines = ["1000 V 13 | 1 2 | 5", "1199 Q 0 3 7 1000:1 2000:2 3000:0 500:5",
             "1500 V 12", "1631 R", "2000 Q 1 9 10 700:1", "2500 R"]
    (tmp_path / "e01.ev").write_text("\n".join(lines) + "\n")
    tasks, _ = replica.tasks_of(tmp_path / "e01", 13)
    assert len(tasks) == 1
    t = tasks[0]
    # (own CPU, queue, cycle, entries from the read index on): the step interrupt
    # nested between the reads is not the task's CPU
    assert t.reads == [(199, 0, 1199, [(1000, 1), (2000, 2), (3000, 0), (500, 5)]),
                       (1000 - 131, 1, 2000, [(700, 1)])]
    # ticksInQueue(): the entries after the running one, ticks x steps, a pause once
    assert replica.ticks_in_queue(t.reads[0][3]) == 2000 * 2 + 3000 + 500 * 5
    assert replica.ticks_in_queue(t.reads[1][3]) == 0
    assert replica.ticks_in_queue([]) == 0


@pytest.mark.skipif(shutil.which("avr-gcc") is None or shutil.which("avr-objdump") is None,
                    reason="needs avr-gcc")
def test_the_fills_read_is_found_in_the_task_vector(tmp_path: Path) -> None:
    src = tmp_path / "t.c"
    src.write_text(
        "#include <avr/io.h>\n#include <avr/interrupt.h>\n"
        "volatile unsigned char q[238];\nvolatile unsigned char out;\n"
        "ISR(TIMER1_OVF_vect) {\n"
        "  unsigned char s = SREG; cli();\n"
        "  unsigned char rp = q[96]; unsigned char wp = q[97];\n"
        "  SREG = s;\n  out = (unsigned char)(wp - rp);\n}\n"
        "int main(void) { for (;;) {} }\n")
    elf = tmp_path / "t.elf"
    subprocess.run(["avr-gcc", "-mmcu=atmega328p", "-Os", "-o", str(elf), str(src)],
                   check=True)
    pc = replica.fill_read_pc(elf, 13)  # TIMER1_OVF: vector 13 on the ATmega328P
    assert pc
    text = subprocess.run(["avr-objdump", "-d", f"--start-address={pc:#x}",
                           f"--stop-address={pc + 2:#x}", str(elf)], check=True,
                          capture_output=True, text=True).stdout
    assert "out\t0x3f" in text  # the instruction that ends the critical section
    assert replica.fill_read_pc(elf, 20) == 0  # no such vector


def test_a_read_is_classed_by_what_differs() -> None:
    run = [(900, 1), (800, 5), (700, 5)]
    after = [(800, 2), (700, 5), (600, 5)]
    assert fill_reads.classify(run, run, 7500, 7500) == "same sum"
    # the replica's fill found the running entry ended: its queue is one entry further
    assert fill_reads.classify(run + [(600, 5)], after, 7500 + 3000, 6500) \
        == "running entry: the replica's ended, the model's runs"
    assert fill_reads.classify(after, run + [(600, 5)], 6500, 10500) \
        == "running entry: the model's ended, the replica's runs"
    assert fill_reads.classify(run, [(900, 1), (800, 5), (650, 5)], 7500, 7250) == "queue"


def test_a_stepper_is_in_step_where_its_step_is_the_firmwares() -> None:
    lags = {0: ([100, 200, 300, 400], [5, 5, 70000, 70000])}
    assert fill_reads.lag_at(lags, 0, 150) == 5
    assert fill_reads.lag_at(lags, 0, 250) == 70000
    assert fill_reads.lag_at(lags, 0, 10**6) == 70000  # after the last step: the last
    assert fill_reads.lag_at(lags, 1, 150) is None


def _build_e(monkeypatch: pytest.MonkeyPatch, **fields: object) -> None:
    table = dict(sim_timing_module.BY_BUILD["e"])
    table["atmega328p"] = replace(table["atmega328p"], **fields)
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)


def _first_reads(tmp_path: Path) -> list[compare.ModelTask]:
    (tmp_path / "e09").mkdir(exist_ok=True)
    (tmp_path / "e09" / "input.txt").write_text(E09 + "\n")
    return [t for t in compare.model_tasks("e09", tmp_path) if t.reads]


def test_the_model_records_what_each_live_read_finds(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _build_e(monkeypatch, fill_reads_queue_live=True)
    tasks = _first_reads(tmp_path)
    assert len(tasks) > 100
    entry = sim_timing_module.BY_BUILD["e"]["atmega328p"]
    for t in tasks:
        assert len(t.read_queues) == len(t.reads) == len(t.read_ticks)
        for (_, _, _, found), ents, at in zip(t.reads, t.read_queues, t.read_ticks,
                                                strict=True):
            # the entries after the one running at the read are what the fill found
            assert replica.ticks_in_queue(ents) == found
            # the read comes after the task's fixed part and the fill's checks
            assert at >= entry.fill_entry_ticks + entry.fill_stepper_ticks


def test_the_tasks_fixed_part_after_its_reads_moves_the_reads_only(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _build_e(monkeypatch, fill_reads_queue_live=True)
    plain = _first_reads(tmp_path)
    _build_e(monkeypatch, fill_reads_queue_live=True, fill_entry_after_reads=True)
    early = _first_reads(tmp_path)
    timing = sim_timing_module.BY_BUILD["e"]["atmega328p"]
    a, b = plain[0], early[0]
    assert a.t == b.t
    # the first read: fill_entry_ticks of CPU sooner (the UART's interrupts in the
    # task stretch the span by whole routines); the task's CPU and writes stay
    moved = a.read_ticks[0] - b.read_ticks[0]
    uart = timing.uart_isr_ticks
    assert moved >= timing.fill_entry_ticks and (moved - timing.fill_entry_ticks) % uart == 0
    assert b.read_ticks[0] >= timing.fill_stepper_ticks
    assert a.cpu == b.cpu and a.reads[0][1] == b.reads[0][1]
