"""``bench/replica/char_shift.py``: two replica runs whose inputs differ by one character,
side by side (docs/timing-model.md, "forty-first pass")."""

from __future__ import annotations

import collections
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))
sys.path.insert(0, str(ROOT / "bench"))

import char_shift  # noqa: E402
import e_fidelity  # noqa: E402

E09 = "M1 A20000 V50 e f M2 A20000 V65 b w1200 M1 S M2 S W M1 W"

W = char_shift.WINDOW_TICKS


def test_loop_sections_read_cli_lines_within_the_span() -> None:
    lines = ["0 C 0", "100 S 4f8c", "150 V 11", "200 C 5270", "300 C 4548", "400 C 5270",
             "500 R"]
    assert char_shift.loop_sections(lines, 150, 400) == [("5270", 200), ("4548", 300)]


def test_an_extra_pass_is_left_out_and_the_chain_shift_is_read() -> None:
    # the second run makes one more pass (site 6c88) and is 238 ticks later after it
    a = [("5270", 0), ("4548", 300), ("5270", 600), ("5270", 900)]
    b = [("5270", 0), ("6c88", 300), ("4548", 538), ("5270", 838), ("5270", 1138)]
    assert char_shift.matched_shifts(a, b) == [(0, 0), (300, 238), (600, 238), (900, 238)]
    assert char_shift.binned([(0, 0), (300, 238), (600, 238)], 500) == [
        (0, [(0, 1), (238, 1)]), (500, [(238, 1)])]


def test_window_rows_name_the_first_wrap_where_the_runs_part() -> None:
    lo = 7 * W
    blocks_a = [(lo + 1000 + 2000 * i, lo + 2582 + 2000 * i) for i in range(5)]
    blocks_b = [(a - 6, b - 6) for a, b in blocks_a[:2]] + [(a + 95, b + 95)
                                                            for a, b in blocks_a[2:]]
    wrap = 65536 + 1500
    rises_a = [lo + 500, lo + 500 + wrap, lo + 500 + 2 * wrap, lo + 500 + 2 * wrap + 1500]
    # the second run keeps the second compare (a period, no wrap) and wraps later
    rises_b = [lo + 500, lo + 500 + wrap, lo + 500 + wrap + 1500, lo + 500 + 2 * wrap + 1500]
    (row,) = char_shift.window_rows(blocks_a, blocks_b, rises_a, rises_b)
    assert row["window"] == 7 and row["first"] == -6 and row["blocks"] == (5, 5)
    assert row["shifts"] == [(95, 3), (-6, 2)]
    assert row["wraps"] == (2, 2)
    assert row["part"] == lo + 500 + wrap  # its second wrap: 1 500 ticks later on b


def test_window_rows_part_where_one_side_has_fewer_wraps() -> None:
    lo = 8 * W
    blocks = [(lo + 1000, lo + 2582)]
    wrap = 65536 + 1500
    rises_a = [lo, lo + wrap, lo + 2 * wrap, lo + 2 * wrap + 1500]
    rises_b = [lo, lo + wrap, lo + wrap + 1500]
    (row,) = char_shift.window_rows(blocks, blocks, rises_a, rises_b)
    assert row["wraps"] == (2, 1)
    assert row["part"] == lo + wrap



# the replica of e09 (build e) while `W` waits, 1 600-1 700 ms: its loop's reads of
# millis() come 242 and 343 ticks apart, commonest first (a pass of `W`'s character and of
# its command in turn, outside the `e` windows; docs/timing-model.md, "forty-first pass")
REPLICA_W_PITCHES = [242, 343]


def _w_hold_pitches(monkeypatch: pytest.MonkeyPatch, settings: list[str]) -> list[int]:
    """The model's two commonest pitches between the loop's reads of millis() while e09's
    `W` waits (1 600-1 700 ms), with build e's figures changed by ``settings``."""
    from fas.sim import backend as bk
    from fas.sim import timing as sim_timing_module
    from stepperdemo.demo import build as demo_build_module

    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", dict(sim_timing_module.BY_BUILD["e"]))
    monkeypatch.setitem(demo_build_module.BY_BUILD, "e", dict(demo_build_module.BY_BUILD["e"]))
    e_fidelity.set_timing(settings)
    reads: list[int] = []
    plain = bk.SimBackend.millis

    def millis(self: bk.SimBackend) -> int:
        reads.append(self.machine.now)
        return plain(self)

    monkeypatch.setattr(bk.SimBackend, "millis", millis)
    e_fidelity.run_model(E09, "atmega328p", "e")
    lo, hi = 1600 * 16_000, 1700 * 16_000
    r = sorted({t for t in reads if lo <= t < hi})
    pitches = collections.Counter(b - a for a, b in zip(r, r[1:], strict=False))
    return [d for d, _ in pitches.most_common(2)]


def test_the_loop_chain_through_w_has_the_replicas_pitches_with_every_pass_kept(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # e_every_pass keeps the chain; a pass outside a window 3 ticks shorter than a
    # window's pass less its block (the sixteenth pass's e01 replica) gives its pitches
    assert _w_hold_pitches(monkeypatch, ["e_every_pass=1", "e_outside_saved_ticks=3"]) \
        == REPLICA_W_PITCHES


def test_with_every_pass_alone_the_chain_runs_3_ticks_a_pass_slow(
        monkeypatch: pytest.MonkeyPatch) -> None:
    assert _w_hold_pitches(monkeypatch, ["e_every_pass=1"]) == [p + 3 for p in REPLICA_W_PITCHES]
