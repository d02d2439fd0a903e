"""The ramp task's fill reads of its queues, the model beside the replica, task by task
(docs/timing-model.md, "twenty-fourth pass").

The library's fill plans commands while ``ticksInQueue()`` - the ticks of the queued
entries after the running one, read once when the fill gets there - plus the commands
planned so far lies below the forward planning horizon (20 ms) or the queue holds at
most one entry.  For every ramp task that plans commands, and for every stepper whose
queue the replica's fill reads (``replica.py tasks``: the ``Q`` lines), this prints
or counts:

* the replica's read: its own CPU and the cycle after the task's entry, the queue's
  entries from the read index on (running entry first) and the sum the library finds;
* the model's read (``compare.py``'s hook): CPU, tick, entries, sum found;
* the commands each planned for that stepper.

A stepper whose commands differ is classed by the first thing that differs:

* ``running entry``: the entries after the running one differ only in that one side's
  running entry is the other's first queued one (that side read after its running
  entry ended: the read moment against the running entry's end);
* ``queue``: the queued entries differ otherwise (an earlier task planned differently);
* ``same sum``: both found the same sum, and planned differently anyway (the ramp's
  commands, the queue-full test, the ramp's end) - with ``same first`` where the first
  command is the same and only the count differs.

Every read is also counted "in step" where the model's stepper is in step with the
firmware's at the task (its step next to the task within ``IN_STEP_TICKS`` of the
firmware's: the replica's rises less its lead): a stepper that made a gap the other
side did not (a compare missed in an `e` window, the timer's wrap waited out) runs
65 536 ticks apart, and every read of its queue until the gaps agree again finds other
entries.  The summary gives the median of the model's read tick after the firmware's
(the replica's less its lead).  ``--show N`` prints the first N differing reads
(``--only CLASS``, ``--in-step``, ``--since MS`` select), ``--series FILE`` appends
one line per read, ``--set`` runs the model with other figures of build e.

    python3 bench/replica/replica.py --fas FAS --simavr SIMAVR --work W tasks e09
    python3 bench/replica/fill_reads.py --work W [--show N] [--set ...] e01 e09 e18
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import compare  # noqa: E402
import replica  # noqa: E402

Entries = list[tuple[int, int]]
# a stepper is "in step" with the firmware's where its step next to the task lies within
# this of the firmware's: no gap (a compare missed, the timer's wrap waited out) made by
# one side only so far, whose 65 536 ticks move every later read by entries
IN_STEP_TICKS = 2000
# per case: (model task tick, stepper, same commands, entries model - replica, sum
# model - replica, the model's read after the firmware's, commands model - replica)
SERIES: dict[str, list[tuple[int, int, bool, int, int, int, int]]] = {}


def _sum(ents: Entries) -> int:
    return replica.ticks_in_queue(ents)


def _norm(ents: Entries) -> list[tuple[int, int]]:
    """Entries compared by ticks and steps (a pause's steps as 0)."""
    return [(t, s) for t, s in ents]


def classify(mine: Entries, theirs: Entries, found_m: int, found_r: int) -> str:
    if found_m == found_r:
        return "same sum"
    a, b = _norm(mine)[1:], _norm(theirs)[1:]
    if a[1:] == b:
        return "running entry: the replica's ended, the model's runs"
    if b[1:] == a:
        return "running entry: the model's ended, the replica's runs"
    if a == b:
        return "same entries, other sum"
    return "queue"


def step_lags(case: str, backend: object, work: Path) -> dict[int, tuple[list[int], list[int]]]:
    """Per queue (0: A, 1: B, ...): the firmware's step rises (the replica's less its
    lead) and the model's rise of the same step after it, model - firmware."""
    board = replica.BOARDS.get(case, replica.UNO)
    lag = compare.FIRMWARE_LAG[board.task_vector]
    rises = replica.rises(work / case)
    out = {}
    for q, sp in enumerate(compare.e_fidelity.stepper_pins(backend.profile)):  # type: ignore[attr-defined]
        pin = board.pins.get(sp.letter)
        if pin is None or pin not in rises:
            continue
        ours = [round(t * 16) for t in compare.e_fidelity.step_times_us(backend, sp.step)]
        fw = [c - lag for c in rises[pin]]
        n = min(len(ours), len(fw))
        out[q] = (fw[:n], [ours[i] - fw[i] for i in range(n)])
    return out


def lag_at(lags: dict[int, tuple[list[int], list[int]]], q: int, t: int) -> int | None:
    """Model - firmware of queue ``q``'s step next to tick ``t``."""
    if q not in lags or not lags[q][0]:
        return None
    fw, d = lags[q]
    i = min(bisect.bisect_left(fw, t), len(d) - 1)
    return d[i]


def analyse(case: str, conf: Path, work: Path, show: int, since_ms: float,
            only: str = "", in_step_only: bool = False) -> collections.Counter:
    keep: list = []
    model = compare.model_tasks(case, conf, keep)
    lags = step_lags(case, keep[0], work)
    board = replica.BOARDS.get(case, replica.UNO)
    tasks, _ = replica.tasks_of(work / case, board.task_vector)
    ts = [t.t for t in tasks]
    # the replica's steppers numbered by their first write (as compare.py's)
    steppers: list[int] = []
    qmap: dict[int, int] = {}  # queue -> stepper number
    for t in tasks:
        cur_q = None
        for m in t.marks:
            if m[1] == replica.WRITE and m[3] > 0 and m[4] < 256 and m[2] not in steppers:
                steppers.append(m[2])
        rd = iter(sorted([(r[2], "r", r) for r in t.reads] + [(m[5], "w", m) for m in t.marks
                                                               if m[1] == replica.WRITE]))
        for _, kind, x in rd:
            if kind == "r":
                cur_q = x[1]
            elif cur_q is not None and x[2] in steppers and cur_q not in qmap:
                qmap[cur_q] = steppers.index(x[2])
    out: collections.Counter = collections.Counter()
    series = SERIES.setdefault(case, [])
    shown = 0
    for rec in model:
        i = bisect.bisect_left(ts, rec.t - compare.PAIR_TICKS)
        if i >= len(ts) or abs(ts[i] - rec.t) > compare.PAIR_TICKS:
            continue
        theirs = compare.replica_tasks_one(tasks[i], steppers)
        if not theirs and not rec.writes:
            continue
        out["tasks planning"] += 1
        t = tasks[i]
        for r_cpu, q, cyc, ents in t.reads:
            k = qmap.get(q)
            if k is None:
                continue
            mw = [(tk, n) for s, _, tk, n in rec.writes if s == k]
            rw = [(tk, n) for s, _, tk, n in theirs if s == k]
            mr = [(j, x) for j, x in enumerate(rec.reads) if x[0] == k]
            if not mr:
                if rw:
                    out["stepper reads: model does not read (not running)"] += 1
                continue
            j, (_, m_cpu, m_at, found_m) = mr[0]
            mq = rec.read_queues[j]
            found_r = _sum(ents)
            # the model's read after the firmware's (the replica runs FIRMWARE_LAG later)
            late = rec.t + rec.read_ticks[j] - (cyc - compare.FIRMWARE_LAG[board.task_vector])
            series.append((rec.t, k, mw == rw, (len(mq) - len(ents)), found_m - found_r, late,
                           len(mw) - len(rw)))
            out["stepper reads"] += 1
            lag = lag_at(lags, q, rec.t)
            in_step = lag is not None and abs(lag) < IN_STEP_TICKS
            if in_step:
                out["in step: reads"] += 1
                out["in step: same commands"] += mw == rw
            out["sum: model - replica, total"] += found_m - found_r
            if mw == rw:
                out["stepper reads: same commands"] += 1
                out["same commands, same sum" if found_m == found_r else
                    "same commands, other sum"] += 1
                continue
            what = classify(mq, ents, found_m, found_r)
            if what == "same sum":
                what += (", same first command" if mw[:1] == rw[:1] else
                         ", other first command")
                if mw[:1] == rw[:1]:
                    what += (", model plans more" if len(mw) > len(rw) else
                             ", replica plans more" if len(rw) > len(mw) else ", same count")
            out["differ: " + what] += 1
            if in_step:
                out["in step: differ: " + what] += 1
            if (rec.t / 16000 >= since_ms and shown < show and what.startswith(only)
                    and (not in_step_only or in_step)):
                shown += 1
                task_off = rec.t - t.t + compare.FIRMWARE_LAG[board.task_vector]
                print(f"  {case} {rec.t / 16000:9.3f} ms M{k + 1} {what} (the model's read "
                      f"{late:+d} ticks after the firmware's, its task {task_off:+d}, "
                      f"its stepper {lag:+d})")
                print(f"     replica: cpu {r_cpu} at +{cyc - t.t} finds {found_r} "
                      f"({len(ents)} entries) writes {rw}")
                print(f"     model:   cpu {m_cpu} at +{m_at} finds {found_m} "
                      f"({len(mq)} entries) writes {mw}")
                if what == "queue":
                    print(f"     queued replica {ents}")
                    print(f"     queued model   {mq}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--conformance", type=Path, default=compare.e_fidelity.DEFAULT_CONF)
    ap.add_argument("--show", type=int, default=5)
    ap.add_argument("--since", type=float, default=0.0)
    ap.add_argument("--in-step", action="store_true", help="print only steppers in step "
                    "with the firmware's (see IN_STEP_TICKS)")
    ap.add_argument("--series", help="append one line per read to this file: case, "
                    "task tick, stepper, same commands, entries / sum / read tick / "
                    "commands model - replica")
    ap.add_argument("--only", default="", help="print only differing steppers of this "
                    "class (the start of its name)")
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE")
    args = ap.parse_args(argv)
    try:
        compare.e_fidelity.set_timing(args.set)
    except ValueError as exc:
        print(f"fill_reads: {exc}", file=sys.stderr)
        return 2
    total: collections.Counter = collections.Counter()
    for case in args.cases:
        c = analyse(case, args.conformance, args.work, args.show, args.since, args.only,
                    args.in_step)
        print(f"{case}:")
        for k, v in sorted(c.items()):
            print(f"    {k}: {v}")
        total.update(c)
    for case, rows in SERIES.items():
        lates = sorted(r[5] for r in rows)
        if lates and any(lates):
            n = len(lates)
            print(f"{case}: the model's read after the firmware's (ticks): median "
                  f"{lates[n // 2]:+d}, quartiles {lates[n // 4]:+d} / {lates[3 * n // 4]:+d}")
        if args.series:
            with open(args.series, "a") as f:
                for r in rows:
                    f.write(f"{case} {r[0]} {r[1]} {int(r[2])} {r[3]} {r[4]} {r[5]} {r[6]}\n")
    if len(args.cases) > 1:
        print("all:")
        for k, v in sorted(total.items()):
            print(f"    {k}: {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
