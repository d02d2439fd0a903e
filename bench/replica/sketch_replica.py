"""Upstream's simulator-tested example sketches (``examples/Issue208``, ``Issue280``, ...)
rebuilt and run cycle by cycle: where the sketch's own interrupts-off sections fall
against the step pulses (docs/timing-model.md, "The upstream sketches' loop sections").

Upstream's test harness builds each sketch with PlatformIO (``-Os``, link-time
optimisation, ``-D SIMULATOR -D SIMAVR_TIME_MEASUREMENT`` on every compile) for the
ATmega328P and runs it in simavr.  This script builds it the same way with the Arduino
AVR core Debian packages and the installed avr-gcc, and runs it with ``replica_run``
(the StepperDemo replica's runner, ``replica.py``): every pin edge and every interrupt
entry, ``reti`` and loop ``cli``/``sei`` by cycle.  Nothing of upstream's sources is
part of this repository: ``--fas`` is a FastAccelStepper tree of the tag the sketches
were measured with (``git -C FastAccelStepper archive 1.2.7 src examples/Issue208
examples/Issue280 | tar x -C DIR``), ``--simavr`` a simavr source tree.

    python3 bench/replica/sketch_replica.py --fas FAS-1.2.7 --simavr SIMAVR --work DIR Issue208

prints the counts and pulse-high figures upstream's evaluation prints for the step pin,
and splits the pulse-high total by what held the step interrupt at each rise: nothing
(alone), another interrupt (behind N), or the sketch loop's interrupts-off section
(loop cli), with the loop sections' widths by the address that opens them, and the
ramp task's own interrupts-off spans (its entry, its exit, each inner section's width;
with ``--mark 'StepperQueue::addQueueEntry('`` also its distance to the next write).
"""

from __future__ import annotations

import argparse
import bisect
import collections
import statistics
import subprocess
from pathlib import Path

import replica  # a sibling script

# the pins upstream's Makefile traces on the 328P: StepA/B (OC1A/B), the time
# measurement's StepISR (PB3) and FillISR (PB4), DirA (PD5), EnableA (PD6)
PINS = {"StepA": "B1", "StepB": "B2", "StepISR": "B3", "FillISR": "B4",
        "DirA": "D5", "EnableA": "D6"}
DEFINES = ("-DSIMULATOR", "-DSIMAVR_TIME_MEASUREMENT")
TPU = replica.TICKS_PER_US


def build_sketch(fas: Path, sketch: str, work: Path) -> Path:
    """The example ``sketch`` as upstream's PlatformIO env builds it; returns the ELF."""
    flags = replica.Flags(extra=DEFINES)
    out = work / f"sk-{sketch}"
    elf = out / "fw.elf"
    if elf.exists():
        return elf
    out.mkdir(parents=True, exist_ok=True)
    core = replica.CORE / "cores" / "arduino"
    defs = ["-mmcu=atmega328p", "-DF_CPU=16000000L", "-DARDUINO=10808", "-DPLATFORMIO",
            "-DARDUINO_AVR_NANO", "-DARDUINO_ARCH_AVR"]
    inc = [f"-I{core}", f"-I{replica.CORE / 'variants' / 'eightanaloginputs'}",
           f"-I{replica.CORE / 'variants' / 'standard'}", f"-I{fas / 'src'}"]
    src = out / f"{sketch}.ino.cpp"
    src.write_text("#include <Arduino.h>\n"
                   + (fas / "examples" / sketch / f"{sketch}.ino").read_text())
    jobs: list[tuple[list[str], Path]] = []
    for f in sorted(core.glob("*.c")):
        jobs.append((["avr-gcc", *flags.cflags(), *defs, *inc, str(f)], out / f"c_{f.name}.o"))
    for f in sorted(core.glob("*.cpp")):
        if f.name != "WString.cpp":
            jobs.append((["avr-g++", *flags.cxxflags(), *defs, *inc, str(f)],
                         out / f"c_{f.name}.o"))
    for f in sorted(core.glob("*.S")):
        jobs.append((["avr-gcc", *flags.asflags(), *defs, *inc, str(f)], out / f"c_{f.name}.o"))
    skip = ("pd_esp32", "pd_pico", "pd_sam", "pd_test", "esp32_pcnt")
    for f in sorted((fas / "src").rglob("*.cpp")):
        if not any(s in str(f) for s in skip):
            name = str(f.relative_to(fas)).replace("/", "_")
            jobs.append((["avr-g++", *flags.cxxflags(), *defs, *inc, str(f)], out / f"f_{name}.o"))
    jobs.append((["avr-g++", *flags.cxxflags(), *defs, *inc, str(src)], out / "sketch.o"))
    for cmd, obj in jobs:
        replica.run([*cmd, "-o", str(obj)])
    replica.run(["avr-gcc", *flags.ldflags(), "-mmcu=atmega328p", "-o", str(elf),
                 *[str(o) for _, o in jobs], "-lm"])
    return elf


