"""Each stepper start's first step, the model beside build d's replica, over every build-d
run (docs/timing-model.md, "forty-fifth pass").

A start is a queue started from rest (the replica's ``StepperQueue::startQueue()`` call,
mark 1; the model's :meth:`fas.sim.channel.SimChannel.start` that sets a stopped channel
running).  The anchor both sides share is the entry of the ramp task that makes the
start (the replica's vector 13 entered, the model's task event; both on the firmware's
time, the replica less its lead ``--lag``).  For every start, paired by stepper and
order (the k-th start of A on both sides):

* ``entry``: the model's task entry less the replica's (a command taken up by another
  task: a multiple of the task's period; else 0 - the task's phase);
* ``to step``: the first rise of the stepper's pin after the start, less the task's
  entry (the start task's length and the queue's start), replica and model, and the
  model's difference;
* ``first step``: the model's first rise less the replica's (``entry`` + the
  difference of ``to step``);
* the kind of start (the model's record of it): ``run`` (a continuous ramp: ``f`` /
  ``b``) or ``move``, ``dir`` (the stepper has a direction pin) or ``no dir``, ``en``
  (auto enable's delay written first: a bare pause) or not, the writes before the
  start (the replica's queue writes in the task, the model's entries queued), and
  the first entry's steps.

``--config`` runs the model once more per group of variants (``bench/d_corpus.py``'s,
separated by spaces; each in its own process).  The last table groups the starts by
kind: per config the median and range of ``to step``'s difference.

::

    python3 bench/replica/start_steps.py --work /tmp/fas-replica \\
        --config 'S42 P43 K43 L43 N44 F44 T44' d35 d14 test_sd_14_328p
    python3 bench/replica/start_steps.py --all --work /tmp/fas-replica --work /tmp/s34rep
"""

from __future__ import annotations

import argparse
import bisect
import collections
import contextlib
import multiprocessing
import statistics
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))

TASK_VECTOR = "13"
STEP_PINS = ("B1", "B2")  # A, B
START_MARK, QUEUE_WRITE_MARK = "1", "2"
RISE_WINDOW = (40, 160)  # a start's own compare rises this far after the call (cycles)


@dataclass
class Start:
    """One start: the stepper (0 = A), the entry of the task that made it, the start
    (the replica's call; the model's compare time), the stepper's first rise after the
    entry (None: none), the commands written before it, its kind (the model's record)
    and its pieces (:func:`pieces_of`, ``start``: the call to the rise)."""

    stepper: int
    entry: int
    call: int
    rise: int | None = None
    writes: int = 0
    kind: dict[str, Any] = field(default_factory=dict)
    pieces: dict[str, int] = field(default_factory=dict)

    @property
    def to_step(self) -> int | None:
        return None if self.rise is None else self.rise - self.entry


PIECES = ("first", "pitch", "tail", "nested", "start")
TAIL = ("tail", "start")  # the two sides split the last write to the rise differently


def pieces_of(writes: list[int], call_cpu: int, call_wall: int) -> dict[str, int]:
    """A start task's pieces from its own CPU at each write of the started queue and at
    the call, and the call's wall time after the entry: ``first`` (entry to the first
    write), ``pitch`` (the first write to the last), ``tail`` (the last write to the
    call), ``nested`` (the interrupts nested up to the call: wall less CPU)."""
    first = writes[0] if writes else call_cpu
    lastw = writes[-1] if writes else call_cpu
    return {"first": first, "pitch": lastw - first, "tail": call_cpu - lastw,
            "nested": call_wall - call_cpu}


