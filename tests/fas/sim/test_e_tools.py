"""The `e` runs' bench tools: ``bench/e_fidelity.py --set`` (build e's figures for one
run) and ``bench/replica/compare.py``'s record of each fill's read of its queue (``--at``,
docs/timing-model.md, "fourteenth pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from fas.sim import timing as sim_timing_module

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import compare  # noqa: E402
import e_fidelity  # noqa: E402

E09 = "M1 A20000 V50 e f M2 A20000 V65 b w1200 M1 S M2 S W M1 W"


@pytest.fixture
def build_e(monkeypatch: pytest.MonkeyPatch) -> dict:
    """Build e's table, restored after the test."""
    table = dict(sim_timing_module.BY_BUILD["e"])
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)
    return table


def test_set_changes_build_e_per_chip_and_refuses_what_it_does_not_know(build_e: dict) -> None:
    before = {k: (v.fill_start_ticks, v.fill_skips_done_ramps) for k, v in build_e.items()}
    e_fidelity.set_timing(["atmega2560:fill_start_ticks=2190", "fill_skips_done_ramps=0"])
    assert not any(v.fill_skips_done_ramps for v in build_e.values())
    for k, v in build_e.items():
        assert v.fill_start_ticks == (2190 if k.startswith("atmega2560") else before[k][0])
    upstream = sim_timing_module.BY_BUILD["upstream_time_measurement"]["atmega328p"]
    assert upstream.fill_skips_done_ramps  # another build keeps its figures
    with pytest.raises(ValueError, match="SimTiming field"):
        e_fidelity.set_timing(["no_such_field=1"])
    with pytest.raises(ValueError, match="SimTiming field"):
        e_fidelity.set_timing(["fill_start_ticks"])
    with pytest.raises(ValueError, match="no chip"):
        e_fidelity.set_timing(["esp32:fill_start_ticks=1"])


def test_set_changes_stepperdemos_own_figures_of_build_e(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from stepperdemo.demo import build as demo_build_module

    table = dict(demo_build_module.BY_BUILD["e"])
    monkeypatch.setitem(demo_build_module.BY_BUILD, "e", table)
    e_fidelity.set_timing(["atmega328p:wake_mid_pass=1"])
    assert table["atmega328p"].wake_mid_pass
    assert not table["atmega32u4"].wake_mid_pass
    assert not demo_build_module.BY_BUILD["e"]["atmega2560"].wake_mid_pass


def test_set_reaches_the_models_run(build_e: dict) -> None:
    def first_rise() -> int:
        backend = e_fidelity.run_model("M1 A30000 V45 f w100 S W", "atmega328p", "e")
        return e_fidelity.step_times_us(backend, 9)[0]  # StepA: pin 9

    plain = first_rise()
    timing = build_e["atmega328p"]
    e_fidelity.set_timing([f"atmega328p:fill_start_ticks={timing.fill_start_ticks + 1600}"])
    later = round((first_rise() - plain) * 16)  # ticks
    # the queue starts 1 600 ticks of task CPU later, the UART's interrupts in between
    uart = timing.uart_isr_ticks
    assert later >= 1600 and (later - 1600) % uart == 0 and later - 1600 < 1600


def test_compare_records_each_running_fills_read_in_task_order(tmp_path: Path) -> None:
    (tmp_path / "e09").mkdir()
    (tmp_path / "e09" / "input.txt").write_text(E09 + "\n")
    tasks = compare.model_tasks("e09", tmp_path)
    both = [t for t in tasks if len(t.reads) == 2]
    assert len(both) > 100  # M1 and M2 run together for ~1.2 s
    for t in both:
        (k1, cpu1, at1, found1), (k2, cpu2, at2, found2) = t.reads
        assert (k1, k2) == (0, 1)  # M1's fill reads first
        # both fills' sums are charged at the task's entry: M2 reads after M1's writes
        assert 0 < cpu1 <= cpu2 <= at2 and cpu1 <= at1  # the UART's stretch only adds
        assert found1 > 0 and found2 > 0
    # a fill that reads finds under the planning horizon (20 ms) what it then fills up
    planning = [t for t in both if any(w[0] == 1 for w in t.writes)]
    assert planning and all(t.reads[1][3] < 20 * 16000 for t in planning)
