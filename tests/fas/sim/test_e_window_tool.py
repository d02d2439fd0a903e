"""``bench/e_window.py``: one `e` run's windows step by step and block by block
(docs/timing-model.md, "thirty-eighth pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import e_fidelity  # noqa: E402
import e_window  # noqa: E402

W = e_window.WINDOW_TICKS
CONF = e_fidelity.DEFAULT_CONF


def test_periods_take_one_wrap_out_of_a_missed_compare() -> None:
    rises = [0, 1500, 1500 + 65536 + 1500, 1500 + 65536 + 3000]
    assert e_window.periods(rises) == [1500, 1500, 1500]


def test_ramp_diff_tells_pairwise_jitter_from_a_drift() -> None:
    a = [0, 1000, 2000, 3000, 4000]
    jitter = [0, 1003, 2000, 3000, 4000]  # one rise 3 ticks late: two periods off, no drift
    assert e_window.ramp_diff(a, jitter) == (4, 3, 3)
    late = [0, 1000, 2010, 3020, 4030]  # a ramp 10 ticks a step slower from the second step
    assert e_window.ramp_diff(a, late) == (4, 10, 30)


def test_window_rows_count_held_missed_place_and_wrap_runs() -> None:
    lo = 8 * W
    blocks = [(lo + 1000 + 2000 * i, lo + 2582 + 2000 * i) for i in range(10)]
    rises = [lo + 900,          # before the first block: outside the blocks' span
             lo + 1050,         # held 50 ticks in, missed: a wrap follows
             lo + 1050 + 65536 + 1500]  # after the last block: outside the span
    # a second train: inside the span, held late in a block, kept
    rises2 = [lo + 3500, lo + 5100, lo + 5100 + 65536 + 10, lo + 5100 + 2 * 65536 + 20,
              lo + 5100 + 2 * 65536 + 1500]
    r = e_window.window_rows(rises, blocks, 8)
    assert (r["blocks"], r["steps"], r["held"], r["missed"]) == (10, 1, 1, 1)
    assert r["place"] == {0: 1}
    assert r["first"] == (1, 65536 + 1500 - 65536)
    r2 = e_window.window_rows(rises2, blocks, 8)
    # 3500 in block 1 at 500 (kept), 5100 in block 2 at 100 (missed, twice in a row)
    assert (r2["steps"], r2["held"], r2["missed"]) == (2, 2, 1)
    assert r2["place"] == {400: 1, 0: 1}
    assert r2["runs"] == {2: 1}


def test_margins_split_by_the_other_stepper_in_the_block() -> None:
    blocks = [(10_000, 11_582), (20_000, 21_582)]
    a = [11_000, 11_000 + 650, 21_500, 21_500 + 65536 + 150]
    other = [20_100]
    m = e_window.margins(a, blocks, [other])
    # 11 000 + 650 - 11 582 = 68: kept, no other compare in that block
    assert m[False] == {(50, False): 1}
    # 21 500 + 150 - 21 582 = 68: missed, the other stepper held in the same block
    assert m[True] == {(50, True): 1}


def test_pitches_key_each_pass_by_what_fell_in_it() -> None:
    lo = 3 * W
    blocks = [(lo, lo + 1582), (lo + 1827, lo + 3409), (lo + 3774, lo + 5356),
              (lo + 5700, lo + 7282)]
    a, b = [lo + 1900], [lo + 100, lo + 4000]
    p = e_window.pitches(a, blocks, [b], 3)
    # lo..: B's compare (no A): 1827; lo+1827..: A's: 1947; lo+3774..: B's again: 1926
    assert p == {(0, 1): {1827: 1, 1926: 1}, (1, 0): {1947: 1}}


def test_e09_a_runs_the_firmware_s_ramp_and_its_last_window_differs_by_its_wraps(
        capsys: pytest.CaptureFixture[str]) -> None:
    tr, fw_blocks, model_blocks = e_window.tracks(CONF, "e09")
    fr, mr = tr["A"]
    # the stop's ramp is the firmware's step for step (M1 S in the same task slot):
    # the periods' sum never drifts more than the pin's jitter
    n, _, drift = e_window.ramp_diff(fr, mr)
    assert n == 21435 and drift <= 3
    fw8, m8 = e_window.window_rows(fr, fw_blocks, 8), e_window.window_rows(mr, model_blocks, 8)
    # the firmware's 11 wraps and the model's 13 (the strict xfail of conformance/e09)
    assert (fw8["missed"], m8["missed"]) == (11, 13)
    # each wrap takes one timer period out of the blocks' span: the held compares follow
    # the count of wraps at the same share held (firmware 124 of 207, model 77 of 119)
    assert (fw8["held"], m8["held"]) == (124, 77)
    for r in (fw8, m8):
        assert 0.55 < r["held"] / r["steps"] < 0.70
    # the blocks' pitches by what ran in the pass are the firmware's to the tick
    fp = e_window.pitches(fr, fw_blocks, [tr["B"][0]], 8)
    mp = e_window.pitches(mr, model_blocks, [tr["B"][1]], 8)
    for key in ((0, 0), (0, 1), (1, 0), (1, 1)):
        assert {t for t, _ in fp[key].most_common(2)} == {t for t, _ in mp[key].most_common(2)}
    argv = ["--conformance", str(CONF), "--pitches", "--margins", "e09", "A", "8"]
    assert e_window.main(argv) == 0
    out = capsys.readouterr().out
    assert "| 8 | firmware | 435 |" in out and "| 8 | model | 446 |" in out


def test_bad_input_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert e_window.main(["--conformance", str(tmp_path), "e09", "A"]) == 2
    assert "no firmware run e09" in capsys.readouterr().err


def test_the_phase_probe_at_phase_0_is_the_plain_run_and_later_starts_move_the_wraps() -> None:
    rows = e_window.phase_rows(CONF, "e09", "A", [8], 200, 100)[8]
    # phase 0 is the model's own run: 13 wraps, 119 steps in the blocks' span, 77 held
    assert rows[0] == (13, 119, 77, 13)
    # the window's first blocks later: the same window makes another count of wraps and
    # held compares (the count is a sample of where the blocks fall, not a fixed figure)
    assert len(rows) == 3 and len({r[:3] for r in rows}) > 1


def test_a_replica_run_takes_the_model_s_column_less_its_lead(tmp_path: Path) -> None:
    lead = 61
    (tmp_path / "r.pins").write_text(
        f"{1000 + lead} B1 1\n{1065 + lead} B1 0\n{3000 + lead} B1 1\n{3065 + lead} B1 0\n"
        f"{2000 + lead} B2 1\n{2070 + lead} B2 0\n")
    (tmp_path / "r.ev").write_text(f"{2900 + lead} C 0\n{2900 + 1582 + lead} S 0\n"
                                   f"{5000 + lead} C 0\n{5010 + lead} S 0\n")
    firmware = {"A": ([1000, 3000], []), "B": ([2000], [])}
    rises, blocks = e_window.replica_tracks(tmp_path / "r", firmware)
    assert rises == {"A": [1000, 3000], "B": [2000]}
    assert blocks == [(2900, 2900 + 1582)]  # a short section is not an `e` block
