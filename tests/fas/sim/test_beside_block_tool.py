"""``bench/beside_block.py`` (docs/path-planner.md, "two channels' blocks, measured"):
the counting wrappers move nothing in the run, and what they count adds up."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import beside_block  # noqa: E402

from fas.sim.channel import SimChannel  # noqa: E402

SEGMENTS = 120  # a short look-ahead program: both axes run, blocks beside single pulses


def test_the_wrapped_run_is_the_unwrapped_one_tick_for_tick() -> None:
    single = SimChannel._single_isr  # noqa: SLF001 - the tool restores it
    out, seen = beside_block.run(SEGMENTS, True, 512)
    assert SimChannel._single_isr is single  # noqa: SLF001 - restored
    assert seen == beside_block.plain_run(SEGMENTS, True)
    pulses = out["pulses"]
    assert pulses["in blocks"] > 0
    assert pulses["single events beside a block"] > 0
    assert pulses["inline beside a block (_go_on)"] > 0
    # every single event beside a block is of one kind; pulses are a part of them
    kinds = out["single events beside a block"]
    assert sum(kinds.values()) >= pulses["single events beside a block"]
    # the channels made every pulse the tool saw (a block cut short is not counted)
    made = sum(ch[0] for ch in seen[-1])
    assert sum(pulses.values()) <= made


def test_the_entries_clear_of_the_block_follow_the_slack() -> None:
    none = beside_block.run(SEGMENTS, False, 10 ** 9)[0]["entries"]
    every = beside_block.run(SEGMENTS, False, -(10 ** 9))[0]["entries"]
    some = beside_block.run(SEGMENTS, False, 512)[0]["entries"]
    total = every["entries beside a block"]
    assert total > 0
    assert none["entries clear of the block by 1000000000 ticks"] == 0
    assert every["entries clear of the block by -1000000000 ticks"] == total
    assert every["the clear entries' pulses"] == every["their pulses"]
    assert 0 <= some["entries clear of the block by 512 ticks"] <= total
