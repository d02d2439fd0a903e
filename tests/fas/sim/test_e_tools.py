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


def _demo_build_e(monkeypatch: pytest.MonkeyPatch) -> dict:
    from stepperdemo.demo import build as demo_build_module

    table = dict(demo_build_module.BY_BUILD["e"])
    monkeypatch.setitem(demo_build_module.BY_BUILD, "e", table)
    return table


def test_phases_show_the_banner_and_the_first_task_move_with_setups_head(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, build_e: dict) -> None:
    from dataclasses import replace

    # a replica run whose timer-0, task and UART vectors enter at the firmware's tick 0
    (tmp_path / "e01.ev").write_text("61 V 16\n65 R\n61 V 13\n70 R\n61 V 19\n66 R\n")
    table = _demo_build_e(monkeypatch)
    conf = e_fidelity.DEFAULT_CONF
    t0, task, uart = compare.phases("e01", conf, tmp_path)
    table["atmega328p"] = replace(table["atmega328p"],
                                  setup_head_ticks=table["atmega328p"].setup_head_ticks - 100)
    t0_h, task_h, uart_h = compare.phases("e01", conf, tmp_path)
    # timer 0 starts before setup(); the banner's characters and the engine's start
    # (the ramp task's phase counts from it) come 100 ticks sooner
    assert (t0_h - t0, task_h - task, uart_h - uart) == (0, -100, -100)
    # the first transmit interrupt (the banner's second character) comes before the
    # engine starts, one character's time on the wire after the first
    assert uart < task - sim_timing_module.BY_BUILD["e"]["atmega328p"].task_phase_ticks


def test_loop_phase_reads_the_replicas_passes_and_tasks(tmp_path: Path) -> None:
    import loop_phase

    lines = []
    for k in range(5):  # passes of 267 ticks: isRunning() (10), millis() (9)
        t = 1000 + 267 * k
        lines += [f"{t} C 4b62", f"{t + 10} S 4b62", f"{t + 148} C 5270", f"{t + 157} S 5270"]
    # a ramp task with a UART interrupt nested in it (118 ticks to its reti)
    lines += ["3000 V 13", "3500 V 19", "3618 R", "5000 R"]
    (tmp_path / "e01.ev").write_text("\n".join(lines) + "\n")
    side, site = loop_phase.replica_side("e01", tmp_path)
    assert site == "5270"
    assert side.reads == [1000 + 148 + 267 * k - 61 for k in range(5)]
    assert side.tasks == [(3000 - 61, 2000 - 118 - 4)]
    assert loop_phase.spans(4 * loop_phase.WINDOW_TICKS)[0] == (80 * 16_000, 252 * 16_000)


def test_loop_phase_kinds_of_the_replicas_tasks(tmp_path: Path) -> None:
    import loop_phase

    assert loop_phase.kind_of(0, [], []) == "0st -"
    assert loop_phase.kind_of(2, [(1, 900, 5, 1000), (2, 800, 5, 800)], ["U", "T0"]) \
        == "2st acc+coast T0 U"
    assert loop_phase.kind_of(1, [(1, 1100, 5, 1000), (1, 1100, 1, 1100)], []) \
        == "1st dec+short"
    lines = [  # a task writing two commands (faster, then as fast), timer 0 nested in it
        "1000 V 13 | 1 1 |", "1500 M 0 727 900 5", "1600 V 16", "1700 R",
        "2000 M 0 727 900 5", "3000 R",
        "70000 V 13 | 1 1 1 |", "70400 V 19", "70518 R", "71000 R",  # nothing written
        "140000 V 13 | 1 |", "140500 M 0 727 1000 5", "142000 R"]  # slower again
    (tmp_path / "e01.ev").write_text("\n".join(lines) + "\n")
    assert loop_phase.replica_kinds("e01", tmp_path) == [
        ("1st acc+coast T0", 2), ("1st - U", 0), ("1st dec", 1)]


