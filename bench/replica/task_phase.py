"""The ramp task's phase and timer 0's in a replica's runs against the model's
(docs/timing-model.md, "thirtieth pass").

For each case: the firmware's ramp-task phase - the most frequent entry of timer 1's
overflow vector in the replica's interrupt log (``WORK/CASE[-TAG].ev``), less the
replica's lead over the firmware (``--lag``), modulo 65 536 - and the earliest such
entry; timer 0's first overflow (its vector's first entry, less the lead and 4 cycles of
the vector's entry, modulo 16 384); beside the model's (its first task tick, the tick its
millis() starts counting, in the given build), and model - firmware for both:

    python3 bench/replica/task_phase.py --work /tmp/fas-replica --tag Os-nolto-inall-pad1 \
        --build d --lag 96 d01 d21 ...

Interrupts that hold the task's vector (a step interrupt, the UART's, a critical section
of the loop) make some entries later than the overflow's own; the most frequent entry is
the one none held.  ``--set`` runs the model with other figures (as
``bench/e_fidelity.py --set``).
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

TASK_PERIOD = 65536
TIMER0_PERIOD = 64 * 256
VECTOR_ENTRY = 4  # cycles from the flag to the vector's first instruction
TASK_VECTOR = 13  # the ATmega328P's TIMER1_OVF
TIMER0_VECTOR = 16  # TIMER0_OVF


@dataclass(frozen=True)
class Phases:
    task_mode: int  # most frequent task entry, mod TASK_PERIOD
    task_min: int  # earliest residue of the task entries (mod TASK_PERIOD)
    task_share: float  # share of the task entries at task_mode
    tasks: int
    timer0: int | None  # timer 0's first overflow, mod TIMER0_PERIOD


def read_phases(lines: Iterable[str], lag: int, task_vector: int = TASK_VECTOR,
                timer0_vector: int = TIMER0_VECTOR) -> Phases:
    """The firmware's phases from a replica's event lines (``cycle V vector``)."""
    entries: list[int] = []
    timer0: int | None = None
    for line in lines:
        p = line.split()
        if len(p) < 3 or p[1] != "V":
            continue
        vec, t = int(p[2]), int(p[0]) - lag
        if vec == task_vector:
            entries.append(t % TASK_PERIOD)
        elif vec == timer0_vector and timer0 is None:
            timer0 = (t - VECTOR_ENTRY) % TIMER0_PERIOD
    if not entries:
        raise ValueError("no ramp task in the log")
    counts = collections.Counter(entries)
    mode, n = counts.most_common(1)[0]
    # the earliest residue: the one the others lie just after (entries come late, never early)
    earliest = min(entries, key=lambda r: (r - mode + TASK_PERIOD // 2) % TASK_PERIOD)
    return Phases(mode, earliest, n / len(entries), len(entries), timer0)


def model_phases(case_input: str, build: str, profile: str = "atmega328p") -> tuple[int, int]:
    """(the model's first ramp task tick mod TASK_PERIOD, timer 0's first overflow mod
    TIMER0_PERIOD): the run stops once the engine's task timeline is set."""
    import e_fidelity

    from fas.sim.backend import SimBackend

    class Stop(Exception):
        pass

    seen: list[int] = []
    plain = SimBackend.attach_engine

    def attach(self: SimBackend, engine: object) -> None:
        plain(self, engine)  # type: ignore[arg-type]
        seen.append(int(self.tasks.origin))
        seen.append(int(self.machine.tick_at_millis(1)))
        raise Stop

    SimBackend.attach_engine = attach  # type: ignore[method-assign]
    try:
        with contextlib.suppress(Stop):
            e_fidelity.run_model(case_input, profile, build)
    finally:
        SimBackend.attach_engine = plain  # type: ignore[method-assign]
    if not seen:
        raise ValueError("the model never started its ramp task")
    return seen[0] % TASK_PERIOD, seen[1] % TIMER0_PERIOD


def signed(d: int, period: int) -> int:
    """``d`` folded to -period/2 .. period/2."""
    return (d + period // 2) % period - period // 2


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--tag", default="", help="the replica build's tag in the file names "
                    "(Os-nolto-inall-pad1 for --build d of replica.py)")
    ap.add_argument("--build", default="d", help="the model's build")
    ap.add_argument("--lag", type=int, default=96, help="replica minus firmware, ticks")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    import e_fidelity
    try:
        e_fidelity.set_timing(args.set)
    except ValueError as exc:
        print(f"task_phase: {exc}", file=sys.stderr)
        return 2
    suffix = f"-{args.tag}" if args.tag else ""
    for case in args.cases:
        path = args.work / f"{case}{suffix}.ev"
        if not path.exists():
            print(f"{case}: no replica run {path}")
            continue
        with open(path) as f:
            fw = read_phases(f, args.lag)
        text = (args.conformance / case / "input.txt").read_text().strip()
        task, t0 = model_phases(text, args.build)
        t0_d = "-" if fw.timer0 is None else f"{signed(t0 - fw.timer0, TIMER0_PERIOD):+d}"
        print(f"{case}: task firmware {fw.task_mode} ({fw.task_share:.0%} of {fw.tasks}, "
              f"earliest {signed(fw.task_min - fw.task_mode, TASK_PERIOD):+d}) model {task} "
              f"model-firmware {signed(task - fw.task_mode, TASK_PERIOD):+d}; timer 0 "
              f"firmware {fw.timer0} model {t0} model-firmware {t0_d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
