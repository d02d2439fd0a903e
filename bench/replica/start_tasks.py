"""The figures of a ramp task that starts a queue, read from the replica's runs
(docs/timing-model.md, "twenty-eighth pass").

For every replica task that calls ``startQueue()``, the own CPU (interrupts nested in
the task left out, their entries in) of each piece the model charges on its own: the
first command's write after the task's entry (a lone start: no other stepper wrote
before it), the pitch from one write of the started stepper to the next by kind (a
one-step command, a pause, a command of several steps), the last write to the
``startQueue()`` call, and the call to the task's end.  Per chip, each piece's count,
mean, median and range:

    python3 bench/replica/start_tasks.py --work /tmp/e16p --work /tmp/h-winstart-rep \\
        --work /tmp/e15p e01 e03 e04 e05 e06 e07 e08 e09 e10 e11 e12 e13 e14 e17 e18

``--running`` lists the running fills instead: the pitches of every task without a
start, and where one stepper runs and writes, its first write and the CPU after its
last.

The replica's runs (``CASE.ev``) are read from the first ``--work`` that holds them
(``replica.py ... tasks CASE`` writes them).  The replica's first step rises 80 cycles
after the ``startQueue()`` call (``compare.QUEUE_START_CYCLES``); the model's compare
comes ``queue_start_ticks`` (10) after its start, so the model's ``fill_start_ticks`` is
the last write to the call plus 70.
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

Pieces = dict[str, list[tuple[str, int]]]


def _kind(steps: int) -> str:
    return "single" if steps == 1 else "pause" if steps == 0 else "command"


def start_pieces(case: str, tasks: list[replica.Task], into: Pieces) -> None:
    """Add the pieces of every task of ``tasks`` that starts a queue to ``into`` (piece
    -> [(case, CPU ticks)])."""
    for t in tasks:
        starts = [m for m in t.marks if m[1] == replica.START]
        if not starts:
            continue
        writes = compare.replica_tasks_one(t, [])
        if not writes:
            continue
        stepper = writes[-1][0]  # the started stepper wrote last
        mine = [w for w in writes if w[0] == stepper]
        others = [w for w in writes if w[0] != stepper]
        if others:
            into["first write after another stepper's last"].append(
                (case, mine[0][1] - others[-1][1]))
        else:
            into["first write (lone start)"].append((case, mine[0][1]))
        for a, b in zip(mine, mine[1:], strict=False):
            into[f"{_kind(a[3])} -> {_kind(b[3])}"].append((case, b[1] - a[1]))
            if b[3] > 1:  # the model's one figure for a starting ramp's longer commands
                into["any -> command"].append((case, b[1] - a[1]))
        call = starts[-1][0]
        into[f"last {_kind(mine[-1][3])} -> startQueue()"].append((case, call - mine[-1][1]))
        into["startQueue() -> task end"].append((case, t.cpu - call))


def running_pieces(case: str, tasks: list[replica.Task], into: Pieces) -> None:
    """``--running``: in every task without a queue start, the pitches from one write
    of a stepper to its next; in those where one stepper runs and writes, its first
    write after the task's entry and the task's CPU after its last write, by the kind
    of its first command (docs/timing-model.md, "thirty-second pass")."""
    for t in tasks:
        if any(m[1] == replica.START for m in t.marks):
            continue
        writes = compare.replica_tasks_one(t, [])
        if not writes:
            continue
        for a, b in zip(writes, writes[1:], strict=False):
            if a[0] == b[0]:
                into[f"running: {_kind(a[3])} -> {_kind(b[3])}"].append((case, b[1] - a[1]))
        if len({w[0] for w in writes}) != 1 or sum(1 for q in t.queues if q) != 1:
            continue
        kind = _kind(writes[0][3])
        into[f"running: first write, {kind}"].append((case, writes[0][1]))
        into[f"running: after the last write, {kind}"].append((case, t.cpu - writes[-1][1]))


def report(pieces: Pieces) -> list[str]:
    lines = ["| piece | n | mean | median | min | max | by run |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, got in pieces.items():
        vals = [v for _, v in got]
        if len(got) <= 16:
            by_run = " ".join(f"{c}:{v}" for c, v in got)
        else:  # each run's mean
            runs: dict[str, list[int]] = {}
            for c, v in got:
                runs.setdefault(c, []).append(v)
            by_run = " ".join(f"{c}:{statistics.mean(v):.0f}" for c, v in runs.items())
        lines.append(f"| {name} | {len(vals)} | {statistics.mean(vals):.1f} | "
                     f"{statistics.median(vals):g} | {min(vals)} | {max(vals)} | {by_run} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", action="append", default=[], type=Path,
                    help="where replica.py wrote CASE.ev; repeatable")
    ap.add_argument("--running", action="store_true",
                    help="the running fills' pieces (tasks without a start) instead")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    by_chip: dict[str, Pieces] = collections.defaultdict(lambda: collections.defaultdict(list))
    for case in args.cases:
        where = next((w for w in args.work if (w / f"{case}.ev").exists()), None)
        if where is None:
            print(f"start_tasks: no {case}.ev in {', '.join(map(str, args.work))}",
                  file=sys.stderr)
            return 1
        board = replica.BOARDS.get(case, replica.UNO)
        tasks, _ = replica.tasks_of(where / case, board.task_vector)
        (running_pieces if args.running else start_pieces)(case, tasks, by_chip[board.mcu])
    for chip, pieces in by_chip.items():
        print(f"{chip}:")
        print("\n".join(report(pieces)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
