"""Figures of issue 12: G-code lines and user outputs on the simulated backend.

    python bench/bench_gcode.py [--steps 10000,3000] [--pwm-seconds 10]

1. The two-axis diagonal ``G1 X<a> Y<b>`` (default 10 000 x 3 000 steps) on every
   profile: the largest distance of the pin position from the straight line (steps,
   measured at every step edge), the difference between the axes' last steps (us), the
   duration, and the wall time of the run.
2. The issue's ordering program on the ESP32 (move X, M62 P0, move back, M63 P0, M64 P1,
   M67 E1 Q23.87) traced to a VCD and read back: where Dout0 changes relative to the
   steps, Dout1's first edge, Aout1's measured frequency and mean duty against the
   produced count (1955/8192).
3. The cost of a traced PWM: ``--pwm-seconds`` of a 5 kHz output to a VCD file, wall
   seconds and edges per wall second, and the peak Python memory (tracemalloc) for half
   and the whole time - flat, because the waveform is made in chunks as the trace
   flushes.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
import tracemalloc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from fas.arch import PROFILES  # noqa: E402
from fas.sim import SimBackend  # noqa: E402
from stepperdemo.demo.build import demo_build  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.watch import observe  # noqa: E402

ORDERING = "G1 X2000 F600000\nM62 P0\nG1 X0\nM63 P0\nM64 P1\nM67 E1 Q23.87\nG4 P0.2\nM2\n"


def diagonal(arch: str, dx: int, dy: int) -> dict | None:
    """The diagonal's figures; None where the profile's StepperDemo wiring connects
    fewer than two axes (the Due: its second stepper's step pin 15 reaches no PWM
    channel, so the G-code program has X only and refuses the Y word)."""
    backend = SimBackend(arch, record=True)
    app = make_program("gcode", backend, scripted=True, output=lambda d: None)
    app.setup()
    if app.machine.axes < 2:
        return None
    t0 = time.perf_counter()
    app.run_script(f"G1 X{dx} Y{dy} F600000\n", max_ticks=3600 * backend.profile.ticks_per_s)
    wall = time.perf_counter() - t0
    p = backend.profile
    xs = backend.recorder.rising(demo_build(p).steppers[0].step)
    ys = backend.recorder.rising(demo_build(p).steppers[1].step)
    events = sorted([(t, 0) for t in xs] + [(t, 1) for t in ys])
    length = math.hypot(dx, dy)
    x = y = 0
    worst = 0.0
    i = 0
    while i < len(events):  # edges on one tick count together
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            x, y = x + (events[i][1] == 0), y + (events[i][1] == 1)
            i += 1
        worst = max(worst, abs(x * dy - y * dx) / length)
    return {"arch": arch, "steps": (len(xs), len(ys)), "deviation_steps": worst,
            "last_step_diff_us": (xs[-1] - ys[-1]) * 1e6 / p.ticks_per_s,
            "duration_s": (xs[-1] - app.machine.motion_log[0][0]) / p.ticks_per_s,
            "wall_s": wall}


def ordering(path: str) -> dict:
    from rigs.vcd import read_vcd

    backend = SimBackend("esp32")
    obs = observe.attach(backend, vcd=path, analyse=False)
    app = make_program("gcode", backend, scripted=True, output=lambda d: None)
    app.run_script(ORDERING)
    obs.finish()
    vcd = read_vcd(path)
    unit_us = 1e-4  # 100 ps
    steps = vcd.rising("StepA")
    (d0_rise,), (d0_fall,) = vcd.rising("Dout0"), vcd.falling("Dout0")
    rises, falls = vcd.rising("Aout1"), vcd.falling("Aout1")
    highs = [f - r for r, f in zip(rises, falls, strict=False)]  # (a last rise may not fall)
    period = (rises[-1] - rises[0]) / (len(rises) - 1)
    return {
        "last step of move 1 -> Dout0 rise us": (d0_rise - steps[1999]) * unit_us,
        "Dout0 rise -> first step of move 2 us": (steps[2000] - d0_rise) * unit_us,
        "last step of move 2 -> Dout0 fall us": (d0_fall - steps[-1]) * unit_us,
        "Dout1 first rise us": vcd.rising("Dout1")[0] * unit_us,
        "first step us": steps[0] * unit_us,
        "Aout1 periods": len(highs),
        "Aout1 frequency Hz": 1 / (period * unit_us * 1e-6),
        "Aout1 mean duty %": 100 * sum(highs) / (len(highs) * period),
        "produced duty % (1955/8192)": 100 * 1955 / 8192,
        "resolution %": 100 / 8192,
    }


def traced_pwm(seconds: float, path: str, memory: bool) -> dict:
    if memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    backend = SimBackend("esp32")
    obs = observe.attach(backend, vcd=path, analyse=True)
    app = make_program("gcode", backend, scripted=True, output=lambda d: None)
    app.run_script(f"M68 E1 Q23.87\nG4 P{seconds}\n")
    obs.finish()
    wall = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] if memory else 0
    if memory:
        tracemalloc.stop()
    return {"edges": obs.stream.edges_out, "wall_s": wall,
            "edges_per_s": obs.stream.edges_out / wall, "peak_mb": peak / 1e6,
            "file_mb": os.path.getsize(path) / 1e6}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", default="10000,3000", help="the diagonal: X,Y steps")
    ap.add_argument("--pwm-seconds", type=float, default=10.0)
    args = ap.parse_args()
    dx, dy = (int(v) for v in args.steps.split(","))
    print(f"diagonal G1 X{dx} Y{dy} F600000 (a = 10000 steps/s^2 per axis, 10 000 steps/s)")
    for arch in PROFILES:
        r = diagonal(arch, dx, dy)
        if r is None:
            print(f"  {arch:11s} skipped: StepperDemo's wiring gives the G-code program "
                  f"one axis here")
            continue
        print(f"  {arch:11s} steps {r['steps']}, largest deviation from the line "
              f"{r['deviation_steps']:.3f} steps, last steps {r['last_step_diff_us']:+.4f} us "
              f"apart, {r['duration_s']:.4f} s of motion, {r['wall_s']:.2f} s wall")
    with tempfile.TemporaryDirectory() as d:
        print("ordering program on esp32 (VCD read back):")
        for k, v in ordering(os.path.join(d, "o.vcd")).items():
            print(f"  {k}: {v:.4f}" if isinstance(v, float) else f"  {k}: {v}")
        print(f"traced 5 kHz PWM for {args.pwm_seconds:g} s of simulated time:")
        r = traced_pwm(args.pwm_seconds, os.path.join(d, "p.vcd"), False)
        print(f"  {r['edges']} edges in {r['wall_s']:.2f} s wall ({r['edges_per_s']:.0f}/s), "
              f"VCD {r['file_mb']:.1f} MB")
        for s in (args.pwm_seconds / 2, args.pwm_seconds):
            m = traced_pwm(s, os.path.join(d, "m.vcd"), True)
            print(f"  peak Python memory for {s:g} s: {m['peak_mb']:.1f} MB")


if __name__ == "__main__":
    main()