# ------------------------------------------------------------------ replica's side
def replica_starts(ev: Iterable[str], pins: Iterable[str], lag: int) -> list[Start]:
    """The starts of a replica run (``CASE-TAG.ev`` / ``.pins`` lines), times less
    ``lag``, each with its task's own CPU (interrupts nested in it left out) at each
    queue write of the started queue and at the call.  The started stepper: the pin
    whose rise follows the call within ``RISE_WINDOW`` (a vote over the run's starts of
    the same queue; a queue that never shows one - its starts begin with auto enable's
    pause: the other stepper than a known one, else the pin that rises first after its
    calls, else A for the lower of two addresses)."""
    # entry, call (wall), queue address, the queue's writes' CPU, the call's CPU
    calls: list[tuple[int, int, int, list[int], int]] = []
    stack: list[str] = []
    entry = cpu = last = 0
    writes: dict[int, list[int]] = collections.defaultdict(list)
    for line in ev:
        p = line.split()
        if len(p) < 2:
            continue
        c = int(p[0]) - lag
        if stack and stack[-1] == TASK_VECTOR:
            cpu += c - last
        last = c
        if p[1] == "V":
            stack.append(p[2])
            if p[2] == TASK_VECTOR:
                entry, cpu = c, 0
                writes = collections.defaultdict(list)
        elif p[1] == "R":
            if stack:
                stack.pop()
        elif p[1] == "M" and TASK_VECTOR in stack:
            if p[2] == QUEUE_WRITE_MARK:
                writes[int(p[3])].append(cpu)
            elif p[2] == START_MARK:
                q = int(p[3])
                calls.append((entry, c, q, list(writes[q]), cpu))
    rises: list[list[int]] = [[], []]
    level = {pin: 0 for pin in STEP_PINS}
    for line in pins:
        p = line.split()
        if len(p) != 3 or p[1] not in level:
            continue
        v = int(p[2])
        if v and not level[p[1]]:
            rises[STEP_PINS.index(p[1])].append(int(p[0]) - lag)
        level[p[1]] = v
    def first_after(s: int, t: int) -> int | None:
        i = bisect.bisect_left(rises[s], t)
        return rises[s][i] if i < len(rises[s]) else None

    votes: dict[int, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    for _, call, q, _, _ in calls:
        for s in (0, 1):
            r = first_after(s, call)
            if r is not None and RISE_WINDOW[0] <= r - call <= RISE_WINDOW[1]:
                votes[q][s] += 1
    addresses = sorted({q for _, _, q, _, _ in calls})
    which: dict[int, int] = {}
    for q in addresses:
        if votes[q]:
            which[q] = votes[q].most_common(1)[0][0]
    for q in addresses:  # a queue whose starts begin with a pause (auto enable's delay)
        if q not in which:
            other = [which[x] for x in which]
            near: collections.Counter[int] = collections.Counter()
            for _, call, q2, _, _ in calls:
                rs = [(r - call, s) for s in (0, 1) if q2 == q
                      and (r := first_after(s, call)) is not None]
                if rs:
                    near[min(rs)[1]] += 1
            which[q] = ((1 - other[0]) if other else near.most_common(1)[0][0] if near
                        else 0 if q == addresses[0] else 1)
    out = []
    for entry_, call, q, ws, call_cpu in calls:
        s = which[q]
        rise = first_after(s, entry_)
        # the last write before the call is the start call's own (no command)
        pieces = pieces_of(ws[:-1] if len(ws) > 1 else ws, call_cpu, call - entry_)
        if rise is not None:
            pieces["start"] = rise - call
        out.append(Start(s, entry_, call, rise, max(len(ws) - 1, 0), pieces=pieces))
    return out


# -------------------------------------------------------------------- model's side
@contextlib.contextmanager
def starts_logged(backend: Any, into: list[Start]) -> Iterator[None]:
    """While it lasts, every start of a stopped channel of ``backend``'s machine goes
    to ``into`` (SimChannel.start wrapped, put back after)."""
    from fas.codes import PIN_UNDEFINED
    from fas.sim.channel import SimChannel

    saved, saved_added = SimChannel.start, SimChannel.entry_added
    m = backend.machine
    writes: dict[int, tuple[int, list[int]]] = {}  # channel: (task entry, CPU at writes)

    def entry_added(self: Any) -> None:
        saved_added(self)
        if self.m is m and m.in_task and not self.running:
            at, ws = writes.get(id(self), (None, []))
            if at != m.now:
                ws = []
                writes[id(self)] = (m.now, ws)
            ws.append(m.task_offset)

    def start(self: Any) -> None:
        was = self.running
        q = self.q
        queued = (q.next_write_idx - q.read_idx) & 0xFF
        e = q.entries[q.read_idx % q.queue_len] if queued else None
        entry = m.now
        saved(self)
        if self.m is not m or was or not self.running:
            return
        pieces: dict[str, int] = {}
        call = m.cpu_now()
        if m.in_task:  # the compare's time: the CPU before the start's tail
            off = m.task_offset
            m.task_offset = off - m.timing.fill_start_tail_ticks
            call, call_cpu = m.cpu_now(), m.task_offset
            m.task_offset = off
            at, ws = writes.get(id(self), (None, []))
            pieces = pieces_of(ws if at == entry else [], call_cpu, call - entry)
        into.append(Start(q.index, entry, call, None,
                          queued, {"run": bool(self.ramp_continuous),
                                   "dir": q.dir_pin != PIN_UNDEFINED,
                                   "en": bool(e is not None and e.steps == 0 and e.bare),
                                   "steps": e.total_steps if e is not None else 0,
                                   "end": bool(self.ramp_ended),
                                   "in_task": bool(m.in_task)}, pieces))

    SimChannel.start = start  # type: ignore[method-assign]
    SimChannel.entry_added = entry_added  # type: ignore[method-assign]
    try:
        yield
    finally:
        SimChannel.start = saved  # type: ignore[method-assign]
        SimChannel.entry_added = saved_added  # type: ignore[method-assign]


def model_starts(text: str) -> list[Start]:
    """The model's starts of ``text`` in build d (the current figures), each with the
    first rise of its pin after its task's entry."""
    from pulse_widths import backend_pulses

    from fas.sim import SimBackend
    from stepperdemo.program import make_program

    backend = SimBackend("atmega328p", record=True, build="d")
    starts: list[Start] = []
    with starts_logged(backend, starts):
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
    pulses = backend_pulses(backend)
    for s in starts:
        rises = [a for a, _ in pulses.get("ABCDEFGH"[s.stepper], [])]
        i = bisect.bisect_left(rises, s.entry)  # the stepper stood: its next rise
        s.rise = rises[i] if i < len(rises) else None
        if s.pieces and s.rise is not None:
            s.pieces["start"] = s.rise - s.call
    return starts


def _model_config(job: tuple[list[str], list[tuple[str, str]]]) -> list[list[Start]]:
    """In a process of its own: build d under ``settings``, the model's starts of each
    (case, text)."""
    from d_corpus import set_build_d

    settings, cases = job
    set_build_d(settings)
    return [model_starts(text) for _, text in cases]


def run_configs(configs: list[list[str]], cases: list[tuple[str, str]]) -> list[list[list[Start]]]:
    """The model's starts per config (a list of variant names) and case, each config in
    a process of its own (the figures are module tables)."""
    from d_corpus import VARIANTS

    jobs = [([s for v in cfg for s in ([v] if "=" in v else VARIANTS[v])], cases)
            for cfg in configs]
    ctx = multiprocessing.get_context("fork")
    out = []
    for job in jobs:
        with ctx.Pool(1) as pool:
            out.append(pool.apply(_model_config, (job,)))
    return out


# ----------------------------------------------------------------------- tables
def kind_text(kind: dict[str, Any]) -> str:
    """A start's kind: run/move, dir/no dir, en (auto enable's pause first)."""
    if not kind:
        return "?"
    return " ".join(("run" if kind["run"] else "move",
                     "dir" if kind["dir"] else "no dir") + (("en",) if kind["en"] else ())
                    + (("end",) if kind.get("end") else ()))


@dataclass
class Row:
    case: str
    stepper: int
    k: int
    replica: Start
    models: list[Start | None]

    @property
    def kind(self) -> str:
        m = next((x for x in self.models if x is not None), None)
        return kind_text(m.kind) if m is not None else "?"


def pair(case: str, replica: list[Start], models: list[list[Start]]) -> list[Row]:
    """Rows of one case: the k-th start of each stepper, the replica's beside each
    config's."""
    def by_stepper(starts: list[Start]) -> dict[tuple[int, int], Start]:
        n: collections.Counter[int] = collections.Counter()
        out = {}
        for s in starts:
            out[(s.stepper, n[s.stepper])] = s
            n[s.stepper] += 1
        return out
    mm = [by_stepper(m) for m in models]
    rows = []
    for (stepper, k), r in by_stepper(replica).items():
        rows.append(Row(case, stepper, k, r, [m.get((stepper, k)) for m in mm]))
    return rows


def _d(a: int | None, b: int | None) -> str:
    return "-" if a is None or b is None else f"{a - b:+d}"


def piece_diffs(r: Start, m: Start) -> dict[str, int] | None:
    """The model's pieces less the replica's: ``first``, ``pitch``, ``tail`` (the last
    write to the first rise: the tail and the queue's start together) and ``nested``."""
    if not r.pieces or not m.pieces or any(k not in x.pieces for x in (r, m) for k in TAIL):
        return None
    out = {k: m.pieces[k] - r.pieces[k] for k in ("first", "pitch", "nested")}
    out["tail"] = sum(m.pieces[k] for k in TAIL) - sum(r.pieces[k] for k in TAIL)
    return out


def _pieces_text(d: dict[str, int] | None) -> str:
    return "-" if d is None else " / ".join(f"{d[k]:+d}" for k in ("first", "pitch", "tail",
                                                                     "nested"))


def start_table(rows: list[Row], labels: list[str]) -> list[str]:
    """One line per start: case, stepper and its k, kind, the commands written before
    the start (replica / model), the first entry's steps, the replica's task entry to
    step; per config: entry, to step (difference), its pieces' differences (first /
    pitch / tail / nested) and the first step's."""
    head = ["case", "start", "kind", "writes r/m", "steps", "replica to step"]
    for lb in labels:
        head += [f"{lb}: entry", f"{lb}: to step", f"{lb}: first / pitch / tail / nested",
                 f"{lb}: first step"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for r in rows:
        m0 = next((x for x in r.models if x is not None), None)
        cells = [r.case, f"{'AB'[r.stepper]}{r.k}", r.kind,
                 f"{r.replica.writes}/{m0.writes if m0 else '-'}",
                 str(m0.kind.get("steps", "?")) if m0 else "-",
                 str(r.replica.to_step) if r.replica.to_step is not None else "-"]
        for m in r.models:
            if m is None:
                cells += ["-", "-", "-", "-"]
            else:
                cells += [_d(m.entry, r.replica.entry), _d(m.to_step, r.replica.to_step),
                          _pieces_text(piece_diffs(r.replica, m)), _d(m.rise, r.replica.rise)]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _spread(d: list[int]) -> str:
    return f"{statistics.median(d):+g} ({min(d):+d}..{max(d):+d})" if d else "-"


def kind_table(rows: list[Row], labels: list[str]) -> list[str]:
    """Per kind of start and config: the count, ``to step``'s difference and each
    piece's (median, min..max) over the starts the model also made."""
    groups: dict[str, list[Row]] = collections.defaultdict(list)
    for r in rows:
        groups[r.kind].append(r)
    lines = ["| kind | config | starts | to step | first | pitch | tail | nested |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for kind in sorted(groups):
        for j, lb in enumerate(labels):
            pairs = [(r.replica, m) for r in groups[kind] if (m := r.models[j]) is not None
                     and m.to_step is not None and r.replica.to_step is not None]
            d = [m.to_step - r.to_step for r, m in pairs]  # type: ignore[operator]
            ps = [x for r, m in pairs if (x := piece_diffs(r, m)) is not None]
            cells = [kind, lb, str(len(pairs)), _spread(d)]
            cells += [_spread([x[k] for x in ps]) for k in ("first", "pitch", "tail", "nested")]
            lines.append("| " + " | ".join(cells) + " |")
    return lines


def _cases_of(works: list[Path], tag: str) -> list[str]:
    suffix = f"-{tag}.ev"
    return sorted({p.name[:-len(suffix)] for w in works for p in w.glob(f"*{suffix}")})


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, action="append", default=[],
                    help="a folder of replica runs (repeatable; the first that holds a case)")
    ap.add_argument("--tag", default="Os-nolto-inall-pad1")
    ap.add_argument("--lag", type=int, default=96, help="replica minus firmware, ticks")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("--config", action="append", default=[],
                    help="variants of bench/d_corpus.py (or FIELD=VALUE settings) separated by "
                         "spaces (repeatable; "
                         "the default's column always comes first)")
    ap.add_argument("--all", action="store_true", help="every run of the --work folders")
    ap.add_argument("--kinds-only", action="store_true", help="only the table by kind")
    ap.add_argument("cases", nargs="*")
    args = ap.parse_args(argv)
    from d_corpus import VARIANTS

    works = args.work or [Path("/tmp/fas-replica")]
    configs: list[list[str]] = [[]] + [c.split() for c in args.config]
    for cfg in configs:
        bad = [v for v in cfg if v not in VARIANTS and "=" not in v]
        if bad:
            print(f"start_steps: unknown variant {bad[0]!r}", file=sys.stderr)
            return 2
    names = args.cases or (_cases_of(works, args.tag) if args.all else [])
    if not names:
        print("start_steps: no case (CASE ... or --all)", file=sys.stderr)
        return 2
    cases, replicas = [], []
    for case in names:
        where = next((w for w in works if (w / f"{case}-{args.tag}.ev").exists()), None)
        text_file = args.conformance / case / "input.txt"
        if where is None or not text_file.exists():
            print(f"start_steps: no replica run or input for {case}", file=sys.stderr)
            return 2
        prefix = where / f"{case}-{args.tag}"
        with open(f"{prefix}.ev") as ev, open(f"{prefix}.pins") as pins:
            replicas.append(replica_starts(ev, pins, args.lag))
        cases.append((case, text_file.read_text().strip()))
    models = run_configs(configs, cases)
    labels = [" ".join(c) or "default" for c in configs]
    rows = []
    for i, (case, _) in enumerate(cases):
        rows += pair(case, replicas[i], [models[j][i] for j in range(len(configs))])
    if not args.kinds_only:
        print("\n".join(start_table(rows, labels)))
        print()
    print("\n".join(kind_table(rows, labels)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
