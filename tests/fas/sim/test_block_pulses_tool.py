"""``bench/replica/block_pulses.py`` (docs/timing-model.md, "thirty-first pass"): the
readers on a written replica log and the build-d overrides."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import block_pulses  # noqa: E402

from fas.sim import timing as sim_timing_module  # noqa: E402
from stepperdemo.demo import build as demo_build_module  # noqa: E402

LAG = 96


def _log() -> list[str]:
    return [
        "0 C 0",
        "10 S 8",                       # a short section (millis()): no block
        f"{1000 + LAG} C 1064",
        f"{1000 + 1599 + LAG} S 1088",  # a block of 1 599
        f"{2000 + LAG + 4} V 19",       # the UART's interrupt, held (entered after it)
        f"{2700 + LAG} R",
        f"{5000 + LAG} C 1064",
        f"{5000 + 1599 + LAG} S 1088",
        f"{300000 + LAG} C 1064",       # the next window
        f"{300000 + 1599 + LAG} S 1088",
        "x",
    ]


def test_the_readers_take_the_blocks_and_the_uarts_requests_less_the_lag() -> None:
    blocks = block_pulses.replica_blocks(_log(), LAG)
    assert blocks == [(1000, 2599), (5000, 6599), (300000, 301599)]
    assert block_pulses.replica_uart(_log(), LAG) == [2000]
    assert [len(w) for w in block_pulses.windows(blocks)] == [2, 1]


def test_held_pulses_are_those_rising_inside_a_block() -> None:
    blocks = [(1000, 2599), (5000, 6599)]
    pulses = [(900, 961), (1200, 2661), (3000, 3061), (6598, 6660)]
    assert block_pulses.held_by(pulses, blocks) == [None, 0, None, 1]
    s = block_pulses.held_summary(pulses, blocks)
    assert (s["held"], s["held width"], s["place in block"], s["other width"]) == (
        2, (1461 + 62) / 2, (200 + 1598) / 2, 61)


def test_nearest_offsets_are_signed() -> None:
    c = block_pulses.nearest_offsets([100, 1596, 3092], [357, 1853, 3000])
    assert c == {-257: 2, 92: 1}


def test_set_changes_build_ds_328p_only(monkeypatch: pytest.MonkeyPatch) -> None:
    t = sim_timing_module.BY_FAMILY["avr"]
    d = demo_build_module.BY_PROFILE["atmega328p"]
    monkeypatch.setitem(sim_timing_module.BY_FAMILY, "avr", t)
    monkeypatch.setitem(demo_build_module.BY_PROFILE, "atmega328p", d)
    tm = sim_timing_module.BY_BUILD["d_time_measurement"]
    monkeypatch.setitem(tm, "atmega328p", tm["atmega328p"])
    block_pulses.set_build_d(["task_phase_ticks=+217", "uart_idle_start_ticks=257",
                              "irq_block_ticks=1582"])
    assert sim_timing_module.BY_FAMILY["avr"].task_phase_ticks == t.task_phase_ticks + 217
    assert sim_timing_module.BY_FAMILY["avr"].uart_idle_start_ticks == 257
    assert demo_build_module.BY_PROFILE["atmega328p"].irq_block_ticks == 1582
    with pytest.raises(ValueError, match="not FIELD=VALUE"):
        block_pulses.set_build_d(["no_such_field=1"])


def test_the_models_run_gives_its_pulses_blocks_and_uart_starts() -> None:
    pulses, blocks, starts = block_pulses.model_run("M1 A2000 V40 e R400 W")
    assert len(pulses) == 400
    assert blocks and {b - a for a, b in blocks} == {1599}
    byte = sim_timing_module.AVR_TIMING.uart_byte_ticks
    assert len(starts) > 64  # more than the UART's ring keeps
    assert byte in {b - a for a, b in zip(starts, starts[1:], strict=False)}


def test_the_tasks_own_cpu_leaves_out_the_interrupts_nested_in_it() -> None:
    log = [f"{1000 + LAG} V 13", f"{1500 + LAG} V 11", f"{1620 + LAG} R",
           f"{3000 + LAG} V 19", f"{3118 + LAG} R", f"{7000 + LAG} R",
           f"{9000 + LAG} V 16", f"{9096 + LAG} R", "x"]
    assert block_pulses.replica_tasks(log, LAG) == [(1000, 6000 - 120 - 118)]


def test_the_models_tasks_carry_the_cpu_they_charge() -> None:
    tasks = block_pulses.model_tasks("M1 A2000 V40 R40 W")
    entry = sim_timing_module.BY_FAMILY["avr"].fill_entry_ticks  # build d's 328P
    assert len(tasks) > 10 and all(cpu >= entry for _, cpu in tasks)


def test_a_build_e_run_is_refused_not_compared_with_build_d(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the model runs in build d and --set edits build d's tables: e09 (build e) would be
    # a build-d model against a build-e replica
    (tmp_path / "e09-x.ev").write_text("0 C 0\n")
    (tmp_path / "e09-x.pins").write_text("")
    assert block_pulses.main(["--work", str(tmp_path), "--tag", "x", "e09"]) == 0
    assert "e09: a build-e run" in capsys.readouterr().out