def test_variants_are_named_sets_of_settings(build_e: dict) -> None:
    """``--variant`` (docs/timing-model.md, "twenty-eighth pass"): R28's figures reach
    the ATmega328P and the ATmega2560 and leave the ATmega32U4 as it is."""
    usb = build_e["atmega32u4"]
    assert e_fidelity.variant_settings(["TH", "U"]) == [
        *e_fidelity.VARIANTS["TH"], *e_fidelity.VARIANTS["U"]]
    e_fidelity.set_timing(e_fidelity.variant_settings(["R28"]))
    uno, mega = build_e["atmega328p"], build_e["atmega2560"]
    assert (uno.fill_start_ticks, uno.fill_start_tail_ticks, uno.fill_single_ticks) == \
        (1045, 362, 1868)
    assert (mega.fill_start_ticks, mega.fill_start_tail_ticks) == (1058, 308)
    # the fixed part split, its sum kept: 433 and 517 (the pitches across a task)
    assert uno.fill_entry_ticks + uno.fill_exit_ticks == 433
    assert mega.fill_entry_ticks + mega.fill_exit_ticks == 517
    assert build_e["atmega32u4"] == usb
    # the thirty-second pass's: a starting ramp's longer commands (the 328P's replica
    # only) and the running singles apart from the starting ones
    e_fidelity.set_timing(e_fidelity.variant_settings(["R32", "Q32"]))
    uno, mega = build_e["atmega328p"], build_e["atmega2560"]
    assert (uno.fill_unstarted_multi_cmd_ticks, uno.fill_start_after_cmd_ticks) == (2115, 1097)
    assert (mega.fill_unstarted_multi_cmd_ticks, mega.fill_start_after_cmd_ticks) == (0, 0)
    # a starting ramp's one-step command as R28 read it: running + the extra
    assert uno.fill_single_ticks + uno.fill_unstarted_cmd_extra_ticks == 1868
    assert mega.fill_single_ticks + mega.fill_unstarted_cmd_extra_ticks == 1922
    assert uno.fill_queued_single_ticks == 46
    assert build_e["atmega32u4"] == usb
    with pytest.raises(ValueError, match="R29"):
        e_fidelity.variant_settings(["R29"])


