"""The helix winder's acceptance figures (issue 13), measured on the pins.

    python bench/bench_winder.py                 # everything below
    python bench/bench_winder.py --sweep-csv sweep.csv --plot traverse.png

1. S1's pot run (``pots pot 1 1023 w2000 pot 1 512 w1000``): peak steps/s and the time
   to reach it, from the step pin.
2. The pot sweep 0..1023: steady steps/s on the step pin against the log rule.
3. The limit switch (``period 2 50 move 2 65535 w300 switch A3 1 w300``): time from the
   switch to S2's last step - simulated chip; device on the loopback (the device's
   own limit stop, and for comparison the host's stop on the Input report).
4. The interlock: max |S2 - S1/3| by the pins for the acceptance line and for a run of
   more than 100 000 S1 steps with pot-driven speed changes (simulation and device).
5. The traverse plot (PNG) and the gear's cost in wall time.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from itertools import pairwise

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas.device.loopback import Loopback  # noqa: E402
from fas.device.relay import Faults  # noqa: E402
from fas.sim import SimBackend  # noqa: E402
from rigs.pins import ratio_error, steps_by_pins  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.winder.potrule import pot_command, rule_speed  # noqa: E402

TPS = 16_000_000
S1, S2 = (9, 5), (10, 7)
A0_PIN, A3_PIN = 14, 17
ACCEPT_INTERLOCK = ("ratio 1:3 interlock 1 pots pot 1 900 w800 pot 1 700 w800 "
                    "pot 1 512 w600")
LONG_INTERLOCK = ("ratio 1:3 interlock 1 pots pot 1 1023 w2000 pot 1 850 w1500 pot 1 1023 "
                  "w1500 pot 1 950 w1000 pot 1 1023 w1500 pot 1 200 w1500 pot 1 512 w1000")
TRAVERSE = "period 2 100 accel 2 20000 traverse 0 2000 w4000 move 2 0 w500"


def steps(recorder, pins) -> list[tuple[int, int]]:
    return steps_by_pins(recorder.pin_edges, *pins)


def interlock_error(recorder, n: int, m: int) -> tuple[float, int, int]:
    """(max |S2 - n/m S1| by the pins, S1's steps, S2's position)."""
    worst, _s1, s2 = ratio_error(recorder.pin_edges, S1, S2, n, m)
    return worst, len(steps(recorder, S1)), s2


def sim_run(line: str, max_s: float = 120):
    b = SimBackend("atmega328p", record=True)
    app = make_program("winder", b, scripted=True)
    t0 = time.perf_counter()
    app.run_script(line, max_ticks=int(max_s * TPS))
    return app, b, time.perf_counter() - t0


# ------------------------------------------------------------------------- 1
def pot_run() -> None:
    app, b, wall = sim_run("pots pot 1 1023 w2000 pot 1 512 w1000")
    s1 = [t for t, _ in steps(b.recorder, S1)]
    periods = [y - x for x, y in pairwise(s1)]
    fastest = min(periods)
    reach = s1[periods.index(fastest)] - s1[0]
    print("## 1. S1 pot run: pots pot 1 1023 w2000 pot 1 512 w1000")
    print(f"steps {len(s1)}, shortest period {fastest} ticks = {fastest / 16:.1f} us "
          f"= {TPS / fastest:.1f} steps/s (rule 20000 -> 12.5 counts -> 13 counts); "
          f"full speed {reach / TPS * 1000:.1f} ms after the first step; "
          f"stopped at {app.steppers[0].get_current_position()}, "
          f"running {app.steppers[0].is_running()}")


# ------------------------------------------------------------------------- 2
def sweep(values, csv_path: str | None) -> None:
    print("\n## 2. Pot sweep (S1, steady speed by the step pin)")
    print("| pot | rule steps/s | period counts | quantized steps/s | measured steps/s |")
    print("| --- | --- | --- | --- | --- |")
    rows = []
    for v in values:
        cmd = pot_command(v)
        if not cmd.active:
            rows.append((v, 0.0, 0, 0.0, 0.0))
            continue
        # long enough for the ramp and at least 6 steps at speed
        wait_ms = int(600 + 6000 * cmd.period_counts * 4 / 1000 / 1000 + 0.5) + 50
        b = SimBackend("atmega328p", record=True)
        app = make_program("winder", b, scripted=True)
        app.run_script(f"pots pot 1 {v} w{wait_ms}", max_ticks=int(wait_ms / 1000 * TPS) + TPS)
        s1 = [t for t, _ in steps(b.recorder, S1)]
        tail = [y - x for x, y in pairwise(s1)][-5:]
        measured = TPS / statistics.median(tail) if tail else 0.0
        rows.append((v, rule_speed(v), cmd.period_counts, cmd.steps_per_s, measured))
    shown = set(values[::16]) | {0, 461, 462, 562, 563, 1023}
    for v, rule, counts, quant, meas in rows:
        if v in shown:
            print(f"| {v} | {rule:.1f} | {counts} | {quant:.1f} | {meas:.1f} |")
    worst = max((abs(meas / quant - 1) for _v, _r, _c, quant, meas in rows if quant), default=0)
    print(f"{len(rows)} pot values; largest |measured/quantized - 1| = {worst:.2e}")
    if csv_path:
        with open(csv_path, "w", encoding="ascii") as f:
            f.write("pot,rule_steps_per_s,period_counts,quantized_steps_per_s,measured_steps_per_s\n")
            for row in rows:
                f.write("{},{:.3f},{},{:.3f},{:.3f}\n".format(*row))
        print(f"every value in {csv_path}")


# ------------------------------------------------------------------------- 3
def limit_sim() -> None:
    print("\n## 3. Limit switch: period 2 50 move 2 65535 w300 switch A3 1 w300")
    app, b, _ = sim_run("period 2 50 move 2 65535 w300 switch A3 1 w300")
    times, levels = b.recorder.pin_edges(A3_PIN)
    t_sw = [t for t, lv in zip(times, levels, strict=True) if lv == 0][-1]
    s2 = [t for t, _ in steps(b.recorder, S2)]
    after = sum(1 for t in s2 if t > t_sw)
    print(f"simulated chip: {after} steps after the switch; last step {(t_sw - s2[-1]) / 16:.1f} "
          f"us before it (period 200 us); stop at the switch tick: "
          f"{app.limit_stops[0][2] - app.limit_stops[0][1]} ticks")


def limit_device(faults: Faults | None, device_limits: bool, at_ms: float) -> tuple[int, float]:
    with Loopback("atmega328p", record=True, faults=faults) as lb:
        dev = lb.device
        if not device_limits:
            lb.backend.set_limit = lambda *a, **k: False  # the host stops S2 itself
        app = make_program("winder", lb.backend, scripted=True)
        t_sw = dev.machine.now + int(at_ms / 1000 * TPS)
        dev.schedule_input(t_sw, A3_PIN, 0)
        app.run_script("period 2 50 move 2 65535 w700", max_ticks=30 * TPS)
        lb.backend.settle()
        s2 = dev.recorder.rising(10)
        return sum(1 for t in s2 if t > t_sw), (s2[-1] - t_sw) / 16


def limits_on_device() -> None:
    print("device on the loopback, 115200 baud paced, switch at 300.0/301.3/302.7/310.1 ms:")
    for latency in (0.0, 1.0, 2.0):
        for device_limits in (True, False):
            res = [limit_device(Faults(latency_ms=latency, baud=115200, seed=1),
                                device_limits, at) for at in (300.0, 301.3, 302.7, 310.1)]
            who = "device stops S2 (Limit)" if device_limits else "host stops S2 (Input report)"
            print(f"  latency {latency:.0f} ms each way, {who}: steps after the switch "
                  f"{[r[0] for r in res]}, switch -> last step "
                  f"{', '.join(f'{r[1]:.0f}' for r in res)} us")


# ------------------------------------------------------------------------- 4
def interlock() -> None:
    print("\n## 4. Interlock: max |S2 - S1/3| by the pins at every step instant")
    for name, line in (("acceptance line", ACCEPT_INTERLOCK), ("long run", LONG_INTERLOCK)):
        app, b, wall = sim_run(line)
        err, n1, s2 = interlock_error(b.recorder, 1, 3)
        g = app.gear.stats
        print(f"simulation, {name}: {n1} S1 steps, S2 at {s2}: max error {err:.3f} steps "
              f"({g.commands} S2 commands, {g.pauses} pauses, {g.late} late; "
              f"{wall:.2f} s wall)")
    for name, schedule, wait in (
            ("acceptance line", [(0.3, 900), (1.1, 700), (1.9, 512)], 2600),
            ("long run", [(0.3, 1023), (2.3, 850), (3.8, 1023), (5.3, 950), (6.3, 1023),
                          (7.8, 200), (9.3, 512)], 10500)):
        with Loopback("atmega328p", record=True,
                      faults=Faults(latency_ms=1, baud=115200, seed=1)) as lb:
            dev = lb.device
            app = make_program("winder", lb.backend, scripted=True)
            base = dev.machine.now
            for t, v in schedule:
                dev.schedule_input(base + int(t * TPS), A0_PIN, v, analog=True)
            app.run_script(f"ratio 1:3 interlock 1 pots w{wait}", max_ticks=60 * TPS)
            lb.backend.settle()
            err, n1, s2 = interlock_error(dev.recorder, 1, 3)
            c = dev.counters
            print(f"device (1 ms latency, 115200 baud), {name}: {n1} S1 steps, S2 at {s2}: "
                  f"max error {err:.3f} steps; underruns {c['underruns']}, "
                  f"late starts {c['late_starts']}")


# ------------------------------------------------------------------------- 5
def traverse(plot: str | None) -> None:
    print("\n## 5. Traverse and the gear's cost")
    if plot:
        from stepperdemo.front.cli import main as cli_main
        cli_main(["winder", "-c", TRAVERSE, "--plot", plot, "--lf"])
        print(f"plot: stepperdemo winder -c \"{TRAVERSE}\" --plot {plot}")
    line_alone = LONG_INTERLOCK.replace("ratio 1:3 interlock 1 ", "")
    _, _, wall_alone = sim_run(line_alone)
    _, _, wall_gear = sim_run(LONG_INTERLOCK)
    print(f"wall time of the long run: S1 alone {wall_alone:.2f} s, with S2 interlocked "
          f"{wall_gear:.2f} s (shared machine: approximate)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sweep-step", type=int, default=1, help="pot values 0..1023 in steps of N")
    ap.add_argument("--sweep-csv", metavar="FILE", help="write every swept value as CSV")
    ap.add_argument("--plot", metavar="FILE.png", help="write the traverse plot")
    ap.add_argument("--skip-device", action="store_true", help="no loopback device runs")
    args = ap.parse_args()
    pot_run()
    values = list(range(0, 1024, args.sweep_step))
    if 1023 not in values:
        values.append(1023)
    sweep(values, args.sweep_csv)
    limit_sim()
    if not args.skip_device:
        limits_on_device()
    interlock()
    traverse(args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
