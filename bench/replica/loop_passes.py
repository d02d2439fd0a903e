"""The main loop's passes and one library call against the ramp task, from a replica run
recorded with marks on ``loop()`` and the call (docs/timing-model.md, "twenty-ninth pass").

``replica.py`` marks the queue's functions only; this re-runs a built firmware (an ELF of
``replica.py``'s work folder, e.g. ``fw-<hash>/fw.elf`` of ``--build d``) in its runner with
marks also on ``loop``, ``FastAccelStepper::stopMove()`` / ``move`` / ``moveTo`` /
``isRunning()`` and ``millis``, and reads its ``.ev``:

* each call of the named function (``--call``, default ``stopMove``): the entry of the
  ramp task before and after it, the call's distance to them (ticks), and the loop pass
  that made it;
* the loop's passes between two times (``--window A B`` in ms), each pass's length from
  ``loop()``'s entry to the next, less the cycles spent in interrupts (vector entry to
  ``reti``), as a histogram, with what each pass called (isRunning, millis).

    python3 bench/replica/loop_passes.py --elf /tmp/fas-replica/fw-<hash>/fw.elf \\
        --work /tmp/lp --ms 3317 --window 700 1139 d21

The runner's recording does not change the firmware's cycles: the step pins come out
the same as ``replica.py``'s run (checked with ``--pins``).
"""

from __future__ import annotations

import argparse
import bisect
import collections
import os
import subprocess
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import replica  # noqa: E402

TICKS_PER_MS = 16000
CALLS = {"stopMove": "FastAccelStepper::stopMove(", "move": "FastAccelStepper::move(",
         "moveTo": "FastAccelStepper::moveTo(",
         "applySpeedAcceleration": "FastAccelStepper::applySpeedAcceleration(",
         "moveByAcceleration": "FastAccelStepper::moveByAcceleration("}
EXTRA = ("loop", "FastAccelStepper::isRunning(", "millis", "HardwareSerial::write(",
         "process_cmd(")


def addresses(elf: Path, names: Sequence[str]) -> dict[str, int]:
    """Byte addresses of functions named exactly (``loop``, ``millis``) or by a prefix of
    their demangled name (``FastAccelStepper::stopMove(``)."""
    text = subprocess.run(["avr-nm", "-C", str(elf)], check=True, capture_output=True,
                          text=True).stdout
    out: dict[str, int] = {}
    for line in text.splitlines():
        parts = line.split(None, 2)
        if len(parts) != 3 or parts[1] not in "Tt":
            continue
        for n in names:
            if n not in out and (parts[2] == n or (n.endswith("(") and parts[2].startswith(n))):
                out[n] = int(parts[0], 16)
    missing = [n for n in names if n not in out]
    if missing:
        raise SystemExit(f"not in {elf}: {', '.join(missing)}")
    return out


def record(elf: Path, work: Path, case: str, ms: float, task_vector: int, queues: int,
           call: str) -> tuple[Path, list[str]]:
    """Run the runner on ``elf`` with the marks; returns the ``.ev`` path and the names
    of the marks in their order (``M k``: the k-th)."""
    names = list(replica.MARK_NAMES) + [CALLS[call], *EXTRA]
    marks = addresses(elf, names)
    _, queue_base = replica.symbols(elf, replica.MARK_NAMES)
    exe = work / "replica_run"
    if not exe.exists():
        raise SystemExit(f"no runner in {work}: run replica.py there first")
    prefix = work / f"{case}-loop"
    env = {**os.environ, "MARKS": ",".join(f"{marks[n]:x}" for n in names),
           "TASK_VECTOR": str(task_vector), "QUEUES": str(queues),
           "QUEUE_BASE": f"{queue_base:x}"}
    pins = replica.UNO.pins.values()
    subprocess.run([str(exe), str(elf), "atmega328p", f"{ms:.0f}", str(prefix), *pins],
                   check=True, env=env)
    return Path(f"{prefix}.ev"), names


class Trace:
    """What an ``.ev`` holds: task entries, mark hits at depth 0, interrupt spans."""

    def __init__(self, lines: Iterable[str], task_vector: int) -> None:
        self.tasks: list[int] = []
        self.marks: dict[int, list[int]] = collections.defaultdict(list)
        self.irq: list[tuple[int, int]] = []  # (entry, reti) of outermost interrupts
        depth = 0
        entry = 0
        for line in lines:
            p = line.split()
            c = int(p[0])
            if p[1] == "V":
                if depth == 0:
                    entry = c
                depth += 1
                if int(p[2]) == task_vector:
                    self.tasks.append(c)
            elif p[1] == "R":
                if depth > 0:
                    depth -= 1
                    if depth == 0:
                        self.irq.append((entry, c))
            elif p[1] == "M" and depth == 0:
                self.marks[int(p[2])].append(c)
        self._ends = [b for _, b in self.irq]
        self._cum = [0]
        for a, b in self.irq:
            self._cum.append(self._cum[-1] + b - a)

    def irq_between(self, a: int, b: int) -> int:
        """Cycles spent in interrupts in [a, b) (whole interrupts whose reti lies there;
        a pass boundary never falls inside one, both are main-program events)."""
        i = bisect.bisect_right(self._ends, a)
        j = bisect.bisect_right(self._ends, b)
        return self._cum[j] - self._cum[i]


