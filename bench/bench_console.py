"""Console figures: start-up time, idle CPU, CPU of a 25 kHz move in real time, and
the recording of the recent motion (issue 16).

    python bench/bench_console.py [--seconds S] [--repeat N] [--memory-minutes M]

1. Wall time of `stepperdemo -c "?"` (a fresh process, median of 5 runs).
2. The interactive console's real-time driver with nothing running: CPU seconds per
   wall second (the console should sleep, not poll).
3. The same while a stepper runs at 25 000 steps/s (`M1 A1000000 V40 f`): the bare
   driver, then the REPL's driver (`Console`) with the recent recording off, on (the
   default) and with `/trace on` (unbounded, for comparison); then the same work on
   virtual time in the call pattern of real time (CPU per simulated second, the least
   of several runs: a shared machine's noise is mostly gone).
4. Memory of the recent recording over a long session on virtual time: the console's
   program runs M minutes (default 10) of 25 kHz motion; tracemalloc's peak with the
   recording and without it, and the recorder's own counts (edges held, bytes).
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


def _console(recent: bool, clock=time.monotonic):
    import tempfile

    from rigs.console import make_console

    return make_console(tempfile.mkdtemp(), clock=clock, recent_trace=recent)


async def drive_console(seconds: float, trace: str) -> float:
    """The REPL's driver (Console.ticker's work) in real time while M1 runs at 25 kHz:
    CPU seconds per wall second.  ``trace``: off, recent, on."""
    console = _console(trace == "recent")
    if trace == "on":
        console.handle_line("/trace on")
    console.driver.advance()
    console.handle_line("M1 A1000000 V40 f")
    cpu0, wall0 = time.process_time(), time.monotonic()
    while time.monotonic() - wall0 < seconds:
        delay = console.driver.advance()
        console.flush()
        await asyncio.sleep(1.0 if delay is None else min(max(delay, 0.0), 0.25))
    cpu = time.process_time() - cpu0
    wall = time.monotonic() - wall0
    assert console.app.steppers[0].is_running()
    console.trace.close()
    return cpu / wall


def replica(sim_seconds: float, trace: str) -> float:
    """The REPL driver's work for ``sim_seconds`` of the 25 kHz move, in the call
    pattern of real time (each pass advances the clock by the sleep the driver asks
    for, at least 0.2 ms, at most 0.25 s) but without sleeping: CPU seconds per
    simulated second, free of the scheduler's noise."""
    from rigs.console import FakeClock

    clock = FakeClock()
    console = _console(trace == "recent", clock)
    if trace == "on":
        console.handle_line("/trace on")
    console.driver.advance()
    console.handle_line("M1 A1000000 V40 f")
    cpu0 = time.process_time()
    while clock.now < sim_seconds:
        delay = console.driver.advance()
        console.flush()
        clock.now += max(min(1.0 if delay is None else delay, 0.25), 0.0002)
    cpu = time.process_time() - cpu0
    console.trace.close()
    return cpu / sim_seconds


def long_session(minutes: float, recent: bool) -> dict:
    """The console's program on virtual time: ``minutes`` of 25 kHz motion, driven as
    the REPL drives it (50 ms of wall clock per step); memory with tracemalloc."""
    import tracemalloc

    from rigs.console import FakeClock

    clock = FakeClock()
    console = _console(recent, clock)
    console.driver.advance()
    console.handle_line("M1 A1000000 V40 f")
    rec = console.trace.recent
    samples = []
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    cpu0 = time.process_time()
    steps = int(minutes * 60 / 0.05)
    for i in range(steps):
        clock.now += 0.05
        console.driver.advance()
        console.flush()
        if rec is not None and (i + 1) % int(60 / 0.05) == 0:  # each simulated minute
            rec.flush()
            samples.append((rec.held, rec.nbytes()))
    cpu = time.process_time() - cpu0
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    pos = console.app.steppers[0].get_current_position()
    out = {"cpu": cpu, "peak": peak, "position": pos, "samples": samples}
    if rec is not None:
        rec.flush()
        out.update(held=rec.held, dropped=rec.dropped, peak_held=rec.peak_held,
                   nbytes=rec.nbytes(), bound=rec.max_edges)
        lines = console.trace.command("/report", [])
        by_pins = next(ln for ln in lines if ln.startswith("  pulses "))
        out["report_position"] = int(by_pins.split("position ")[1].split()[0])
    console.trace.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--memory-minutes", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3, help="runs per REPL driver figure")
    args = ap.parse_args()
    print(f"start-up `stepperdemo -c \"?\"`: {startup():.3f} s wall (median of 5)")
    for arch in ("atmega328p", "esp32"):
        idle = asyncio.run(drive(args.seconds, None, arch))
        print(f"idle console ({arch}): {idle * 100:.2f} % of one core")
    busy = asyncio.run(drive(args.seconds, "M1 A1000000 V40 f", "atmega328p"))
    print(f"25 kHz move in real time (atmega328p), bare driver: {busy * 100:.1f} % of one core")
    modes = (("off", "recording off"), ("recent", "recent recording (default)"),
             ("on", "/trace on (unbounded)"))
    shares: dict[str, list[float]] = {m: [] for m, _ in modes}
    for _ in range(args.repeat):  # interleaved: a busy neighbour hits every mode alike
        for trace, _what in modes:
            shares[trace].append(asyncio.run(drive_console(args.seconds, trace)))
    for trace, what in modes:
        runs = " ".join(f"{x * 100:.1f}" for x in shares[trace])
        print(f"25 kHz move in real time, REPL driver, {what}: "
              f"{statistics.median(shares[trace]) * 100:.1f} % of one core (median; {runs})")
    cpu: dict[str, list[float]] = {m: [] for m, _ in modes}
    for _ in range(max(args.repeat, 5)):
        for trace, _what in modes:
            cpu[trace].append(replica(20.0, trace))
    for trace, what in modes:
        print(f"the same on virtual time in real time's call pattern, {what}: "
              f"{min(cpu[trace]) * 100:.2f} % of one core per simulated second (least of "
              f"{len(cpu[trace])} runs of 20 s)")
    if args.memory_minutes > 0:
        m = args.memory_minutes
        off = long_session(m, False)
        on = long_session(m, True)
        edges = on["held"] + on["dropped"]
        print(f"{m:g} min of 25 kHz motion on virtual time ({edges} edges): "
              f"tracemalloc peak {off['peak'] / 1e6:.1f} MB without the recording, "
              f"{on['peak'] / 1e6:.1f} MB with it; CPU {off['cpu']:.1f} s / {on['cpu']:.1f} s "
              f"(tracemalloc on)")
        print(f"  recent recording: bound {on['bound']} edges, peak held {on['peak_held']}, "
              f"held {on['held']}, dropped {on['dropped']}, arrays {on['nbytes'] / 1e6:.2f} MB")
        print("  per simulated minute (held edges, bytes): "
              + ", ".join(f"{h}/{b / 1e6:.2f}MB" for h, b in on["samples"]))
        print(f"  position by the pins in /report {on['report_position']}, "
              f"library {on['position']}")


if __name__ == "__main__":
    main()
