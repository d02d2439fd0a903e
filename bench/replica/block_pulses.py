"""A build-d `e` run against its replica, pulse by pulse: the blocks, the pulses they
hold, the step train's offset and the UART's phase (docs/timing-model.md, "thirty-first
pass").  Build d only: the model runs in build d and ``--set`` edits build d's tables, so
a build-e run (e01..) is refused; ``bench/e_window.py`` compares those from the
conformance folder's measured blocks (thirty-eighth pass).

From a replica run (``WORK/CASE[-TAG].pins`` and ``.ev``, less the replica's lead over
the firmware, ``--lag``) and the model's run of the same input in build d (ATmega328P):

* ``blocks``: the loop's `e` sections (a ``C`` line followed by its ``S`` 1 500-1 700
  cycles later in the replica's log; the model's ``Machine.block_listeners``), their
  count and lengths;
* ``held``: pulses whose rise falls inside a block (their step interrupt waits for the
  block's end), the count on each side, how many are the same pulse (by index), their
  mean width and their rise's mean place in the block; the other pulses' mean width;
* ``steps``: model minus replica, rise by rise (where both make the same number);
* ``uart``: for each transmit interrupt of the replica (vector 19's entry less 4), the
  nearest start of a character on the model's line: the most common offsets;
* per window (blocks less than 100 000 cycles apart): its first block and count on
  each side, and the commonest distances between blocks;
* ``--tasks``: the ramp task's own CPU, task by task from the first step on (the
  replica: its vector's entry to its ``reti`` less the interrupts nested in it; the
  model: the CPU it charges the task).

``--set FIELD=VALUE`` runs the model with another figure of build d's ATmega328P: a
field of :class:`fas.sim.timing.SimTiming` or of StepperDemo's
:class:`stepperdemo.demo.build.DemoBuild`; ``+N`` / ``-N`` add to the current value::

    python3 bench/replica/block_pulses.py --work /tmp/fas-replica --tag Os-nolto-inall-pad1 d30
    python3 bench/replica/block_pulses.py ... --set build_d=fitted --set task_phase_ticks=+217 \\
        --set fill_entry_ticks=-217 --set timer0_lag_ticks=405 --set timer0_data_align=2 d30

(``build_d=fitted`` first: the figures fitted before build d's read ones became the
default, fortieth pass; ``bench/d_corpus.py``'s variant FIT.)
"""

from __future__ import annotations

import argparse
import bisect
import collections
import re
import sys
from collections.abc import Iterable
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))

from d_corpus import set_build_d  # noqa: E402  (build d's figures changed: one reader of --set)

BUILD_E_CASE = re.compile(r"e\d+")  # the conformance's build-e runs (not this tool's)
BLOCK_TICKS = (1500, 1700)  # a 100 us block: cli ... SREG restore
WINDOW_GAP = 100_000  # blocks further apart belong to different windows
UART_VECTOR, VECTOR_ENTRY = 19, 4  # the ATmega328P's USART_UDRE, the hardware's entry
TASK_VECTOR = 13  # the ATmega328P's TIMER1_OVF: the ramp task
STEP_PIN = "B1"  # stepper A's step pin (OC1A)

Span = tuple[int, int]


def replica_blocks(lines: Iterable[str], lag: int) -> list[Span]:
    """The loop's `e` blocks ``(cli, restore)`` of a replica's interrupt log, less ``lag``."""
    out: list[Span] = []
    cli = None
    for line in lines:
        p = line.split()
        if len(p) < 2:
            continue
        if p[1] == "C":
            cli = int(p[0])
        elif p[1] == "S" and cli is not None:
            if BLOCK_TICKS[0] <= int(p[0]) - cli <= BLOCK_TICKS[1]:
                out.append((cli - lag, int(p[0]) - lag))
            cli = None
    return out


def replica_uart(lines: Iterable[str], lag: int) -> list[int]:
    """The transmit interrupt's requests (its vector's entries less the entry and ``lag``)."""
    return [int(p[0]) - lag - VECTOR_ENTRY for p in (line.split() for line in lines)
            if len(p) >= 3 and p[1] == "V" and p[2] == str(UART_VECTOR)]


