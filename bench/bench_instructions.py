"""Issue 25's speed as a count of machine instructions: one ``bench_gcode.la_run`` of the
look-ahead program, counted by Valgrind (``cachegrind``, no cache simulation), with the
interpreter's start, the imports and the program's lines subtracted.  Wall and CPU time
on a shared machine move by several per cent from run to run (and a machine of this
workplace may be twice as slow as another); the count moves by about 0.1 %, so it is
what tells whether a change to the planner or the chip pays.

    python3 bench/bench_instructions.py [--segments 2000] [--mode both|grbl|blends]
        [--traced] [--root TREE] [--variant NAME ...]

``--mode blends`` runs with corner blends and plain corners (``$172=1 $173=0.125``, the
mode that meets issue 25's other lines), ``grbl`` with Grbl's junctions (the default).
The run is untraced, as the bench's timed runs are, unless ``--traced`` (the pins'
edges recorded, as for the bench's pin figures).  ``--root`` counts another checkout
(a worktree of an earlier commit, say): both trees' byte code is compiled first, since a
machine that sets ``PYTHONDONTWRITEBYTECODE`` would otherwise count the compiling of
the G-code modules the run imports (about 0.2 G instructions at 2 000 segments).  The
count is taken with ``PYTHONHASHSEED=0``.  Needs ``valgrind`` (Debian's package).
"""

from __future__ import annotations

import argparse
import compileall
import os
import re
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
MODES = {"grbl": False, "blends": True}
#: with blends: the plain corners bench_gcode's acceptance figures use (--plain-corners)
PLAIN_CORNERS = 0.125
REFS = re.compile(r"I\s+refs:\s+([\d,]+)")


def child(root: str, blends: bool, segments: int, traced: bool, run: bool,
          variants: list[str]) -> None:
    """Inside Valgrind: the program's lines, and the run itself when ``run``."""
    sys.path.insert(0, root)
    sys.path.insert(1, os.path.join(root, "bench"))
    os.chdir(root)
    if variants:
        import d_corpus

        d_corpus.set_build_d([s for v in variants for s in d_corpus.VARIANTS[v]])
    import bench_gcode as bg

    bg.PLAIN_CORNERS = PLAIN_CORNERS if blends else None
    lines = bg.la_lines(segments)
    if run:
        r = bg.la_run(lines, 0, traced, blends=blends)
        if r["errors"]:
            raise SystemExit(f"bench_instructions: the program answered {r['errors']} errors")


def interpreter() -> str:
    """The interpreter's own binary: Valgrind cannot follow a launcher script (pyenv's
    ``python3`` is one)."""
    return os.path.realpath(getattr(sys, "_base_executable", None) or sys.executable)


def count(root: str, blends: bool, segments: int, traced: bool, run: bool,
          variants: list[str]) -> int:
    cmd = ["valgrind", "--tool=cachegrind", "--cache-sim=no",
           "--cachegrind-out-file=/dev/null", interpreter(), os.path.abspath(__file__),
           "--child", "--root", root, "--segments", str(segments),
           "--mode", "blends" if blends else "grbl"]
    cmd += ["--traced"] if traced else []
    cmd += [] if run else ["--setup-only"]
    for v in variants:
        cmd += ["--variant", v]
    env = dict(os.environ, PYTHONHASHSEED="0")
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    m = REFS.search(p.stderr)
    if p.returncode != 0 or m is None:
        last = (p.stderr.strip().splitlines() or ["no output"])[-1]
        raise SystemExit(f"bench_instructions: the counted run failed: {last}")
    return int(m.group(1).replace(",", ""))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", type=int, default=2000)
    ap.add_argument("--mode", choices=["both", *MODES], default="both")
    ap.add_argument("--traced", action="store_true", help="record the pins' edges")
    ap.add_argument("--root", default=os.path.dirname(HERE), help="the checkout to count")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME",
                    help="a variant of bench/d_corpus.py set on build d (repeatable)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--setup-only", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.segments < 1:
        ap.error("--segments must be at least 1")
    root = os.path.abspath(a.root)
    if not os.path.isfile(os.path.join(root, "bench", "bench_gcode.py")):
        ap.error(f"--root {a.root}: no bench/bench_gcode.py there")
    modes = list(MODES) if a.mode == "both" else [a.mode]
    if a.child:
        child(root, MODES[modes[0]], a.segments, a.traced, not a.setup_only, a.variant)
        return 0
    if shutil.which("valgrind") is None:
        print("bench_instructions: valgrind not found (apt-get install valgrind)",
              file=sys.stderr)
        return 2
    for pkg in ("fas", "stepperdemo", "bench"):
        compileall.compile_dir(os.path.join(root, pkg), quiet=1)
    for mode in modes:
        blends = MODES[mode]
        full = count(root, blends, a.segments, a.traced, True, a.variant)
        setup = count(root, blends, a.segments, a.traced, False, a.variant)
        what = "blends, $173=%g" % PLAIN_CORNERS if blends else "Grbl's junctions"
        print(f"{mode}: {(full - setup) / 1e6:.1f} M instructions, one la_run of "
              f"{a.segments} segments ({what}, {'traced' if a.traced else 'untraced'}; "
              f"set-up {setup / 1e6:.1f} M subtracted) - {root}"
              + (f" with {' '.join(a.variant)}" if a.variant else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
