"""The ramp task's CPU read piece by piece from a replica's runs, every task of every run
(docs/timing-model.md, "thirty-third pass": build d's figures).

Each replica task (its vector's entry to its ``reti``, the interrupts nested in it left
out, their entries in) is described by what the model charges for it: no stepper running
(the idle task), the running steppers and the entries queued behind each one's running
entry at the task's entry (one-step entries and pauses apart from those of several
steps), the commands the task writes by kind (a pause, one step, several steps at the
speed of the one before - a coast - or not), and whether it starts a queue.  The CPU of
all tasks is then solved for one figure a piece by least squares (``fit``), and the
pieces are also read directly (the idle task's median, the tasks without a write by
their queue's length):

    python3 bench/replica/task_costs.py --work /tmp/h-d30/rep d01 d02 ... test_sd_19_328p

The runs are ``CASE.ev`` files of ``replica.py`` (``--build d`` writes
``CASE-Os-nolto-inall-pad1.ev``: link them as ``CASE.ev``).
"""

from __future__ import annotations

import argparse
import collections
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import compare  # noqa: E402
import replica  # noqa: E402

# the pieces, in the model's terms (fas.sim.timing.SimTiming)
PIECES = ("task", "stepper", "queued multi", "queued single", "plan", "pause", "single",
          "command", "coast", "start")


def features(t: replica.Task) -> dict[str, int]:
    """What the model would charge for replica task ``t``: piece -> count.  ``task``
    is 1 for a task in which a stepper runs or a command is written (entry + exit)."""
    f = dict.fromkeys(PIECES, 0)
    running = [q for q in t.queues if q]
    writes = compare.replica_tasks_one(t, [])
    f["task"] = 1
    f["stepper"] = len(running)
    for q in running:
        for s in q[1:]:
            f["queued single" if s <= 1 else "queued multi"] += 1
    last: dict[int, int] = {}
    for stepper, _, ticks, steps in writes:
        kind = ("pause" if steps == 0 else "single" if steps == 1
                else "coast" if last.get(stepper) == ticks else "command")
        f[kind] += 1
        last[stepper] = ticks
    if writes and running:
        f["plan"] = 1
    f["start"] = sum(1 for m in t.marks if m[1] == replica.START)
    return f


def is_idle(f: dict[str, int]) -> bool:
    return not f["stepper"] and not any(f[k] for k in ("pause", "single", "command",
                                                       "coast", "start"))


