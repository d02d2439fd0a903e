"""Where two step time lines part: a ramp-task slot or a timer wrap (docs/timing-model.md,
"twenty-third pass").

Compares the rising step edges of a conformance run (``steps_X.tsv.gz``), of the model
(build d or e) and, where given, of the firmware's replica (``CASE.pins`` of
``bench/replica/replica.py``), pair by pair, and prints every step where the offset
between two lines changes by more than ``--threshold`` ticks.  Each such step is classed:

* ``wrap in LINE (+N)``: that line's gap is its previous gap plus a timer period
  (65 536 ticks): a compare was missed and the 16-bit timer wrapped first.  ``N`` is the
  gap less the period less the previous gap: 0 where the compare was programmed in time
  and lost (a step interrupt held past it makes the same gap), ``RESTART_TICKS`` (10)
  where the queue ran dry and the step interrupt restarted it with ``ticks = 10``
  (``fas/sim/channel.py``) - that path can only follow the last step of a queue entry;
* ``slot``: the first step after a stop (a gap of more than a ramp task's period) comes
  a whole number of ramp-task periods apart: the move was planned in another task;
* ``other``.

``--calls`` times the moves started by the loop (the library's ``move``/``moveTo``
called while a stepper has stopped): in the model, per call, the tick of the last
queue stop before it (the compare whose interrupt finds the queue empty), the call and
the next ramp task; with ``--replica WORK --elf ELF``, the same from the replica's
interrupt log: the entry of the last step interrupt before the call, the ``cli`` inside
``FastAccelStepper::move``/``moveTo`` (their address ranges read from the ELF with
``avr-nm``) and the next ramp task's entry.

    python3 bench/slot_jumps.py --conformance ../shared/conformance test_seq_sd_02_328p
    python3 bench/slot_jumps.py --build e --replica /tmp/rep test_seq_sd_02_328p
    python3 bench/slot_jumps.py --build e --calls --replica /tmp/rep \\
        --elf /tmp/rep/fw-<hash>/fw.elf test_seq_sd_02_328p
"""

from __future__ import annotations

import argparse
import bisect
import gzip
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from pulse_widths import replica_rises  # noqa: E402

from fas.sim.channel import RESTART_TICKS  # noqa: E402

PERIOD = 65536  # timer 1 of the ATmega328P: its wrap and the ramp task's period
WRAP_SLACK = 40  # ticks: a wrap's gap against its previous gap + PERIOD
SLOT_SLACK = 3000  # ticks: a slot's offset change against a whole number of periods
TICKS_PER_US = 16
STEP_VECTORS = {11, 12}  # TIMER1_COMPA/B on the ATmega328P
TASK_VECTOR = 13  # TIMER1_OVF
REPLICA_PINS = {"A": "B1", "B": "B2"}


def jumps(a: Sequence[int], b: Sequence[int], threshold: int) -> list[tuple[int, int, int]]:
    """(index, offset before, offset after) where ``a[i] - b[i]`` changes by more than
    ``threshold`` ticks from one step to the next (the first step counts as a change
    from 0 only if its offset exceeds it)."""
    out: list[tuple[int, int, int]] = []
    prev = 0
    for i in range(min(len(a), len(b))):
        d = a[i] - b[i]
        if abs(d - prev) > threshold:
            out.append((i, prev, d))
        prev = d
    return out


def wrap_excess(line: Sequence[int], i: int) -> int | None:
    """Ticks of ``line``'s gap before step ``i`` beyond its previous gap + one timer
    period, if that gap is a wrap (within ``WRAP_SLACK``), else None."""
    if i < 2:
        return None
    excess = (line[i] - line[i - 1]) - PERIOD - (line[i - 1] - line[i - 2])
    return excess if abs(excess) <= WRAP_SLACK else None


def classify(names: tuple[str, str], a: Sequence[int], b: Sequence[int], i: int,
             change: int) -> str:
    """The kind of the jump at step ``i`` of the pair (a, b) (module docstring)."""
    if i == 0:
        return "the first step"
    for name, line in zip(names, (a, b), strict=True):
        excess = wrap_excess(line, i)
        if excess is not None:
            kind = "dry-queue restart" if abs(excess - RESTART_TICKS) <= 2 else "compare lost"
            return f"wrap in {name} ({excess:+d}: {kind})"
    k = round(change / PERIOD)
    rest = min(a[i] - a[i - 1], b[i] - b[i - 1]) > PERIOD
    if k and abs(change - k * PERIOD) <= SLOT_SLACK and rest:
        return f"slot ({k:+d})"
    return "other"


