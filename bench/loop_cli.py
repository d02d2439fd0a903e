"""The main loop's own critical sections, read from a replica run of the firmware.

While a stepper runs, StepperDemo's ``loop()`` turns interrupts off for a few ticks at
fixed places of each pass (``isRunning()``'s queue read, ``millis()``, a position read,
``HardwareSerial::write``); a step compare that falls inside one makes its interrupt
wait for the section's end, and the pulse is longer by that much (issue 23 item 2).
The replica's runner (``bench/replica/replica.py``) records each ``cli`` and ``sei``
of the main program (``C addr`` / ``S addr`` lines of ``CASE.ev``, no interrupt
running).  This tool reads them for the span from the first to the last rise of a step
pin and prints:

* per site (the address of its ``cli``): sections, per ms, ticks from ``cli`` to the
  instruction that turns interrupts on again, and the share of the time;
* the loop's passes, a pass starting at the most frequent site: per kind of pass (its
  sites in order) the count, each section's offset in the pass and the pass length,
  both in the loop's own CPU time (the interrupts' time removed, their 4-tick hardware
  entry included);
* per site, how long after the section's end the step interrupt of a pulse rising
  inside it entered (pulse width beyond the plain width, less the section's remaining
  ticks): the instruction the CPU runs after interrupts come on again.

    python3 bench/replica/replica.py --fas FAS-1.2.6 --simavr SIMAVR --work /tmp/pw steps e02
    python3 bench/loop_cli.py --replica /tmp/pw e02
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pulse_widths import PROFILE, REPLICA, replica_pulses  # noqa: E402

ENTRY_TICKS = 4  # the hardware's interrupt entry before the vector's first instruction
TICKS_PER_MS = 16_000


def read_ev(ev: Path) -> tuple[list[tuple[int, int, str, int]], list[tuple[int, int]]]:
    """([(cli tick, loop CPU tick at the cli, site, ticks to the sei)],
    [(entry, reti)] of the outermost interrupts)."""
    sections: list[tuple[int, int, str, int]] = []
    isrs: list[tuple[int, int]] = []
    depth = 0
    entry = 0
    isr_ticks = 0
    cli: tuple[int, int, str] | None = None
    with open(ev) as f:
        for line in f:
            parts = line.split()
            t = int(parts[0])
            kind = parts[1]
            if kind == "V":
                if not depth:
                    entry = t
                depth += 1
            elif kind == "R":
                depth -= 1
                if not depth:
                    isrs.append((entry, t))
                    isr_ticks += t - entry + ENTRY_TICKS
            elif kind == "C":
                cli = (t, t - isr_ticks, parts[2])
            elif kind == "S" and cli is not None:
                sections.append((cli[0], cli[1], cli[2], t - cli[0]))
                cli = None
    return sections, isrs


def _few(items: tuple[object, ...], shown: int = 6) -> str:
    """The first ``shown`` items (a pass that prints has dozens of sections)."""
    text = " ".join(str(x) for x in items[:shown])
    return text if len(items) <= shown else f"{text} ... ({len(items)} in all)"


def report(case: str, replica: Path, letter: str) -> None:
    board = PROFILE.get(case, "atmega328p")
    pin, _vec = REPLICA[board][letter]
    pulses = replica_pulses(replica / f"{case}.pins", pin)
    if not pulses:
        print(f"## {case} {letter}: no pulses")
        return
    t0, t1 = pulses[0][0], pulses[-1][0]
    sections, _isrs = read_ev(replica / f"{case}.ev")
    inside = [s for s in sections if t0 <= s[0] <= t1]
    span_ms = (t1 - t0) / TICKS_PER_MS
    print(f"## {case} {letter} ({board}): {len(pulses)} pulses, {span_ms:.1f} ms "
          f"from the first rise to the last")
    if not inside:
        print("no critical sections of the loop recorded in that span (a run without "
              "`C`/`S` lines?)")
        return
    by_site: dict[tuple[str, int], int] = collections.Counter(
        (site, ticks) for _, _, site, ticks in inside)
    print("| site | ticks | sections | per ms | share of the time |")
    print("| --- | --- | --- | --- | --- |")
    for (site, ticks), n in sorted(by_site.items(), key=lambda kv: -kv[1])[:12]:
        print(f"| {site} | {ticks} | {n} | {n / span_ms:.1f} | "
              f"{100 * n * ticks / (t1 - t0):.2f} % |")
    off = sum(ticks for _, _, _, ticks in inside)
    print(f"interrupts off in the loop: {100 * off / (t1 - t0):.2f} % of the time")
    # passes, each starting at the most frequent site
    start_site = collections.Counter(site for _, _, site, _ in inside).most_common(1)[0][0]
    passes: list[list[tuple[int, str, int]]] = []
    for _, cpu, site, ticks in inside:
        if site == start_site:
            passes.append([(cpu, site, ticks)])
        elif passes:
            passes[-1].append((cpu, site, ticks))
    kinds: dict[tuple[str, ...], list[tuple[tuple[int, ...], int]]] = (
        collections.defaultdict(list))
    for a, b in zip(passes, passes[1:], strict=False):
        base = a[0][0]
        kinds[tuple(site for _, site, _ in a)].append(
            (tuple(cpu - base for cpu, _, _ in a), b[0][0] - base))
    print()
    print(f"passes from site {start_site} (loop CPU time; the most frequent offsets and "
          "lengths):")
    print("| sites | passes | offsets | pass length |")
    print("| --- | --- | --- | --- |")
    for sites, rows in sorted(kinds.items(), key=lambda kv: -len(kv[1]))[:8]:
        offs = collections.Counter(o for o, _ in rows).most_common(2)
        lens = collections.Counter(n for _, n in rows).most_common(3)
        print(f"| {_few(sites)} | {len(rows)} | "
              f"{'; '.join(f'[{_few(o)}] ({n})' for o, n in offs)} | "
              f"{', '.join(f'{n} ({c})' for n, c in lens)} |")
    # pulses rising inside a section: how long after its end the interrupt entered
    plain = collections.Counter(f - r for r, f in pulses).most_common(1)[0][0]
    starts = [s[0] for s in sections]
    after: dict[str, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    for r, f in pulses:
        i = bisect.bisect_right(starts, r) - 1
        if i < 0:
            continue
        c, _, site, ticks = sections[i]
        if c <= r < c + ticks:
            after[site][(f - r - plain) - (c + ticks - r)] += 1
    print()
    print(f"pulses rising inside a section (plain width {plain} ticks): the step "
          "interrupt entered this many ticks after the section's end")
    print("| site | pulses | ticks after the end (pulses) |")
    print("| --- | --- | --- |")
    for site, hist in sorted(after.items(), key=lambda kv: -sum(kv[1].values())):
        print(f"| {site} | {sum(hist.values())} | "
              f"{', '.join(f'{k} ({n})' for k, n in sorted(hist.items())[:6])} |")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--replica", type=Path, default=Path("/tmp/fas-replica"),
                    help="the replica's runs (CASE.pins, CASE.ev with C/S lines)")
    ap.add_argument("--pin", default="A", help="the step pin whose pulses span the report")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    for case in args.cases:
        report(case, args.replica, args.pin)
    return 0


if __name__ == "__main__":
    sys.exit(main())
