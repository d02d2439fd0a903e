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
4. Issue 25, look-ahead (``--lookahead-only`` runs this section alone): a
   ``--segments`` program (default 10 000: circles of short chords and a laser raster,
   bench/bench_path.py's, 80 steps/mm, 1000 mm/s^2, 12 000 mm/min per axis, $11 =
   0.01 mm) as G-code lines through the G-code machine on the simulated chip, traced:
   real-time factor (CPU time, best of ``--repeat``; target >= 50), the planner alone
   (blocks/s, target >= 20 000), the job's duration with look-ahead against the
   exact-stop executor (``$171=1``; target <= half), from the pins: the largest
   Chebyshev distance of the axes from the commanded polyline at every step (target
   <= 1 step), each axis's top rate (positions interpolated between step edges, over
   2 ms) and acceleration against $110/$120 (the acceleration as a divided
   difference over three of the axis's step edges at least 20 ms - and 10 ms -
   apart, where the position is exact: :func:`rate_and_accel`), the feed across the
   raster's collinear joints (X over 16 steps around each joint, away from the line
   ends), and the planned speed at every junction that junction deviation limits
   against Grbl's formula ``v^2 = a_j d sin(theta/2) / (1 - sin(theta/2))`` computed
   here from the geometry.  The look-ahead's figures come once per corner mode:
   Grbl's junctions (``$172=0``, the default: the commanded polyline, each axis's
   velocity jumping at a corner) and corner blends (``$172=1``: every axis within
   its acceleration, the path up to $11 inside each corner - then also the distance
   from the path as run and the blends' figures from the geometry).
5. Issue 25, on a device (``--device-only``): the same program through ``--port`` on
   the Python device and on our firmware in simavr, at 115 200 and 1 000 000 baud, on
   the loopback's virtual clock: motion time, underruns, late starts, rejected
   commands, final position, the bytes the host sent on average and in the busiest
   second against the line's capacity - the link margin.
"""

from __future__ import annotations

import argparse
import bisect
import itertools
import math
import os
import sys
import tempfile
import time
import tracemalloc

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
sys.path.insert(1, os.path.join(ROOT, "bench"))  # bench_path's program

from fas.arch import PROFILES  # noqa: E402
from fas.path import executor as path_executor  # noqa: E402
from fas.sim import SimBackend  # noqa: E402
from rigs.path import (  # noqa: E402
    commanded_deviation,
    edge_accels,
    instants,
    path_as_run,
    timed_deviation,
)
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


# ------------------------------------------------------------ issue 25
LA_ARCH = "atmega328p"
ACC_WINDOW_MS = 20
#: what steps up to 1/8 step early (the path planner's grouping) can add to the divided
#: difference over step edges at least the window apart (rate_and_accel): 2 e / W^2,
#: steps/s^2 (the position at a step's tick is exact otherwise: no interpolation)
ACC_EARLY_STEPS = 0.125


def acc_resolution(window_ms: int) -> float:
    return 2 * ACC_EARLY_STEPS / (window_ms * 1e-3) ** 2


#: with blends: ``$173`` (``--plain-corners``), corners within this many steps of their
#: blend taken as Grbl's corner (docs/path-planner.md, "Corners no step can tell apart");
#: None: the machine's default
PLAIN_CORNERS: float | None = None
#: the corner modes section 4 runs (False: Grbl's junctions, True: blends)
LA_MODES: tuple[bool, ...] = (False, True)


def la_setup(motion: int, blends: bool = False) -> list[str]:
    import bench_path as bp

    plain = [f"$173={PLAIN_CORNERS:g}"] if blends and PLAIN_CORNERS is not None else []
    return ([f"$10{i}={bp.SPU}" for i in range(2)] + [f"$11{i}={bp.MAX_RATE}" for i in range(2)]
            + [f"$12{i}={bp.ACCEL}" for i in range(2)]
            + [f"$11={bp.JUNCTION}", f"$171={motion}", f"$172={int(blends)}"] + plain)


def la_program(backend, motion: int, blends: bool = False) -> tuple:
    """The two-axis G-code program on ``backend``, set up, and the list its machine's
    block queue appends every block to (targets in steps, feed) as it is pushed."""
    app = make_program("gcode", backend, scripted=True, output=lambda d: None, axes=2,
                       setup_lines=la_setup(motion, blends))
    app.setup()
    m = app.machine
    moves: list = []
    push = m.blocks.push

    def recording_push(block) -> None:
        moves.append(block)
        push(block)

    m.blocks.push = recording_push  # type: ignore[method-assign]
    return app, moves


def la_lines(segments: int) -> list[str]:
    import bench_path as bp

    return [f"G1 X{p[0]:.4f} Y{p[1]:.4f} F{f:g}" for p, f in bp.cam_program(segments)]


def la_run(lines: list[str], motion: int, record: bool, corners: bool = False,
           blends: bool = False) -> dict:
    """The program through the G-code machine (``blends``: ``$172=1``): motion time,
    CPU time, the blocks (targets in steps, feed) and, traced, the step and direction
    edges."""
    backend = SimBackend(LA_ARCH, record=record)
    app, moves = la_program(backend, motion, blends)
    m = app.machine
    #: id(move) -> (planned speed at its end units/s, the tick it ends)
    exits: dict[int, tuple[float, int]] = {}
    #: the corner blends executed: (corner in steps, its segment), in order
    blends: list = []
    mids: dict[int, int] = {}  # id(move) -> the middle of the blend at its end
    seen: set[int] = set()  # segments' seq (unique across runs)
    trim = path_executor.Executor.trim
    begin = path_executor.Executor.begin
    #: the corners taken plain ($173): (corner in steps, its tick), in order
    plain: list = []
    if corners:
        def recording_begin(ex, t0: float) -> None:
            ex.plain_log = plain
            begin(ex, t0)

        path_executor.Executor.begin = recording_begin  # type: ignore[method-assign]

        def recording_trim(ex, keep_from: int) -> None:
            for seg in ex.segments:
                if seg.seq >= keep_from or not seg.complete or seg.seq in seen:
                    continue
                seen.add(seg.seq)
                if seg.blend:
                    blends.append((seg.block.start, seg))
                    mids[id(seg.tag)] = int((seg.t_start + seg.t_done) / 2)
                elif seg.pieces:
                    last = seg.pieces[-1]
                    exits[id(seg.tag)] = ((last.v0 + last.a * (last.t1 - last.t0)) * ex.tps,
                                          seg.end_tick)
                else:  # all of it in the blends at its ends: at their speed
                    exits[id(seg.tag)] = (blends[-1][1].b.speed if blends else 0.0,
                                          seg.end_tick)
            trim(ex, keep_from)

        path_executor.Executor.trim = recording_trim  # type: ignore[method-assign]
    try:
        c0, w0 = time.process_time(), time.perf_counter()
        app.run_script("\n".join(lines) + "\n",
                       max_ticks=3600 * backend.profile.ticks_per_s)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    finally:
        path_executor.Executor.trim = trim  # type: ignore[method-assign]
        path_executor.Executor.begin = begin  # type: ignore[method-assign]
    tps = backend.profile.ticks_per_s
    build = demo_build(backend.profile)
    steps = [backend.recorder.rising(c.step) for c in build.steppers[:2]] if record else []
    end = max(st[-1] for st in steps) if steps else backend.now()
    start = m.motion_log[0][0]
    out = {"motion_s": (end - start) / tps, "cpu_s": cpu, "wall_s": wall, "moves": moves,
           "exits": exits, "blends": blends, "plain": plain, "mids": mids,
           "errors": m.errors,
           "executor": m.executor.kind,
           "positions": m.positions(), "backend": backend, "steppers": m.steppers}
    out["rtf"] = out["motion_s"] / cpu
    return out


def signed_steps(backend, stepper, cfg) -> list[tuple[int, int]]:
    """(tick, +1/-1) of every step of one axis, the direction from its pin's level."""
    rec = backend.recorder
    steps = rec.rising(cfg.step)
    times, levels = rec.pin_edges(cfg.direction)
    high_up = stepper.direction_pin_high_counts_up()
    out = []
    k = -1
    level = 0  # the level before any edge (the pin starts low)
    for t in steps:
        while k + 1 < len(times) and times[k + 1] <= t:
            k += 1
            level = levels[k]
        out.append((t, 1 if bool(level) == high_up else -1))
    return out


def chebyshev_to_segment(px: float, py: float, a: tuple, b: tuple) -> float:
    ax, ay = a[0] - px, a[1] - py
    dx, dy = b[0] - a[0], b[1] - a[1]
    cands = [0.0, 1.0]
    for num, den in ((ax, dx), (ay, dy), (ax - ay, dx - dy), (ax + ay, dx + dy)):
        if den:
            t = -num / den
            if 0.0 < t < 1.0:
                cands.append(t)
    return min(max(abs(ax + t * dx), abs(ay + t * dy)) for t in cands)


def path_deviation(events: list[tuple[int, int, int]], verts: list[tuple[int, int]],
                   ends: list[int]) -> float:
    """The largest Chebyshev distance (steps) of the axes' position, after every tick
    with steps, from the commanded polyline: from the block the planner had at that
    tick (``ends``: each block's end tick) or its neighbours."""
    x = y = 0
    k = 0
    worst = 0.0
    n = len(verts) - 1
    i = 0
    while i < len(events):
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            _, axis, d = events[i]
            if axis == 0:
                x += d
            else:
                y += d
            i += 1
        while k < n - 1 and ends[k] < t:
            k += 1
        best = min(chebyshev_to_segment(x, y, verts[j], verts[j + 1])
                   for j in range(max(0, k - 1), min(k + 2, n)))
        worst = max(worst, best)
    return worst


def interpolated(steps: list[tuple[int, int]], grid: list[int]) -> list[float]:
    """Position (steps, fractional between edges) at each tick of ``grid``."""
    out = []
    pos = 0
    k = 0
    n = len(steps)
    for g in grid:
        while k < n and steps[k][0] <= g:
            pos += steps[k][1]
            k += 1
        if 0 < k < n and steps[k][1] == steps[k - 1][1]:
            t0, t1 = steps[k - 1][0], steps[k][0]
            out.append(pos + steps[k][1] * (g - t0) / (t1 - t0))
        else:
            out.append(float(pos))
    return out


def rate_and_accel(steps: list[tuple[int, int]], tps: int, corners: list[int],
                   window_ms: int = ACC_WINDOW_MS) -> tuple[float, float, float]:
    """Top speed (steps/s, over 2 ms) and acceleration (steps/s^2) from one axis's
    signed step edges: everywhere, and away from the ``corners`` (ticks of junctions
    that turn, where Grbl's model changes each axis's speed at once by what junction
    deviation allows).

    The acceleration is a divided difference over three of the axis's own step
    edges, about the window apart: for every step b, a = the last step at least the
    window before it, c = the first at least the window after it, and
    ``2 ((x_c - x_b) / (t_c - t_b) - (x_b - x_a) / (t_b - t_a)) / (t_c - t_a)``.  At
    a step's tick the axis's position is exact (no interpolation between edges, no
    model of a reversal), and for a motion whose velocity is continuous this is a
    weighted mean of its acceleration (a non-negative kernel), so it never exceeds
    the largest |acceleration|; a velocity jump Dv between a and c adds up to
    2 Dv / (t_c - t_a).  Steps placed up to e = 1/8 step early (grouping) make it off
    by at most 2 e / W^2 (:func:`acc_resolution`)."""
    t0, t1 = steps[0][0], steps[-1][0]
    dt = tps // 1000  # 1 ms grid for the speed
    grid = list(range(t0 - 20 * dt, t1 + 20 * dt, dt))
    x = interpolated(steps, grid)
    top = max(abs(x[i + 1] - x[i - 1]) / (2e-3) for i in range(1, len(x) - 1))
    ticks = [t for t, _ in steps]
    xs = list(itertools.accumulate(d for _, d in steps))
    margin = 5 * dt
    acc = acc_away = 0.0
    for ta, _tb, tc, v in edge_accels(ticks, xs, tps, window_ms / 1000):
        if v > acc:
            acc = v
        k = bisect.bisect_left(corners, ta - margin)
        if k < len(corners) and corners[k] <= tc + margin:
            continue
        if v > acc_away:
            acc_away = v
    return top, acc, acc_away


def jd_speed(u: tuple[float, float], w: tuple[float, float], accel: float, d: float) -> float:
    """Grbl's junction-deviation speed (units/s) from direction ``u`` into ``w``."""
    cos_theta = -(u[0] * w[0] + u[1] * w[1])
    if cos_theta > 0.999999:
        return 0.0
    if cos_theta < -0.999999:
        return math.inf
    bx, by = w[0] - u[0], w[1] - u[1]
    norm = math.hypot(bx, by)
    a_j = min(accel / abs(c / norm) for c in (bx, by) if c)
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return math.sqrt(a_j * d * sin_half / (1.0 - sin_half))


def blend_figures(moves: list, exits: dict, spu: float, accel: float) -> dict:
    """The corner blend of docs/path-planner.md (executed) at every
    junction that turns, at the speed executed there: the velocity goes from ``v u``
    to ``v w`` at ``a_j`` along ``w - u`` (every axis within its limit by
    construction); its length along each block ``v^2 |w - u| / (2 a_j)``, how far
    inside the corner it passes ``v^2 |w - u|^2 / (8 a_j)`` (steps), whether it fits
    in half of both blocks, and where an axis turns round inside it."""
    worst = 0.0
    worst_jd = 0.0
    turning = too_long = too_long_jd = reversals = 0
    fit = 1.0  # the lowest share of its speed a junction keeps if its blend must fit
    for k in range(len(moves) - 1):
        a, b = moves[k], moves[k + 1]
        if id(a) not in exits:
            continue
        da = [(a.target[i] - a.start[i]) / spu for i in range(2)]
        db = [(b.target[i] - b.start[i]) / spu for i in range(2)]
        la, lb = math.hypot(*da), math.hypot(*db)
        u = (da[0] / la, da[1] / la)
        w = (db[0] / lb, db[1] / lb)
        diff = (w[0] - u[0], w[1] - u[1])
        n = math.hypot(*diff)
        if n < 2e-3:  # straight on (cos > 0.999998): no blend
            continue
        v = exits[id(a)][0]
        if v <= 0.0:
            continue  # a stop: nothing to blend
        turning += 1
        a_j = min(accel / abs(c / n) for c in diff if c)
        length = v * v * n / (2 * a_j)
        inside = v * v * n * n / (8 * a_j) * spu
        worst = max(worst, inside)
        limited = v < 0.99 * min(a.feed, b.feed) / 60
        if limited:
            worst_jd = max(worst_jd, inside)
        if length > la / 2 or length > lb / 2:
            too_long += 1
            too_long_jd += limited
            fit = min(fit, math.sqrt(a_j * min(la, lb) / n) / v)
        if any(u[i] * w[i] < 0 for i in range(2)):
            reversals += 1
    return {"turning": turning, "inside": worst, "inside_jd": worst_jd,
            "too_long": too_long, "too_long_jd": too_long_jd, "fit": fit,
            "reversals": reversals}


def lookahead_section(segments: int, repeat: int) -> None:
    """Section 4, once per corner mode: Grbl's junctions (``$172=0``, the default) and
    corner blends (``$172=1``)."""
    import bench_path as bp

    lines = la_lines(segments)
    print(f"look-ahead: {len(lines)} G-code lines (bench_path's program), {LA_ARCH}, "
          f"2 axes, 80 steps/mm, $11={bp.JUNCTION}")
    program = bp.steps_of(bp.cam_program(segments))
    p = min((bp.planner_alone(program) for _ in range(repeat)), key=lambda x: x["cpu_s"])
    print(f"  planner alone: {p['blocks_per_s']:.0f} blocks/s")
    t = la_run(lines, 1, record=False)
    print(f"  exact stop ($171=1): motion {t['motion_s']:.3f} s ({t['executor']})")
    for blends in LA_MODES:
        lookahead_mode(lines, repeat, blends, t["motion_s"])


def lookahead_mode(lines: list[str], repeat: int, blends: bool, exact_stop_s: float) -> None:
    import bench_path as bp

    plain = f", $173={PLAIN_CORNERS:g}" if PLAIN_CORNERS is not None else ""
    mode = f"blends ($172=1{plain})" if blends else "Grbl junctions ($172=0, default)"
    print(f" corners: {mode}")
    runs = [la_run(lines, 0, record=False, blends=blends) for _ in range(repeat)]
    r = min(runs, key=lambda x: x["cpu_s"])
    print(f"  motion {r['motion_s']:.3f} s in {r['cpu_s']:.2f} s CPU ({r['wall_s']:.2f} s wall): "
          f"{r['rtf']:.1f}x real time, {len(lines) / r['cpu_s']:.0f} lines/s "
          f"(executor {r['executor']}, errors {r['errors']}); "
          f"{r['motion_s'] / exact_stop_s:.1%} of exact stop's motion")
    traced = la_run(lines, 0, record=True, corners=True, blends=blends)
    backend = traced["backend"]
    tps = backend.profile.ticks_per_s
    build = demo_build(backend.profile)
    axes = [signed_steps(backend, traced["steppers"][i], build.steppers[i]) for i in range(2)]
    moves = traced["moves"]
    verts = [moves[0].start] + [mv.target for mv in moves]
    final = [sum(d for _, d in a) for a in axes]
    print(f"  traced: {traced['motion_s']:.3f} s, final position {final} (machine "
          f"{traced['positions']}, program {list(verts[-1])})")
    ins = instants([[(t, d) for t, d in a] for a in axes], tuple(verts[0]))
    slack = int(0.02 * tps)
    print(f"  largest distance from the commanded path: "
          f"{commanded_deviation(ins, verts, traced['blends'], slack, traced['plain']):.3f} steps "
          f"(Chebyshev, at every step; target <= 1)")
    if blends:
        run_path = path_as_run(verts, traced["blends"], ins, (bp.SPU, bp.SPU),
                               plain=traced["plain"])
        print(f"  largest distance from the path as run (the commanded path, its corners "
              f"blended: {len(traced['blends'])} blends): "
              f"{timed_deviation(ins, run_path, slack):.3f} steps (Chebyshev, at every step)")
    # a junction's tick: where the block ends, or the middle of the blend there
    mids, exits = traced["mids"], traced["exits"]
    # (the run's last block: its segment ends with the run, not trimmed - not needed)
    ends = [mids[id(mv)] if id(mv) in mids else exits[id(mv)][1] for mv in moves[:-1]]
    corners = []
    for k in range(len(moves) - 1):
        a, b = moves[k], moves[k + 1]
        ua = [a.target[i] - a.start[i] for i in range(2)]
        ub = [b.target[i] - b.start[i] for i in range(2)]
        cos = (ua[0] * ub[0] + ua[1] * ub[1]) / (math.hypot(*ua) * math.hypot(*ub))
        if cos < 0.999999:  # any change of direction
            corners.append(ends[k])
    corners.sort()
    for i, name in enumerate("XY"):
        for w in (ACC_WINDOW_MS, ACC_WINDOW_MS // 2):
            top, acc, away = rate_and_accel(axes[i], tps, corners, w)
            rate = (f"top rate {top / bp.SPU * 60:.0f} mm/min (limit {bp.MAX_RATE:.0f}); "
                    if w == ACC_WINDOW_MS else " " * 3)
            print(f"  {name}: {rate}acceleration over step edges >= {w} ms apart "
                  f"{away / bp.SPU:.1f} mm/s^2 away from the {len(corners)} junctions "
                  f"that turn, {acc / bp.SPU:.1f} with them (limit {bp.ACCEL:.0f}; "
                  f"resolution +{acc_resolution(w) / bp.SPU:.1f})")
    # the raster's collinear joints: X speed over 16 steps around each
    xs = [t for t, _ in axes[0]]
    ratios = []
    units = [(mv.target[0] - mv.start[0], mv.target[1] - mv.start[1]) for mv in moves]
    pos_x = 0
    counted = 0  # X steps made up to each block's end (|steps|, as edges come)
    run_len = 0
    for k, mv in enumerate(moves[:-1]):
        counted += abs(units[k][0])
        pos_x = mv.target[0]
        straight = units[k][1] == 0 and units[k + 1][1] == 0 and units[k][0] * units[k + 1][0] > 0
        run_len = run_len + 1 if straight else 0
        if not straight or mv.feed != bp.RASTER_FEED or run_len < 12:
            continue
        rest = 0  # blocks of the same line after this joint
        for j in range(k + 1, min(k + 13, len(moves) - 1)):
            if units[j][1] == 0 and units[j + 1][1] == 0:
                rest += 1
        if rest < 12 or counted + 8 >= len(xs):
            continue
        speed = 16 / ((xs[counted + 7] - xs[counted - 9]) / tps) / bp.SPU * 60
        ratios.append(speed / bp.RASTER_FEED)
    del pos_x
    if ratios:
        print(f"  feed across {len(ratios)} collinear raster joints: {min(ratios):.4f} .. "
              f"{max(ratios):.4f} of F{bp.RASTER_FEED:g} (from the X pin)")
    exits = traced["exits"]
    errs = []
    for k in range(len(moves) - 1):
        a, b = moves[k], moves[k + 1]
        ua = [(a.target[i] - a.start[i]) / bp.SPU for i in range(2)]
        ub = [(b.target[i] - b.start[i]) / bp.SPU for i in range(2)]
        la, lb = math.hypot(*ua), math.hypot(*ub)
        v = jd_speed((ua[0] / la, ua[1] / la), (ub[0] / lb, ub[1] / lb), bp.ACCEL,
                     bp.JUNCTION)
        if v < 0.99 * min(a.feed, b.feed) / 60 and id(a) in exits and v > 0:
            errs.append(exits[id(a)][0] / v - 1)
    if errs:
        print(f"  planned speed at {len(errs)} junctions limited by junction deviation: "
              f"{min(errs):+.4%} .. {max(errs):+.4%} of the formula")
    if not blends:
        return
    bl = blend_figures(moves, exits, bp.SPU, bp.ACCEL)
    print(f"  corner blends (docs/path-planner.md), from the geometry at the "
          f"{bl['turning']} junctions that turn, at the speeds executed: inside the "
          f"corner by {bl['inside']:.3f} steps at most ({bl['inside_jd']:.3f} where junction "
          f"deviation limits; $11 = {bp.JUNCTION * bp.SPU:.2f} steps), {bl['too_long']} "
          f"longer than half a block ({bl['too_long_jd']} of them where junction deviation "
          f"limits; fitting them keeps {bl['fit']:.1%} of the speed at least), "
          f"{bl['reversals']} with an axis turning round in it")


def device_run(lines: list[str], device: str, baud: int) -> dict:
    """The program through ``--port`` on a device (the Python device or the firmware in
    simavr) on the loopback's virtual clock: motion, the device's counters, the bytes
    the host sent - on average and in the busiest second - against the line's
    capacity (10 bits a byte)."""
    from fas.device.loopback import Loopback
    from rigs.pins import steps_by_pins

    kw = {"record": True} if device == "python" else {}
    with Loopback(device=device, baud=baud, **kw) as lb:
        b = lb.backend
        tps = b.profile.ticks_per_s
        app, moves = la_program(b, 0)
        m = app.machine
        ends: dict[int, int] = {}
        trim = path_executor.Executor.trim

        def recording_trim(ex, keep_from: int) -> None:
            for seg in ex.segments:
                if seg.seq < keep_from and seg.complete:
                    ends[id(seg.tag)] = seg.end_tick
            trim(ex, keep_from)

        path_executor.Executor.trim = recording_trim  # type: ignore[method-assign]
        wire = lb.device.in_wires[0]  # host to device
        samples: list[tuple[int, int]] = []
        poll = m.poll

        def sampling_poll() -> None:
            samples.append((b.now(), wire.sent))
            poll()

        m.poll = sampling_poll  # type: ignore[method-assign]
        w0 = time.perf_counter()
        try:
            app.run_script("\n".join(lines) + "\n", max_ticks=3600 * tps)
            settled = b.settle()
        finally:
            path_executor.Executor.trim = trim  # type: ignore[method-assign]
        wall = time.perf_counter() - w0
        start = m.motion_log[0][0]
        motion = (b.now() - start) / tps
        counters = b.device_counters()
        edges = lb.device.trace().edges if device == "simavr" else lb.device.recorder.pin_edges
        build = demo_build(b.profile)
        axes = [steps_by_pins(edges, c.step, c.direction, s.direction_pin_high_counts_up())
                for c, s in zip(build.steppers[:2], m.steppers, strict=True)]
        busiest = 0
        j = 0
        for i in range(len(samples)):  # bytes sent in any second of the run
            while samples[i][0] - samples[j][0] > tps:
                j += 1
            busiest = max(busiest, samples[i][1] - samples[j][1])
        verts = [moves[0].start] + [mv.target for mv in moves]
        events = sorted([(t, 0, d) for t, d in axes[0]] + [(t, 1, d) for t, d in axes[1]])
        deviation = path_deviation(events, verts, [ends[id(mv)] for mv in moves])
        return {"motion_s": motion, "wall_s": wall, "settled": settled,
                "deviation": deviation,
                "errors": m.errors, "positions": m.positions(),
                "program": list(m.interp.position_steps), "bytes": wire.sent,
                "busiest": busiest, "capacity": baud / 10, "counters": counters,
                "runs": len(m.motion_log), "underruns": m.executor.group.stats.underruns
                if m.executor.kind == "lookahead" else None}


def device_section(segments: int) -> None:
    lines = la_lines(segments)
    print(f"on a device through --port: {len(lines)} lines, the same program")
    for device in ("python", "simavr"):
        for baud in (115_200, 1_000_000):
            r = device_run(lines, device, baud)
            c = r["counters"]
            print(f"  {device:6s} {baud:>7d} baud: motion {r['motion_s']:.3f} s "
                  f"({r['wall_s']:.1f} s wall), runs {r['runs']}, host underruns "
                  f"{r['underruns']}, device underruns {c['underruns']}, late starts "
                  f"{c['late_starts']}, rejected {c['rejected']}, errors {r['errors']}, "
                  f"position {r['positions']} (program {r['program']}), largest distance "
                  f"from the path {r['deviation']:.3f} steps")
            avg = r["bytes"] / r["motion_s"]
            print(f"      host->device {r['bytes']} bytes: {avg:.0f} B/s on average, "
                  f"{r['busiest']} B in the busiest second, of {r['capacity']:.0f} B/s: "
                  f"link margin {r['capacity'] / r['busiest']:.2f}x "
                  f"({1 - r['busiest'] / r['capacity']:.0%} of the line free)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", default="10000,3000", help="the diagonal: X,Y steps")
    ap.add_argument("--pwm-seconds", type=float, default=10.0)
    ap.add_argument("--segments", type=int, default=10000, help="look-ahead program")
    ap.add_argument("--repeat", type=int, default=3, help="look-ahead runs; fastest counts")
    ap.add_argument("--lookahead-only", action="store_true",
                    help="only section 4 (issue 25's look-ahead figures)")
    ap.add_argument("--device-only", action="store_true",
                    help="only section 5 (the look-ahead program through --port)")
    ap.add_argument("--plain-corners", type=float, default=None, metavar="STEPS",
                    help="blend mode's $173: corners within STEPS of their blend taken as "
                         "Grbl's corner (default: the machine's)")
    ap.add_argument("--blends-only", action="store_true",
                    help="with --lookahead-only: only the corner-blend mode")
    args = ap.parse_args()
    global PLAIN_CORNERS
    PLAIN_CORNERS = args.plain_corners
    if args.blends_only:
        global LA_MODES
        LA_MODES = (True,)
    if args.lookahead_only:
        lookahead_section(args.segments, args.repeat)
        return
    if args.device_only:
        device_section(args.segments)
        return
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
    lookahead_section(args.segments, args.repeat)
    device_section(args.segments)


if __name__ == "__main__":
    main()