def replica_tasks(lines: Iterable[str], lag: int) -> list[Span]:
    """(entry less ``lag``, own CPU) of every ramp task: its vector's entry to its
    ``reti``, less the interrupts nested in it."""
    stack: list[list[int]] = []  # [entry, vector, nested ticks]
    out: list[Span] = []
    for line in lines:
        p = line.split()
        if len(p) >= 3 and p[1] == "V":
            stack.append([int(p[0]), int(p[2]), 0])
        elif len(p) >= 2 and p[1] == "R" and stack:
            entry, vec, nested = stack.pop()
            span = int(p[0]) - entry
            if stack:
                stack[-1][2] += span
            if vec == TASK_VECTOR:
                out.append((entry - lag, span - nested))
    return out


def model_tasks(text: str) -> list[Span]:
    """(tick, CPU charged) of every ramp task of the model's run in build d."""
    from fas.sim import SimBackend
    from fas.sim import backend as backend_module
    from stepperdemo.program import make_program

    out: list[Span] = []
    original = backend_module.SimBackend._task  # noqa: SLF001

    def task(self: SimBackend, index: int) -> None:
        m = self.machine
        before, now = m.stolen_ticks, m.now
        original(self, index)
        out.append((now, m.stolen_ticks - before))

    backend_module.SimBackend._task = task  # type: ignore[method-assign]  # noqa: SLF001
    try:
        backend = SimBackend("atmega328p", build="d")
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
    finally:
        backend_module.SimBackend._task = original  # type: ignore[method-assign]  # noqa: SLF001
    return out


def report_tasks(case: str, ev: Path, pins: Path, conf: Path, lag: int) -> None:
    sys.path.insert(0, str(HERE.parent))
    from pulse_widths import replica_rises

    first = replica_rises(pins, STEP_PIN)[0] - lag
    with open(ev) as f:
        rep = [t for t in replica_tasks(f, lag) if t[0] >= first - 65536]
    mod = model_tasks((conf / case / "input.txt").read_text().strip())
    mod = [t for t in mod if t[0] >= first - 65536][:len(rep)]
    print(f"## {case}: the ramp task's own CPU from the first step's task on")
    print("| | tasks | mean | median | commonest |")
    print("| --- | --- | --- | --- | --- |")
    for name, ts in (("replica", rep), ("model", mod)):
        cpu = sorted(c for _, c in ts)
        common = collections.Counter(cpu).most_common(4)
        print(f"| {name} | {len(cpu)} | {sum(cpu) / len(cpu):.0f} | {cpu[len(cpu) // 2]} "
              f"| {common} |")
    print()


def held_by(pulses: list[Span], blocks: list[Span]) -> list[int | None]:
    """For each pulse the index of the block its rise falls in, or None."""
    starts = [a for a, _ in blocks]
    out: list[int | None] = []
    for rise, _ in pulses:
        k = bisect.bisect_right(starts, rise) - 1
        out.append(k if k >= 0 and blocks[k][0] <= rise < blocks[k][1] else None)
    return out


def nearest_offsets(ticks: list[int], ref: list[int]) -> collections.Counter[int]:
    """For each of ``ref`` the signed distance to the nearest of ``ticks`` (sorted)."""
    out: collections.Counter[int] = collections.Counter()
    for t in ref:
        k = bisect.bisect_left(ticks, t)
        near = [ticks[j] - t for j in (k - 1, k) if 0 <= j < len(ticks)]
        if near:
            out[min(near, key=abs)] += 1
    return out


def windows(blocks: list[Span]) -> list[list[Span]]:
    out: list[list[Span]] = []
    for b in blocks:
        if out and b[0] - out[-1][-1][1] <= WINDOW_GAP:
            out[-1].append(b)
        else:
            out.append([b])
    return out


def held_summary(pulses: list[Span], blocks: list[Span]) -> dict[str, float]:
    h = held_by(pulses, blocks)
    held = [(p, blocks[k]) for p, k in zip(pulses, h, strict=True) if k is not None]
    free = [b - a for (a, b), k in zip(pulses, h, strict=True) if k is None]
    n = len(held)
    return {"held": n,
            "held width": sum(b - a for (a, b), _ in held) / n if n else 0.0,
            "place in block": sum(a - blk[0] for (a, _), blk in held) / n if n else 0.0,
            "other width": sum(free) / len(free) if free else 0.0,
            "total us": sum(b - a for a, b in pulses) / 16}


