"""Benchmark of VCD tracing on the simulated backend (issue: step traces as VCD).

    python bench/bench_vcd.py [--steps N] [--out FILE.vcd]

A move of N steps (default 1 000 000) at 25 000 steps/s on the atmega328p profile,
its step/dir/enable pins and the interrupt-blocked signal streamed to a VCD file.
Prints wall seconds, edges written per wall second and the file size; then the peak
Python memory of the same run repeated under tracemalloc (which slows Python down a
lot, hence a second run) for N/4 and N steps: memory stays flat in the run length.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import tracemalloc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIGNALS = {9: "StepA", 5: "DirA", 6: "EnableA"}


def run(steps: int, path: str, trace_memory: bool = False) -> dict:
    if ROOT not in sys.path:
        sys.path.insert(0, ROOT)
    from fas import Engine
    from fas.sim import SimBackend
    from fas.sim.trace import VcdTrace

    if trace_memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    backend = SimBackend("atmega328p")
    trace = VcdTrace(backend, path, SIGNALS).start()
    engine = Engine(backend)
    engine.init()
    s = engine.stepper_connect_to_pin(9)
    s.set_direction_pin(5)
    s.set_enable_pin(6)
    s.set_auto_enable(True)
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(steps)
    backend.wait_until(lambda: not s.is_running(), 10_000 * 16_000_000)
    trace.close()
    wall = time.perf_counter() - t0
    peak = 0
    if trace_memory:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert s.get_current_position() == steps
    assert trace.writer.changes >= 2 * steps and trace.stream.late_edges == 0
    return {"wall_s": wall, "edges": trace.writer.changes,
            "edges_per_s": trace.writer.changes / wall, "bytes": os.path.getsize(path),
            "motor_s": backend.now() / backend.profile.ticks_per_s,
            "peak_mib": peak / 2**20, "peak_buffered": trace.stream.peak_buffered}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--out", help="VCD file to write (default: a temporary file)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = args.out or os.path.join(tmp, "bench.vcd")
        r = run(args.steps, path)
        print(f"steps {args.steps}  motor {r['motor_s']:.2f} s  wall {r['wall_s']:.3f} s  "
              f"edges {r['edges']}  {r['edges_per_s']:,.0f} edges/s  "
              f"file {r['bytes'] / 2**20:.1f} MiB")
        for steps in (args.steps // 4, args.steps):
            m = run(steps, path, trace_memory=True)
            print(f"  under tracemalloc: {steps} steps  peak memory {m['peak_mib']:.2f} MiB  "
                  f"(at most {m['peak_buffered']} edges buffered)")


if __name__ == "__main__":
    main()
