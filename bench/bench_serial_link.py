"""Serial link under USB latency and line faults: smooth motion and prompt stops.

For every combination of adapter latency (0 / 1 / 16 ms delivery bursts, a USB
adapter's latency timer), faults (none / 0.1 % / 1 % of bytes corrupted, half as
many dropped and as many duplicated) and baud rate (115200 / 1 000 000, both
directions paced) the issue's two command lines run through a relay to a simulated
device:

* underruns and late starts on the device, frames retransmitted of frames sent, no
  command lost or repeated, positions equal to the simulation's;
* wall time (virtual) against the fault-free run at the same latency and baud;
* stop latencies on a 25 kHz move at cruise speed, command to effect on the device,
  the longest of three commands 5 ms apart: S - the first step of the deceleration
  (nan: the queue had run dry), X - the step timer stopped, E - the emergency stop's
  halt.  The simulated chip's S (its 20 ms queue) is the reference.

Then the issue's acceptance figures: the two runs through the relay as the issue
ran them, and a 50 ms host stall in the middle of a 25 kHz two-stepper move.  All on
a virtual clock: deterministic, no wall time measured, the machine's load does not
matter.

    python bench/bench_serial_link.py [--quick] [--seeds N]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.sim import SimBackend
from fas.sim.pins import EdgeRecorder
from stepperdemo.demo.app import StepperDemo

TPS = 16_000_000
MS_TICKS = TPS // 1000
LINES = ("M1 A100000 V40 R20000 M2 A100000 V40 R-20000 W M2 W",
         "M1 A1000 V100 R3200 W M2 A2000 V200 R-1000 W M1 A20000 V50 R-6000 W")
LATENCIES_MS = (0, 1, 16)
FAULTS = (0.0, 0.001, 0.01)
BAUDS = (115200, 1_000_000)
CRUISE_US = 40  # 25 kHz
CRUISE_TICKS = CRUISE_US * 16
STOP_AT_MS = 500
STOP_OFFSETS_MS = (0, 5, 10)
DEVICE: dict = {}  # device options (--queue-len, --rx-slots): what if the Uno had more


def faults(latency_ms: float, p: float, baud: int, seed: int = 1, **extra) -> Faults:
    return Faults(corrupt=p, drop=p / 2, dup=p / 2, chunk_ms=latency_ms, baud=baud,
                  seed=seed, **extra)


@dataclass
class Run:
    wall_s: float
    underruns: int
    late: int
    lost: int
    dup: int
    resent: int
    frames: int
    ok: bool


def run_line(line: str, f: Faults | None) -> Run:
    sim = StepperDemo(SimBackend("atmega328p"), scripted=True)
    sim.run_script(line, max_ticks=600 * TPS)
    with Loopback(faults=f, device_options=DEVICE) as lb:
        b = lb.backend
        app = StepperDemo(b, scripted=True)
        t0 = b.now()
        app.run_script(line, max_ticks=600 * TPS)
        wall = (b.now() - t0) / TPS
        b.settle()
        b.request_status()
        c = b.device_counters()
        link = b.link_stats()
        dev = lb.device
        pos = [s.get_current_position() for s in app.steppers]
        ok = (pos == [s.get_current_position() for s in sim.steppers]
              == [dev.position(i) for i in sorted(dev.queues)])
        return Run(wall, c["underruns"], c["late_starts"], c["entries_lost"],
                   c["entries_duplicated"], link["retransmissions"], link["frames_sent"], ok)


def _cruise(backend, offset_ms: int = 0):
    app = StepperDemo(backend, scripted=True)
    app.setup()
    s = app.steppers[0]
    s.set_speed_in_us(CRUISE_US)
    s.set_acceleration(100_000)
    s.move(1_000_000)
    backend.app_spend((STOP_AT_MS + offset_ms) * MS_TICKS)
    return app, s


def _decel_start(rising: list[int], t_call: int) -> float:
    """ms from ``t_call`` to the first step of the deceleration (a longer period)."""
    after = [t for t in rising if t >= t_call]
    for a, b in zip(after, after[1:], strict=False):
        if b - a > CRUISE_TICKS * 101 // 100:
            return (a - t_call) / MS_TICKS
    return float("nan")


def stop_latency(kind: str, f: Faults | None, offset_ms: int = 0) -> float:
    """ms from the command on the host to its effect on the device (device clock);
    S: NaN when the device queue ran dry in the run (no clean cruise to stop from)."""
    with Loopback(faults=f, record=kind == "S", device_options=DEVICE) as lb:
        b = lb.backend
        dev = lb.device
        _app, s = _cruise(b, offset_ms)
        t_call = dev.tick_at(lb.clock.now_ns())
        if kind == "S":
            s.stop_move()
        elif kind == "X":
            s.force_stop_and_new_position(0)
        else:
            b.emergency_stop()
        b.wait_until(lambda: not s.is_running())
        b.settle()
        if kind == "S":
            if dev.counters["underruns"]:  # not cruising, or ran dry while stopping
                return float("nan")
            return _decel_start(dev.recorder.rising(s.get_step_pin()), t_call)
        stop = dev.steppers.stop_ticks.get(0) if kind == "X" else dev.session.estop_tick
        return float("nan") if stop is None else (stop - t_call) / MS_TICKS


def worst_stop(kind: str, f: Faults | None) -> float:
    """The longest latency over commands given at 0, 5, 10 ms past a round time (the
    adapter's bursts make it depend on the moment)."""
    values = [stop_latency(kind, f, offset) for offset in STOP_OFFSETS_MS]
    return float("nan") if any(math.isnan(v) for v in values) else max(values)


def sim_stop_latency() -> float:
    """S on the simulated chip: the deceleration begins after its 20 ms queue."""
    b = SimBackend("atmega328p")
    rec = EdgeRecorder()
    b.machine.pins.sinks.append(rec)
    _app, s = _cruise(b)
    t_call = b.now()
    s.stop_move()
    b.wait_until(lambda: not s.is_running(), 10 * TPS)
    return _decel_start(rec.rising(s.get_step_pin()), t_call)


def host_stall(f: Faults | None, stall_ms: int = 50, at_ms: int = 700) -> tuple[int, int, bool]:
    """(underruns, late starts, positions right) with the host silent for ``stall_ms``
    in the middle of a 25 kHz two-stepper move."""
    with Loopback(faults=f, device_options=DEVICE) as lb:
        b = lb.backend
        app = StepperDemo(b, scripted=True)
        app.setup()
        moves = (20_000, -20_000)
        for s, d in zip(app.steppers, moves, strict=True):
            s.set_speed_in_us(CRUISE_US)
            s.set_acceleration(100_000)
            s.move(d)
        b.app_spend(at_ms * MS_TICKS)
        lb.clock.run_until(lb.clock.now_ns() + stall_ms * 1_000_000)  # the host is away
        b.wait_until(lambda: not any(s.is_running() for s in app.steppers))
        b.settle()
        b.request_status()
        c = b.device_counters()
        ok = [lb.device.position(i) for i in (0, 1)] == list(moves)
        return c["underruns"], c["late_starts"], ok


def table(quick: bool) -> None:
    lats = (0, 16) if quick else LATENCIES_MS
    bauds = (115200,) if quick else BAUDS
    print(f"{'latency':>7s} {'faults':>6s} {'baud':>7s} | {'underr':>6s} {'late':>4s} "
          f"{'resent/frames':>13s} {'lost':>4s} {'dup':>3s} {'wall':>6s} {'vs clean':>8s} | "
          f"{'S ms':>5s} {'X ms':>5s} {'E ms':>5s}  ok")
    for baud in bauds:
        for lat in lats:
            clean_wall = None
            for p in FAULTS:
                f = faults(lat, p, baud)
                runs = [run_line(line, f) for line in LINES]
                wall = sum(r.wall_s for r in runs)
                if p == 0.0:
                    clean_wall = wall
                stops = [worst_stop(k, f) for k in "SXE"]
                ok = all(r.ok for r in runs)
                print(f"{lat:5d}ms {100 * p:5.1f}% {baud:7d} | "
                      f"{sum(r.underruns for r in runs):6d} {sum(r.late for r in runs):4d} "
                      f"{sum(r.resent for r in runs):6d}/{sum(r.frames for r in runs):<6d} "
                      f"{sum(r.lost for r in runs):4d} {sum(r.dup for r in runs):3d} "
                      f"{wall:5.2f}s {100 * (wall / clean_wall - 1):+7.1f}% | "
                      f"{stops[0]:5.1f} {stops[1]:5.1f} {stops[2]:5.1f}  "
                      f"{'yes' if ok else 'NO'}", flush=True)
    print(f"simulated chip (queue of 20 ms): S {sim_stop_latency():.1f} ms")


def acceptance(seeds: int) -> None:
    usb = Faults(chunk_ms=16, baud=115200)
    r = run_line(LINES[0], usb)
    print(f"run 1 ({LINES[0]}; --chunk-ms 16 --baud 115200): {r.lost} lost, {r.dup} "
          f"duplicated, {r.underruns} underruns, {r.late} late starts, positions "
          f"{'right' if r.ok else 'WRONG'}, {r.wall_s:.2f} s")
    clean = run_line(LINES[1], Faults(latency_ms=2))
    print(f"run 2 fault-free (--latency-ms 2): {clean.wall_s:.2f} s, {clean.frames} frames")
    for seed in range(1, seeds + 1):
        noisy = Faults(corrupt=0.01, drop=0.005, dup=0.005, latency_ms=2, seed=seed)
        r = run_line(LINES[1], noisy)
        print(f"run 2 seed {seed} (1 % corrupted, 0.5 % dropped, 0.5 % duplicated, 2 ms): "
              f"{r.lost} lost, {r.dup} duplicated, {r.underruns} underruns, {r.late} late "
              f"starts, {r.resent} of {r.frames} frames resent, {r.wall_s:.2f} s = "
              f"{100 * (r.wall_s / clean.wall_s - 1):+.1f} % against fault-free, positions "
              f"{'right' if r.ok else 'WRONG'}")
    for name, f in (("direct pty", None),
                    ("115200 baud, 1 ms bursts", Faults(baud=115200, chunk_ms=1)),
                    ("115200 baud, 16 ms bursts", Faults(baud=115200, chunk_ms=16))):
        u, late, ok = host_stall(f)
        print(f"50 ms host stall, 25 kHz two-stepper move, {name}: {u} underruns, "
              f"{late} late starts, positions {'right' if ok else 'WRONG'}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="latency 0 and 16 ms, 115200 only")
    ap.add_argument("--seeds", type=int, default=3, help="seeds of the faulty run (3)")
    ap.add_argument("--no-table", action="store_true", help="only the acceptance figures")
    ap.add_argument("--queue-len", type=int, help="the device's ring (default: fas/arch.py)")
    ap.add_argument("--rx-slots", type=int, help="the device's frame slots (default: arch)")
    args = ap.parse_args(argv)
    if args.queue_len:
        DEVICE["queue_len"] = args.queue_len
    if args.rx_slots is not None:
        DEVICE["rx_slots"] = args.rx_slots
    if not args.no_table:
        table(args.quick)
        print()
    acceptance(args.seeds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
