"""Console figures: start-up time, idle CPU, CPU of a 25 kHz move in real time.

    python bench/bench_console.py [--seconds S]

1. Wall time of `stepperdemo -c "?"` (a fresh process, median of 5 runs).
2. The interactive console's real-time driver with nothing running: CPU seconds per
   wall second (the console should sleep, not poll).
3. The same while a stepper runs at 25 000 steps/s (`M1 A1000000 V40 f`).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def startup(runs: int = 5) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "stepperdemo", "-c", "?"], check=True,
                       stdout=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


async def drive(seconds: float, line: str | None, arch: str) -> float:
    from fas.sim import SimBackend
    from stepperdemo.demo.app import StepperDemo
    from stepperdemo.front.console import RealTimeDriver

    app = StepperDemo(SimBackend(arch), scripted=False)
    driver = RealTimeDriver(app)
    driver.advance()  # start-up output
    if line:
        app.feed(line + "\n")
    cpu0, wall0 = time.process_time(), time.monotonic()
    while time.monotonic() - wall0 < seconds:
        delay = driver.advance()
        await asyncio.sleep(1.0 if delay is None else min(max(delay, 0.0), 1.0))
    cpu = time.process_time() - cpu0
    wall = time.monotonic() - wall0
    if line:
        assert app.steppers[0].is_running()
    return cpu / wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    args = ap.parse_args()
    print(f"start-up `stepperdemo -c \"?\"`: {startup():.3f} s wall (median of 5)")
    for arch in ("atmega328p", "esp32"):
        idle = asyncio.run(drive(args.seconds, None, arch))
        print(f"idle console ({arch}): {idle * 100:.2f} % of one core")
    busy = asyncio.run(drive(args.seconds, "M1 A1000000 V40 f", "atmega328p"))
    print(f"25 kHz move in real time (atmega328p): {busy * 100:.1f} % of one core")


if __name__ == "__main__":
    main()
