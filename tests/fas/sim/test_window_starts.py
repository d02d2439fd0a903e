"""Where an `e` window starts (docs/timing-model.md, "twenty-second pass"): StepperDemo's
check after its ``ms`` read (``DemoBuild.e_read_block_ticks``), the replica tool that
reads each window's start against timer 0 (``bench/replica/window_starts.py``) and
``bench/e_fidelity.py``'s oracle that puts each window's first block at the firmware's
(``--replay-starts``) and its histograms of the starts."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import e_fidelity  # noqa: E402

INPUT = "M1 A30000 V45 e f w600 S W"


def _window_starts(blocks: list[tuple[int, int]]) -> list[int]:
    return [a for i, (a, _) in enumerate(blocks) if i == 0 or a - blocks[i - 1][0] > 100_000]


def _blocks() -> list[tuple[int, int]]:
    blocks: list[tuple[int, int]] = []
    e_fidelity.run_model(INPUT, "atmega328p", "e", blocks)
    return blocks


def _pitches(blocks: list[tuple[int, int]]) -> set[int]:
    """The six most common pitches between two blocks (ticks)."""
    from collections import Counter

    return {p for p, _ in Counter(b[0] - a[1] for a, b in zip(blocks, blocks[1:], strict=False)
                                  if b[0] - a[1] < 1000).most_common(6)}


def test_the_check_after_the_read_moves_each_window_start_not_the_pitch(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from stepperdemo.demo import build as demo_build_module

    plain = _blocks()
    table = {k: replace(v, e_read_block_ticks=26)
             for k, v in demo_build_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(demo_build_module.BY_BUILD, "e", table)
    checked = _blocks()
    # the loop woken at a window's deadline reads ms at once and blocks 26 ticks later
    later = [b - a for a, b in zip(_window_starts(plain), _window_starts(checked),
                                   strict=True)]
    assert later == [26] * len(later) and len(later) == 5
    # the 26 ticks are the pass's own: the pitches between two blocks stay (270 on the
    # pause path, 275 / 376 while W holds the input, + 120 with a step interrupt ...;
    # a few interrupts fall on the other side of a block now)
    assert _pitches(checked) == _pitches(plain) == {270, 275, 376, 390, 395, 496}
    # ... and so does the number of blocks, but for where the blocks fall against the
    # step compares (a missed compare's wrap frees the loop): within one per window
    assert abs(len(checked) - len(plain)) <= len(later)


def test_replay_puts_each_windows_first_block_at_the_given_tick() -> None:
    from fas.sim import SimBackend
    from stepperdemo.program import make_program

    plain = _window_starts(_blocks())
    wanted = [a + 300 for a in plain[:2]] + [a - 300 for a in plain[2:]]
    backend = SimBackend("atmega328p", record=True, build="e")
    blocks: list[tuple[int, int]] = []
    backend.machine.block_listeners.append(lambda a, b: blocks.append((a, b)))
    e_fidelity._replay(backend, wanted)  # noqa: SLF001
    make_program("demo", backend, scripted=True).run_script(INPUT, firmware_end=True)
    got = _window_starts(blocks)
    # a later start is met (an interrupt at that tick may hold it a little); an
    # earlier one cannot be: the model's own start stays
    assert all(0 <= g - w < 130 for g, w in zip(got[:2], wanted[:2], strict=True))
    assert got[2:] == plain[2:]


def test_start_histograms_compare_the_two_sides() -> None:
    text = e_fidelity.start_histograms([(218, 101), (374, 101), (439, 301)])
    assert "on both sides: 3" in text
    assert "firmware mean 344" in text and "200:1 300:1 400:1" in text
    assert "model    mean 168" in text and "100:2 300:1" in text
    assert "|model - firmware| 176 ticks" in text
    assert e_fidelity.start_histograms([]) == "no window starts both sides"


def _replica_ev(path: Path) -> int:
    """A replica run: timer 0 every 16 384 ticks (97 ticks with its entry), the loop's
    ``ms`` read (9 ticks at site 5270) every 300 ticks of loop CPU, a 100 us block
    (site 62f0) 26 ticks after a read inside a window.  Returns the tick of timer 0's
    entry that makes millis() reach 256."""
    lines: list[tuple[int, str]] = []
    ov_256 = 0
    m = f = 0
    t0 = [1000 + 16_384 * k for k in range(260)]
    for k, t in enumerate(t0):
        lines += [(t, f"{t} V 16"), (t + 93, f"{t + 93} R")]
        before = m
        m, f = m + 1, f + 3
        if f >= 125:
            m, f = m + 1, f - 125
        if m // 256 > before // 256:
            ov_256 = t
        if k >= 240:  # the loop's reads around the window's deadline
            for r in (t - 100, t + 200):
                lines += [(r, f"{r} C 5270"), (r + 9, f"{r + 9} S 5270")]
                if k >= 249 and (r > ov_256 > 0):
                    lines += [(r + 26, f"{r + 26} C 62f0"), (r + 1608, f"{r + 1608} S 62f0")]
    path.write_text("\n".join(text for _, text in sorted(lines)) + "\n")
    return ov_256


def test_window_starts_reads_the_pass_the_overflow_fell_in(tmp_path: Path) -> None:
    import window_starts

    ov = _replica_ev(tmp_path / "e01.ev")
    rows = window_starts.windows("e01", tmp_path)
    assert len(rows) == 1
    r = rows[0]
    assert r["ov"] == ov
    # the block: the read 200 ticks after the overflow's entry, then 26 ticks
    assert r["start"] == 226
    # the pass from the read 100 ticks before the overflow to the one after, without
    # timer 0's 93 ticks and its 4-tick entry
    assert r["pass"] == 300 - 97
    assert r["at"] == 100
    assert r["rest"] == 226 - 97
    assert r["isr"] == {"16": 97}
    assert window_starts.biased_rest([272, 373]) == pytest.approx((272**2 + 373**2) / 1290)


def test_align_first_steps_puts_each_first_step_at_the_firmwares(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    import gzip

    from fas.sim.channel import SimChannel

    monkeypatch.setattr(SimChannel, "start", SimChannel.start)  # restored afterwards
    monkeypatch.setattr(e_fidelity, "ALIGN_FIRST_STEPS", {})
    inp = "M1 A30000 V45 f w100 S W"
    plain = e_fidelity.step_times_us(e_fidelity.run_model(inp, "atmega328p", "e"), 9)
    folder = tmp_path / "e01"
    folder.mkdir()
    (folder / "input.txt").write_text(inp + "\n")
    fw_first = plain[0] + 50.0  # the firmware's first rise 50 us (800 ticks) later
    with gzip.open(folder / "steps_A.tsv.gz", "wt") as f:
        f.write(f"{fw_first:.3f}\t1\n{fw_first + 4000:.3f}\t1\n")
    e_fidelity.align_first_steps(tmp_path)
    # the shift is what brings the rise there (a UART interrupt nested in the task
    # after the shift stretches it: less than the 800 ticks)
    shift = e_fidelity.ALIGN_FIRST_STEPS[inp, "atmega328p"][9]
    assert 0 < shift <= 800
    aligned = e_fidelity.step_times_us(e_fidelity.run_model(inp, "atmega328p", "e"), 9)
    assert round((aligned[0] - fw_first) * 16) == 0
    assert len(aligned) == len(plain)
