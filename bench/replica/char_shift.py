"""What one more input character costs the firmware: two replica runs of the same build
whose inputs differ by a character, side by side (docs/timing-model.md, "forty-first pass").

Per run pair (``replica.py steps`` writes ``CASE.ev`` and ``CASE.pins``; e.g. e09's input
with one more space and a control of the same length with the space at the line's end):

* ``loop``: the loop's own critical sections (the ``C`` lines: the loop's ``millis()``
  read, the serial driver's sections, ...) matched in order by site between the two runs
  (a longest-common-subsequence match, so one run's extra pass is left out), and each
  matched section's shift (the second run less the first), in ``BIN_MS`` bins from ``--from``
  to ``--to``: the commonest shifts per bin.  A shift that stays means the loop's pass
  chain carries the character; a shift of a pass length less the character's cost means
  the chain is one pass behind at nearly the same phase.
* per window: the first block's shift, the commonest shifts of the window's blocks
  (matched by index), and stepper A's wraps (timer-1 intervals over ``WRAP_MIN``) on each
  side, with the first wrap where the two runs part.
* ``--model``: the same two inputs (``--conformance COPY``'s ``CASE/input.txt``, the line
  kept as it is, trailing spaces included) in the model (build e), each window's first
  block's shift and (with ``--to``) its console writes' shifts per bin, with ``--set`` as
  in ``e_fidelity.py``.

    python3 bench/replica/char_shift.py --work /tmp/h-e09c/rep --from 1452 --to 1545 \\
        e09s7 e09s1
    python3 bench/replica/char_shift.py --work /tmp/h-e09c/rep --model \\
        --conformance /tmp/h-e09c/conf [--set e_every_pass=1] e09s7 e09s1
"""

from __future__ import annotations

import argparse
import collections
import difflib
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from block_pulses import replica_blocks  # noqa: E402
from pulse_widths import replica_rises  # noqa: E402

TICKS_PER_MS = 16_000
WINDOW_TICKS = 256 * TICKS_PER_MS  # a window every 256 ms of millis() (timer 1's ticks)
WRAP_MIN = 60_000  # an interval this long holds a wrap of timer 1
BIN_MS = 10
PART_TICKS = 1_000  # a wrap this much later or earlier on the other side: the runs part
PIN_A = "B1"  # the ATmega328P's OC1A: stepper A

Section = tuple[str, int]  # (site, cli tick)
Span = tuple[int, int]


def loop_sections(lines: Iterable[str], lo: int, hi: int) -> list[Section]:
    """The loop's critical sections ``(site, tick)`` of an interrupt log within [lo, hi)."""
    out: list[Section] = []
    for line in lines:
        p = line.split()
        if len(p) < 3 or p[1] != "C":
            continue
        t = int(p[0])
        if t >= hi:
            break
        if t >= lo:
            out.append((p[2], t))
    return out


def matched_shifts(a: Sequence[Section], b: Sequence[Section]) -> list[tuple[int, int]]:
    """(tick in ``a``, shift ``b - a``) of every section matched by site in order."""
    sm = difflib.SequenceMatcher(a=[s for s, _ in a], b=[s for s, _ in b], autojunk=False)
    out: list[tuple[int, int]] = []
    for blk in sm.get_matching_blocks():
        for j in range(blk.size):
            x, y = a[blk.a + j][1], b[blk.b + j][1]
            out.append((x, y - x))
    return out


