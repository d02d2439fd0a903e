"""The model's ramp-task tick beside timer 1's wrap in the replica (docs/timing-model.md,
"twenty-fifth pass").

The model runs its ramp task every 65 536 ticks from ``task_phase_ticks``; the firmware's
runs at timer 1's overflow.  For each case: the model's task phase (ticks modulo 65 536)
in the given build, the replica's wrap phase (from
``WORK/CASE.timer``, ``replica.py --timer-check``), and wrap - task.

    python3 bench/replica/task_wrap.py --work W [--build e] CASE...
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import e_fidelity  # noqa: E402
import timer_check  # noqa: E402

PERIOD = timer_check.PERIOD


def model_task_phase(case_input: str, build: str, profile: str = "atmega328p") -> int:
    """Ticks modulo PERIOD of the model's ramp-task runs over the scripted input (its
    task timeline at the end of the run)."""
    backend = e_fidelity.run_model(case_input, profile, build)
    assert backend.tasks.period == PERIOD, backend.tasks.period
    return int(backend.tasks.origin) % PERIOD


def signed(d: int) -> int:
    """``d`` folded to -PERIOD/2 .. PERIOD/2."""
    return (d + PERIOD // 2) % PERIOD - PERIOD // 2


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--build", default="e")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    for case in args.cases:
        text = (args.conformance / case / "input.txt").read_text().strip()
        task = model_task_phase(text, args.build)
        rep = timer_check.check((args.work / f"{case}.timer").read_text().splitlines())
        if rep.phase is None:
            print(f"{case}: no overflow in {args.work / case}.timer")
            continue
        print(f"{case}: model task {task}, replica wrap {rep.phase}, "
              f"wrap - task {signed(rep.phase - task)} ticks")
    return 0


if __name__ == "__main__":
    sys.exit(main())