def run_sketch(args: argparse.Namespace) -> Path:
    work = Path(args.work)
    elf = build_sketch(Path(args.fas), args.sketch, work)
    exe = replica.build_runner(Path(args.simavr), work)
    prefix = work / (args.sketch + ("-m-" + "-".join(args.mark) if args.mark else ""))
    if not Path(f"{prefix}.ev").exists() or args.again:
        env = {"TASK_VECTOR": "13", "QUEUES": "0", "PATH": "/usr/bin:/bin",
               "TASK_SECTIONS": "1"}
        if args.mark:
            found, _ = replica.symbols(elf, tuple(args.mark))
            missing = [n for n in args.mark if n not in found]
            if missing:
                raise SystemExit(f"no function {missing[0]!r} in {elf} (inlined?)")
            env["MARKS"] = ",".join(f"{found[n]:x}" for n in args.mark)
        subprocess.run([str(exe), str(elf), "atmega328p", str(args.ms), str(prefix),
                        *PINS.values()], check=True, env=env)
    return prefix


def edges(prefix: Path) -> dict[str, list[tuple[int, int]]]:
    out: dict[str, list[tuple[int, int]]] = collections.defaultdict(list)
    level: dict[str, int] = {}
    with open(f"{prefix}.pins") as f:
        for line in f:
            c, pin, v = line.split()
            if level.get(pin, 0) != int(v):
                out[pin].append((int(c), int(v)))
            level[pin] = int(v)
    return out


