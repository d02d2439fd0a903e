"""Fuzz the StepperDemo console: random lines, invariants checked after every run.

    python bench/fuzz.py --lines N [--seed S] [--jobs J] [--arch NAME ...] [--max-time S]

Prints every failing line with its violations and a summary (runs, failures, wall
time).  Exit code 1 if anything failed.  The same generator and checks run in the
test suite with a small seeded amount (tests/stepperdemo/test_fuzz.py).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from stepperdemo.fuzz import fuzz


def _chunk(args: tuple) -> tuple[int, list]:
    lines, seed, archs, max_time = args
    failures = []
    n = 0
    for res in fuzz(lines, seed, arch_choice=archs, max_time_s=max_time):
        n += 1
        if not res.ok:
            failures.append((res.arch, res.line, res.violations))
    return n, failures


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--arch", nargs="+", default=["atmega328p", "atmega2560", "esp32",
                                                   "sam_due"])
    ap.add_argument("--max-time", type=float, default=20.0, help="simulated seconds per line")
    args = ap.parse_args()
    t0 = time.perf_counter()
    chunk = 25  # small chunks keep both cores busy to the end
    jobs = [(min(chunk, args.lines - k), args.seed * 1_000_003 + k, tuple(args.arch),
             args.max_time) for k in range(0, args.lines, chunk)]
    runs, failures = 0, []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for n, fails in pool.map(_chunk, jobs):
            runs += n
            failures += fails
            for arch, line, violations in fails:
                print(f"FAIL [{arch}] {line!r}")
                for v in violations:
                    print("    " + v)
    wall = time.perf_counter() - t0
    print(f"{runs} runs, {len(failures)} failures, {wall:.1f} s wall "
          f"({runs / wall:.0f} runs/s, seed {args.seed})")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
