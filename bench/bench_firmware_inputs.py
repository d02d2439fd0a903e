"""The firmware's inputs and limit switches (issue 11 with issue 13's section 18), in simavr.

    python bench/bench_firmware_inputs.py [--runs N]

1. Size: flash and RAM of both builds (avr-size), the RAM left for the stack.
2. The limit switch's reaction on the chip: a stepper runs (alone, or with the other
   channel stepping too, so that the switch may find a step interrupt running), the
   switch closes at N seeded random moments; per case the share of runs with a step
   after the switch and the latest such step (the reaction time: a pulse whose compare
   falls within it may still come), and when the pin-change interrupt began.
3. Issue 13's winder lines through the serial backend on the firmware (lockstep, the
   pots and the switch driven on the chip's pins by the host's SetInput): the pot run's
   top speed, the limit line's stop, the interlock's max |S2 - S1/3| by the pins (the
   acceptance line and a run of more than 100 000 S1 steps with pot-driven speed
   changes); the deepest the chip's stack went; wall time per run.

Simulated chip time does not depend on the computer; wall times do (shared machines:
approximate).
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import sys
import tempfile
import time
from itertools import pairwise

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas.device import simavr
from fas.device.loopback import Loopback
from fas.serial.protocol import (
    L_UP,
    PROTOCOL_VERSION,
    UNSEQUENCED,
    W_PULLUP,
    Config,
    Entry,
    ForceStop,
    Hello,
    Limit,
    LimitHit,
    Start,
    WatchInput,
)
from rigs.firmware import Host  # noqa: E402
from rigs.pins import ratio_error  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402

TPS = 16_000_000
SWITCH = 17  # A3
BAUDS = (115200, 1_000_000)
POT_LINE = "pots pot 1 1023 w2000 pot 1 512 w1000"
LIMIT_LINE = "period 2 50 move 2 65535 w300 switch A3 1 w300"
ACCEPT_INTERLOCK = "ratio 1:3 interlock 1 pots pot 1 900 w800 pot 1 700 w800 pot 1 512 w600"
LONG_INTERLOCK = ("ratio 1:3 interlock 1 pots pot 1 1023 w2000 pot 1 850 w1500 pot 1 1023 "
                  "w1500 pot 1 950 w1000 pot 1 1023 w1500 pot 1 200 w1500 pot 1 512 w1000")


def sizes() -> None:
    print("## 1. Size (ATmega328P: 32768 bytes flash, 2048 bytes RAM)")
    for baud in BAUDS:
        b = simavr.build(baud)
        flash_pct, ram_pct = 100 * b.flash_bytes / 32768, 100 * b.ram_bytes / 2048
        print(f"  {baud:>7} baud: flash {b.flash_bytes} bytes ({flash_pct:.1f} %), "
              f"RAM {b.ram_bytes} bytes static ({ram_pct:.1f} %), "
              f"{2048 - b.ram_bytes} bytes left for the stack")


# ------------------------------------------------------------------------- 2
def _entries(stepper: int, first: int, n: int, ticks: int) -> list[Entry]:
    return [Entry(stepper, first + i, 255, ticks, False, True, True, False) for i in range(n)]


class TraceTail:
    """The rising edges of one pin that the harness wrote since the last look."""

    def __init__(self, dev, pin: int) -> None:
        self.dev, self.pin, self.offset = dev, str(pin), 0

    def rising(self) -> list[int]:
        self.dev.chip.flush_trace()
        base = self.dev.info().timer1_start
        out = []
        with open(self.dev.trace_path) as f:
            f.seek(self.offset)
            for line in f:
                if not line.endswith("\n"):
                    break
                self.offset += len(line)
                if line.startswith("#"):
                    continue
                cycle, pin, level = line.split()
                if pin == self.pin and level == "1":
                    out.append(int(cycle) - base)
        return out


def reaction(runs: int, ticks: int, both: bool, seed: int = 1) -> dict:
    """S2 steps every ``ticks`` (S1 too if ``both``); the switch closes at random."""
    rng = random.Random(seed)
    elf = simavr.build(115200).elf
    tmp = tempfile.mkdtemp(prefix="bench-fw-inputs-")
    h = Host(elf, os.path.join(tmp, "trace.txt"))
    pin10 = TraceTail(h.dev, 10)
    after = []  # per run: the last step after the switch (ticks), or None
    isr = []  # per run: the pin-change interrupt's start after the switch (ticks)
    try:
        h.send(UNSEQUENCED, Hello(PROTOCOL_VERSION, 5, 60_000, 2))
        h.send(0, Config(0, 9, 5, 0, 0), Config(1, 10, 7, 0, 0))
        h.send(1, WatchInput(SWITCH, W_PULLUP, 0), Limit(1, SWITCH, 0, L_UP, 0))
        seq, index = 2, 0
        for _ in range(runs):
            msgs = _entries(1, index, 2, ticks) + (_entries(0, index, 2, ticks) if both else [])
            h.send(seq, *msgs[:4], ms=0)
            h.send((seq + 1) % 128, *msgs[4:], Start(3 if both else 2, 0), ms=2)
            seq = (seq + 2) % 128
            at = h.dev.tick + rng.randrange(4 * ticks, 5 * ticks)
            h.dev.schedule_input(at, SWITCH, 0)
            got = h.run(at / 16_000 - h.dev.tick / 16_000 + 10)  # the report's line time
            hits = [m for _, m in got if isinstance(m, LimitHit) and m.stepper == 1]
            steps = pin10.rising()
            late = [t - at for t in steps if t >= at]
            after.append(max(late) if late else None)
            isr.append(hits[0].tick - at if hits else None)
            index = (index + 2) & 0xFF
            h.send(seq, ForceStop(1, index, 1), ForceStop(0, index, 1), ms=1)
            seq = (seq + 1) % 128
            h.dev.set_input(SWITCH, 1)
            h.run(1)
    finally:
        h.dev.close()
        shutil.rmtree(tmp, ignore_errors=True)
    late = [a for a in after if a is not None]
    return {"runs": runs, "with_step_after": len(late),
            "latest_after_us": max(late, default=0) / 16,
            "isr_max_us": max(i for i in isr if i is not None) / 16,
            "missed": sum(1 for i in isr if i is None)}


def reactions(runs: int) -> None:
    print(f"\n## 2. Limit switch reaction on the chip ({runs} random moments per case)")
    print("| case | runs with a step after the switch | latest such step "
          "| pin-change interrupt began |")
    print("| --- | --- | --- | --- |")
    for name, ticks, both in (("S2 alone, 200 us steps", 3200, False),
                              ("S2 alone, 50 us steps", 800, False),
                              ("S2 and S1, 50 us steps each", 800, True),
                              ("S2 and S1, 40 us steps each", 640, True)):
        r = reaction(runs, ticks, both)
        print(f"| {name} | {r['with_step_after']} of {r['runs']} | "
              f"{r['latest_after_us']:.1f} us | at most {r['isr_max_us']:.1f} us after it |")


# ------------------------------------------------------------------------- 3
def interlock_error(trace) -> tuple[float, int, int]:
    """(max |S2 - S1/3| by the pins, S1's position, S2's position)."""
    return ratio_error(trace.edges, (9, 5), (10, 7), 1, 3)


def winder_run(line: str, max_s: int = 60):
    with Loopback(device="simavr") as lb:
        app = make_program("winder", lb.backend, scripted=True)
        t0 = time.perf_counter()
        app.run_script(line, max_ticks=max_s * TPS)
        lb.backend.settle()
        wall = time.perf_counter() - t0
        dev = lb.device
        info = dev.info()
        return (app, dev.trace(), wall, dev.stack_used(), 1 - info.sleep_cycles / info.cycle,
                lb.backend.device_counters())


def winder() -> None:
    print("\n## 3. Issue 13's lines through --port on the firmware (lockstep)")
    app, tr, wall, stack, busy, _ = winder_run(POT_LINE)
    s1 = tr.rising(9)
    gaps = [b - a for a, b in pairwise(s1)]
    top = min(gaps)
    reach = s1[gaps.index(top)] - s1[0]
    print(f"{POT_LINE}: {len(s1)} steps; shortest period {top} ticks = {top / 16:.1f} us = "
          f"{TPS / top:.1f} steps/s (13 counts of 4 us); full speed {reach / TPS * 1000:.1f} ms "
          f"after the first step; stack {stack} bytes; chip busy {100 * busy:.1f} %; "
          f"{wall:.2f} s wall")
    app, tr, wall, stack, busy, _ = winder_run(LIMIT_LINE)
    times, levels = tr.edges(SWITCH)
    sw = [t for t, lv in zip(times, levels, strict=True) if lv == 0][0]
    s2 = tr.rising(10)
    after = sum(1 for t in s2 if t >= sw)
    print(f"{LIMIT_LINE}: {after} steps after the switch, the last one {(sw - s2[-1]) / 16:.1f} "
          f"us before it (200 us a step); S2 stopped at {app.steppers[1].get_current_position()}"
          f" = {len(s2)} steps on pin 10; stack {stack} bytes; {wall:.2f} s wall")
    for name, line in (("acceptance line", ACCEPT_INTERLOCK), ("long run", LONG_INTERLOCK)):
        app, tr, wall, stack, busy, c = winder_run(line)
        err, n1, n2 = interlock_error(tr)
        g = app.gear.stats
        print(f"interlock, {name}: {n1} S1 steps, S2 at {n2}: max |S2 - S1/3| = {err:.3f} "
              f"steps by the pins; {g.commands} S2 commands; underruns {c['underruns']}, "
              f"late starts {c['late_starts']}; stack {stack} bytes; chip busy "
              f"{100 * busy:.1f} %; {wall:.2f} s wall")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200, help="switch moments per case (200)")
    args = ap.parse_args()
    sizes()
    reactions(args.runs)
    winder()
    return 0


if __name__ == "__main__":
    sys.exit(main())
