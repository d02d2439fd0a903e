"""The corner blend's cost, planned (issue 25; docs/path-planner.md, "Corners:
blends"): bench_path's 10 000-segment program through the look-ahead planner, each
block's time from its planned entry and exit, today and with every corner blended.

    python bench/bench_blend.py [--segments 10000] [--share 0.25 0.5]

Today: a block is a ramp over its whole length between its junction speeds.  Blended
(:mod:`fas.path.blend`): a block is the second half of the blend at its start, a ramp,
the first half of the blend at its end; a blend at junction speed ``v`` takes
``k v^2`` of each block (``k = |w - u| / (2 a_j)``) at the speed ``v``.  The planner
keeps Grbl's passes over a shorter length: the newest block keeps ``share`` of its
length free at its end until the next block is known, then the blend's reserve
``k m`` (``m`` the junction's largest speed squared, capped so that its blend takes at
most ``share`` of either block) - a length that only grows once the next block is
known, so what is final stays final.  The execution is emulated as bench_path's
planner-alone run does (a block taken when the queue is full, its exit the next
block's entry then); the blocks' times are summed.  The emulation of today's
execution is checked against the executed motion time (bench_path / bench_gcode:
74.53 s).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence

ROOT = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(ROOT))

import bench_path as bp  # noqa: E402

from fas.path import AxisLimits  # noqa: E402
from fas.path.blend import corner_blend, fit_sqr  # noqa: E402
from fas.path.executor import phase_ticks, trapezoid  # noqa: E402
from fas.path.lookahead import Block, Lookahead  # noqa: E402


class ReserveLookahead(Lookahead):
    """Grbl's passes over each block's length less its blends' reserves."""

    def __init__(self, axes: Sequence[AxisLimits], junction_deviation: float, size: int,
                 share: float) -> None:
        super().__init__(axes, junction_deviation, size)
        self.share = share
        self.cap = math.inf
        self.res_in: dict[int, float] = {}
        self.res_out: dict[int, float] = {}
        self.zone_in: dict[int, float] = {}  # k of the blend at its start
        self.zone_out: dict[int, float] = {}
        self.capped = 0  # junctions whose speed the fit lowered

    def junction_sqr(self, a: Sequence[float], b: Sequence[float]) -> float:
        return min(super().junction_sqr(a, b), self.cap)

    def add(self, block: Block) -> None:
        prev = self.blocks[-1] if self.blocks and self.prev_unit is not None else None
        k = m = 0.0
        self.cap = math.inf
        if prev is not None:
            jd = min(super().junction_sqr(prev.unit, block.unit),
                     prev.nominal_speed ** 2, block.nominal_speed ** 2)
            fit = fit_sqr(prev.unit, block.unit, self.accel, prev.length, block.length,
                          self.share)
            m = min(jd, fit)
            if fit < jd:
                self.capped += 1
            self.cap = m
            blend = corner_blend(prev.unit, block.unit, 1.0, self.accel)
            k = blend.zone if blend is not None else 0.0
            self.res_out[id(prev)] = k * m  # shorter than the share kept free
            self.zone_out[id(prev)] = k
            prev.remaining = prev.length - self.res_in[id(prev)] - k * m
        self.res_in[id(block)] = k * m
        self.zone_in[id(block)] = k
        self.zone_out[id(block)] = 0.0
        self.res_out[id(block)] = self.share * block.length
        block.remaining = block.length - k * m - self.share * block.length
        super().add(block)


def block_time(entry_sqr: float, exit_sqr: float, block: Block, k_in: float,
               k_out: float) -> tuple[float, bool]:
    """(seconds, whether the ramp reaches the exit) of a block between its junction
    speeds, its blends taking ``k v^2`` of it at their speed."""
    v0, v1 = math.sqrt(entry_sqr), math.sqrt(exit_sqr)
    dist = block.length - k_in * entry_sqr - k_out * exit_sqr
    zones = k_in * v0 + k_out * v1  # reach / v on each side
    a = block.acceleration
    ok = dist >= -1e-12 and abs(entry_sqr - exit_sqr) <= 2 * a * max(dist, 0.0) * (1 + 1e-9)
    t = zones
    for v, acc, d in trapezoid(v0, block.nominal_speed, v1, a, max(dist, 0.0)):
        t += phase_ticks(v, acc, d)[0]
    return t, ok


def emulate(program: list[tuple[tuple[int, int], float]], share: float | None) -> dict:
    limits = AxisLimits(bp.SPU, bp.MAX_RATE, bp.ACCEL)
    if share is None:
        la: Lookahead = Lookahead((limits, limits), bp.JUNCTION, 32)
    else:
        la = ReserveLookahead((limits, limits), bp.JUNCTION, 32, share)
    total = 0.0
    bad = 0
    handed = 0.0  # the exit the block before was executed to: this block's entry
    sharp = turning = 0
    inside = 0.0

    def take() -> None:
        nonlocal total, bad, handed, sharp, turning, inside
        block = la.blocks[0]
        exit_sqr = la.blocks[1].entry_sqr if len(la.blocks) > 1 else 0.0
        k_in = k_out = 0.0
        if isinstance(la, ReserveLookahead):
            k_in, k_out = la.zone_in[id(block)], la.zone_out[id(block)]
            if k_out and exit_sqr > 0:
                turning += 1
                sharp += 2 * block.acceleration * k_out > 1
                nxt = la.blocks[1]
                b = corner_blend(block.unit, nxt.unit, math.sqrt(exit_sqr), la.accel)
                if b is not None:
                    inside = max(inside, b.inside)
        t, ok = block_time(handed, exit_sqr, block, k_in, k_out)
        total += t
        bad += not ok
        handed = exit_sqr
        la.pop_first()
        if la.blocks:
            la.blocks[0].entry_sqr = exit_sqr

    pos = (0, 0)
    for target, feed in program:
        delta = (target[0] - pos[0], target[1] - pos[1])
        block = la.make_block(pos, delta, feed, None)
        if block is None:
            continue
        if la.full():
            take()
        la.add(block)
        pos = target
    while la.blocks:
        take()
    out = {"time_s": total, "infeasible": bad, "turning": turning, "sharp": sharp,
           "inside_steps": inside * bp.SPU}
    if isinstance(la, ReserveLookahead):
        out["capped"] = la.capped
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", type=int, default=10000)
    ap.add_argument("--share", type=float, nargs="+", default=[0.25, 0.5])
    args = ap.parse_args()
    program = bp.steps_of(bp.cam_program(args.segments))
    today = emulate(program, None)
    print(f"bench_path's program, {args.segments} segments, $11={bp.JUNCTION}, "
          f"{bp.ACCEL:g} mm/s^2, 80 steps/mm; block times from the planned speeds")
    print(f"  today (velocity jumps at corners): {today['time_s']:.3f} s "
          f"(ramps not reaching their exit: {today['infeasible']})")
    for share in args.share:
        r = emulate(program, share)
        print(f"  blended, share {share:g}: {r['time_s']:.3f} s "
              f"({100 * (r['time_s'] / today['time_s'] - 1):+.2f} %), "
              f"{r['turning']} blends, {r['capped']} junction limits lowered by the fit, "
              f"{r['sharp']} where 2 a k > 1, inside the corner by "
              f"{r['inside_steps']:.3f} steps at most, ramps not reaching their exit: "
              f"{r['infeasible']}")


if __name__ == "__main__":
    main()
