"""Build d's plain step pulse on its replica: from the compare match (the pin's rise) to the
step interrupt's clear, per channel (docs/timing-model.md, "forty-third pass").

From replica runs (``WORK/CASE-TAG.pins`` / ``.ev`` of ``replica.py --build d``): every
pulse's width and its step vector's entry (``V 11`` / ``V 12``) after the rise.  A pulse
whose interrupt enters at the rise is plain; the others wait for the instruction that runs
or a section with interrupts off.  Printed per channel: the plain width (all such
pulses), how many entries wait 1-14 ticks and the mean width of the pulses up to the
plain width + 14 (what a model without those waits makes its one figure stand for).

With ``--elf``, the step vector's path in the built firmware up to the force-compare
write that clears the pin (an entry with steps: the queue not empty, every conditional
branch not taken), its cycles by piece::

    python3 bench/replica/plain_pulse.py --work /tmp/fas-replica --tag Os-nolto-inall-pad1 \\
        --elf /tmp/fas-replica/fw-6c42e8b7b36c/fw.elf

With ``--sections``, the ramp task's own sections with interrupts off in runs made with
``TASK_SECTIONS=1`` in the runner's environment (``sketch_replica.task_sections``): its
entry to its ``sei``, its last ``cli`` to its ``reti``, and per ``cli`` address the
commonest width and the commonest distance (the task's own CPU) to its next queue write::

    TASK_SECTIONS=1 python3 bench/replica/replica.py --fas FAS --simavr SIMAVR --build d \
        --no-lto --input-everywhere --data-pad 1 --work /tmp/s34rep steps d02
    python3 bench/replica/plain_pulse.py --work /tmp/s34rep --sections d02

The model: ``SimTiming.isr_latency_ticks`` (build d's read figures:
``BUILD_D_REPLICA_PLAIN_PULSE_TICKS``, variant P43 of ``bench/d_corpus.py``) and
``fill_cmd_mask_sections`` (``BUILD_D_REPLICA_CMD_MASK_SECTIONS``, variant K43).
"""

from __future__ import annotations

import argparse
import bisect
import collections
import re
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

STEP = {"B1": 11, "B2": 12}  # the step pins of channels A / B and their compare vectors
WAIT = 14  # the longest wait of an entry not held by a routine (the 60 build-d runs)
FOC = "0x0082"  # the force-compare register (TCCR1C)

# cycles of the ATmega328P's instructions on the path (a skip / branch not taken)
CYCLES = {"push": 2, "pop": 2, "lds": 2, "sts": 2, "ld": 2, "ldd": 2, "st": 2, "std": 2,
          "mul": 2, "adiw": 2, "sbiw": 2, "rjmp": 2, "jmp": 3, "sbi": 2, "cbi": 2}
