"""Fuzz every console program on every profile: random input, invariants after every run.

    python bench/fuzz.py [--program demo|gcode|winder|all[=RUNS] ...] [--runs N]
                         [--seed S] [--jobs J] [--arch NAME ...] [--max-time S]
                         [--replay RUN]

``--runs N`` runs in all, shared equally by the programs (``--program gcode=8000
demo=2000`` gives a program its own number); each program's runs take its profiles in
turn (StepperDemo and G-code: every profile of ``fas/arch.py``; the winder: the
profiles that host it - the others are checked to refuse it with one line).  A run is
one input: a StepperDemo line (its ``g`` mode visits several lines), a G-code file of
a few lines or a sender's stream of lines and real-time bytes, a winder command line;
the input lines are counted.  Run k of a program is made from (seed, program, k)
alone: ``--replay k`` with one ``--program`` runs it again and prints everything it
broke.

Prints per program the runs, input lines, failures (exceptions - those that passed
through ``stepperdemo/gcode/`` counted apart - and violated invariants), wall time
and runs/s; then every failure kind once with its count, profiles, first input and
the replay command.  Each worker runs with a memory limit (``--mem-mb``) and a wall
time limit per run (``--run-timeout``): a run past either is a finding, not a dead
machine.  Exit code 1 if anything failed.  The suite runs the same targets with a
small seeded amount (tests/stepperdemo/test_fuzz.py).
"""

from __future__ import annotations

import argparse
import os
import resource
import signal
import sys
import time
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from stepperdemo.fuzz import TARGETS, fuzz_program, replay
from stepperdemo.fuzz.winder import check_refusal, refusing_profiles

CHUNK = {"demo": 20, "gcode": 50, "winder": 20}  # runs per job: small keeps both cores busy


class WallTimeout(Exception):
    """A run took longer than --run-timeout seconds of wall time."""


def _limits(mem_mb: int, run_timeout: int) -> None:
    """Worker start: a memory ceiling, and an alarm that ends a run stuck too long."""
    if mem_mb:
        resource.setrlimit(resource.RLIMIT_AS, (mem_mb * 2**20, mem_mb * 2**20))

    def alarm(signum, frame):
        raise WallTimeout(f"run exceeded {run_timeout} s of wall time")

    signal.signal(signal.SIGALRM, alarm)
    os.environ["FUZZ_RUN_TIMEOUT"] = str(run_timeout)


def _chunk(job: tuple) -> tuple[int, int, list]:
    program, first, count, seed, archs, max_time = job
    timeout = int(os.environ.get("FUZZ_RUN_TIMEOUT", "0"))
    failures = []
    runs = lines = 0
    results = fuzz_program(program, count, seed, first=first, archs=archs, max_time_s=max_time)
    while True:
        signal.alarm(timeout)
        try:
            item = next(results, None)
        finally:
            signal.alarm(0)
        if item is None:
            break
        run, res = item
        runs += 1
        lines += res.lines
        if not res.ok:
            failures.append((run, res.arch, res.in_gcode, res.exception, res.signature,
                             str(res.case), res.violations[:3]))
    return runs, lines, failures


