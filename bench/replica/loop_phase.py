"""The main loop's phase between the `e` windows: the model's passes beside the
replica's (docs/timing-model.md, "sixteenth pass").

A window starts in the pass whose ``ms = millis()`` reads the deadline, so the model
keeps the firmware's window starts only if it keeps the loop's phase from one window to
the next.  Per span between two windows (from ``SKIP_MS`` after a multiple of 256 ms to
``GUARD_MS`` before the next) this counts, on each side:

* the loop's reads of ``ms``: the replica's critical section of ``millis()`` in
  ``loop()`` (the most frequent site of the 9-tick sections: one per pass on every
  path), the model's reads of ``millis()`` at distinct ticks (run with
  ``--set e_every_pass=1``, or its passes between the windows are skipped);
* the ramp tasks and their own CPU time (the replica: the task vector's entry to its
  ``reti``, the interrupts nested in it left out; the model: the cost it charges).

A difference of one read is one pass (267 ticks on the pause path) of phase.

    python3 bench/replica/replica.py --fas FAS --simavr SIMAVR --work /tmp/e16p steps e09
    python3 bench/replica/loop_phase.py --work /tmp/e16p e09 \\
        --set e_every_pass=1 --set e_outside_saved_ticks=3 [--set ...]

``--by-kind``: the ramp tasks' CPU over the spans per kind of task (``kind_of``), each
replica task beside the model's task nearest to it (docs/timing-model.md, "nineteenth
pass").
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "bench"))

import compare  # noqa: E402
import e_fidelity  # noqa: E402
import replica  # noqa: E402

from fas.sim import SimBackend  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402

WINDOW_TICKS = 256 * 16_000  # a window every 256 ms of millis() (1.024 ms per 1 ms)
SKIP_MS = 80  # a span starts this long after a window's deadline (the window is over)
GUARD_MS = 4  # ... and ends this long before the next deadline
READ_SECTION_TICKS = 9  # millis()'s cli ... SREG restore in the replica


class Side:
    """One side's reads of ``ms`` and its ramp tasks (tick, own CPU ticks)."""

    def __init__(self) -> None:
        self.reads: list[int] = []
        self.tasks: list[tuple[int, int]] = []
        self.kinds: list[str] = []  # the model's: per task, as ``kind_of``
        self.cmds: list[int] = []  # the model's: per task, the commands it writes


def replica_side(case: str, work: Path) -> tuple[Side, str]:
    """The replica's reads and tasks, in firmware ticks; and the read's site."""
    board = replica.BOARDS.get(case, replica.UNO)
    lag = compare.FIRMWARE_LAG[board.task_vector]
    vector = str(board.task_vector)
    side = Side()
    sites: dict[str, list[int]] = collections.defaultdict(list)
    open_at: dict[str, int] = {}
    stack: list[list] = []
    with open(work / f"{case}.ev") as f:
        for line in f:
            p = line.split()
            kind = p[1]
            if kind == "C":
                open_at[p[2]] = int(p[0])
            elif kind == "S":
                for site, t0 in open_at.items():
                    if int(p[0]) - t0 == READ_SECTION_TICKS:
                        sites[site].append(t0 - lag)
                open_at.clear()
            elif kind == "V":
                stack.append([int(p[0]), p[2], 0])
            elif kind == "R" and stack:
                t0, v, nested = stack.pop()
                took = int(p[0]) - t0
                if v == vector:
                    side.tasks.append((t0 - lag, took - nested))
                if stack:
                    stack[-1][2] += took + 4  # its reti
    if not sites:
        raise SystemExit(f"{case}: no critical sections in {work / case}.ev "
                         "(replica.py steps writes them)")
    site = max(sites, key=lambda s: len(sites[s]))
    side.reads = sites[site]
    return side, site