_INSN = re.compile(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(\w+)\s*([^;]*)")


def pulses(pins: Iterable[str], pin: str) -> list[tuple[int, int]]:
    """(rise, width) of every pulse on ``pin`` in a ``.pins`` log (repeated writes of the
    same level are one edge)."""
    out = []
    rise = None
    level = 0
    for line in pins:
        t, p, v = line.split()
        if p != pin:
            continue
        if v == "1" and level == 0:
            rise = int(t)
        elif v == "0" and level == 1 and rise is not None:
            out.append((rise, int(t) - rise))
        level = int(v)
    return out


def vector_entries(ev: Iterable[str], vector: int) -> list[int]:
    """The ticks at which ``vector`` was entered in an ``.ev`` log."""
    want = str(vector)
    return [int(p[0]) for p in (line.split() for line in ev)
            if len(p) >= 3 and p[1] == "V" and p[2] == want]


def waits(pulse_list: list[tuple[int, int]], entries: list[int]) -> list[tuple[int, int]]:
    """(entry - rise, width) per pulse whose vector entry follows its rise."""
    out = []
    for rise, width in pulse_list:
        i = bisect.bisect_left(entries, rise)
        if i < len(entries):
            out.append((entries[i] - rise, width))
    return out


def summary(pairs: list[tuple[int, int]]) -> dict[str, float]:
    """The plain width (entries at the rise), the entries waiting 1..WAIT ticks, the mean
    width of the pulses up to plain + WAIT."""
    plain = collections.Counter(w for d, w in pairs if d == 0).most_common(1)[0][0]
    short = [w for d, w in pairs if d <= WAIT and w <= plain + WAIT]
    return {"plain": plain, "at_once": sum(1 for d, _ in pairs if d == 0),
            "waiting": sum(1 for d, _ in pairs if 0 < d <= WAIT),
            "widths_equal_plain_plus_wait": sum(1 for d, w in pairs if d <= WAIT
                                                and w == plain + d),
            "mean_short": sum(short) / len(short)}


def path_cycles(listing: str, vector: int) -> list[tuple[str, int]]:
    """(instruction, cycles) from ``__vector_<vector>``'s first instruction to the start of
    its ``sts`` to the force-compare register, on the path of an entry with steps."""
    lines = listing.splitlines()
    index = {}
    for i, line in enumerate(lines):
        m = _INSN.match(line)
        if m:
            index[int(m.group(1), 16)] = i
    head = next(i for i, line in enumerate(lines) if f"<__vector_{vector}>:" in line)
    i = head + 1
    out: list[tuple[str, int]] = []
    while len(out) < 200:
        m = _INSN.match(lines[i])
        if not m:
            i += 1
            continue
        op, args = m.group(2), m.group(3).strip()
        if op == "sts" and args.startswith(FOC):
            return out
        out.append((f"{op} {args}".strip(), CYCLES.get(op, 1)))
        if op in ("rjmp", "jmp"):
            target = re.search(r"0x([0-9a-f]+)", lines[i].split(";")[-1])
            if target is None:
                raise ValueError(f"no target in {lines[i]!r}")
            i = index[int(target.group(1), 16)]
        else:
            i += 1
    raise ValueError(f"no force-compare write in __vector_{vector}")


def report_sections(work: Path, tag: str, cases: list[str]) -> int:
    """Each case's ramp-task sections (``TASK_SECTIONS`` runs), one line per section."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import sketch_replica  # noqa: PLC0415 (a sibling script)
    from replica import QUEUE_WRITE  # noqa: PLC0415
    for case in cases:
        prefix = work / f"{case}-{tag}"
        if not prefix.with_name(prefix.name + ".ev").exists():
            print(f"plain_pulse: no replica run {prefix}.ev", file=sys.stderr)
            return 2
        out = sketch_replica.task_sections(prefix, 13, write_mark=QUEUE_WRITE)
        print(f"## {case}: entry to sei {out['entry'].most_common(1)}, "
              f"last cli to reti {out['exit'].most_common(1)}")
        for pc in sorted(k for k in out if k not in ("entry", "exit")
                         and not k.startswith("before:")):
            before = out.get(f"before:{pc}")
            print(f"{pc}: {sum(out[pc].values())} sections, width {out[pc].most_common(1)}"
                  + (f", before the next write {before.most_common(2)}" if before else ""))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--tag", default="Os-nolto-inall-pad1")
    ap.add_argument("--elf", type=Path, help="the build's ELF: the vector's path, by piece")
    ap.add_argument("--sections", action="store_true",
                    help="the ramp task's own sections (runs made with TASK_SECTIONS=1)")
    ap.add_argument("cases", nargs="*", help="case names (default: every run with the tag)")
    args = ap.parse_args(argv)
    if args.sections:
        return report_sections(args.work, args.tag, args.cases)
    runs = ([args.work / f"{c}-{args.tag}.pins" for c in args.cases] if args.cases
            else sorted(args.work.glob(f"*-{args.tag}.pins")))
    if not runs or not all(p.exists() for p in runs):
        print(f"plain_pulse: no replica runs in {args.work}", file=sys.stderr)
        return 2
    print(f"{len(runs)} runs")
    for pin, vector in STEP.items():
        pairs: list[tuple[int, int]] = []
        for pins in runs:
            text = pins.read_text().splitlines()
            ev = pins.with_suffix(".ev").read_text().splitlines()
            pairs += waits(pulses(text, pin), vector_entries(ev, vector))
        if not pairs:
            continue
        s = summary(pairs)
        print(f"{pin} (vector {vector}): plain {s['plain']} ticks ({s['at_once']} entries at "
              f"the rise), {s['waiting']} entries 1-{WAIT} ticks late "
              f"({s['widths_equal_plain_plus_wait']} pulses = plain + the wait), "
              f"mean width up to plain + {WAIT}: {s['mean_short']:.2f}")
        if args.elf:
            listing = subprocess.run(["avr-objdump", "-d", str(args.elf)], check=True,
                                     capture_output=True, text=True).stdout
            path = path_cycles(listing, vector)
            walked = sum(c for _, c in path)
            print(f"  vector {vector}: {walked} cycles from its first instruction to the "
                  f"clear ({len(path)} instructions); the rise to that first instruction "
                  f"{s['plain'] - walked}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
