"""The model's ramp tasks beside the replica's, task by task (docs/timing-model.md,
"ninth pass").

For each run given, every ramp task of the simulation model (build e, the case's
profile) is paired with the replica's task at the same timer overflow (the replica's
cycle lies within ``PAIR_TICKS`` of the model's tick) and compared: the commands each
stepper's fill planned (steps and ticks of every queue write, in order), the CPU time
of each write after the task's entry (the model: its ``task_offset`` when the write is
charged; the replica: its own cycles, interrupts nested in the task left out), and the
task's own CPU time; for each queue start, its CPU time after the task's entry and its
first compare (the replica's first step rises 80 cycles after ``startQueue()``),
model - replica.  The first tasks whose commands differ are printed with both
timelines; the summary counts the tasks that plan the same commands and the median
difference of each kind of write's CPU time.

A task whose commands differ is classed (docs/timing-model.md, "tenth pass"): the
replica writes the model's and more ("..., model's queue full" where the model's queue
held its 16 entries: the firmware's ``isQueueFull()`` read while its task runs), the
model writes the replica's and more, the replica planned the model's commands in the
task before or after ("a task apart"), or other.  The tasks that find the replica's
queues at their entry (the same entries after the running one) are counted apart: a
task whose queues differ plans differently because of what came before (a stepper one
gap ahead), not because of how it plans.

    python3 bench/replica/compare.py --work /tmp/fas-replica e01 e03 e09 e13 e14

``--at MS`` prints the task at that time whatever it planned, with the model's read of
each running stepper's queue (docs/timing-model.md, "fourteenth pass"): the task's
CPU time when its fill reads, the tick it reads at after the task's tick (that CPU
time stretched by the interrupts the model counts inside the task), and the ticks it
finds queued after the running entry - beside the replica's writes and the CPU of the
interrupts nested in its task, by vector.  ``--set [CHIP:]FIELD=VALUE`` runs the
model with other figures of build e (as ``bench/e_fidelity.py --set``).

``--phases`` prints, per run, timer 0's first overflow, the first ramp task and the
console's first transmit interrupt (the banner's second character loaded: the phase of
every character printed without a pause after it) of the model against the firmware's:
the replica's vector entries less the replica's constant lead over the firmware
(``FIRMWARE_LAG``, ``replica.py steps``) - docs/timing-model.md, "fifteenth pass" and
"sixteenth pass".

The replica's runs (``CASE.ev``) are read from ``--work``: ``replica.py ... tasks CASE``
writes them there (its ``--fas`` and ``--simavr`` are needed for that only).
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

import e_fidelity  # noqa: E402
import replica  # noqa: E402

from fas.queue import StepperQueue  # noqa: E402
from fas.sim import SimBackend  # noqa: E402
from fas.sim.channel import SimChannel  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402

QUEUE_START_CYCLES = 80  # the replica's first step rises this long after startQueue()
QUEUE_SLOTS = 16  # the AVR queue's entries
# the model's build (``--build``): e, the build of e01-e18; d, the default build of the
# d*/test_sd_* runs (its replica, ``replica.py --build d``, leads the firmware by 96)
MODEL_BUILD = "e"
PAIR_TICKS = 2000  # the replica's task enters within this of the model's (median +160)

# the replica's steps and `e` blocks come this many cycles after the firmware's from the
# first on (replica.py steps), by the replica's task vector; its timer-0 overflow vector
TIMER0_VECTOR = {13: 16, 20: 23}
UART_VECTOR = {13: 19, 20: 26}  # the console's data-register-empty interrupt
FIRMWARE_LAG = {13: 61, 20: 150}

Write = tuple[int, int, int, int]  # stepper, CPU ticks after the task's entry, ticks, steps


class ModelTask:
    def __init__(self, t: int) -> None:
        self.t = t
        self.cpu = 0
        self.writes: list[Write] = []
        self.queued: list[list[int]] = []
        # stepper, CPU ticks of its queue start, its first compare after the task's tick
        self.starts: list[tuple[int, int, int]] = []
        # each fill's read of its queue (a running stepper's): stepper, CPU ticks of the
        # task by then, the tick it reads at after the task's tick (the interrupts nested
        # in the task counted where SimTiming.task_nested_isrs says so), the ticks it
        # finds queued after the running entry
        self.reads: list[tuple[int, int, int, int]] = []
        # each read's queue: (ticks, steps) of the entries from the read index on, the
        # running one first (the model's read index: where its live read skips to)
        self.read_queues: list[list[tuple[int, int]]] = []
        self.read_ticks: list[int] = []


def model_tasks(case: str, conf: Path, keep: list[SimBackend] | None = None) -> list[ModelTask]:
    """Run the model on the case; return its ramp tasks with their writes (the backend
    appended to ``keep`` where given)."""
    plain_task, plain_added = SimBackend._task, SimChannel.entry_added  # noqa: SLF001
    plain_start = SimChannel.start
    # the fill's read of its queue: the planner's call (a model that reads the queue
    # live has a method of its own for it)
    read_name = ("fill_ticks_in_queue" if hasattr(StepperQueue, "fill_ticks_in_queue")
                 else "ticks_in_queue")
    plain_read = getattr(StepperQueue, read_name)
    log: list[ModelTask] = []
    letters: dict[int, int] = {}

    def task(self: SimBackend, index: int) -> None:
        m = self.machine
        rec = ModelTask(m.now)
        for ch in self.channels:
            q = ch.q
            rec.queued.append([q.entries[(q.read_idx + k) % q.queue_len].total_steps
                               for k in range((q.next_write_idx - q.read_idx) & 0xFF)]
                              if ch.running else [])
        log.append(rec)
        before = m.stolen_ticks
        plain_task(self, index)
        rec.cpu = m.stolen_ticks - before

    def added(ch: SimChannel) -> None:
        plain_added(ch)
        if ch.m.in_task and log:
            q = ch.q
            e = q.entries[(q.next_write_idx - 1) % q.queue_len]
            if not e.bare:  # auto enable's pauses: written inside the firmware's first
                k = letters.setdefault(id(ch), len(letters))  # command's call
                log[-1].writes.append((k, ch.m.task_offset, e.ticks, e.total_steps))

    def start(ch: SimChannel) -> None:
        was = ch.running
        plain_start(ch)
        if ch.m.in_task and log and ch.running and not was:
            k = letters.setdefault(id(ch), len(letters))
            m = ch.m
            tail = m.timing.fill_start_tail_ticks  # charged after the start: not in it
            m.task_offset -= tail
            log[-1].starts.append((k, m.task_offset, m.cpu_now() + ch.start_ticks - log[-1].t))
            m.task_offset += tail

    def read(q: StepperQueue) -> int:
        ch = q.channel
        if not (isinstance(ch, SimChannel) and ch.m.in_task and ch.running and log):
            return plain_read(q)
        m = ch.m
        live = getattr(m.timing, "fill_reads_queue_live", False)
        found = plain_read(q)  # (a live read charges the fill's checks first)
        work = m.task_offset
        nested = getattr(m.timing, "task_nested_isrs", 0)
        at = m.nested_stretched(work) if nested else m.stretched(work)  # type: ignore[attr-defined]
        k = letters.setdefault(id(ch), len(letters))
        log[-1].reads.append((k, work, at, found))
        n = q.queue_len
        ents = [(q.entries[(q.read_idx + j) % n].ticks, q.entries[(q.read_idx + j) % n].total_steps)
                for j in range((q.next_write_idx - q.read_idx) & 0xFF)]
        # a live read that finds the running entry ended counts from the next one
        while len(ents) > 1 and sum(t * max(s, 1) for t, s in ents[1:]) > found:
            ents = ents[1:]
        log[-1].read_queues.append(ents)
        # the tick the read finds the queue at, after the task's tick (the task's entry
        # without the live read)
        log[-1].read_ticks.append(ch.fill_read_tick - m.now if live else 0)
        return found

    SimBackend._task = task  # type: ignore[method-assign]  # noqa: SLF001
    setattr(StepperQueue, read_name, read)
    SimChannel.entry_added = added  # type: ignore[method-assign]
    SimChannel.start = start  # type: ignore[method-assign]
    try:
        folder = conf / case
        backend = e_fidelity.run_model((folder / "input.txt").read_text().strip(),
                                       e_fidelity.PROFILE.get(case, "atmega328p"), MODEL_BUILD)
        if keep is not None:
            keep.append(backend)
        del backend  # steppers numbered by their first write, as the replica's
    finally:
        SimBackend._task = plain_task  # type: ignore[method-assign]  # noqa: SLF001
        SimChannel.entry_added = plain_added  # type: ignore[method-assign]
        SimChannel.start = plain_start  # type: ignore[method-assign]
        setattr(StepperQueue, read_name, plain_read)
    return log


ReplicaTask = tuple[int, int, list[Write], list[list[int]], dict[int, int],
                    list[tuple[int, int]]]


def replica_tasks(case: str, work: Path) -> list[ReplicaTask]:
    """(cycle, own CPU, writes, queued steps, nested ticks by vector, CPU of each queue
    start) of every replica task.  A write's CPU time is that of its last queue write
    (the first command of a stepper writes auto enable's pauses before it), as the
    model's is charged when the entry is written; the call that starts a queue (no
    command: it is followed by the queue start) is left out."""
    board = replica.BOARDS.get(case, replica.UNO)
    tasks, _ = replica.tasks_of(work / case, board.task_vector)
    steppers: list[int] = []  # numbered by their first write, as the model's
    out = []
    for t in tasks:
        marks = t.marks
        # CPU of each queue start; its first compare (80 cycles after the call: the
        # first step's rise) after the task's entry
        starts = [(m[0], m[5] + QUEUE_START_CYCLES - t.t) for m in marks
                  if m[1] == replica.START]
        w = replica_tasks_one(t, steppers)
        out.append((t.t, t.cpu, w, t.queues, dict(t.nested), starts))
    return out


def replica_tasks_one(t: replica.Task, steppers: list[int]) -> list[Write]:
    """The command writes of one replica task (``steppers``: the steppers numbered by
    their first write, extended as new ones write)."""
    marks = t.marks
    w: list[Write] = []
    for j, m in enumerate(marks):
        if m[1] != replica.WRITE or not (m[3] > 0 and m[4] < 256):
            continue
        nxt = marks[j + 1:j + 3]
        if any(x[1] == replica.START for x in nxt):
            continue  # the start call
        cpu = m[0]
        for x in marks[j + 1:]:
            if x[1] == replica.QUEUE_WRITE:
                cpu = x[0]
            elif x[1] in (replica.WRITE, replica.START):
                break
        if m[2] not in steppers:
            steppers.append(m[2])
        w.append((steppers.index(m[2]), cpu, m[3], m[4]))
    return w


def _kind(w: Write, before: Write | None) -> str:
    if w[3] == 0:
        return "pause"
    if w[3] == 1:
        return "one step"
    if before is not None and before[0] == w[0] and before[2] == w[2]:
        return "coast"
    return "several"


def _queues_alike(mine: list[list[int]], theirs: list[list[int]]) -> bool:
    """The model's queues at the task's entry hold the replica's entries after the
    running one (whose steps left the model does not count down)."""
    n = max(len(mine), len(theirs))
    mine = mine + [[]] * (n - len(mine))
    theirs = theirs + [[]] * (n - len(theirs))
    return all(len(a) == len(b) and a[1:] == b[1:] for a, b in zip(mine, theirs, strict=True))


def _same(a: list[Write], b: list[Write]) -> bool:
    return [(s, t, n) for s, _, t, n in a] == [(s, t, n) for s, _, t, n in b]


def _differ(rec: ModelTask, writes: list[Write]) -> str:
    """How a task's commands differ from the replica's: the replica writes the model's
    and more to a stepper whose queue the model left full (a slot that freed while the
    firmware's task ran: its fill reads ``isQueueFull()`` live), or the model writes the
    replica's and more, or else."""
    mine = [(s, t, n) for s, _, t, n in rec.writes]
    theirs = [(s, t, n) for s, _, t, n in writes]
    if theirs[:len(mine)] == mine:
        extra = [s for s in {s for s, _, _ in theirs[len(mine):]}
                 if s < len(rec.queued) and rec.queued[s]]  # steppers running
        full = bool(extra) and all(
            len(rec.queued[s]) + sum(1 for x in mine if x[0] == s) >= QUEUE_SLOTS
            for s in extra)
        return "replica writes more, model's queue full" if full else "replica writes more"
    if mine[:len(theirs)] == theirs:
        return "model writes more"
    if sorted(mine) == sorted(theirs):
        return "same commands, other order"
    return "other"


def _fmt(w: list[Write]) -> str:
    return " ".join(f"M{s + 1}:{n}x{t}@{c}" for s, c, t, n in w) or "-"


def _print_task(case: str, rec: ModelTask, theirs: ReplicaTask, kind: str) -> None:
    t, cpu, writes, queued, nested, starts = theirs
    print(f"  {case} task at {rec.t / 16000:9.3f} ms (replica +{t - rec.t}, {kind}): "
          f"CPU model {rec.cpu} / replica {cpu} (nested {nested})")
    print(f"      queued model   {rec.queued}")
    print(f"      queued replica {queued}")
    print(f"      writes model   {_fmt(rec.writes)}")
    print(f"      writes replica {_fmt(writes)}")
    print(f"      queue starts model {rec.starts} / replica {starts}")
    if rec.reads:
        print("      model's reads  " + " ".join(
            f"M{k + 1}:cpu {cpu_at}, at +{at}, finds {found}"
            for k, cpu_at, at, found in rec.reads))


def compare(case: str, conf: Path, work: Path, show: int, since_ms: float,
            only: str = "", at_ms: tuple[float, ...] = ()) -> dict:
    mine = model_tasks(case, conf)
    theirs = replica_tasks(case, work)
    ts = [r[0] for r in theirs]
    paired = same = planned = 0
    planned_alike = same_alike = 0  # ... of the tasks that find the replica's queues
    diffs: dict[str, list[int]] = collections.defaultdict(list)
    cpu_diff: list[int] = []
    entry_diff: list[int] = []
    start_diff: list[int] = []
    kinds: collections.Counter[str] = collections.Counter()
    kinds_alike: collections.Counter[str] = collections.Counter()
    shown = 0
    first_bad: float | None = None
    for rec in mine:
        i = bisect.bisect_left(ts, rec.t - PAIR_TICKS)
        if i >= len(ts) or abs(ts[i] - rec.t) > PAIR_TICKS:
            continue
        t, cpu, writes, queued, nested, starts = theirs[i]
        if rec.starts and starts:
            cpu_off = rec.starts[-1][1] - starts[-1][0]
            first_off = rec.starts[-1][2] - starts[-1][1] - (t - rec.t)
            start_diff.append((cpu_off, first_off))
        paired += 1
        entry_diff.append(t - rec.t)
        if any(abs(rec.t / 16000 - a) < 2.048 for a in at_ms):
            _print_task(case, rec, theirs[i], "asked for")
        if not writes and not rec.writes:
            continue
        planned += 1
        alike = _queues_alike(rec.queued, queued)
        planned_alike += alike
        if _same(writes, rec.writes):
            same += 1
            same_alike += alike
            cpu_diff.append(rec.cpu - cpu)
            prev_m: Write | None = None
            prev_r: Write | None = None
            for wm, wr in zip(rec.writes, writes, strict=True):
                if prev_m is None or prev_r is None or prev_m[0] != wm[0]:
                    diffs["first of a stepper"].append(wm[1] - wr[1])
                else:
                    diffs[_kind(wr, prev_r)].append((wm[1] - prev_m[1]) - (wr[1] - prev_r[1]))
                prev_m, prev_r = wm, wr
            continue
        kind = _differ(rec, writes)
        if kind == "other" and any(_same(theirs[j][2], rec.writes) for j in (i - 1, i + 1)
                                   if 0 <= j < len(theirs)):
            kind = "the replica's a task apart"
        kinds[kind] += 1
        if alike:
            kinds_alike[kind] += 1
        if first_bad is None:
            first_bad = rec.t / 16000
        if rec.t / 16000 >= since_ms and shown < show and (not only or kind.startswith(only)
                                                                or only == "alike" and alike):
            shown += 1
            _print_task(case, rec, theirs[i], kind)
    med = replica._median  # noqa: SLF001
    print(f"{case}: {paired} tasks paired, {planned} plan commands, {same} the same commands"
          f" ({planned - same} differ, first at {first_bad} ms); replica's entry "
          f"{med(entry_diff):+d} ticks after the model's; own CPU model - replica "
          f"(tasks with the same commands) median {med(cpu_diff):+d}")
    if kinds:
        print("    differing tasks: " + ", ".join(f"{k} {n}" for k, n in kinds.most_common()))
    if start_diff:
        print("    queue starts, model - replica: (CPU after the task's entry, first compare) "
              f"{start_diff}")
    for k, v in sorted(diffs.items()):
        what = "CPU after the task's entry" if k.startswith("first") else \
            "CPU since the write before"
        print(f"    {k:18s} write: model - replica {what} {med(v):+5d} (median of {len(v)})")
    print(f"    tasks finding the replica's queues (the entries after the running one):"
          f" {planned_alike} plan commands, {same_alike} the same commands"
          + "".join(f", {k} {n}" for k, n in kinds_alike.most_common()))
    return {"paired": paired, "planned": planned, "same": same,
            "planned_alike": planned_alike, "same_alike": same_alike, **kinds,
            **{f"alike: {k}": n for k, n in kinds_alike.items()}}


def phases(case: str, conf: Path, work: Path) -> tuple[int, int, int]:
    """(timer 0's first overflow, the first ramp task, the console's first transmit
    interrupt): model - firmware, in ticks."""
    first: list[int] = []
    plain_task = SimBackend._task  # noqa: SLF001

    def task(self: SimBackend, index: int) -> None:
        if not first:
            first.append(self.machine.now)
        plain_task(self, index)

    uart: list[int] = []

    class Records(collections.deque):
        """The UART's newest characters, noting the first one the machine loaded."""

        def append(self, rec: list[int]) -> None:
            # [write tick, load tick, ...]: loaded later than written - by the
            # interrupt, while the one before it was on the wire
            if not uart and rec[1] > rec[0]:
                uart.append(rec[1])
            super().append(rec)

    SimBackend._task = task  # type: ignore[method-assign]  # noqa: SLF001
    try:
        backend = SimBackend(e_fidelity.PROFILE.get(case, "atmega328p"), record=True,
                             build="e")
        backend.machine.uart.records = Records(maxlen=backend.machine.uart.capacity)
        app = make_program("demo", backend, scripted=True)
        app.run_script((conf / case / "input.txt").read_text().strip(), firmware_end=True)
    finally:
        SimBackend._task = plain_task  # type: ignore[method-assign]  # noqa: SLF001
    board = replica.BOARDS.get(case, replica.UNO)
    vectors = (TIMER0_VECTOR[board.task_vector], board.task_vector,
               UART_VECTOR[board.task_vector])
    lag = FIRMWARE_LAG[board.task_vector]
    fw: dict[int, int] = {}
    with open(work / f"{case}.ev") as f:
        for line in f:
            p = line.split()
            if p[1] == "V" and int(p[2]) in vectors and int(p[2]) not in fw:
                fw[int(p[2])] = int(p[0]) - lag
                if len(fw) == len(vectors):
                    break
    assert len(fw) == len(vectors) and first and uart
    return (backend.machine.tick_at_millis(1) - fw[vectors[0]], first[0] - fw[vectors[1]],
            uart[0] - fw[vectors[2]])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"),
                    help="where replica.py wrote CASE.ev")
    ap.add_argument("--conformance", type=Path, default=e_fidelity.DEFAULT_CONF)
    ap.add_argument("--show", type=int, default=3, help="differing tasks to print per case")
    ap.add_argument("--since", type=float, default=0.0, help="print differing tasks from (ms)")
    ap.add_argument("--kind", default="", help="print only differing tasks of this kind "
                    "(the start of its name: 'model writes more', 'replica writes more', "
                    "'the replica's a task apart', 'other'; 'alike': those that found "
                    "the replica's queues)")
    ap.add_argument("--at", type=float, action="append", default=[], metavar="MS",
                    help="print the task at this time (ms) whatever it planned, with the "
                    "model's reads of each queue; repeatable")
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE",
                    help="a figure or mechanism of build e's timing for the model's runs "
                    "(as bench/e_fidelity.py --set); repeatable")
    ap.add_argument("--variant", action="append", default=[],
                    choices=sorted(e_fidelity.VARIANTS),
                    help="a named set of --set (as bench/e_fidelity.py --variant), applied "
                    "before --set; repeatable")
    ap.add_argument("--build", choices=("e", "d"), default="e",
                    help="the model's build: e (the runs e01-e18) or d (the d*/test_sd_* runs; "
                    "their replica: replica.py --build d, links CASE.ev)")
    ap.add_argument("--phases", action="store_true",
                    help="timer 0's first overflow, the first ramp task and the console's first "
                    "transmit interrupt, model - firmware")
    args = ap.parse_args(argv)
    global MODEL_BUILD
    MODEL_BUILD = args.build
    try:
        e_fidelity.set_timing(e_fidelity.variant_settings(args.variant) + args.set)
    except ValueError as exc:
        print(f"compare: {exc}", file=sys.stderr)
        return 2
    if args.phases:
        for case in args.cases:
            t0, task, uart = phases(case, args.conformance, args.work)
            print(f"{case}: model - firmware: timer 0's first overflow {t0:+d} ticks, "
                  f"the first ramp task {task:+d}, the console's first transmit "
                  f"interrupt {uart:+d}")
        return 0
    total = collections.Counter()
    for case in args.cases:
        if not (args.work / f"{case}.ev").exists():
            print(f"{case}: no replica run in {args.work} (replica.py ... tasks {case})")
            continue
        total.update(compare(case, args.conformance, args.work, args.show, args.since,
                             args.kind, tuple(args.at)))
    print(f"all: {total['planned']} tasks plan commands, {total['same']} the same commands")
    print(f"all, tasks finding the replica's queues: {total['planned_alike']} plan commands, "
          f"{total['same_alike']} the same commands"
          + "".join(f", {k[7:]} {n}" for k, n in sorted(total.items(), key=lambda x: -x[1])
                    if k.startswith("alike: ")))
    rest = {k: n for k, n in total.items()
            if k not in ("paired", "planned", "same", "planned_alike", "same_alike")
            and not k.startswith("alike: ")}
    print("all differing: " + ", ".join(f"{k} {n}" for k, n in
                                      sorted(rest.items(), key=lambda x: -x[1])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