def model_side(case: str, conf: Path) -> Side:
    inp = (conf / case / "input.txt").read_text().strip()
    backend = SimBackend(e_fidelity.PROFILE.get(case, "atmega328p"), record=True, build="e")
    m = backend.machine
    side = Side()
    millis = backend.millis

    def read() -> int:
        if not side.reads or side.reads[-1] != m.now:
            side.reads.append(m.now)
        return millis()

    plain_task = backend._task  # noqa: SLF001

    def task(index: int) -> None:
        before, t = m.stolen_ticks, m.now
        running = [ch for ch in backend.channels if ch.running]
        wps = [ch.q.next_write_idx for ch in backend.channels]
        plain_task(index)
        side.tasks.append((t, m.stolen_ticks - before))
        writes = []
        for ch, wp in zip(backend.channels, wps, strict=True):
            q = ch.q
            for k in range((q.next_write_idx - wp) & 0xFF):
                e, prev = q.entries[(wp + k) % q.queue_len], q.entries[(wp + k - 1) % q.queue_len]
                known = k > 0 or ch in running
                writes.append((id(ch), e.ticks, e.total_steps, prev.ticks if known else -1))
        side.kinds.append(kind_of(len(running), writes, []))
        side.cmds.append(len(writes))

    backend.millis = read  # type: ignore[method-assign]
    backend._task = task  # type: ignore[method-assign]  # noqa: SLF001
    app = make_program("demo", backend, scripted=True)
    app.run_script(inp, firmware_end=True)
    return side


# the interrupts that nest in a ramp task besides the step interrupts, per chip
NESTED = {"atmega328p": {16: "T0", 19: "U"}, "atmega2560": {23: "T0", 26: "U"}}


def kind_of(running: int, writes: list[tuple[int, int, int, int]],
            nested: list[str]) -> str:
    """A ramp task's kind: running steppers (``1st``/``2st``, ``0st`` none), the commands
    it writes (``-`` none; ``acc`` faster than the one before or the first one (``prev``
    0 or less: none known), ``dec`` slower, ``coast``
    at the same speed, ``short`` a pause or a single step, joined by ``+``) and the
    UART's (``U``) and timer 0's (``T0``) interrupts nested in it."""
    sorts = {"short" if steps <= 1 else "coast" if ticks == prev
             else "acc" if ticks < prev or prev <= 0 else "dec" for _, ticks, steps, prev in writes}
    w = "+".join(sorted(sorts)) or "-"
    return " ".join([f"{running}st", w, *sorted(set(nested))])


def replica_kinds(case: str, work: Path) -> list[tuple[str, int]]:
    """The replica's tasks' kinds (``kind_of``) and the commands each writes, in the
    order of ``replica_side``."""
    board = replica.BOARDS.get(case, replica.UNO)
    tasks, _ = replica.tasks_of(work / case, board.task_vector)
    last: dict[int, int] = {}
    out = []
    for t in tasks:
        writes = []
        for _, mark, this, ticks, steps, _ in t.marks:
            if mark == replica.WRITE and steps < 256 and ticks > 0:
                writes.append((this, ticks, steps, last.get(this, -1)))
                last[this] = ticks
        running = sum(1 for q in t.queues if q)
        names = NESTED[board.mcu]
        out.append((kind_of(running, writes, [names[v] for v in t.nested if v in names]),
                    len(writes)))
    return out


def spans(last_tick: int) -> list[tuple[int, int]]:
    out = []
    k = 0
    while (k + 1) * WINDOW_TICKS < last_tick:
        out.append((k * WINDOW_TICKS + SKIP_MS * 16_000,
                    (k + 1) * WINDOW_TICKS - GUARD_MS * 16_000))
        k += 1
    return out


def _count(ticks: list[int], lo: int, hi: int) -> int:
    return bisect.bisect_left(ticks, hi) - bisect.bisect_left(ticks, lo)


def _tasks(tasks: list[tuple[int, int]], lo: int, hi: int) -> tuple[int, int]:
    inside = [c for t, c in tasks if lo <= t < hi]
    return len(inside), sum(inside)


