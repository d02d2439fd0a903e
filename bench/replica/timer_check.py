"""Timer 1's compares against the hardware rule: which ones did the simulator not raise?

Reads the event file that ``replica_run`` writes with ``TIMER_CHECK`` (``replica.py
--timer-check``: ``WORK/CASE.timer``; docs/timing-model.md, "twenty-fifth pass"):

    T cycle            timer 1's overflow flag raised
    C cycle ch         compare channel ch's flag raised
    W cycle ch value   OCR1x holds a new value (seen after the writing instruction)

In normal mode the counter wraps every 65 536 cycles (prescaler 1), and a channel
matches where TCNT1 == OCR1x: its flag rises one cycle later, at ``overflow + OCR + 1``
(the datasheet's "at the next timer clock").  Every such moment while a value is held
is an expected compare; one without a flag within ``slack`` cycles is *missing* (the
simulator lost it), a flag no expected moment explains is *extra*.  The first and last
``slack`` cycles of a value's span, and of the file, are not judged (where the write lands
within its instruction; the start-up code's timer settings before the first overflow of
the run's phase).  The overflow's moment is the earliest of its flags' residues and of
the compares' (flag - OCR - 1): the simulator raises a flag after the instruction that
spans its moment, 0-3 cycles late.

    python3 bench/replica/timer_check.py WORK/CASE.timer ... [--show N]
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from dataclasses import dataclass, field
from pathlib import Path

PERIOD = 65536  # timer 1, normal mode, prescaler 1
SLACK = 5  # cycles: an instruction's length plus the write's place in it


@dataclass
class Missing:
    """An expected compare without a flag."""

    cycle: int  # the hardware's flag moment
    channel: int
    ocr: int
    written: int  # the cycle the value was seen written
    after_overflow: int  # cycles after the last overflow


@dataclass
class Report:
    """What one event file holds against the hardware rule."""

    overflows: int = 0
    phase: int | None = None  # the overflow's moment modulo PERIOD
    expected: dict[int, int] = field(default_factory=dict)  # channel -> compares
    missing: list[Missing] = field(default_factory=list)
    extra: dict[int, int] = field(default_factory=dict)  # channel -> flags unexplained
    extra_at: list[tuple[int, int]] = field(default_factory=list)  # (cycle, channel)
    # expected compares by cycles after the overflow, in bins of BIN cycles
    after_overflow: collections.Counter[int] = field(default_factory=collections.Counter)

    def summary(self) -> str:
        exp = sum(self.expected.values())
        return (f"{self.overflows} overflows, {exp} expected compares, "
                f"{len(self.missing)} missing, {sum(self.extra.values())} extra")


BIN = 50


def parse(lines: list[str]) -> tuple[list[int], dict[int, list[int]],
                                     dict[int, list[tuple[int, int]]]]:
    """The overflows, each channel's flags and each channel's writes (cycle, value)."""
    tovs: list[int] = []
    flags: dict[int, list[int]] = collections.defaultdict(list)
    writes: dict[int, list[tuple[int, int]]] = collections.defaultdict(list)
    for line in lines:
        f = line.split()
        if not f:
            continue
        if f[0] == "T":
            tovs.append(int(f[1]))
        elif f[0] == "C":
            flags[int(f[2])].append(int(f[1]))
        elif f[0] == "W":
            writes[int(f[2])].append((int(f[1]), int(f[3])))
    return tovs, flags, writes


def overflow_phase(tovs: list[int]) -> tuple[int, int] | None:
    """The overflow's moment modulo PERIOD and the first overflow that keeps it.

    The most common residue's class (within SLACK); before it the start-up code runs
    the timer with other settings (the Arduino core's prescaler 64).
    """
    if not tovs:
        return None
    ref = collections.Counter(t % PERIOD for t in tovs).most_common(1)[0][0]
    d = [((t - ref + PERIOD // 2) % PERIOD) - PERIOD // 2 for t in tovs]
    near = [x for x in d if abs(x) <= SLACK]
    phase = (ref + min(near)) % PERIOD
    first = next(t for t, x in zip(tovs, d, strict=True) if abs(x) <= SLACK)
    return phase, first


def check(lines: list[str], slack: int = SLACK) -> Report:
    """Every expected compare of every channel, set against the flags."""
    tovs, flags, writes = parse(lines)
    rep = Report(overflows=len(tovs))
    found = overflow_phase(tovs)
    if found is None:
        return rep
    phase, first = found
    # a flag is raised after the instruction that spans its moment: every overflow may
    # be late, so the compares' flags bound the moment too (flag - OCR - 1)
    for ch, seen in flags.items():
        ws = [(0, 0), *writes.get(ch, [])]
        wc = [c for c, _ in ws]
        for t in seen:
            if t < first:
                continue
            v = ws[bisect.bisect_right(wc, t) - 1][1]
            d = ((t - v - 1 - phase + PERIOD // 2) % PERIOD) - PERIOD // 2
            if -SLACK <= d < 0:
                phase = (phase + d) % PERIOD
    rep.phase = phase
    # the last event ends what is judged (the run's end is not in the file)
    end = max([tovs[-1], *(f[-1] for f in flags.values() if f),
               *(w[-1][0] for w in writes.values() if w)]) + 1
    for ch in sorted(set(writes) | set(flags)):
        seen = sorted(flags.get(ch, []))
        used = [False] * len(seen)
        n = 0
        ws = [(0, 0), *writes.get(ch, [])]  # OCR1x is 0 from reset; W lines are changes
        for i, (c, v) in enumerate(ws):
            stop = ws[i + 1][0] if i + 1 < len(ws) else end
            if stop <= first:
                continue
            c = max(c, first)
            # first moment >= c with moment = phase + v + 1 (mod PERIOD)
            m = c + ((phase + v + 1 - c) % PERIOD)
            while m < stop:
                if c + slack < m < stop - slack:
                    n += 1
                    after = (m - phase) % PERIOD
                    rep.after_overflow[after // BIN * BIN] += 1
                    j = bisect.bisect_left(seen, m)
                    if j < len(seen) and seen[j] <= m + slack:
                        used[j] = True
                    else:
                        rep.missing.append(Missing(m, ch, v, c, after))
                m += PERIOD
        # flags near a write are not judged; the rest must be explained
        wc = [c for c, _ in ws]
        extra = 0
        for j, t in enumerate(seen):
            if used[j] or t <= first + slack or t >= end - slack:
                continue
            k = bisect.bisect_right(wc, t)
            near = any(abs(t - wc[q]) <= slack + 1 for q in (k - 1, k) if 0 <= q < len(wc))
            if not near:
                extra += 1
                rep.extra_at.append((t, ch))
        rep.expected[ch] = n
        rep.extra[ch] = extra
    return rep


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--show", type=int, default=10, help="missing compares to list")
    ap.add_argument("--bins", action="store_true",
                    help="expected compares by cycles after the overflow (first 1000)")
    args = ap.parse_args(argv)
    total: collections.Counter[str] = collections.Counter()
    bins: collections.Counter[int] = collections.Counter()
    for path in args.files:
        rep = check(path.read_text().splitlines())
        print(f"{path.stem}: {rep.summary()}")
        for m in rep.missing[:args.show]:
            print(f"  missing: channel {m.channel} at {m.cycle} ({m.cycle / 16:.3f} us), "
                  f"OCR {m.ocr} written at {m.written}, {m.after_overflow} after the overflow")
        total["expected"] += sum(rep.expected.values())
        total["missing"] += len(rep.missing)
        total["extra"] += sum(rep.extra.values())
        bins.update(rep.after_overflow)
    if len(args.files) > 1:
        print(f"all: {total['expected']} expected, {total['missing']} missing, "
              f"{total['extra']} extra")
    if args.bins:
        print(" ".join(f"{b}:{bins[b]}" for b in range(0, 1000, BIN)))
    return 1 if total["missing"] else 0


if __name__ == "__main__":
    sys.exit(main())