def model_run(text: str) -> tuple[list[Span], list[Span], list[int]]:
    """(pulses of stepper A, `e` blocks, character starts on the UART) of the model."""
    from fas.sim import SimBackend, printing
    from stepperdemo.program import make_program
    from stepperdemo.scenarios.evaluate import stepper_pins

    backend = SimBackend("atmega328p", record=True, build="d")
    blocks: list[Span] = []
    backend.machine.block_listeners.append(lambda a, b: blocks.append((a, b)))
    starts: set[int] = set()
    uart = backend.machine.uart
    original = printing.print_chars
    records = uart.records

    def watch(*args: object) -> None:  # every character's start (the ring keeps 64)
        original(*args)  # type: ignore[arg-type]
        starts.update(r[2] for r in records)

    import fas.sim.backend as backend_module
    backend_module.print_chars = watch  # type: ignore[assignment]
    try:
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
    finally:
        backend_module.print_chars = original
    starts.update(r[2] for r in records)
    from pulse_widths import backend_pulses
    pulses = backend_pulses(backend)[stepper_pins(backend.profile)[0].letter]
    return pulses, blocks, sorted(starts)


def report(case: str, ev: Path, pins: Path, conf: Path, lag: int) -> None:
    sys.path.insert(0, str(HERE.parent))
    from pulse_widths import replica_pulses

    rp = [(a - lag, b - lag) for a, b in replica_pulses(pins, STEP_PIN)]
    with open(ev) as f:
        lines = f.readlines()
    rb, ru = replica_blocks(lines, lag), replica_uart(lines, lag)
    mp, mb, mu = model_run((conf / case / "input.txt").read_text().strip())
    print(f"## {case}")
    print(f"blocks: replica {len(rb)} (lengths {dict(collections.Counter(b - a for a, b in rb))}), "
          f"model {len(mb)} (lengths {dict(collections.Counter(b - a for a, b in mb))})")
    rs, ms = held_summary(rp, rb), held_summary(mp, mb)
    print("| | pulses | total high (us) | held by a block | held: mean width | held: rise's "
          "place in its block | others: mean width |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, n, s in (("replica", len(rp), rs), ("model", len(mp), ms)):
        print(f"| {name} | {n} | {s['total us']:.1f} | {s['held']:.0f} | {s['held width']:.1f} "
              f"| {s['place in block']:.1f} | {s['other width']:.2f} |")
    if len(rp) == len(mp):
        same = sum(1 for x, y in zip(held_by(rp, rb), held_by(mp, mb), strict=True)
                   if x is not None and y is not None)
        d = sorted(m[0] - r[0] for r, m in zip(rp, mp, strict=True))
        print(f"held in both: {same}; steps, model - replica: min {d[0]}, median "
              f"{d[len(d) // 2]}, max {d[-1]} ticks")
    print(f"uart, model's character starts - replica's interrupts: "
          f"{nearest_offsets(mu, ru).most_common(4)}")
    print("| window | replica: first block, blocks, commonest distances | model: the same |")
    print("| --- | --- | --- |")
    rw, mw = windows(rb), windows(mb)
    for i in range(max(len(rw), len(mw))):
        cells = []
        for w in (rw[i] if i < len(rw) else [], mw[i] if i < len(mw) else []):
            if not w:
                cells.append("-")
                continue
            gaps = collections.Counter(w[j + 1][0] - w[j][0] for j in range(len(w) - 1))
            cells.append(f"{w[0][0]}, {len(w)}, {[g for g, _ in gaps.most_common(3)]}")
        print(f"| {i} | {cells[0]} | {cells[1]} |")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--tag", default="Os-nolto-inall-pad1",
                    help="the replica build's tag in the file names ('' for none)")
    ap.add_argument("--lag", type=int, default=96, help="replica minus firmware, ticks")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    ap.add_argument("--tasks", action="store_true", help="the ramp task's CPU, task by task")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    try:
        set_build_d(args.set)
    except ValueError as exc:
        print(f"block_pulses: {exc}", file=sys.stderr)
        return 2
    suffix = f"-{args.tag}" if args.tag else ""
    for case in args.cases:
        if BUILD_E_CASE.fullmatch(case):
            print(f"{case}: a build-e run; this tool runs the model in build d (use "
                  "bench/e_window.py on the conformance folder's blocks)")
            continue
        ev, pins = (args.work / f"{case}{suffix}.ev", args.work / f"{case}{suffix}.pins")
        if not ev.exists() or not pins.exists():
            print(f"{case}: no replica run {ev} / {pins}")
            continue
        if args.tasks:
            report_tasks(case, ev, pins, args.conformance, args.lag)
        else:
            report(case, ev, pins, args.conformance, args.lag)
    return 0


if __name__ == "__main__":
    sys.exit(main())
