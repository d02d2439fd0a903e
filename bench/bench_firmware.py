"""The device firmware in simavr: size, step timing against the Python device, link margin.

1. Size: flash and RAM of the two builds (115200 and 1 000 000 baud), from avr-size.
2. Step timing: every acceptance line (rigs/serial.py) runs through the
   serial backend against the firmware in simavr (lockstep with the host's virtual
   clock).  The bytes the chip received are then replayed, at the ticks they reached
   its UART, into the Python device: the same session on both.  Per step pin: the
   difference of each rising edge (firmware minus Python device, ticks of 62.5 ns),
   median and maximum, and the pulse widths; plus the wall time of the simavr run,
   the simulated time and how busy the chip was (1 - sleep / total cycles).
3. Step rate limits: the step generator alone (the rig firmware, no protocol): the
   shortest period at which every step of 500 comes on its tick, one channel, and two
   channels whose every edge coincides (the worst case for the interrupts).
4. Link margin: the shortest legal commands (one step each) streamed into both
   queues through the chip's own UART (simavr times a character as 11 bits, so its
   line is 10 % slower than a real one): commands/s sustained, against what the
   two-stepper 25 kHz line needs (peak commands/s over 20 ms on the simulated chip);
   and that line itself at both speeds: underruns, late starts, link round trip.

Wall times depend on the machine (shared machines: approximate).

    python bench/bench_firmware.py [--lines N] [--seconds S]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas.device import simavr  # noqa: E402
from fas.device.loopback import Loopback  # noqa: E402
from rigs.demo import command_stamps  # noqa: E402
from rigs.firmware import run_firmware  # noqa: E402
from rigs.serial import LINES, stream_minimal  # noqa: E402

TWO_25KHZ = "M1 A100000 V40 R20000 M2 A100000 V40 R-20000 W M2 W"
ISSUE_LINE = "M1 A1000 V100 R3200 W M2 A2000 V200 R-1000 W"
BAUDS = (115200, 1_000_000)
TPS = 16_000_000


def sizes() -> None:
    print("firmware size (ATmega328P: 32768 bytes flash, 2048 bytes RAM)")
    for baud in BAUDS:
        b = simavr.build(baud)
        flash_pct, ram_pct = 100 * b.flash_bytes / 32768, 100 * b.ram_bytes / 2048
        print(f"  {baud:>7} baud: flash {b.flash_bytes} bytes ({flash_pct:.1f} %), "
              f"RAM {b.ram_bytes} bytes static ({ram_pct:.1f} %), "
              f"{2048 - b.ram_bytes} bytes left for the stack")
    print()


def _widths(times, levels) -> list[int]:
    return [times[i + 1] - times[i] for i in range(len(times) - 1) if levels[i] == 1]


def timing(lines: list[str]) -> None:
    print("step timing, firmware in simavr vs Python device on the same session "
          "(rising edges; 1 tick = 62.5 ns)")
    print(f"{'line':52s} {'pin':>3s} {'steps':>6s} {'median':>6s} {'max':>4s} "
          f"{'width fw/py':>11s} {'sim s':>6s} {'wall s':>6s} {'busy':>5s} {'stack':>5s}")
    for line in lines:
        t0 = time.monotonic()
        fw = run_firmware(line)
        wall = time.monotonic() - t0
        tr = fw.trace
        end = tr.end_cycle - tr.timer1_start
        info_cpb = 10 * 17 * 8  # 115200 baud, U2X: 10 bits of 136 cycles
        py = simavr.replay_on_python_device(fw.rx_log, tr.timer1_start, info_cpb, end)
        sim_s = tr.end_cycle / TPS
        busy = fw.busy
        for pin in (9, 10):
            f = tr.rising(pin)
            p = py.recorder.rising(pin)
            if not f and not p:
                continue
            if len(f) != len(p):
                print(f"{line:52s} {pin:3d} firmware {len(f)} steps, Python device {len(p)}")
                continue
            d = [abs(a - b) for a, b in zip(f, p, strict=True)]
            fw_w = statistics.median(_widths(*tr.edges(pin)))
            py_w = statistics.median(_widths(*py.recorder.pin_edges(pin)))
            print(f"{line:52s} {pin:3d} {len(f):6d} {statistics.median(d):6.0f} {max(d):4d} "
                  f"{fw_w:5.0f}/{py_w:<5.0f} {sim_s:6.2f} {wall:6.2f} {100 * busy:4.0f}% "
                  f"{fw.stack_bytes:5d}")
    print()


def limits() -> None:
    from rigs.stepgen import Both, Rig, build_rig

    elf = build_rig()

    tmp = tempfile.mkdtemp(prefix="bench-firmware-")

    def on_time(period: int, channels: tuple[int, ...]) -> bool:
        rig = Rig(elf, os.path.join(tmp, "trace.txt"))
        both = Both(rig)
        for ch in channels:
            both.entry(ch, 250, period)
            both.entry(ch, 250, period)
        at = rig.tick() + 30_000
        for ch in channels:
            both.start_at(ch, at)
        both.run_to_tick(at + 520 * period + 50_000)
        trace = rig.dev.trace()
        rig.dev.close()
        for ch in channels:
            fw, py = trace.rising(9 + ch), both.model.rising(9 + ch)
            # (the Python device may have made more or fewer: the pairs both made count)
            if len(fw) != 500 or any(a - b > 1 for a, b in zip(fw, py, strict=False)):
                return False
        return True

    print("step rate limits of the step generator (500 steps, every one on its tick)")
    for channels, what in (((0,), "one channel"),
                           ((0, 1), "two channels, every edge coinciding")):
        lo, hi = 100, 1000
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if on_time(mid, channels) else (mid, hi)
        print(f"  {what}: {hi} ticks ({TPS / hi / 1000:.1f} kHz)")
    print("  (FastAccelStepper on the ATmega328P: 320 ticks for one stepper, 426 for two)")
    print()
    shutil.rmtree(tmp, ignore_errors=True)


def sustained(baud: int, seconds: float) -> tuple[float, float]:
    """(commands/s, frames/s) streaming one-step commands into both queues."""
    with Loopback(device="simavr", baud=baud) as lb:
        cmds, frames, _resent = stream_minimal(lb, 2, seconds)
        return cmds, frames


def needed(line: str) -> int:
    """Peak commands/s of ``line`` over 20 ms windows on the simulated chip."""
    from collections import Counter

    stamps, _profile = command_stamps(line)
    window = 20 * TPS // 1000
    return max(Counter(t // window for t in stamps).values()) * 50


def margin(seconds: float) -> None:
    need = needed(TWO_25KHZ)
    print(f"link margin, two steppers at 25 kHz ({TWO_25KHZ}): needs {need} commands/s "
          "at peak")
    for baud in BAUDS:
        cmds, frames = sustained(baud, seconds)
        t0 = time.monotonic()
        fw = run_firmware(TWO_25KHZ, baud=baud)
        wall = time.monotonic() - t0
        c = fw.counters
        ok = fw.pin_positions == [20000, -20000] and c["entries_lost"] == 0
        print(f"  {baud:>7} baud: sustains {cmds:6.0f} commands/s in {frames:4.0f} frames/s, "
              f"margin {cmds / need:4.2f}; the line: {c['underruns']} underruns, "
              f"{c['late_starts']} late starts, rtt {fw.link['rtt_us']} us, chip busy "
              f"{100 * fw.busy:.0f} %, positions {'ok' if ok else fw.pin_positions}, "
              f"wall {wall:.1f} s")
    print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=len(LINES) + 1,
                    help="how many acceptance lines (default all, and the issue's)")
    ap.add_argument("--seconds", type=float, default=1.0,
                    help="virtual seconds of each saturation run (default 1)")
    args = ap.parse_args(argv)
    problem = simavr.toolchain_problem()
    if problem:
        print(f"cannot run: {problem}")
        return 2
    sizes()
    timing(([ISSUE_LINE] + LINES)[:args.lines])
    limits()
    margin(args.seconds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