def pulses(pin_edges: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """(rise, fall) cycle pairs."""
    out, rise = [], None
    for c, v in pin_edges:
        if v:
            rise = c
        elif rise is not None:
            out.append((rise, c))
            rise = None
    return out


def timeline(prefix: Path) -> tuple[list[tuple[int, int, int]], list[tuple[int, int, int]]]:
    """Interrupt runs (entry, reti, vector) at depth 0 and loop sections (cli, sei, pc)."""
    runs, loops = [], []
    stack: list[tuple[int, int]] = []
    cli: tuple[int, int] | None = None
    with open(f"{prefix}.ev") as f:
        for line in f:
            parts = line.split()
            c, kind = int(parts[0]), parts[1]
            if kind == "V":
                stack.append((c, int(parts[2])))
            elif kind == "R" and stack:
                start, vec = stack.pop()
                if not stack:
                    runs.append((start, c, vec))
            elif kind == "C":
                cli = (c, int(parts[2], 16))
            elif kind == "S" and cli is not None:
                loops.append((cli[0], c, cli[1]))
                cli = None
    return runs, loops


def classify(step: list[tuple[int, int]], runs: list[tuple[int, int, int]],
             loops: list[tuple[int, int, int]], plain: int,
             own: tuple[int, ...] = (11, 12)) -> dict[str, tuple[int, int]]:
    """Each pulse by what held its step interrupt at the rise: the loop's interrupts-off
    section ("loop cli"), another routine ("behind N"; the step vectors ``own`` are the
    pulse's own entry), or nothing ("alone"); per kind (pulses, ticks beyond ``plain``)."""
    starts = [r[0] for r in runs]
    lstarts = [s[0] for s in loops]
    kinds: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    for a, b in step:
        i = bisect.bisect_right(lstarts, a) - 1
        j = bisect.bisect_right(starts, a) - 1
        if i >= 0 and loops[i][0] <= a < loops[i][1]:
            k = "loop cli"
        elif j >= 0 and runs[j][0] <= a < runs[j][1] and runs[j][2] not in own:
            k = f"behind {runs[j][2]}"
        else:
            k = "alone"
        kinds[k][0] += 1
        kinds[k][1] += b - a - plain
    return {k: (v[0], v[1]) for k, v in kinds.items()}


def passes(prefix: Path) -> dict[int, collections.Counter[int]]:
    """Per loop section (by the address of its ``cli``), the ticks from one to the next
    where no interrupt entered in between: the loop's pass in its own CPU time."""
    last: dict[int, tuple[int, bool]] = {}
    out: dict[int, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    with open(f"{prefix}.ev") as f:
        for line in f:
            parts = line.split()
            if parts[1] in ("V", "M"):
                last = {pc: (c, True) for pc, (c, _) in last.items()}
            elif parts[1] == "C":
                c, pc = int(parts[0]), int(parts[2], 16)
                if pc in last and not last[pc][1]:
                    out[pc][c - last[pc][0]] += 1
                last[pc] = (c, False)
    return out


def task_sections(prefix: Path, vector: int = 13,
                  write_mark: int | None = None) -> dict[str, collections.Counter[int]]:
    """The ramp task's own interrupts-off spans (``TASK_SECTIONS``): "entry" (entry to its
    sei), "exit" (its last cli to the reti) and per inner section's cli address its
    widths; with ``write_mark`` (the mark index of ``addQueueEntry``) also, per address,
    the task's own CPU ticks (nested interrupts left out) from the section's cli to the
    task's next write ("before:ADDR")."""
    out: dict[str, collections.Counter[int]] = collections.defaultdict(collections.Counter)
    depth, cur, base, nested, nest_at = 0, None, 0, 0, 0
    with open(f"{prefix}.ev") as f:
        for line in f:
            p = line.split()
            c, k = int(p[0]), p[1]
            if k == "V":
                depth += 1
                if depth == 1 and int(p[2]) == vector:
                    cur, base, nested = [], c, 0
                elif depth == 2:
                    nest_at = c
            elif k == "R":
                if depth == 2 and cur is not None:
                    nested += c - nest_at
                depth = max(0, depth - 1)
                if depth == 0 and cur is not None:
                    _task_spans(cur, c - base - nested, out, write_mark)
                    cur = None
            elif (cur is not None and depth == 1 and k in ("c", "s", "M")
                  and (k != "M" or write_mark is None or int(p[2]) == write_mark)):
                cur.append((k, c - base - nested, p[2]))
    return out


def _task_spans(ev: list[tuple[str, int, str]], end: int,
                out: dict[str, collections.Counter[int]], write_mark: int | None) -> None:
    secs = [e for e in ev if e[0] in ("c", "s")]
    if secs and secs[0][0] == "s":
        out["entry"][secs[0][1]] += 1
        secs = secs[1:]
    if secs and secs[-1][0] == "c":
        out["exit"][end - secs[-1][1]] += 1
        secs = secs[:-1]
    writes = [t for k, t, _ in ev if k == "M"]
    for i in range(len(secs) - 1):
        if secs[i][0] == "c" and secs[i + 1][0] == "s":
            t, pc = secs[i][1], secs[i][2]
            out[pc][secs[i + 1][1] - t] += 1
            nxt = [w for w in writes if w >= t]
            if write_mark is not None and nxt:
                out[f"before:{pc}"][nxt[0] - t] += 1


def marks(prefix: Path) -> list[tuple[int, int]]:
    """(cycle, mark index) of each call of a ``--mark`` function."""
    with open(f"{prefix}.ev") as f:
        return [(int(p[0]), int(p[2])) for p in (line.split() for line in f) if p[1] == "M"]


def cmd_report(args: argparse.Namespace) -> int:
    prefix = run_sketch(args)
    pe = edges(prefix)
    step = pulses(pe[PINS["StepA"]])
    widths = [b - a for a, b in step]
    print(f"{args.sketch}: StepA {len(step)} pulses, Max High "
          f"{max(widths) // TPU if widths else 0} us, Total High {sum(widths) / TPU:.0f} us")
    runs, loops = timeline(prefix)
    plain = statistics.mode(widths) if widths else 0
    print(f"plain width {plain} ticks")
    for k, (n, excess) in sorted(classify(step, runs, loops, plain).items()):
        print(f"  {k:>10}: {n:7d} pulses, excess {excess:+8d} ticks ({excess / TPU:+.0f} us)")
    by_pc: dict[int, list[int]] = collections.defaultdict(list)
    for a, b, pc in loops:
        by_pc[pc].append(b - a)
    per = passes(prefix)
    print("loop sections by the address of their cli: count, cli..restore ticks "
          "min/median/max, pass with no interrupt inside: mean (count)")
    for pc, ws in sorted(by_pc.items(), key=lambda kv: -len(kv[1]))[:12]:
        cn = per.get(pc)
        mean = (f"{sum(k * v for k, v in cn.items()) / sum(cn.values()):.2f} "
                f"({sum(cn.values())})" if cn else "-")
        print(f"  {pc:#06x}: {len(ws):8d}  {min(ws)}/{statistics.median(ws):.0f}/{max(ws)}"
              f"  {mean}")
    lstarts = [s[0] for s in loops]
    shown: collections.Counter[int] = collections.Counter()
    for c, k in marks(prefix):
        shown[k] += 1
        if shown[k] > 10:  # (a function called in every task: its first ten calls)
            continue
        i = bisect.bisect_left(lstarts, c)
        first = f"first cli ends {loops[i][0] - c} ticks later ({loops[i][2]:#06x})" \
            if i < len(loops) else "no cli after it"
        sel = [(a, b) for a, b in step if a >= c]
        print(f"mark {args.mark[k]} at {c}: {first}; {len(sel)} pulses from it, "
              f"{sum(b - a for a, b in sel) / TPU:.1f} us high")
    spans = task_sections(prefix, write_mark=(args.mark.index("StepperQueue::addQueueEntry(")
                                              if "StepperQueue::addQueueEntry(" in args.mark
                                              else None))
    if spans:
        print("ramp task's own interrupts-off spans (ticks: count), the commonest:")
        for key, cn in sorted(spans.items(), key=lambda kv: -sum(kv[1].values())):
            print(f"  {key:>12}: {sum(cn.values()):7d}  {cn.most_common(3)}")
    for name in ("EnableA", "DirA"):
        e = pe[PINS[name]]
        print(f"{name}: {sum(v for _, v in e)} L->H, {sum(1 - v for _, v in e)} H->L")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fas", required=True, help="FastAccelStepper source tree (1.2.7)")
    ap.add_argument("--simavr", required=True, help="simavr source tree")
    ap.add_argument("--work", default="/tmp/fas-sketch-replica")
    ap.add_argument("--ms", type=int, default=12000, help="simulated milliseconds")
    ap.add_argument("--again", action="store_true", help="run again even if recorded")
    ap.add_argument("--mark", action="append", default=[],
                    help="a function whose calls to mark (avr-nm -C name, e.g. delay); "
                         "prints where the first loop section falls after each call")
    ap.add_argument("sketch")
    return cmd_report(ap.parse_args())


if __name__ == "__main__":
    raise SystemExit(main())
