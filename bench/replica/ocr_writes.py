"""Where the step interrupt writes its next compare, path by path, on a replica run
(docs/timing-model.md, "thirty-fourth pass").

FastAccelStepper's AVR compare interrupt clears the step pin (a write of the timer's
force-compare register) and adds the period to the compare register at its end.  How
far apart the two writes are depends on the path the interrupt takes: the entry has
more steps, the next entry is taken up (with steps, a pause, a direction toggle), the
queue runs dry.  This finds both writes in each step vector of a built firmware (an ELF
of ``replica.py``'s work folder), re-runs it in the runner with marks on them, and
prints per channel a histogram of the cycles from the pin's clear to the compare write.

    python3 bench/replica/ocr_writes.py --elf /tmp/fas-replica/fw-<hash>/fw.elf \\
        --work /tmp/fas-replica [--out DIR] --ms 3700 e09

The model: ``SimTiming.isr_ocr_ticks`` (one path) and ``isr_ocr_next_ticks`` (the entry
switch's extra, per channel).
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import replica  # noqa: E402

# the step channels' compare vectors (timer 1: A, B, C) and the registers the interrupt
# writes: the force-compare register (TCCR1C) and each channel's compare low byte
STEP_VECTORS = {"atmega328p": (11, 12), "atmega2560": (17, 18, 19)}
FOC = 0x82
OCR_LOW = (0x88, 0x8A, 0x8C)

_INSN = re.compile(r"^\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} )+\s*(\w+)\s*([^;]*)")


def write_sites(listing: str, vectors: Iterable[int]) -> list[tuple[int, int]]:
    """Per step vector (channel A, B, ...): (address of the last ``sts`` to the
    force-compare register, address of the ``sts`` to the channel's compare low byte)
    in an ``avr-objdump -d`` listing."""
    out = []
    for ch, vector in enumerate(vectors):
        head = f"<__vector_{vector}>:"
        at = listing.find(head)
        if at < 0:
            raise ValueError(f"no __vector_{vector} in the listing")
        foc = ocr = None
        for line in listing[at + len(head):].splitlines()[1:]:
            m = _INSN.match(line)
            if not m:
                if line.strip() == "" and foc is not None:
                    break  # the vector's end
                continue
            addr, op, args = int(m.group(1), 16), m.group(2), m.group(3).strip()
            if op == "sts":
                reg = int(args.split(",")[0], 16)
                if reg == FOC and ocr is None:
                    foc = addr  # the pin's clear (the last before the write)
                elif reg == OCR_LOW[ch]:
                    ocr = addr
            if op == "reti":
                break
        if foc is None or ocr is None:
            raise ValueError(f"__vector_{vector}: no force-compare / compare write found")
        out.append((foc, ocr))
    return out


def histograms(lines: Iterable[str], channels: int) -> list[collections.Counter]:
    """From a runner's ``.ev`` with marks 2k (clear) and 2k+1 (write) for channel k: the
    cycles from each clear to the write that follows it, per channel."""
    last: dict[int, int] = {}
    out: list[collections.Counter] = [collections.Counter() for _ in range(channels)]
    for line in lines:
        p = line.split()
        if len(p) < 3 or p[1] != "M":
            continue
        k, c = int(p[2]), int(p[0])
        if k % 2 == 0:
            last[k // 2] = c
        elif k // 2 in last:
            out[k // 2][c - last.pop(k // 2)] += 1
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elf", required=True, type=Path, help="a replica build's fw.elf")
    ap.add_argument("--work", required=True, type=Path,
                    help="replica.py's work folder (its runner, replica_run)")
    ap.add_argument("--out", type=Path, help="folder for the run's .ev/.pins (default: --work)")
    ap.add_argument("--ms", type=float, default=4000, help="simulated time to run")
    ap.add_argument("case", help="the case the ELF was built for (its board)")
    args = ap.parse_args(argv)
    board = replica.BOARDS.get(args.case, replica.UNO)
    exe = args.work / "replica_run"
    if not exe.exists():
        print(f"ocr_writes: no runner in {args.work}: run replica.py there first",
              file=sys.stderr)
        return 2
    listing = subprocess.run(["avr-objdump", "-d", str(args.elf)], check=True,
                             capture_output=True, text=True).stdout
    vectors = STEP_VECTORS[board.mcu][:len(board.pins)]
    sites = write_sites(listing, vectors)
    prefix = (args.out or args.work) / f"{args.case}-ocr"
    env = {**os.environ, "MARKS": ",".join(f"{a:x},{b:x}" for a, b in sites)}
    subprocess.run([str(exe), str(args.elf), board.mcu, f"{args.ms:.0f}", str(prefix),
                    *board.pins.values()], check=True, env=env)
    with open(f"{prefix}.ev") as f:
        hists = histograms(f, len(sites))
    for letter, (foc, ocr), h in zip(board.pins, sites, hists, strict=False):
        cells = ", ".join(f"{d}: {n}" for d, n in sorted(h.items()))
        print(f"{args.case} {letter} (clear {foc:#x}, write {ocr:#x}): cycles from the "
              f"pin's clear to the compare write: {cells or 'none'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