def _report(program: str, failures: list, seed: int) -> None:
    kinds: dict[str, list] = {}
    for f in failures:
        kinds.setdefault(f[4], []).append(f)
    for sig, fs in sorted(kinds.items(), key=lambda kv: -len(kv[1])):
        run, arch, in_gcode, exc, _, case, violations = fs[0]
        where = " (through stepperdemo/gcode/)" if in_gcode else ""
        archs = sorted({f[1] for f in fs})
        print(f"  FAIL x{len(fs)}{where}: {sig}")
        print(f"    profiles: {' '.join(archs)}")
        print(f"    first: run {run} [{arch}] {case[:300]}")
        for v in violations:
            print("      " + v.replace("\n", "\n      ")[:1500])
        print(f"    replay: python bench/fuzz.py --program {program} --seed {seed} "
              f"--replay {run}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--program", nargs="+", default=["all"], metavar="NAME[=RUNS]",
                    help=f"the programs to fuzz: {', '.join(TARGETS)} or all (default), "
                    "each with its own number of runs if given")
    ap.add_argument("--runs", "--lines", type=int, default=1000, dest="runs",
                    help="runs in all (one input each), shared by the programs "
                    "without a number of their own")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--arch", nargs="+", help="only these profiles (default: every profile "
                    "that hosts the program)")
    ap.add_argument("--max-time", type=float, help="simulated seconds per run "
                    "(default: the program's own)")
    ap.add_argument("--mem-mb", type=int, default=1200, help="memory limit of a worker, MB")
    ap.add_argument("--run-timeout", type=int, default=120, help="wall seconds per run")
    ap.add_argument("--replay", type=int, metavar="RUN", help="run RUN again, in full")
    args = ap.parse_args()
    asked: dict[str, int | None] = {}
    for item in args.program:
        name, _, runs = item.partition("=")
        if name not in (*TARGETS, "all") or (runs and not runs.isdigit()):
            ap.error(f"--program {item}: a program ({', '.join(TARGETS)}, all), "
                     "optionally =RUNS")
        for one in (TARGETS if name == "all" else [name]):
            asked[one] = int(runs) if runs else None
    programs = list(asked)

    if args.replay is not None:
        if len(programs) != 1:
            ap.error("--replay needs one --program")
        _limits(args.mem_mb, 0)
        res = replay(programs[0], args.seed, args.replay,
                     tuple(args.arch) if args.arch else None, args.max_time)
        print(f"[{res.program} {res.arch}] {res.case} -> {res.end or '-'}")
        for v in res.violations:
            print(v)
        return 0 if res.ok else 1

    t_all = time.perf_counter()
    shared = [p for p in programs if asked[p] is None]
    share, extra = divmod(args.runs, max(1, len(shared)))
    totals = {"runs": 0, "lines": 0, "exceptions": 0, "in_gcode": 0, "failures": 0}
    all_failures: list[tuple[str, list]] = []
    refusal_problems = []
    for program in programs:
        target = TARGETS[program]
        archs = tuple(args.arch) if args.arch else target.profiles()
        if program == "winder" and args.arch:
            archs = tuple(a for a in archs if a in target.profiles())
        n = asked[program] if asked[program] is not None else (
            share + (1 if shared.index(program) < extra else 0))
        if not archs or not n:
            continue
        size = CHUNK[program]
        jobs = [(program, first, min(size, n - first), args.seed, archs, args.max_time)
                for first in range(0, n, size)]
        t0 = time.perf_counter()
        runs = lines = 0
        failures: list = []
        with ProcessPoolExecutor(max_workers=args.jobs, initializer=_limits,
                                 initargs=(args.mem_mb, args.run_timeout)) as pool:
            for r, ln, fails in pool.map(_chunk, jobs):
                runs += r
                lines += ln
                failures += fails
        wall = time.perf_counter() - t0
        exceptions = sum(1 for f in failures if f[3] is not None)
        in_gcode = sum(1 for f in failures if f[3] is not None and f[2])
        print(f"{program:7s} {len(archs):2d} profiles {runs:7d} runs {lines:7d} lines  "
              f"{len(failures)} failures ({exceptions} exceptions, {in_gcode} of them through "
              f"stepperdemo/gcode/)  {wall:7.1f} s wall  {runs / wall:6.1f} runs/s "
              f"{lines / wall:6.1f} lines/s", flush=True)
        if program == "winder" and not args.arch:
            refusing = refusing_profiles()
            refusal_problems = [r for r in (check_refusal(a) for a in refusing) if not r.ok]
            print(f"winder  refused with one line on {len(refusing) - len(refusal_problems)} "
                  f"of {len(refusing)} other profiles")
        totals["runs"] += runs
        totals["lines"] += lines
        totals["exceptions"] += exceptions
        totals["in_gcode"] += in_gcode
        totals["failures"] += len(failures)
        all_failures.append((program, failures))
    for program, failures in all_failures:
        if failures:
            print(f"{program}:")
            _report(program, failures, args.seed)
    for r in refusal_problems:
        print(f"  FAIL winder refusal [{r.arch}]: {r.violations}")
    wall = time.perf_counter() - t_all
    t = totals
    print(f"{t['runs']} runs, {t['lines']} input lines, {t['failures']} failures "
          f"({t['exceptions']} exceptions: {t['in_gcode']} through stepperdemo/gcode/, "
          f"{t['exceptions'] - t['in_gcode']} elsewhere), {wall:.1f} s wall "
          f"({t['runs'] / wall:.0f} runs/s, {t['lines'] / wall:.0f} lines/s, seed {args.seed})")
    return 1 if t["failures"] or refusal_problems else 0


if __name__ == "__main__":
    sys.exit(main())
