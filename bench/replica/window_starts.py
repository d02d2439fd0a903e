"""Where each `e` window starts against timer 0's overflow, read from a replica run:
the pass of the loop in progress when the overflow makes ``millis()`` reach the window
(docs/timing-model.md, "twenty-second pass").

StepperDemo's ``loop()`` reads ``ms = millis()`` once per pass and blocks interrupts
for 100 us right after it when ``(ms & 0xff) < 0x40``.  So a window's first block comes
where the loop next reads ``ms`` after the timer-0 interrupt that makes ``millis()`` a
multiple of 256: the rest of the pass the overflow fell in, plus the interrupts that run
meanwhile.  Per window this prints, from the replica's ``CASE.ev`` (``replica.py
steps CASE`` writes it, with the loop's ``cli``/``sei`` lines):

* ``start``: the first block's ``cli`` less the timer-0 interrupt's entry (ticks; what
  ``e_fidelity.py --starts`` reads from the firmware's blocks, there against the
  model's overflow);
* ``pass``: the loop CPU (interrupts removed) of the pass the overflow fell in, from the
  ``ms`` read before it to the one after; ``at``: the overflow's position in it (loop
  CPU); ``rest``: ``pass - at`` plus the read's ``cli`` to the block's;
* ``isr``: the interrupts' ticks between the overflow and the block, by vector;
* ``passes skipped``: passes after the overflow's whose read did not block (a pass
  with a command or a print before the read, a ramp task, ...);
* the pass's kind: ``P`` the pause check (a ``w`` running), ``U`` a character handed to
  the serial port, ``B`` the block (inside a window), ``-`` none of these.

Then, over all windows of the cases given: the histogram of ``start`` and of ``at /
pass`` (uniform if the overflow falls anywhere in a pass) and the pass lengths'
length-biased mean rest, ``E[L^2] / (2 E[L])`` over the passes of the 16 ms before
each window: what a model that knows the pass lengths by path but not the loop's phase
draws on average.

    python3 bench/replica/window_starts.py --work /tmp/h-winstart-rep e06 e07 e11
    python3 bench/replica/window_starts.py --work /tmp/e16p --hist e01 e09 e18
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from pathlib import Path

ENTRY_TICKS = 4  # the hardware's interrupt entry before the vector's first instruction
BLOCK_TICKS = (1500, 1700)  # a 100 us block: cli ... sei (1 582 ticks)
TIMER0 = {"atmega328p": 16, "atmega2560": 23}
CHIP = {"e13": "atmega2560", "e14": "atmega2560"}
MILLIS_FRACT_INC, MILLIS_FRACT_MAX = 3, 125  # the Arduino core's timer-0 ISR
BEFORE_TICKS = 16 * 16_000  # passes looked at before each window (length-biased mean)
BIN = 100  # histogram bins (ticks)
WINDOW_TICKS = 64 * 16_000  # a window's blocks: while millis() & 0xff < 0x40


class Run:
    """One replica run's loop sections, interrupts and loop CPU clock."""

    def __init__(self, ev: Path, timer0: int) -> None:
        self.sections: list[tuple[int, str, int]] = []  # (cli tick, site, ticks to sei)
        self.isrs: list[tuple[int, int, str]] = []  # outermost: (entry, reti, vector)
        self.t0: list[int] = []  # timer 0's entries (nested or not)
        depth = 0
        entry, vec = 0, ""
        cli: tuple[int, str] | None = None
        t0v = str(timer0)
        with open(ev) as f:
            for line in f:
                p = line.split()
                t, kind = int(p[0]), p[1]
                if kind == "V":
                    if p[2] == t0v:
                        self.t0.append(t)
                    if not depth:
                        entry, vec = t, p[2]
                    depth += 1
                elif kind == "R":
                    depth -= 1
                    if not depth:
                        self.isrs.append((entry, t, vec))
                elif kind == "C":
                    cli = (t, p[2])
                elif kind == "S" and cli is not None:
                    self.sections.append((cli[0], cli[1], t - cli[0]))
                    cli = None
        self.isr_starts = [a for a, _, _ in self.isrs]
        # loop CPU before each interrupt's entry: cumulative interrupt ticks
        self.cum: list[int] = []
        s = 0
        for a, b, _ in self.isrs:
            self.cum.append(s)
            s += b - a + ENTRY_TICKS
        blocks = [s for s in self.sections if BLOCK_TICKS[0] <= s[2] < BLOCK_TICKS[1]]
        self.block_site = collections.Counter(s for _, s, _ in blocks).most_common(1)[0][0]
        self.blocks = [t for t, s, _ in self.sections if s == self.block_site]
        # the read of ms: the section most often right before a block
        cli_ticks = [t for t, _, _ in self.sections]
        before = collections.Counter()
        for b in self.blocks:
            i = bisect.bisect_left(cli_ticks, b) - 1
            if i >= 0:
                before[self.sections[i][1]] += 1
        self.read_site = before.most_common(1)[0][0]
        self.reads = [t for t, s, _ in self.sections if s == self.read_site]
        self.cli_ticks = cli_ticks

    def cpu(self, t: int) -> int:
        """Loop CPU ticks up to tick ``t`` (interrupts and their entries removed)."""
        i = bisect.bisect_right(self.isr_starts, t) - 1
        if i < 0:
            return t
        a, b, _ = self.isrs[i]
        inside = min(t, b + ENTRY_TICKS) - a if t < b + ENTRY_TICKS else b - a + ENTRY_TICKS
        return t - self.cum[i] - inside

    def isr_between(self, lo: int, hi: int) -> collections.Counter[str]:
        out: collections.Counter[str] = collections.Counter()
        i = bisect.bisect_left(self.isr_starts, lo)
        while i < len(self.isrs) and self.isrs[i][0] < hi:
            a, b, v = self.isrs[i]
            out[v] += b - a + ENTRY_TICKS
            i += 1
        return out

    def window_overflows(self) -> list[int]:
        """Timer 0's entries that make ``millis()`` a multiple of 256 (k >= 1)."""
        m = f = 0
        out = []
        for t in self.t0:
            before = m
            m += 1
            f += MILLIS_FRACT_INC
            if f >= MILLIS_FRACT_MAX:
                f -= MILLIS_FRACT_MAX
                m += 1
            if m // 256 > before // 256:
                out.append(t)
        return out

    def kind(self, lo: int, hi: int) -> str:
        sites = {s for t, s, _ in self.sections[bisect.bisect_left(self.cli_ticks, lo):
                                                   bisect.bisect_left(self.cli_ticks, hi)]}
        k = ""
        if any(s != self.read_site and s in self.pause_sites for s in sites):
            k += "P"
        if any(s in self.uart_sites for s in sites):
            k += "U"
        if self.block_site in sites:
            k += "B"
        return k or "-"

    pause_sites: set[str] = set()
    uart_sites: set[str] = set()


