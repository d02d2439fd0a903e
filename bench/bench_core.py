"""Benchmark of the fas core on the simulated backend (issue: fas core).

    python bench/bench_core.py [--steps N]

A 1 000 000-step move at 25 000 steps/s (40 s of motor time) on the atmega328p
profile, once without and once with per-edge recording.  Prints wall seconds, the
ratio motor-time / wall-time, edges per wall second, and the peak Python memory
of the same run repeated under tracemalloc.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import tracemalloc

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas import Engine
from fas.sim import SimBackend


def run(steps: int, record: bool, trace_memory: bool = False) -> dict:
    if trace_memory:
        tracemalloc.start()
    t0 = time.perf_counter()
    backend = SimBackend("atmega328p", record=record)
    engine = Engine(backend)
    engine.init()
    s = engine.stepper_connect_to_pin(9)
    s.set_direction_pin(5)
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(steps)
    backend.wait_until(lambda: not s.is_running(), 10_000 * 16_000_000)
    wall = time.perf_counter() - t0
    peak = 0
    if trace_memory:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    motor_s = backend.now() / backend.profile.ticks_per_s
    edges = backend.machine.pins.rising(9) + backend.machine.pins.falling(9)
    assert s.get_current_position() == steps
    return {"record": record, "wall_s": wall, "motor_s": motor_s, "ratio": motor_s / wall,
            "edges": edges, "edges_per_s": edges / wall, "peak_mib": peak / 2**20}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    args = ap.parse_args()
    for record in (False, True):
        r = run(args.steps, record)
        # memory is measured in a second run: tracemalloc slows Python down a lot
        r["peak_mib"] = run(args.steps, record, trace_memory=True)["peak_mib"]
        print(f"recording={'on ' if record else 'off'}  wall {r['wall_s']:.3f} s  "
              f"motor {r['motor_s']:.2f} s  ratio {r['ratio']:.0f}x  "
              f"edges {r['edges']}  {r['edges_per_s']:,.0f} edges/s  "
              f"peak memory {r['peak_mib']:.1f} MiB")


if __name__ == "__main__":
    main()