def report(case: str, conf: Path, work: Path) -> int:
    theirs, site = replica_side(case, work)
    ours = model_side(case, conf)
    print(f"## {case}: the loop's reads of ms (replica site {site}) and ramp tasks per span")
    print("| span (ms) | reads replica / model | model - replica (passes) "
          "| tasks | task CPU replica / model (ticks) | model - replica |")
    print("| --- | --- | --- | --- | --- | --- |")
    total = 0
    for lo, hi in spans(min(theirs.reads[-1], ours.reads[-1])):
        r, m = _count(theirs.reads, lo, hi), _count(ours.reads, lo, hi)
        (nr, cr), (nm, cm) = _tasks(theirs.tasks, lo, hi), _tasks(ours.tasks, lo, hi)
        total += abs(m - r)
        print(f"| {lo // 16_000}-{hi // 16_000} | {r} / {m} | {m - r:+d} | {nr} / {nm} "
              f"| {cr} / {cm} | {cm - cr:+d} |")
    print(f"sum of |model - replica| over the spans: {total} passes")
    return 0


PAIR_TICKS = 8_000  # a model task pairs with the replica's task this close to it


def by_kind(case: str, conf: Path, work: Path,
            acc: dict[str, list[int]] | None = None) -> dict[str, list[int]]:
    """Per kind of task (the replica's ``kind_of``) over the spans: tasks, the replica's
    CPU, the model's, how many of the model's tasks wrote other commands or ran on a
    running stepper more or less (or none ran: the model skips a task while idle), and
    the commands written, replica's and model's."""
    theirs, _ = replica_side(case, work)
    kinds = replica_kinds(case, work)
    if len(kinds) != len(theirs.tasks):
        raise SystemExit(f"{case}: {len(kinds)} tasks with marks, {len(theirs.tasks)} without")
    ours = model_side(case, conf)
    acc = {} if acc is None else acc
    starts = [t for t, _ in ours.tasks]
    for lo, hi in spans(min(theirs.reads[-1], ours.reads[-1])):
        paired = set()
        for (t, cpu), (kind, cmds) in zip(theirs.tasks, kinds, strict=True):
            if not lo <= t < hi:
                continue
            i = bisect.bisect_left(starts, t - PAIR_TICKS)
            row = acc.setdefault(kind, [0] * 6)
            row[0] += 1
            row[1] += cpu
            row[4] += cmds
            if i < len(starts) and abs(starts[i] - t) <= PAIR_TICKS:
                paired.add(i)
                row[2] += ours.tasks[i][1]
                row[3] += ours.kinds[i] != " ".join(kind.split()[:2])
                row[5] += ours.cmds[i]
            else:
                row[3] += 1  # the model runs no task here
        for i in range(bisect.bisect_left(starts, lo), bisect.bisect_left(starts, hi)):
            if i not in paired:  # the replica runs no task here
                row = acc.setdefault("model only: " + ours.kinds[i], [0] * 6)
                row[0] += 1
                row[2] += ours.tasks[i][1]
                row[5] += ours.cmds[i]
    return acc


def print_by_kind(title: str, acc: dict[str, list[int]]) -> None:
    print(f"## {title}: ramp tasks per kind over the spans between the windows")
    print("| kind | tasks | CPU replica / model (ticks) | model - replica | per task "
          "| commands replica / model | model's task differs |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for kind, (n, cr, cm, other, wr, wm) in sorted(acc.items(),
                                                   key=lambda kv: -abs(kv[1][2] - kv[1][1])):
        print(f"| {kind} | {n} | {cr} / {cm} | {cm - cr:+d} | {(cm - cr) / n:+.0f} "
              f"| {wr} / {wm} | {other} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"),
                    help="the replica's runs (CASE.ev of replica.py steps)")
    ap.add_argument("--conformance", type=Path, default=e_fidelity.DEFAULT_CONF)
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE",
                    help="a figure of build e for this run (as e_fidelity.py --set)")
    ap.add_argument("--by-kind", action="store_true",
                    help="per kind of ramp task (steppers, commands, nested interrupts)")
    args = ap.parse_args(argv)
    try:
        e_fidelity.set_timing(args.set)
    except ValueError as exc:
        ap.error(str(exc))
    if args.by_kind:
        total: dict[str, list[int]] = {}
        for case in args.cases:
            one = by_kind(case, args.conformance, args.work)
            print_by_kind(case, one)
            for kind, row in one.items():
                total[kind] = [a + b for a, b in zip(total.get(kind, [0] * 6), row, strict=True)]
        if len(args.cases) > 1:
            print_by_kind(" ".join(args.cases), total)
        return 0
    for case in args.cases:
        report(case, args.conformance, args.work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