def report(names: tuple[str, str], a: Sequence[int], b: Sequence[int],
           threshold: int, most: int = 12) -> list[str]:
    """One line per jump (at most ``most``; then how many more)."""
    lines = []
    found = jumps(a, b, threshold)
    for i, before, after in found[:most]:
        gaps = f" (gaps {a[i] - a[i - 1]} / {b[i] - b[i - 1]})" if i else ""
        kind = classify(names, a, b, i, after - before)
        lines.append(f"  step {i} at {b[i] / TICKS_PER_US / 1e6:.4f} s: {names[0]} - "
                     f"{names[1]} {before:+d} -> {after:+d} ticks{gaps}: {kind}")
    if len(found) > most:
        lines.append(f"  ... {len(found) - most} more")
    return lines


def firmware_rises(path: Path) -> list[int]:
    with gzip.open(path, "rt") as fh:
        return [round(float(line.split()[0]) * TICKS_PER_US) for line in fh if line.strip()]


# ---------------------------------------------------------------- moves from the loop
def replica_calls(ev: Path, ranges: Sequence[tuple[int, int]]
                  ) -> list[tuple[int, int, int]]:
    """Per first ``cli`` of the main program inside one of ``ranges`` (byte addresses,
    [lo, hi)) after a step interrupt: (entry of the last step interrupt before it, the
    ``cli``, the next ramp task's entry) in cycles.  The step interrupt enters 4 cycles
    after its compare when nothing holds it (the model's stop is at the compare)."""
    last_step = None
    calls: list[list[int]] = []
    tasks: list[int] = []
    stack: list[tuple[int, int]] = []
    armed = False
    with open(ev) as fh:
        for line in fh:
            p = line.split()
            if p[1] == "V":
                v = int(p[2])
                stack.append((v, int(p[0])))
                if v == TASK_VECTOR:
                    tasks.append(int(p[0]))
            elif p[1] == "R" and stack:
                v, entry = stack.pop()
                if v in STEP_VECTORS:
                    last_step = entry
                    armed = True
            elif p[1] == "C" and not stack and armed and last_step is not None:
                addr = int(p[2], 16)
                if any(lo <= addr < hi for lo, hi in ranges):
                    calls.append([last_step, int(p[0])])
                    armed = False
    out = []
    for stop, call in calls:
        j = bisect.bisect_right(tasks, call)
        out.append((stop, call, tasks[j] if j < len(tasks) else -1))
    return out


def move_ranges(elf: Path) -> list[tuple[int, int]]:
    """Byte address ranges of ``FastAccelStepper::move``/``moveTo`` (their clones too)."""
    text = subprocess.run(["avr-nm", "-C", "-S", str(elf)], check=True, capture_output=True,
                          text=True).stdout
    out = []
    for line in text.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[3].startswith(("FastAccelStepper::move(",
                                                     "FastAccelStepper::moveTo(")):
            lo = int(parts[0], 16) & 0xFFFFF
            out.append((lo, lo + int(parts[1], 16)))
    return out