def binned(shifts: Sequence[tuple[int, int]], bin_ticks: int, top: int = 3
           ) -> list[tuple[int, list[tuple[int, int]]]]:
    """Per bin (its first tick): the ``top`` commonest shifts with their counts."""
    bins: dict[int, collections.Counter[int]] = {}
    for t, d in shifts:
        bins.setdefault(t // bin_ticks * bin_ticks, collections.Counter())[d] += 1
    return [(k, c.most_common(top)) for k, c in sorted(bins.items())]


def window_blocks(blocks: Sequence[Span]) -> dict[int, list[Span]]:
    out: dict[int, list[Span]] = {}
    for a, b in blocks:
        out.setdefault(a // WINDOW_TICKS, []).append((a, b))
    return out


def wraps(rises: Sequence[int], window: int) -> list[int]:
    """The rises in ``window`` that are followed by a wrap (their ticks)."""
    return [rises[i] for i in range(len(rises) - 1)
            if rises[i] // WINDOW_TICKS == window and rises[i + 1] - rises[i] > WRAP_MIN]


def window_rows(blocks_a: Sequence[Span], blocks_b: Sequence[Span], rises_a: Sequence[int],
                rises_b: Sequence[int]) -> list[dict]:
    """Per window: the first block's shift, the blocks' commonest shifts by index, the
    wraps of A on each side and the first wrap (side a's tick) where they part."""
    wa, wb = window_blocks(blocks_a), window_blocks(blocks_b)
    rows = []
    for w in sorted(set(wa) & set(wb)):
        x, y = wa[w], wb[w]
        shifts = collections.Counter(q[0] - p[0] for p, q in zip(x, y, strict=False))
        ka, kb = wraps(rises_a, w), wraps(rises_b, w)
        part = next((p for p, q in zip(ka, kb, strict=False) if abs(q - p) > PART_TICKS), None)
        if part is None and len(ka) != len(kb):
            part = (ka + [None])[min(len(ka), len(kb))]
        rows.append({"window": w, "first": y[0][0] - x[0][0], "blocks": (len(x), len(y)),
                     "shifts": shifts.most_common(3), "wraps": (len(ka), len(kb)),
                     "part": part})
    return rows


def model_run(inp: str, sets: Sequence[str]) -> tuple[dict[int, int], list[int]]:
    """The model's (build e, ATmega328P) first block of each window for an input line,
    and the ticks of its console writes."""
    import e_fidelity as ef
    from command_costs import model_hooks

    if sets:
        ef.set_timing(list(sets))
    blocks: list[Span] = []
    with model_hooks() as log:
        ef.run_model(inp, "atmega328p", "e", blocks)
    return {w: v[0][0] for w, v in window_blocks(blocks).items()}, list(log["write"])


def _read_run(work: Path, case: str) -> tuple[list[Span], list[int]]:
    with open(work / f"{case}.ev") as f:
        blocks = replica_blocks(f, 0)
    return blocks, replica_rises(work / f"{case}.pins", PIN_A)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, required=True, help="the replica runs' folder")
    ap.add_argument("--from", dest="lo", type=float, default=0.0, help="ms (loop sections)")
    ap.add_argument("--to", dest="hi", type=float, default=0.0, help="ms (0: no loop table)")
    ap.add_argument("--model", action="store_true", help="the model's window starts too")
    ap.add_argument("--conformance", type=Path, help="the folders of the two inputs")
    ap.add_argument("--set", action="append", default=[], help="FIELD=VALUE (model)")
    ap.add_argument("first")
    ap.add_argument("second")
    a = ap.parse_args(argv)
    if a.hi > a.lo:
        lo, hi = round(a.lo * TICKS_PER_MS), round(a.hi * TICKS_PER_MS)
        with open(a.work / f"{a.first}.ev") as f1, open(a.work / f"{a.second}.ev") as f2:
            s1, s2 = loop_sections(f1, lo, hi), loop_sections(f2, lo, hi)
        print(f"## loop sections {a.second} less {a.first} ({len(s1)} / {len(s2)} sections)")
        print("| from (ms) | commonest shifts (ticks: sections) |")
        print("| --- | --- |")
        for t, top in binned(matched_shifts(s1, s2), BIN_MS * TICKS_PER_MS):
            print(f"| {t / TICKS_PER_MS:.0f} | " + ", ".join(f"{d}: {n}" for d, n in top) + " |")
    (b1, r1), (b2, r2) = _read_run(a.work, a.first), _read_run(a.work, a.second)
    model: dict[int, int] = {}
    if a.model:
        if a.conformance is None:
            ap.error("--model needs --conformance")
        (f1, w1), (f2, w2) = (model_run((a.conformance / c / "input.txt").read_text()
                                        .rstrip("\n"), a.set) for c in (a.first, a.second))
        model = {w: f2[w] - f1[w] for w in f1 if w in f2}
        if a.hi > a.lo and len(w1) == len(w2):
            lo, hi = round(a.lo * TICKS_PER_MS), round(a.hi * TICKS_PER_MS)
            print(f"## the model's console writes {a.second} less {a.first}")
            print("| from (ms) | commonest shifts (ticks: writes) |")
            print("| --- | --- |")
            pairs = [(x, y - x) for x, y in zip(w1, w2, strict=True) if lo <= x < hi]
            for t, top in binned(pairs, BIN_MS * TICKS_PER_MS):
                print(f"| {t / TICKS_PER_MS:.0f} | "
                      + ", ".join(f"{d}: {n}" for d, n in top) + " |")
    print(f"## windows {a.second} less {a.first}")
    print("| window | first block | blocks | commonest block shifts | A's wraps | parts at (ms)"
          + (" | model: first block |" if a.model else " |"))
    print("| --- | --- | --- | --- | --- | ---" + (" | --- |" if a.model else " |"))
    for r in window_rows(b1, b2, r1, r2):
        part = "-" if r["part"] is None else f"{r['part'] / TICKS_PER_MS:.3f}"
        cells = [str(r["window"]), str(r["first"]), "%d / %d" % r["blocks"],
                 ", ".join(f"{d}: {n}" for d, n in r["shifts"]), "%d / %d" % r["wraps"], part]
        if a.model:
            cells.append(str(model.get(r["window"], "-")))
        print("| " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
