"""A starting ramp's commands on build d's replica, command by command: what each costs
the start task by the branch the ramp's arithmetic took (docs/timing-model.md,
"forty-seventh pass").

The start task's ``pitch`` (bench/replica/start_steps.py, "forty-fifth pass") is the
task's own CPU from its first command's write to its last.  This tool reads it per
command from a replica run made with ``--profile`` (``replica.py --build d --profile
pitches CASE``; the run's ``CASE-TAG.ev`` and ``CASE.funcs``): every command of several
steps a ramp task writes while no queue runs (the start task's ramp up), after another
command of the same stepper, with the CPU between the two writes (``pitch``, nested
interrupts left out) and the routines that ran in between.  Each command is classed by
what ``_getNextCommand()`` did for it:

* ``acc`` / ``coast`` / ``dec``: the command against the one before (faster, the same
  period, slower);
* ``maths``: ``ramp_config_s::calculate_ticks()`` ran (a coast takes the current period
  and skips it);
* ``near``: the period before (``rw->curr_ticks``) under two ``MIN_CMD_TICKS`` (1 280
  ticks: the accelerating branch that looks at the ramp's coast; read on the period
  alone, so a coast at the travel speed is ``near`` here too);
* ``check``: the ramp's coast check multiplied (``__mulsi3``: at a period under two
  ``MIN_CMD_TICKS`` with 1..510 steps possible to coast, ``possible_coast_steps *
  curr_ticks``);
* ``after 1``: the command after a first write of one step (its pitch holds that
  write's ``enableOutputs()`` and direction pin: left out of the classes' figures).

The table gives each class's commands, their mean and median pitch and range, and the
mean less the plain ``acc maths`` class's (the start task's pitch is their sum)::

    python3 bench/replica/start_pitch.py --work /tmp/s36rep d35 d23 test_sd_09_328p
"""

from __future__ import annotations

import argparse
import statistics
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import replica  # noqa: E402

TASK_VECTOR = 13
MATHS = "ramp_config_s::calculate_ticks("
CHECK = "__mulsi3"
PLAIN = "acc maths"
NEAR = 2 * 640  # two of the ATmega328P's MIN_CMD_TICKS (TICKS_PER_S / 25 000)


def function_names(funcs: Path) -> dict[str, str]:
    """The profile's function numbers (line order of ``CASE.funcs``) -> names."""
    if not funcs.exists():
        return {}
    return {str(i): line.split(None, 2)[2]
            for i, line in enumerate(funcs.read_text().splitlines()) if line.strip()}


def class_of(row: dict[str, Any], names: dict[str, str]) -> str:
    """A start task's command by its kind and the arithmetic that ran for it."""
    fns = [names.get(k, k) for k in row["by_function"]]
    if row["steps0"] <= 1:
        return "after 1"
    label = str(row["kind"])
    if row["ticks0"] < NEAR:
        label += " near"
    if any(f.startswith(CHECK) for f in fns):
        label += " check"
    label += " maths" if any(f.startswith(MATHS) for f in fns) else " no maths"
    return label


def start_commands(rows: Iterable[dict[str, Any]], names: dict[str, str]) -> list[
        tuple[str, dict[str, Any]]]:
    """The commands of several steps written in tasks that began with no queue running."""
    return [(class_of(r, names), r) for r in rows
            if r["running"] == 0 and r["steps"] > 1]


def class_table(commands: list[tuple[str, str, dict[str, Any]]]) -> list[str]:
    by: dict[str, list[int]] = {}
    for _, cls, r in commands:
        by.setdefault(cls, []).append(int(r["pitch"]))
    base = round(statistics.fmean(by[PLAIN]), 1) if PLAIN in by else None
    out = ["| class | commands | pitch mean / median (min..max) | mean less `acc maths` | runs |",
           "| --- | --- | --- | --- | --- |"]
    for cls in sorted(by, key=lambda c: (c == "after 1", c)):
        p = by[cls]
        mean, med = round(statistics.fmean(p), 1), statistics.median(p)
        less = "" if base is None or cls == "after 1" else f"{mean - base:+.1f}"
        runs = sorted({case for case, c, _ in commands if c == cls})
        more = f" +{len(runs) - 4}" if len(runs) > 4 else ""
        out.append(f"| {cls} | {len(p)} | {mean:g} / {med:g} ({min(p)}..{max(p)}) | {less} | "
                   f"{' '.join(runs[:4])}{more} |")
    return out


def command_lines(case: str, commands: list[tuple[str, dict[str, Any]]]) -> list[str]:
    return [f"{case} t={r['t']} {r['ticks0']}x{r['steps0']} -> {r['ticks']}x{r['steps']} "
            f"pitch {r['pitch']} {cls}" for cls, r in commands]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--tag", default="Os-nolto-inall-pad1")
    ap.add_argument("--commands", action="store_true", help="one line per command too")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    found: list[tuple[str, str, dict[str, Any]]] = []
    for case in args.cases:
        prefix = args.work / f"{case}-{args.tag}"
        if not Path(f"{prefix}.ev").exists():
            print(f"start_pitch: no replica run {prefix}.ev "
                  "(replica.py --build d --profile pitches CASE)", file=sys.stderr)
            return 2
        names = function_names(args.work / f"{case}.funcs")
        cmds = start_commands(replica.pitches_of(prefix, TASK_VECTOR), names)
        if args.commands:
            print("\n".join(command_lines(case, cmds)))
        found += [(case, cls, r) for cls, r in cmds]
    print("\n".join(class_table(found)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