def windows(case: str, work: Path) -> list[dict[str, object]]:
    chip = CHIP.get(case, "atmega328p")
    run = Run(work / f"{case}.ev", TIMER0[chip])
    # the pause check: a 9-tick section of main() other than the read (both are millis())
    nine = collections.Counter(s for _, s, n in run.sections if n == 9 and s != run.read_site)
    run.pause_sites = {s for s, _ in nine.most_common(1)}
    # HardwareSerial::write's section: the 14-tick one
    run.uart_sites = {s for s, n in collections.Counter(
        s for _, s, n in run.sections if n == 14).most_common(1)}
    rows = []
    for ov in run.window_overflows():
        i = bisect.bisect_left(run.blocks, ov)
        if i >= len(run.blocks):
            break
        blk = run.blocks[i]
        if blk - ov >= WINDOW_TICKS:
            continue  # `e` off in this window (e08 switches it on and off)
        j = bisect.bisect_left(run.reads, blk) - 1
        k = bisect.bisect_left(run.reads, ov) - 1
        if j < 0 or k < 0:
            continue
        rd, prev = run.reads[j], run.reads[k]
        nxt = run.reads[k + 1] if k + 1 < len(run.reads) else rd
        length = run.cpu(nxt) - run.cpu(prev)
        at = run.cpu(ov) - run.cpu(prev)
        # the passes of the 16 ms before: their loop CPU lengths
        a = bisect.bisect_left(run.reads, ov - BEFORE_TICKS)
        lens = [run.cpu(run.reads[n + 1]) - run.cpu(run.reads[n]) for n in range(a, k)]
        rows.append({
            "case": case, "ov": ov, "start": blk - ov, "pass": length, "at": at,
            "rest": run.cpu(blk) - run.cpu(ov), "passes": j - k - 1,
            "isr": run.isr_between(ov, blk), "kind": run.kind(prev, nxt), "lens": lens,
        })
    return rows


def biased_rest(lens: list[int]) -> float:
    """Mean wait from a random instant to the pass's end: E[L^2] / (2 E[L])."""
    return sum(x * x for x in lens) / (2 * sum(lens)) if lens else 0.0


def hist(values: list[int], lo: int, hi: int, width: int) -> str:
    c = collections.Counter(min(hi, max(lo, v)) // width * width for v in values)
    return " ".join(f"{b}:{c[b]}" for b in range(lo // width * width, hi + 1, width) if c[b])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, action="append",
                    help="replica run folders (CASE.ev); the first holding CASE is read")
    ap.add_argument("--hist", action="store_true", help="only the histograms")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    works = args.work or [Path("/tmp/fas-replica")]
    allrows = []
    for case in args.cases:
        work = next((w for w in works if (w / f"{case}.ev").exists()), None)
        if work is None:
            print(f"{case}: no replica run in {' '.join(map(str, works))}")
            continue
        rows = windows(case, work)
        allrows += rows
        if args.hist:
            continue
        print(f"## {case} ({work})")
        print("| overflow (ms) | start | pass | at | rest (loop CPU) | passes skipped "
              "| kind | interrupts by vector (ticks) | biased mean rest before |")
        print("| --- " * 9 + "|")
        for r in rows:
            isr = " ".join(f"{v}:{n}" for v, n in sorted(r["isr"].items()))
            print(f"| {r['ov'] / 16_000:.3f} | {r['start']} | {r['pass']} | {r['at']} | "
                  f"{r['rest']} | {r['passes']} | {r['kind']} | {isr} | "
                  f"{biased_rest(r['lens']):.0f} |")
    starts = [r["start"] for r in allrows]
    frac = [round(100 * r["at"] / r["pass"]) for r in allrows if r["pass"]]
    print(f"\nall {len(allrows)} windows: start (ticks after timer 0's entry) "
          f"{hist(starts, 0, 2000, BIN)}")
    print(f"overflow's place in its pass (% of the pass): {hist(frac, 0, 100, 10)}")
    plain = [r for r in allrows if r["start"] < 2000]
    if plain:
        mean = sum(r["start"] for r in plain) / len(plain)
        rest = sum(biased_rest(r["lens"]) for r in plain) / len(plain)
        print(f"starts below 2000: {len(plain)}, mean {mean:.0f}; the passes before: "
              f"length-biased mean rest {rest:.0f} (loop CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
