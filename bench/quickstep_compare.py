"""QuickStep vs FastAccelStepper on the same StepperDemo move, and FIFO depth 1 vs 20.

    python bench/quickstep_compare.py                       # tables on stdout
    python bench/quickstep_compare.py --png compare.png     # plus speed over time

Runs the console on virtual time (``python -m stepperdemo -c ... --steps-csv``) and
measures from the step times: duration (first to last step), peak speed, the
largest jump of speed from one step interval to the next, distinct step periods;
for the depth comparison the starts from rest (the motor stopped and started
again) and the longest pause between two steps.  Deterministic: the same figures on
every machine.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from itertools import pairwise
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TPS = 16_000_000
MOVE = "M1 A1000 V100 R3200 W"
RUNS = [("FastAccelStepper ramp", MOVE)] + [
    (f"QuickStep p{n}", f"c M1 q{2 * n + 1} p{n} l1 x {MOVE}") for n in (4, 17, 64)]
SHORT = "M1 A20000 V250 R400 R400 R400 R400 R400 W"
DEPTHS = [(f"QuickStep q{q} p4", f"c M1 q{q} p4 l1 x {SHORT}") for q in (1, 20)]


def step_ticks(line: str) -> list[int]:
    """Step times (ticks) of stepper 1 for one console line."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "steps.csv")
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        subprocess.run([sys.executable, "-m", "stepperdemo", "-c", line, "--steps-csv", path],
                       check=True, capture_output=True, env=env, cwd=ROOT)
        with open(path, newline="") as f:
            return [int(r["tick"]) for r in csv.DictReader(f) if r["stepper"] == "1"]


def figures(ticks: list[int]) -> dict[str, float]:
    iv = [b - a for a, b in pairwise(ticks)]
    speeds = [TPS / i for i in iv]
    jumps = [abs(b - a) for a, b in pairwise(speeds)]
    return {"steps": len(ticks), "duration_ms": (ticks[-1] - ticks[0]) * 1000 / TPS,
            "peak": max(speeds), "jump": max(jumps), "periods": len(set(iv)),
            "first": speeds[0], "longest_pause_ms": max(iv) * 1000 / TPS}


def starts_from_rest(line: str) -> int:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-m", "stepperdemo", "-c", line, "--report"],
                         check=True, capture_output=True, env=env, cwd=ROOT, text=True).stdout
    for row in out.splitlines():
        if "start(s) from rest" in row:
            return int(row.split(",")[-1].split()[0])
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--png", help="write speed over time of the four runs to this PNG")
    args = ap.parse_args()
    print(f"same move: {MOVE}")
    print(f"{'planner':24} {'steps':>6} {'duration ms':>12} {'peak steps/s':>13} "
          f"{'largest jump':>13} {'periods':>8} {'first steps/s':>14}")
    series = []
    for name, line in RUNS:
        t = step_ticks(line)
        f = figures(t)
        series.append((name, t))
        print(f"{name:24} {f['steps']:>6} {f['duration_ms']:>12.1f} {f['peak']:>13.0f} "
              f"{f['jump']:>13.0f} {f['periods']:>8} {f['first']:>14.0f}")
    print()
    print(f"short moves: {SHORT}")
    print(f"{'planner':24} {'steps':>6} {'duration ms':>12} {'starts from rest':>17} "
          f"{'longest pause ms':>17}")
    for name, line in DEPTHS:
        f = figures(step_ticks(line))
        print(f"{name:24} {f['steps']:>6} {f['duration_ms']:>12.1f} "
              f"{starts_from_rest(line):>17} {f['longest_pause_ms']:>17.2f}")
    if args.png:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        fig = Figure(figsize=(12, 6), dpi=100, layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.subplots()
        for name, t in series:
            xs = [(b - t[0]) / TPS for b in t[1:]]
            ys = [TPS / (b - a) for a, b in pairwise(t)]
            ax.step(xs, ys, where="pre", label=name, linewidth=1.1)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("speed [steps/s]")
        ax.set_title(MOVE)
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.savefig(args.png)
        print(f"wrote {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
