"""Serial link at 115200 baud: what it sustains versus what the ramp generator needs.

1. Needed: every scenario line runs on the simulated backend; each queue command the
   ramp generator writes is time-stamped.  The peak rate over 20 ms windows (the
   forward-planning time) is what the link must carry, in commands/s and - packed as
   the host packs them, one frame per 4 ms ramp task - in frames/s.
2. Sustained: the host streams the shortest legal commands (one step, MIN_CMD_TICKS)
   to a device through a relay that paces both directions to 115200 baud (10 bits a
   byte, 1 ms latency, 1 ms delivery bursts as a USB adapter).  The device empties
   them faster than they come, so the link is the limit: commands/s and frames/s.
3. The scenarios themselves through the same paced line: device queue underruns,
   late synchronized starts, retransmissions and the bytes/s actually used.

Margin = sustained / needed commands per second; the worst scenario decides.  Runs on
a virtual clock (deterministic; no wall time is measured).  Latency, faults and stops:
bench/bench_serial_link.py.

    python bench/bench_serial.py [--arch atmega328p] [--seconds 2]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from fas.arch import get_profile
from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.sim import SimBackend
from stepperdemo.demo.app import StepperDemo
from tests.fas.serial.helpers import LINES

BAUD = 115200
WINDOW_MS = 20
LINE = Faults(latency_ms=1.0, baud=BAUD, chunk_ms=1.0)


def needed(line: str, arch: str) -> tuple[int, int, int]:
    """(commands, peak commands/s, peak frames/s) of ``line`` on the simulated chip."""
    backend = SimBackend(arch)
    stamps: list[int] = []
    allocate = backend.allocate_channel

    def counting(queue):
        ch = allocate(queue)
        plain = ch.entry_added

        def entry_added():
            stamps.append(backend.now())
            plain()

        ch.entry_added = entry_added
        return ch

    backend.allocate_channel = counting
    app = StepperDemo(backend, scripted=True)
    app.run_script(line)
    p = backend.profile
    window = WINDOW_MS * p.ticks_per_ms
    per_window = Counter(t // window for t in stamps)
    tasks = {t // p.fill_period_ticks * p.fill_period_ticks for t in stamps}
    frames = Counter(t // window for t in tasks)
    scale = 1000 // WINDOW_MS
    return (len(stamps), max(per_window.values(), default=0) * scale,
            max(frames.values(), default=0) * scale)


def sustained(arch: str, seconds: float, steppers: int) -> tuple[float, float, int]:
    """(commands/s, frames/s, retransmissions) streaming minimal commands at BAUD
    into the queues of ``steppers`` steppers at once."""
    with Loopback(arch, faults=LINE) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        app.setup()
        used, dir_pins = [], set()  # steppers with a direction pin of their own
        for s in app.steppers:
            if s is not None and s.get_direction_pin() not in dir_pins:
                dir_pins.add(s.get_direction_pin())
                used.append(s)
        used = used[:steppers]
        for s in used:
            s.set_auto_enable(False)
        p = backend.profile
        ticks = max(p.min_cmd_ticks, used[0].get_max_speed_in_ticks())
        warm_end = backend.now() + p.ticks_per_s // 5
        t0 = f0 = e0 = None
        end = None
        sent = 0
        while end is None or backend.now() < end:
            added = 0
            for s in used:
                if not s.is_queue_full() and s.add_queue_entry(ticks, 1, True) == 0:
                    added += 1
            sent += added
            if added:
                continue
            backend.app_spend(p.ticks_per_s // 10000)
            if t0 is None and backend.now() >= warm_end:
                t0, f0, e0 = backend.now(), backend.link.stats.frames_sent, sent
                end = t0 + int(seconds * p.ticks_per_s)
        dt = (backend.now() - t0) / p.ticks_per_s
        frames = backend.link.stats.frames_sent - f0
        return (sent - e0) / dt, frames / dt, backend.link.stats.retransmissions


def through_line(line: str, arch: str) -> dict:
    with Loopback(arch, faults=LINE) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        t0 = backend.now()
        app.run_script(line)
        backend.settle()
        backend.request_status()
        dt = (backend.now() - t0) / backend.profile.ticks_per_s
        c = backend.device_counters()
        link = backend.link_stats()
        return {"underruns": c["underruns"], "late": c["late_starts"],
                "lost": c["entries_lost"], "dup": c["entries_duplicated"],
                "rtx": link["retransmissions"], "bytes_s": link["bytes_sent"] / dt,
                "pos": [s.get_current_position() for s in app.steppers if s is not None],
                "dev": [lb.device.position(i) for i in sorted(lb.device.queues)],
                "moves": [lb.device.pulses(i) for i in sorted(lb.device.queues)]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", default="atmega328p")
    ap.add_argument("--seconds", type=float, default=2.0,
                    help="virtual seconds of the saturation run (default 2)")
    args = ap.parse_args(argv)
    p = get_profile(args.arch)
    wire = BAUD // 10
    print(f"serial link at {BAUD} baud ({wire} bytes/s each way), profile {p.name}, "
          f"device queue {p.serial_queue_len}, {p.serial_rx_slots} frame slots")
    capacity = {}
    for n in range(1, min(p.max_steppers, 2) + 1):
        cmds, frames, rtx = sustained(args.arch, args.seconds, n)
        capacity[n] = cmds
        print(f"sustained with {n} queue(s) streaming: {cmds:6.0f} commands/s in "
              f"{frames:4.0f} frames/s, {rtx} retransmissions")
    print("(one queue is bound by its slots in flight; two fill the wire)")
    print()
    print(f"{'scenario':50s} {'cmds':>5s} {'need/s':>7s} {'frm/s':>6s} {'margin':>6s} "
          f"{'underr':>6s} {'late':>4s} {'rtx':>4s} {'B/s':>6s}  ok")
    worst = None
    total_underruns = 0
    for line in LINES:
        n, peak, peak_frames = needed(line, args.arch)
        res = through_line(line, args.arch)
        moving = max(1, sum(1 for pos in res["moves"] if pos))
        cap = capacity[min(moving, max(capacity))]
        margin = cap / peak if peak else float("inf")
        ok = res["pos"] == res["dev"] and res["lost"] == res["dup"] == 0
        if worst is None or margin < worst[0]:
            worst = (margin, line)
        total_underruns += res["underruns"]
        print(f"{line:50s} {n:5d} {peak:7d} {peak_frames:6d} {margin:6.2f} "
              f"{res['underruns']:6d} {res['late']:4d} {res['rtx']:4d} "
              f"{res['bytes_s']:6.0f}  {'yes' if ok else 'NO'}")
    print()
    print(f"worst-case margin {worst[0]:.2f} ({worst[1]}); "
          f"device queue underruns in all scenarios: {total_underruns}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