def solve(rows: list[list[float]], ys: list[float]) -> list[float]:
    """Least squares by the normal equations (Gaussian elimination; a column never used
    gets 0)."""
    n = len(rows[0])
    a = [[0.0] * (n + 1) for _ in range(n)]
    for r, y in zip(rows, ys, strict=True):
        for i in range(n):
            if r[i]:
                for j in range(n):
                    a[i][j] += r[i] * r[j]
                a[i][n] += r[i] * y
    used = [i for i in range(n) if a[i][i]]
    m = [[a[i][j] for j in used] + [a[i][n]] for i in used]
    k = len(used)
    for c in range(k):
        p = max(range(c, k), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(k):
            if r != c and m[c][c]:
                g = m[r][c] / m[c][c]
                m[r] = [x - g * y for x, y in zip(m[r], m[c], strict=True)]
    out = [0.0] * n
    for c, i in enumerate(used):
        out[i] = m[c][k] / m[c][c] if m[c][c] else 0.0
    return out


GROUPS = ("idle", "start", "running, no write", "running, writes", "other")
KINDS = ("pause", "single", "command", "coast")


def group(f: dict[str, int]) -> str:
    """The kind of a task: nothing runs nor is written (idle), a lone start (no stepper
    running), one stepper running that writes nothing or writes, anything else."""
    writes = sum(f[k] for k in KINDS)
    if is_idle(f):
        return "idle"
    if not f["stepper"]:
        return "start" if f["start"] else "other"
    if f["stepper"] == 1 and not f["start"]:
        return "running, writes" if writes else "running, no write"
    return "other"


def regress(items: list[tuple[dict[str, int], int]], keys: tuple[str, ...],
            fixed: dict[str, float]) -> tuple[list[float], list[int]]:
    """CPU = const + sum(piece x figure) over ``items`` ((features, cpu)), the pieces of
    ``fixed`` at their given figures: (const and ``keys``' figures, |residuals|)."""
    rows = [[1.0] + [float(f[k]) for k in keys] for f, _ in items]
    ys = [cpu - sum(v * f[k] for k, v in fixed.items()) for f, cpu in items]
    coef = solve(rows, ys)
    res = sorted(round(abs(y - sum(a * b for a, b in zip(coef, r, strict=True))))
                 for r, y in zip(rows, ys, strict=True))
    return coef, res


def read(runs: dict[str, list[replica.Task]], base: float = 813.0, per_multi: float = 75.0,
         per_single: float = 30.0) -> dict[str, object]:
    """The pieces over ``runs`` (case -> its tasks).  ``base``, ``per_multi`` and
    ``per_single``: a planning stepper's task that writes nothing (entry, exit, the
    stepper's checks) and its sum of a queued entry, which the writing tasks' solve
    takes as they are (the table ``nowrite`` reads them)."""
    by: dict[str, list[tuple[dict[str, int], int]]] = {g: [] for g in GROUPS}
    nowrite: dict[tuple[int, int], list[int]] = collections.defaultdict(list)
    for ts in runs.values():
        for t in ts:
            f = features(t)
            g = group(f)
            by[g].append((f, t.cpu))
            if g == "running, no write":
                nowrite[(f["queued multi"], f["queued single"])].append(t.cpu)
    out: dict[str, object] = {"count": {g: len(v) for g, v in by.items()},
                              "idle": [c for _, c in by["idle"]], "nowrite": dict(nowrite)}
    if by["running, writes"]:
        out["writes"] = regress(by["running, writes"], KINDS,
                                {"task": base, "queued multi": per_multi,
                                 "queued single": per_single})
    if by["start"]:
        out["start"] = regress(by["start"], KINDS, {})
    return out


def _fit_line(name: str, keys: tuple[str, ...], got: tuple[list[float], list[int]]) -> str:
    coef, res = got
    figs = " ".join(f"{k} {v:.0f}" for k, v in zip(("const", *keys), coef, strict=True))
    return (f"{name}: {figs}; |residual| median {res[len(res) // 2]}, "
            f"90 % {res[len(res) * 9 // 10]} ({len(res)} tasks)")


def report(r: dict[str, object]) -> list[str]:
    count = r["count"]
    assert isinstance(count, dict)
    out = ["tasks: " + ", ".join(f"{g} {n}" for g, n in count.items())]
    idle = r["idle"]
    assert isinstance(idle, list)
    out.append(f"idle task (no stepper running, nothing written): median "
               f"{statistics.median(idle) if idle else 0:g} "
               f"({min(idle, default=0)}..{max(idle, default=0)})")
    nowrite = r["nowrite"]
    assert isinstance(nowrite, dict)
    out.append("one stepper running, nothing written, by its queued entries (several "
               "steps, one step or pause): tasks, median")
    for key in sorted(nowrite):
        v = nowrite[key]
        if len(v) >= 5:
            out.append(f"  {key[0]:3d} {key[1]:3d}: {len(v):6d} {statistics.median(v):8g}")
    if "writes" in r:
        got = r["writes"]
        assert isinstance(got, tuple)
        out.append(_fit_line("one stepper running, writes (const: beyond the no-write "
                             "task's base)", KINDS, got))
    if "start" in r:
        got = r["start"]
        assert isinstance(got, tuple)
        out.append(_fit_line("a lone start (const: entry, the start, its tail, exit)",
                             KINDS, got))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", action="append", default=[], type=Path,
                    help="where the runs' CASE.ev lie; repeatable")
    ap.add_argument("--base", type=float, default=813.0,
                    help="a planning stepper's task that writes nothing (ticks)")
    ap.add_argument("--per-multi", type=float, default=75.0,
                    help="its sum of a queued entry of several steps (ticks)")
    ap.add_argument("--per-single", type=float, default=30.0,
                    help="... of a queued entry of one step or a pause (ticks)")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    runs: dict[str, list[replica.Task]] = {}
    for case in args.cases:
        where = next((w for w in args.work if (w / f"{case}.ev").exists()), None)
        if where is None:
            print(f"task_costs: no {case}.ev in {', '.join(map(str, args.work))}",
                  file=sys.stderr)
            return 1
        board = replica.BOARDS.get(case, replica.UNO)
        runs[case], _ = replica.tasks_of(where / case, board.task_vector)
    print("\n".join(report(read(runs, args.base, args.per_multi, args.per_single))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
