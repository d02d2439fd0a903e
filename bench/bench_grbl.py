"""Figures of issue 24: the Grbl controller on virtual time.

    python bench/bench_grbl.py [--arch atmega2560]

1. Feed hold from 6000 mm/min (80 steps/mm, 500 mm/s², the diagonal G1 X200 Y100): how
   long after the ``!`` the deceleration begins (the frontier of the queues), the speed
   there (from the pins), where each axis must stop (v²/2a from its position at the
   frontier) and where it stopped, the largest distance from the line, and the end
   position after ``~``.
2. ``G1 X400 F24000 / M62 P0 / G1 X800 F24000 / M65 P0``: Dout0 at the end.
3. The servo sweep (``sequences/gcode/servo_sweep.gcode``): each step's duty and time.
4. Cost: the 1 000-line program streamed by a character-counting sender on virtual
   time - simulated seconds, CPU seconds, and their ratio (the real-time endpoint
   keeps up with ``--speed`` up to about that factor on an idle core).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections import deque

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from stepperdemo.demo.build import demo_build  # noqa: E402
from stepperdemo.gcode.program import RawGrbl  # noqa: E402
from stepperdemo.watch.outputs import duty_steps  # noqa: E402

MM = b"$100=80\n$101=80\n$110=12000\n$111=12000\n$120=500\n$121=500\n"


def feed_hold(arch: str) -> None:
    g = RawGrbl(arch, record=True)
    tps = g.ticks_per_s
    g.send(MM)
    g.settle()
    g.send(b"G1 X200 Y100 F6000\n")
    g.advance(1.0)
    asked = g.backend.now()
    g.send(b"!")
    g.advance(0.6)
    rec = g.machine.executor.holds[-1]
    pins = demo_build(g.backend.profile).steppers
    print(f"1. feed hold from 6000 mm/min on {arch}: the deceleration begins "
          f"{(rec.frontier - asked) / tps * 1000:.2f} ms after the '!'")
    accel_path = rec.accel
    for axis, n in ((0, 16000), (1, 8000)):
        edges = g.backend.recorder.rising(pins[axis].step)
        before = [t for t in edges if t < rec.frontier]
        window = [t for t in before if t >= rec.frontier - tps // 2]
        v = (len(window) - 1) / ((window[-1] - window[0]) / tps)
        accel = accel_path * n
        at = len(before) + (rec.frontier - before[-1]) / tps * v
        stop = at + v * v / (2 * accel)
        print(f"   {'XY'[axis]}: {v:.1f} steps/s, a {accel:.0f} steps/s^2, at the frontier "
              f"{at:.2f}, must stop at {stop:.2f} (v^2/2a = {v * v / (2 * accel):.2f} steps), "
              f"stopped at {len(edges)}: {len(edges) - stop:+.2f} steps")
    g.send(b"~")
    g.settle()
    xs = g.backend.recorder.rising(pins[0].step)
    ys = g.backend.recorder.rising(pins[1].step)
    x = y = 0
    worst = 0.0
    for _t, axis in sorted([(t, 0) for t in xs] + [(t, 1) for t in ys]):
        x, y = x + (axis == 0), y + (axis == 1)
        worst = max(worst, abs(x * 8000 - y * 16000) / math.hypot(16000, 8000))
    print(f"   after '~': {g.machine.positions()[:2]} ({len(xs)}/{len(ys)} pulses), at most "
          f"{worst:.3f} steps from the line, last steps {abs(xs[-1] - ys[-1])} ticks apart")


def seed_003(arch: str) -> None:
    g = RawGrbl(arch, record=True)
    g.send(b"G1 X400 F24000\nM62 P0\nG1 X800 F24000\nM65 P0\n")
    g.settle()
    pin = g.machine.engine.outputs.digital_pin(0)
    print(f"2. G1 X400 / M62 P0 / G1 X800 / M65 P0 on {arch}: Dout0 (pin {pin}) ends "
          f"{'high' if g.backend.read_pin(pin) else 'low'}; answers {g.take().count(b'ok')} ok")


def servo_sweep() -> None:
    g = RawGrbl("atmega2560", record=True)
    with open(os.path.join(ROOT, "sequences", "gcode", "servo_sweep.gcode")) as f:
        text = f.read()
    g.program.run_script(text)
    pin = g.machine.engine.outputs.analog_pin(0)
    g.backend.deliver_edges()
    times, levels = g.backend.recorder.pin_edges(pin)
    steps = duty_steps(times, levels, g.backend.now())
    tps = g.ticks_per_s
    print("3. servo sweep: " + ", ".join(f"{d:.2f} % for {t / tps:.3f} s ({n} periods)"
                                         for d, n, t in steps))


def streaming_cost(arch: str) -> None:
    g = RawGrbl(arch)
    with open(os.path.join(ROOT, "sequences", "gcode", "zigzag1000.gcode")) as f:
        lines = [ln.split(";")[0].strip() for ln in f]
    lines = [ln for ln in lines if ln]
    inflight: deque[int] = deque()
    buf = b""
    g.take()
    t0 = time.process_time()
    i = 0
    while i < len(lines) or inflight:
        while i < len(lines) and sum(inflight) + len(lines[i]) + 1 <= 128:
            g.send(lines[i].encode() + b"\n")
            inflight.append(len(lines[i]) + 1)
            i += 1
        g.advance(0.005)
        buf += g.take()
        while b"\n" in buf:
            line, _, buf = buf.partition(b"\n")
            if line.strip() == b"ok" or line.startswith(b"error"):
                inflight.popleft()
    g.settle()
    cpu = time.process_time() - t0
    sim = g.backend.now() / g.ticks_per_s
    print(f"4. zigzag1000 streamed by a counting sender on {arch}: {sim:.1f} s simulated in "
          f"{cpu:.1f} s CPU ({sim / cpu:.0f}x real time), end {g.machine.positions()}, "
          f"{g.machine.errors} errors, {g.machine.rx.dropped} bytes dropped")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", default="atmega2560")
    args = ap.parse_args()
    feed_hold(args.arch)
    seed_003(args.arch)
    servo_sweep()
    streaming_cost(args.arch)
    return 0


if __name__ == "__main__":
    sys.exit(main())