def test_compare_takes_the_named_variants(tmp_path: Path, build_e: dict,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """``compare.py --variant`` (docs/timing-model.md, "thirty-second pass"): the named
    sets reach build e's table before ``--set``; a name it does not know is refused."""
    assert compare.main(["--work", str(tmp_path), "--variant", "R32", "--variant", "Q32",
                         "--set", "atmega328p:fill_queued_single_ticks=45", "e09"]) == 0
    assert "e09: no replica run" in capsys.readouterr().out
    uno = build_e["atmega328p"]
    assert (uno.fill_unstarted_multi_cmd_ticks, uno.fill_single_ticks) == (2115, 1831)
    assert uno.fill_queued_single_ticks == 45  # --set after the variant
    with pytest.raises(SystemExit):
        compare.main(["--variant", "R99", "e09"])


def test_a_running_fills_fixed_work_can_come_after_its_writes(
        tmp_path: Path, build_e: dict) -> None:
    """``fill_charges_after_writes`` (off; docs/timing-model.md, "thirty-second pass"):
    a running stepper's first write comes its own fixed work sooner (M1's also M2's,
    charged at the entry before), M2's first write in a task where both write by its own
    only (M1's work is charged before it), and every task's CPU stays."""
    (tmp_path / "e09").mkdir()
    (tmp_path / "e09" / "input.txt").write_text(E09 + "\n")
    before = compare.model_tasks("e09", tmp_path)
    e_fidelity.set_timing(["fill_charges_after_writes=1"])
    after = compare.model_tasks("e09", tmp_path)
    assert [(t.t, t.cpu) for t in after] == [(t.t, t.cpu) for t in before]
    uno = build_e["atmega328p"]
    fixed = uno.fill_stepper_ticks + uno.fill_plan_ticks  # + 100 a queued entry
    moved = both = 0
    for b, a in zip(before, after, strict=True):
        if not b.writes or b.writes[0][0] != 0 or not b.queued[0]:
            continue
        assert [w[2:] for w in a.writes] == [w[2:] for w in b.writes]
        m2 = [k for k, w in enumerate(b.writes) if w[0] == 1]
        if b.queued[1] and not m2:
            continue  # M2 runs without planning (its ramp may be done: not charged)
        # M1's first write: sooner by M1's work, and M2's where M2 runs (all at the entry
        # before); the sum 100 a queued entry after the running one
        sooner = fixed + sum(uno.fill_stepper_ticks * (k > 0) + uno.fill_queued_entry_ticks
                             * (len(q) - 1) for k, q in enumerate(b.queued) if q)
        assert b.writes[0][1] - a.writes[0][1] == sooner
        moved += 1
        if m2 and b.queued[1]:
            # M2's first write: sooner by M2's own work only (M1's is charged before it)
            own = fixed + uno.fill_queued_entry_ticks * (len(b.queued[1]) - 1)
            assert b.writes[m2[0]][1] - a.writes[m2[0]][1] == own
            both += 1
    assert moved > 100 and both > 100


def test_the_corpus_runs_under_a_variant(build_e: dict,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    """``bench/e_corpus.py`` (docs/timing-model.md, "thirty-second pass"): the variant
    reaches build e's table, the scenarios run as ``stepperdemo run`` runs them, and a
    figure it does not know is a one-line error."""
    import e_corpus

    scenario = str(ROOT / "sequences" / "conformance" / "e02.toml")
    assert e_corpus.main(["--variant", "R32", scenario]) == 0
    assert build_e["atmega328p"].fill_start_after_cmd_ticks == 1097
    assert "1 scenarios, 0 failed" in capsys.readouterr().out
    assert e_corpus.main(["--set", "fill_nothing=1", scenario]) == 2
    assert capsys.readouterr().err.startswith("e_corpus: --set 'fill_nothing=1'")


def test_window_split_counts_each_windows_rises_and_held_pulses() -> None:
    """``e_fidelity.py --pulses --windows`` (docs/timing-model.md, "thirty-fourth pass"):
    a rise inside a block is held to the block's end; rises between windows go under -1."""
    period = 256_000 * 16  # a window every 256 ms
    blocks = [(period + 1000, period + 2582), (period + 3000, period + 4582)]
    rises = [period + 500, period + 1500, period + 2000, period + 4000,  # window 1
             period + 80_000 * 16,                                  # after its span
             2 * period + 10]                                       # window 2, no block
    split = e_fidelity.window_split(rises, blocks)
    assert split == {1: [4, 3, (2582 - 1500) + (2582 - 2000) + (4582 - 4000)],
                     -1: [1, 0, 0], 2: [1, 0, 0]}
    # the per-pulse helper agrees with the pooled one
    assert e_fidelity.held_extra(rises, blocks) == (3, split[1][2])


def test_high_spread_counts_the_phases_inside_the_scenarios_tolerance() -> None:
    line = e_fidelity.high_spread(10_000, [9_900, 10_100, 10_200, 9_850])
    # 1.44 % of 10 000 + 1 us: 145 us
    assert line == ("pulse-high total: firmware 10000 +- 145 us, model 9850-10200 "
                    "(mean 10012, +12), inside at 2 of 4 phases")


def test_e13s_rises_per_window_are_the_firmwares() -> None:
    """The model's step rises per `e` window of e13 (the 2560) are the firmware's, window
    by window: what its pulse-high total misses is where the rises fall in the blocks."""
    folder = ROOT / "sequences" / "reference" / "e13"
    ref, _ = e_fidelity.read_reference_track(folder / "steps_A.tsv.gz")
    inp = "M1 A40000 V55 e f w900 S W"
    backend = e_fidelity.run_model(inp, "atmega2560_timer1", "e")
    pin = e_fidelity.stepper_pins(backend.profile)[0]
    ours = e_fidelity.step_times_us(backend, pin.step)
    fw = e_fidelity.window_split([round(t * 16) for t in ref], [])
    model = e_fidelity.window_split([round(t * 16) for t in ours], [])
    assert sorted(k for k in fw if k >= 0) == [1, 2, 3, 4, 5, 6]
    assert {k: v[0] for k, v in model.items()} == {k: v[0] for k, v in fw.items()}


def test_p33_sets_the_entry_switch_figure_per_channel(build_e: dict) -> None:
    """``--variant P33`` (docs/timing-model.md, "thirty-fourth pass"): a figure per
    channel, comma-separated, reaches every chip of build e."""
    e_fidelity.set_timing(e_fidelity.variant_settings(["P33"]))
    for timing in build_e.values():
        assert timing.isr_ocr_next_ticks == (24, 28)
        assert [timing.isr_ocr_next(k) for k in range(3)] == [24, 28, 28]
    e_fidelity.set_timing(["atmega2560:isr_ocr_next_ticks=5"])
    assert build_e["atmega2560"].isr_ocr_next(2) == 5
    assert build_e["atmega328p"].isr_ocr_next(2) == 28