def model_calls(case_input: str, profile: str, build: str) -> tuple[list[tuple[int, int, int]],
                                                                      object]:
    """The model's (last queue stop before the call, the call, next ramp task) per
    ``move``/``move_to`` of the library, and the backend of the run."""
    import e_fidelity

    from fas import stepper as fas_stepper
    from fas.sim import backend as sim_backend
    stops: list[int] = []
    calls: list[tuple[int, int]] = []
    tasks: list[int] = []
    cls = sim_backend.SimBackend
    saved = (cls._task, cls.queue_ran_dry, fas_stepper.Stepper.move, fas_stepper.Stepper.move_to)
    current: list[object] = []

    def task(self, index):  # type: ignore[no-untyped-def]
        tasks.append(self.machine.now)
        return saved[0](self, index)

    def dry(self):  # type: ignore[no-untyped-def]
        stops.append(self.machine.now)
        return saved[1](self)

    def wrap(orig):  # type: ignore[no-untyped-def]
        def call(self, *args, **kw):  # type: ignore[no-untyped-def]
            if current and stops and not getattr(current[0], "_nested", False):
                calls.append((stops[-1], current[0].now()))  # type: ignore[attr-defined]
            return orig(self, *args, **kw)
        return call

    cls._task = task  # type: ignore[method-assign]
    cls.queue_ran_dry = dry  # type: ignore[method-assign]
    fas_stepper.Stepper.move = wrap(saved[2])  # type: ignore[method-assign]
    fas_stepper.Stepper.move_to = wrap(saved[3])  # type: ignore[method-assign]
    orig_init = cls.__init__

    def init(self, *args, **kw):  # type: ignore[no-untyped-def]
        orig_init(self, *args, **kw)
        current[:] = [self]

    cls.__init__ = init  # type: ignore[method-assign]
    try:
        backend = e_fidelity.run_model(case_input, profile, build)
    finally:
        cls._task, cls.queue_ran_dry = saved[0], saved[1]  # type: ignore[method-assign]
        fas_stepper.Stepper.move, fas_stepper.Stepper.move_to = saved[2], saved[3]  # type: ignore[method-assign]
        cls.__init__ = orig_init  # type: ignore[method-assign]
    out = []
    seen = set()
    for stop, call in calls:
        if (stop, call) in seen:  # move() calls move_to(): one call
            continue
        seen.add((stop, call))
        j = bisect.bisect_right(tasks, call)
        out.append((stop, call, tasks[j] if j < len(tasks) else -1))
    return out, backend


def calls_table(name: str, rows: Sequence[tuple[int, int, int]]) -> list[str]:
    lines = [f"{name}: {len(rows)} moves started by the loop; ticks after the queue's "
             "stop: the call, the next ramp task (margin = task - call)"]
    for stop, call, task in rows:
        lines.append(f"  {stop / TICKS_PER_US / 1e6:9.4f} s: call +{call - stop}, task "
                     f"+{task - stop}, margin {task - call}")
    return lines


def main(argv: list[str] | None = None) -> int:
    import e_fidelity

    from stepperdemo.scenarios.evaluate import step_times_us, stepper_pins

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("case")
    ap.add_argument("--conformance", type=Path, default=e_fidelity.DEFAULT_CONF)
    ap.add_argument("--build", choices=("d", "e"), help="the model's build (default: the "
                    "case's, bench/e_fidelity.py build_of)")
    ap.add_argument("--profile", default="atmega328p")
    ap.add_argument("--replica", type=Path, help="a replica.py --work folder with CASE.pins")
    ap.add_argument("--elf", type=Path, help="the replica's firmware (for --calls)")
    ap.add_argument("--threshold", type=int, default=2000, help="ticks")
    ap.add_argument("--most", type=int, default=12, help="jumps listed per pair")
    ap.add_argument("--calls", action="store_true", help="time the moves started by the loop")
    args = ap.parse_args(argv)
    folder = args.conformance / args.case
    build = args.build or e_fidelity.build_of(args.case)
    inp = (folder / "input.txt").read_text().strip()
    if args.calls:
        rows, backend = model_calls(inp, args.profile, build)
        print("\n".join(calls_table(f"model (build {build})", rows)))
        if args.replica and args.elf:
            rep = replica_calls(args.replica / f"{args.case}.ev", move_ranges(args.elf))
            print("\n".join(calls_table("replica", rep)))
    else:
        backend = e_fidelity.run_model(inp, args.profile, build)
    for sp in stepper_pins(backend.profile):  # type: ignore[attr-defined]
        path = folder / f"steps_{sp.letter}.tsv.gz"
        if not path.exists():
            continue
        lines = {"firmware": firmware_rises(path),
                 f"model {build}": [round(t * TICKS_PER_US)
                                    for t in step_times_us(backend, sp.step)]}  # type: ignore[arg-type]
        pins = args.replica / f"{args.case}.pins" if args.replica else None
        if pins is not None and pins.exists():
            lines["replica"] = replica_rises(pins, REPLICA_PINS[sp.letter])
        print(f"== {args.case} {sp.letter}: " + ", ".join(f"{k} {len(v)} steps"
                                                          for k, v in lines.items()))
        names = list(lines)
        for x in range(len(names)):
            for y in range(x + 1, len(names)):
                pair = (names[y], names[x])
                print(f"{pair[0]} - {pair[1]}:")
                print("\n".join(report(pair, lines[pair[0]], lines[pair[1]], args.threshold,
                                       args.most))
                      or "  no jump")
    return 0


if __name__ == "__main__":
    sys.exit(main())
