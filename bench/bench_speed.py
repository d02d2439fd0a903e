"""Speed of the scripted console: how many times real time `stepperdemo -c` runs.

    python bench/bench_speed.py [--runs N] [--tree DIR ...] [--callgrind] [--line LINE]

Runs ``python -m stepperdemo -c LINE`` (default: ``M1 A100000 V40 R1000000 W``, 40 s of
motor time with status lines) as a fresh process, the way a user does, N times per
source tree, interleaved so that every tree sees the same load on a shared machine.
Reports per tree the wall time and the CPU time (user + sys) of the whole process,
minimum and median, and the simulated time divided by them (x real time).  CPU time is
the figure to compare on a machine other programs use; ``--callgrind`` adds the
instruction count of one run (valgrind, slow) as a figure that does not depend on load.

``--tree DIR`` benchmarks another checkout (e.g. ``git worktree add /tmp/before
<commit>`` or ``git archive <commit> | tar x -C /tmp/before``) beside this one.

As installed: ``pip install`` compiles the packages' bytecode, so every tree's ``fas``
and ``stepperdemo`` are compiled first (``compileall``, into their ``__pycache__``,
which git ignores) - otherwise, with ``PYTHONDONTWRITEBYTECODE`` set as on our build
machines, every start would compile every module again (about 30 ms).  ``--no-compile``
measures that cold start instead.  The interpreter is ``sys.executable`` itself (not a
wrapper such as a pyenv shim); the bare start of that interpreter (``python -c pass``:
interpreter, site-packages' ``.pth`` files) is measured alongside, so the share that is
ours shows.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LINE = "M1 A100000 V40 R1000000 W"


def sim_seconds(tree: Path, line: str) -> float:
    """Simulated time of the run, from the program itself (not timed)."""
    code = ("from fas.sim import SimBackend\n"
            "from stepperdemo.demo.app import StepperDemo\n"
            "b = SimBackend('atmega328p')\n"
            "app = StepperDemo(b, scripted=True)\n"
            f"app.run_script({line!r})\n"
            "print(b.now() / b.profile.ticks_per_s)\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=tree, check=True,
                         env=dict(os.environ, PYTHONPATH=str(tree)), capture_output=True,
                         text=True).stdout
    return float(out.strip())


def compile_tree(tree: Path) -> None:
    """Byte-compile the tree's packages in place, as ``pip install`` does."""
    subprocess.run([sys.executable, "-m", "compileall", "-q", "fas", "stepperdemo"], cwd=tree,
                   check=True, env=dict(os.environ, PYTHONPATH=str(tree)),
                   stdout=subprocess.DEVNULL)


def one_run(tree: Path | None, line: str) -> tuple[float, float]:
    """(wall, cpu) seconds of one fresh `python -m stepperdemo -c LINE` process
    (``tree`` None: of a bare ``python -c pass``)."""
    if tree is None:
        cmd, cwd, env = [sys.executable, "-c", "pass"], None, None
    else:
        cmd = [sys.executable, "-m", "stepperdemo", "-c", line]
        cwd, env = tree, dict(os.environ, PYTHONPATH=str(tree))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=cwd, check=True, env=env, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def instructions(tree: Path, line: str) -> int | None:
    """Instructions executed by one run (valgrind --tool=callgrind), None without it."""
    if shutil.which("valgrind") is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        res = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                              sys.executable, "-m", "stepperdemo", "-c", line], cwd=tree,
                             env=dict(os.environ, PYTHONPATH=str(tree)),
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        m = re.search(r"Collected : (\d+)", res.stderr)
        return int(m.group(1)) if m else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--tree", action="append", default=[], help="another source tree")
    ap.add_argument("--line", default=LINE)
    ap.add_argument("--callgrind", action="store_true", help="also count instructions")
    ap.add_argument("--no-compile", action="store_true",
                    help="do not byte-compile the trees first (a cold source checkout)")
    args = ap.parse_args()
    trees = [ROOT] + [Path(t).resolve() for t in args.tree]
    if not args.no_compile:
        for t in trees:
            compile_tree(t)
    sim = {t: sim_seconds(t, args.line) for t in trees}
    times: dict[Path | None, list[tuple[float, float]]] = {t: [] for t in [None, *trees]}
    load = os.getloadavg()[0]
    for _ in range(args.runs):  # interleaved: the trees share the machine's load
        for t in times:
            times[t].append(one_run(t, args.line))
    load = max(load, os.getloadavg()[0])
    print(f"stepperdemo -c {args.line!r}, {args.runs} runs each, {os.cpu_count()} cores, "
          f"load {load:.2f}, {sys.executable}, "
          + ("source trees as checked out" if args.no_compile else "bytecode compiled first"))
    walls = [w for w, _ in times[None]]
    cpus = [c for _, c in times[None]]
    print(f"python -c pass (the interpreter's own start): wall min {min(walls):.3f} s median "
          f"{statistics.median(walls):.3f} s; cpu min {min(cpus):.3f} s median "
          f"{statistics.median(cpus):.3f} s")
    for t in trees:
        walls = [w for w, _ in times[t]]
        cpus = [c for _, c in times[t]]
        s = sim[t]
        line = (f"{t}: {s:.2f} s simulated; wall min {min(walls):.3f} s median "
                f"{statistics.median(walls):.3f} s (x{s / min(walls):.0f} / "
                f"x{s / statistics.median(walls):.0f} real time); cpu min {min(cpus):.3f} s "
                f"median {statistics.median(cpus):.3f} s (x{s / min(cpus):.0f} / "
                f"x{s / statistics.median(cpus):.0f})")
        if args.callgrind:
            n = instructions(t, args.line)
            line += f"; {n / 1e9:.2f} G instructions" if n else "; callgrind unavailable"
        print(line)


if __name__ == "__main__":
    main()
