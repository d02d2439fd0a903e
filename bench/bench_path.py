"""Figures of issue 25 (part 1): the look-ahead path planner on the simulated chip.

    python bench/bench_path.py [--arch atmega328p] [--segments 10000] [--repeat 3]
                               [--skip-today]

The program is CAM-like: circles of short segments (arcs of radius 4..20 mm cut into
segments within the arc tolerance, 0.002 mm: 0.25 .. 0.57 mm each) and a laser raster
(lines of 0.5 mm segments, 0.1 mm apart, back and forth), 80 steps/mm, 2 axes, feed
3000 mm/min on the circles and 6000 mm/min on the raster, 1000 mm/s^2 and
12000 mm/min per axis, junction deviation 0.01 mm.

1. Planned and executed by a path group on the simulated chip: the simulated motion
   time, the CPU time of the run (``time.process_time``; the machine is shared, so
   the best of ``--repeat`` runs, and the wall time beside it) and their ratio, the
   real-time factor (target >= 50); blocks per CPU second; per axis commands, pauses
   and steps placed off their tick.
2. The planner alone (junction speeds and both passes, each block taken as soon as it
   is queued, as the executor would when the queue is full): blocks per second
   (target >= 20 000).
3. The same program stopping at every block: the same planner with junction deviation
   0 (every junction from rest), and today's G-code machine (``stepperdemo gcode``,
   every move from rest to rest); the look-ahead time against both (target: at most
   half of today's).
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from fas import Engine  # noqa: E402
from fas.path import AxisLimits, PathGroup, PathResult, PathSettings, Plane  # noqa: E402
from fas.path.arc import arc_points  # noqa: E402
from fas.path.lookahead import Lookahead  # noqa: E402
from fas.sim import SimBackend  # noqa: E402

SPU = 80.0  # steps/mm
MAX_RATE = 12000.0  # mm/min per axis
ACCEL = 1000.0  # mm/s^2 per axis
JUNCTION = 0.01  # mm
ARC_TOL = 0.002  # mm
CIRCLE_FEED = 3000.0
RASTER_FEED = 6000.0


def cam_program(segments: int) -> list[tuple[tuple[float, float], float]]:
    """(target mm, feed mm/min) of ``segments`` moves: circles, then a raster."""
    moves: list[tuple[tuple[float, float], float]] = []
    pos = (0.0, 0.0)
    half = segments // 2
    radius = 4.0
    while len(moves) < half:  # circles around (radius, 0), growing
        for p in arc_points(pos, pos, (radius, 0.0), Plane.XY, len(moves) % 2 == 0, ARC_TOL):
            moves.append(((p[0], p[1]), CIRCLE_FEED))
        radius = 4.0 + (radius + 2.0) % 16.0
    moves = moves[:half]
    pos = moves[-1][0]
    y = pos[1] + 2.0
    x0 = pos[0]
    direction = 1
    while len(moves) < segments:  # raster lines of 0.5 mm "pixels", 0.1 mm apart
        moves.append(((pos[0], y), RASTER_FEED))
        for k in range(1, 81):
            moves.append(((x0 + direction * 0.5 * k, y), RASTER_FEED))
        pos = moves[-1][0]
        x0 = pos[0]
        direction = -direction
        y += 0.1
    return moves[:segments]


def steps_of(moves: list[tuple[tuple[float, float], float]]) -> list[tuple[tuple[int, int], float]]:
    return [((round(p[0] * SPU), round(p[1] * SPU)), f) for p, f in moves]


def make_group(arch: str, junction: float, record: bool = False
               ) -> tuple[SimBackend, PathGroup]:
    backend = SimBackend(arch, record=record)
    engine = Engine(backend)
    engine.init()
    p = backend.profile
    groups = p.step_pin_groups
    pins = [g[0] for g in groups[:2]] if len(groups) >= 2 else list(groups[0][:2])
    taken = {pin for g in groups for pin in g}
    dirs = [pin for pin in range(20, 200) if pin not in taken][:2]
    steppers = []
    for sp, dp in zip(pins, dirs, strict=True):
        s = engine.stepper_connect_to_pin(sp)
        assert s is not None
        s.set_direction_pin(dp)
        steppers.append(s)
    limits = AxisLimits(SPU, MAX_RATE, ACCEL)
    group = PathGroup(steppers, PathSettings(axes=(limits, limits),
                                             junction_deviation=junction,
                                             arc_tolerance=ARC_TOL))
    assert group.attach() == PathResult.OK
    return backend, group


def execute(arch: str, program: list[tuple[tuple[int, int], float]], junction: float
            ) -> dict[str, float]:
    """Run the program through a path group; motion time and wall time."""
    backend, group = make_group(arch, junction)
    tps = backend.profile.ticks_per_s
    t0 = time.perf_counter()
    c0 = time.process_time()
    sent = 0
    start_tick = None
    while sent < len(program):
        target, feed = program[sent]
        res = group.line(target, feed)
        if res == PathResult.QUEUE_FULL:
            backend.wait_until(lambda: group.room() > 0, 3600 * tps)
            continue
        if start_tick is None:
            start_tick = backend.now()
        sent += 1
    group.flush()
    backend.wait_until(group.is_idle, 3600 * tps)
    cpu = time.process_time() - c0
    wall = time.perf_counter() - t0
    motion = (backend.now() - (start_tick or 0)) / tps
    stats = group.axis_stats()
    return {"motion_s": motion, "wall_s": wall, "cpu_s": cpu, "rtf": motion / cpu,
            "blocks_per_s": len(program) / cpu, "runs": group.stats.runs,
            "underruns": group.stats.underruns,
            "commands": sum(s.commands for s in stats), "pauses": sum(s.pauses for s in stats),
            "shifted": sum(s.shifted for s in stats),
            "shift_max": max(s.shift_max for s in stats)}


def planner_alone(program: list[tuple[tuple[int, int], float]]) -> dict[str, float]:
    """Junction speeds and both passes for every block: queued, then the first taken
    when the queue is full (the executor's part is left out)."""
    limits = AxisLimits(SPU, MAX_RATE, ACCEL)
    la = Lookahead((limits, limits), JUNCTION, 32)
    pos = (0, 0)
    t0 = time.process_time()
    for target, feed in program:
        delta = (target[0] - pos[0], target[1] - pos[1])
        block = la.make_block(pos, delta, feed, None)
        if block is None:
            continue
        if la.full():
            la.pop_first()
        la.add(block)
        pos = target
    cpu = time.process_time() - t0
    return {"blocks_per_s": len(program) / cpu, "cpu_s": cpu,
            "pass_steps_per_block": la.pass_steps / len(program)}


def today(arch: str, program: list[tuple[tuple[int, int], float]]) -> dict[str, float]:
    """The program on the G-code machine's exact-stop executor (``$171=1``): every move
    from rest to rest."""
    from stepperdemo.program import make_program

    backend = SimBackend(arch)
    setup = [f"$10{i}={SPU}" for i in range(2)] + [f"$11{i}={MAX_RATE}" for i in range(2)] \
        + [f"$12{i}={ACCEL}" for i in range(2)] + ["$171=1"]
    app = make_program("gcode", backend, scripted=True, output=lambda d: None, axes=2,
                       setup_lines=setup)
    lines = [f"G1 X{t[0] / SPU:.4f} Y{t[1] / SPU:.4f} F{f:g}" for t, f in program]
    t0 = time.perf_counter()
    app.run_script("\n".join(lines) + "\n", max_ticks=3600 * backend.profile.ticks_per_s)
    wall = time.perf_counter() - t0
    log = app.machine.motion_log
    tps = backend.profile.ticks_per_s
    return {"motion_s": (backend.now() - log[0][0]) / tps, "wall_s": wall,
            "moves": app.machine.lines, "executor": app.machine.executor.kind}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", default="atmega328p")
    ap.add_argument("--segments", type=int, default=10000)
    ap.add_argument("--repeat", type=int, default=3, help="runs; the fastest counts")
    ap.add_argument("--skip-today", action="store_true",
                    help="leave out today's G-code machine (it takes a while)")
    args = ap.parse_args()
    moves = cam_program(args.segments)
    program = steps_of(moves)
    ends = [(0.0, 0.0)] + [m[0] for m in moves]
    length = sum(math.dist(a, b) for a, b in itertools.pairwise(ends))
    print(f"program: {len(program)} segments, {length:.1f} mm, on {args.arch}")
    r = min((execute(args.arch, program, JUNCTION) for _ in range(args.repeat)),
            key=lambda x: x["cpu_s"])
    print(f"1. look-ahead (junction deviation {JUNCTION} mm): {r['motion_s']:.3f} s of motion "
          f"in {r['cpu_s']:.2f} s CPU ({r['wall_s']:.2f} s wall) - real-time factor "
          f"{r['rtf']:.1f}x, {r['blocks_per_s']:.0f} blocks/s; runs {r['runs']}, underruns "
          f"{r['underruns']}, commands {r['commands']}, pauses {r['pauses']}, steps off "
          f"their tick {r['shifted']} (at most {r['shift_max']} ticks)")
    p = min((planner_alone(program) for _ in range(args.repeat)), key=lambda x: x["cpu_s"])
    print(f"2. planner alone: {p['blocks_per_s']:.0f} blocks/s ({p['cpu_s']:.3f} s CPU; "
          f"{p['pass_steps_per_block']:.1f} blocks visited per block queued)")
    s = execute(args.arch, program, 0.0)
    print(f"3. stop at every block, same planner (junction deviation 0): "
          f"{s['motion_s']:.3f} s of motion ({s['cpu_s']:.2f} s CPU); look-ahead takes "
          f"{r['motion_s'] / s['motion_s']:.1%} of it")
    if not args.skip_today:
        t = today(args.arch, program)
        print(f"   the G-code machine's exact stop ($171=1, {t['executor']}): "
              f"{t['motion_s']:.3f} s of motion ({t['wall_s']:.1f} s wall, {t['moves']} "
              f"lines); look-ahead takes "
              f"{r['motion_s'] / t['motion_s']:.1%} of it")


if __name__ == "__main__":
    main()
