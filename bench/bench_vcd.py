"""Benchmark of VCD tracing on the simulated backend (issue: step traces as VCD).

    python bench/bench_vcd.py [--steps N] [--out FILE.vcd]
    python bench/bench_vcd.py --sigrok [--keep DIR]

A move of N steps (default 1 000 000) at 25 000 steps/s on the atmega328p profile,
its step/dir/enable pins and the interrupt-blocked signal streamed to a VCD file.
Prints wall seconds, edges written per wall second and the file size; then the peak
Python memory of the same run repeated under tracemalloc (which slows Python down a
lot, hence a second run) for N/4 and N steps: memory stays flat in the run length.

``--sigrok`` (issue 26): the console's VCD files (``/vcd FILE`` at the default unit) of
two 100 s recordings - a mostly idle one (the recent recording: a 3200-step move, 9 s
still, then 85 short moves a second apart) and a busy one (``/trace on``: 10 000
steps/s for 100 s) - opened by sigrok-cli as PulseView opens them: the import
``sigrok-cli -I vcd -i FILE -O null`` (target: < 5 s for 100 s), and the rising edges of
StepA counted by its ``counter`` decoder against the console's ``/report``.  For
comparison the idle recording in finer units too (``--units``).  Needs sigrok-cli
(``apt-get install sigrok-cli``); a bound on each sigrok run (``--limit``).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
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


IDLE_LINE = ("M1 A1000 V100 R3200 W w9000 A1000000 V40 "
             + " ".join(["R53 W w1000"] * 85))
BUSY_LINE = "M1 A10000 V100 f"


def console_recording(folder: str, line: str, seconds: float, unbounded: bool
                      ) -> tuple[object, int]:
    """The console (on a virtual wall clock) after ``line`` and ``seconds``; the pulses
    its /report counts for M1."""
    if ROOT not in sys.path:
        sys.path.insert(0, ROOT)
    from rigs.console import advance, make_console

    console = make_console(folder)
    if unbounded:
        console.handle_line("/trace on")
    console.handle_line(line)
    advance(console, seconds, step_s=0.25)
    n = len(console.lines)
    console.handle_line("/report")
    found = re.search(r"^  pulses +(\d+) ", "\n".join(console.lines[n:]), re.MULTILINE)
    return console, int(found.group(1)) if found else -1


def sigrok(path: str, limit_s: float, *extra: str) -> tuple[float | None, str]:
    """Wall seconds of one sigrok-cli run on ``path`` (None: over ``limit_s``), its output."""
    t0 = time.perf_counter()
    try:
        res = subprocess.run(["sigrok-cli", "-I", "vcd", "-i", path, *extra],
                             capture_output=True, text=True, timeout=limit_s, check=True)
    except subprocess.TimeoutExpired:
        return None, ""
    return time.perf_counter() - t0, res.stdout


def sigrok_bench(keep: str | None, limit_s: float, units: list[str]) -> None:
    if shutil.which("sigrok-cli") is None:
        sys.exit("sigrok-cli is not installed (apt-get install sigrok-cli)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = keep or tmp
        os.makedirs(folder, exist_ok=True)
        for name, line, seconds, unbounded in (("idle", IDLE_LINE, 118.0, False),
                                               ("busy", BUSY_LINE, 100.0, True)):
            t0 = time.perf_counter()
            console, pulses = console_recording(folder, line, seconds, unbounded)
            made = time.perf_counter() - t0
            for unit in (["", *units] if name == "idle" else [""]):
                path = os.path.join(folder, f"{name}{unit.replace(' ', '') or ''}.vcd")
                console.handle_line(f"/vcd {path} {unit}".rstrip())
                said = console.lines[-1]
                with open(path, encoding="ascii") as f:
                    head = f.read(400)
                shown = re.search(r"\$timescale (.*?) \$end", head)
                import_s, _ = sigrok(path, limit_s, "-O", "null")
                count_s, out = sigrok(path, limit_s, "-P",
                                      "counter:data=StepA:data_edge=rising", "-A", "counter")
                counts = re.findall(r"counter-1: (\d+)", out)
                counted = int(counts[-1]) if counts else None

                def s(v: float | None) -> str:
                    return f"{v:.2f} s" if v is not None else f"> {limit_s:g} s"
                print(f"{name} {seconds:g} s ({made:.0f} s to simulate)  unit "
                      f"{shown.group(1) if shown else '?'}  {os.path.getsize(path) / 2**20:.2f}"
                      f" MiB  sigrok import (-O null) {s(import_s)}  counter {s(count_s)}: "
                      f"{counted} rising StepA, /report {pulses} pulses"
                      f"{'' if counted == pulses else '  (DIFFER)'}")
                if "no width" in said:
                    print("   ", said.split(" - ", 1)[-1])
            console.trace.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000)
    ap.add_argument("--out", help="VCD file to write (default: a temporary file)")
    ap.add_argument("--sigrok", action="store_true",
                    help="time sigrok-cli on the console's VCD of 100 s recordings")
    ap.add_argument("--keep", metavar="DIR", help="--sigrok: keep the VCD files in DIR")
    ap.add_argument("--limit", type=float, default=120.0, metavar="S",
                    help="--sigrok: give up a sigrok-cli run after S seconds")
    ap.add_argument("--units", default="100ns", metavar="U,U",
                    help="--sigrok: the idle recording also in these units (default 100ns; "
                         "e.g. 100ns,10ns,exact)")
    args = ap.parse_args()
    if args.sigrok:
        sigrok_bench(args.keep, args.limit, [u for u in args.units.split(",") if u])
        return
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