def call_rows(tr: Trace, k: int, loop_k: int) -> list[tuple[int, int, int, int]]:
    """Per call of mark ``k``: (the call, the task before, the task after, the loop
    pass's start)."""
    loops = tr.marks[loop_k]
    out = []
    for c in tr.marks[k]:
        j = bisect.bisect_right(tr.tasks, c)
        before = tr.tasks[j - 1] if j else -1
        after = tr.tasks[j] if j < len(tr.tasks) else -1
        i = bisect.bisect_right(loops, c)
        out.append((c, before, after, loops[i - 1] if i else -1))
    return out


def passes(tr: Trace, loop_k: int, a: int, b: int,
           extra: dict[str, int]) -> list[tuple[int, int, dict[str, list[int]]]]:
    """The loop's passes starting in [a, b): (start, CPU length without interrupts,
    {mark name: offsets of its calls in the pass, interrupts taken out})."""
    loops = tr.marks[loop_k]
    out = []
    for i in range(bisect.bisect_left(loops, a), len(loops) - 1):
        s, e = loops[i], loops[i + 1]
        if s >= b:
            break
        hits: dict[str, list[int]] = {}
        for name, k in extra.items():
            xs = tr.marks[k]
            lo, hi = bisect.bisect_left(xs, s), bisect.bisect_left(xs, e)
            hits[name] = [x - s - tr.irq_between(s, x) for x in xs[lo:hi]]
        out.append((s, e - s - tr.irq_between(s, e), hits))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case")
    ap.add_argument("--elf", type=Path, required=True, help="the replica's built firmware")
    ap.add_argument("--work", type=Path, required=True,
                    help="a replica.py work folder (its runner); the .ev goes there")
    ap.add_argument("--ev", type=Path, help="read this .ev (recorded before) instead")
    ap.add_argument("--ms", type=float, default=5000.0, help="simulated time")
    ap.add_argument("--call", choices=sorted(CALLS), default="stopMove")
    ap.add_argument("--window", type=float, nargs=2, metavar=("A_MS", "B_MS"),
                    help="list the loop's passes starting in [A, B) ms")
    args = ap.parse_args(argv)
    names = list(replica.MARK_NAMES) + [CALLS[args.call], *EXTRA]
    if args.ev:
        ev = args.ev
    else:
        ev, names = record(args.elf, args.work, args.case, args.ms, replica.UNO.task_vector,
                           replica.UNO.queues, args.call)
    k_call, k_loop = names.index(CALLS[args.call]), names.index("loop")
    with open(ev) as fh:
        tr = Trace(fh, replica.UNO.task_vector)
    print(f"{args.case}: {len(tr.tasks)} ramp tasks, {len(tr.marks[k_loop])} loop passes")
    for c, before, after, start in call_rows(tr, k_call, k_loop):
        print(f"  {args.call} at {c} ({c / TICKS_PER_MS:.4f} ms): task before -{c - before}, "
              f"task after +{after - c}; its pass began {c - start} before "
              f"({c - start - tr.irq_between(start, c)} without interrupts)")
    if args.window:
        a, b = (round(x * TICKS_PER_MS) for x in args.window)
        extra = {"isRunning": names.index("FastAccelStepper::isRunning("),
                 "millis": names.index("millis")}
        rows = passes(tr, k_loop, a, b, extra)
        hist = collections.Counter((n, tuple(len(h[m]) for m in extra)) for _, n, h in rows)
        print(f"  {len(rows)} passes in [{args.window[0]}, {args.window[1]}) ms "
              "(ticks without interrupts; calls of isRunning, millis): count")
        for (n, calls), cnt in sorted(hist.items(), key=lambda x: -x[1])[:12]:
            print(f"    {n:6d} {calls}: {cnt}")
        offs = collections.Counter(tuple(tuple(v) for v in h.values()) for _, _, h in rows)
        print("  call offsets in the pass (isRunning, millis): count")
        for o, cnt in offs.most_common(6):
            print(f"    {o}: {cnt}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
