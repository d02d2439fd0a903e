"""Figures of issue 25's arcs: the radius error of G2/G3 measured from the pins.

    python bench/bench_arcs.py [--random 40] [--seed 1]

The Grbl controller on the simulated ATmega2560, 80 steps/mm, $110-$112 = 12 000
mm/min, $120-$122 = 500 mm/s^2, $12 = 0.002 mm unless a line says otherwise.  For each
arc, at every step of either axis (the position of both axes from the step and
direction pins just after the step - where two axes step on one tick, also between
them): the largest distance from the circle minus the radius, in mm and in steps
beyond $12 (the issue's target: $12 + 1 step); "inside" is the part before the pins
come within 1.5 steps of the last chord's start (each axis on the step nearest to the
path there), "last" the last block (each axis less than a step behind the path, to end
on the target on one tick; where the interpreter cuts the last chord - fas.path.arc's
arc_end_cut - the part after the cut), "end" the target's own distance from the circle in whole
steps, "forced" the farthest of the points the end rule forces: just before the end
tick every axis that makes its last step on it (each that moves in the last chord; the
end exact) stands a step before the target, and between the steps on that tick some
do - points set by the target and the directions the arc ends in, so where one lies
beyond $12 + 1 step no placement of the steps meets that bound.  Both executors:
look-ahead (the default) and the exact stop ($171=1, which stops on the chord ends
rounded to steps, moving along the chords themselves).

1. The four arcs of the tests (a half, a quarter, a full circle, a long R arc).
2. ``--random`` arcs (seeded): centre, sweep, direction, feed, $12 at random, their
   targets in whole micrometres (so neither on whole steps nor quite on the circle).
"""

from __future__ import annotations

import argparse
import math
import os
import random
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from fas.path.arc import Plane, arc_center_from_radius  # noqa: E402
from rigs.gcode import path_from_pins  # noqa: E402
from stepperdemo.gcode.interp import Interpreter, Move  # noqa: E402
from stepperdemo.gcode.parser import parse_line  # noqa: E402
from stepperdemo.gcode.program import RawGrbl  # noqa: E402

SPU = 80
SETUP = (f"$100={SPU}\n$101={SPU}\n$102={SPU}\n$110=12000\n$111=12000\n$112=12000\n"
         "$120=500\n$121=500\n$122=500\n")
ARCS = [  # (line, centre in mm) from X0 Y0
    ("G2 X20 Y0 I10 J0 F3000", (10.0, 0.0)),
    ("G3 X10 Y10 I10 J0 F3000", (10.0, 0.0)),
    ("G2 X0 Y0 I10 J5 F3000", (10.0, 5.0)),
    ("G3 X7.5 Y-2.5 R-5 F3000", None),
]


def pins_path(g: RawGrbl) -> list[tuple[int, ...]]:
    """(X, Y) in steps after every step of either axis, from the pins."""
    return [p for _t, p in path_from_pins(g)]


def run_arc(line: str, centre: tuple[float, float], tol: float, exact_stop: bool) -> dict:
    g = RawGrbl("atmega2560", record=True)
    g.send((SETUP + f"$12={tol}\n$171={1 if exact_stop else 0}\n").encode())
    g.settle()
    g.take()
    g.send((line + "\n").encode())
    assert g.settle(), line
    answer = g.take().decode().split("\r\n")[:-1]
    assert answer == ["ok"], (line, answer)
    moves = [a for a in Interpreter(3, g.machine.settings).interpret(parse_line(line))
             if isinstance(a, Move)]
    c = (centre[0] * SPU, centre[1] * SPU)
    r = math.hypot(*c)

    def off(p: tuple[float, ...]) -> float:
        return abs(math.dist(p[:2], c) - r)

    path = pins_path(g)
    start_last = moves[-2].exact if len(moves) > 1 else None
    k = len(path)
    if start_last is not None:
        k = next((i for i, p in enumerate(path) if math.dist(p, start_last[:2]) <= 1.5),
                 len(path))
    if exact_stop and len(moves) > 1:  # its chords end on the rounded points
        k = next((i for i, p in enumerate(path) if p == moves[-2].target[:2]), len(path))
    events = path_from_pins(g)
    end = events[-1][0]
    # the end rule's points: where the axes stand just before the end tick and between
    # the steps on it (the target less some of the last steps made on it)
    forced = [p for _t, p in events if _t < end][-1:] + [p for _t, p in events
                                                         if _t == end][:-1]
    return {"worst": max(map(off, path)), "inside": max(map(off, path[:k]), default=0.0),
            "last": max(map(off, path[k:]), default=0.0),
            "forced": max(map(off, forced), default=0.0),
            "end": off(moves[-1].target), "exact": g.machine.positions()[:2]
            == list(moves[-1].target[:2]), "tol": tol}


def show(label: str, res: dict) -> None:
    tol = res["tol"] * SPU
    print(f"  {label:44s} {res['worst'] / SPU * 1000:6.2f} um = $12 + "
          f"{res['worst'] - tol:5.2f} steps (inside {res['inside'] - tol:5.2f}, last "
          f"{res['last'] - tol:5.2f}, end {res['end']:4.2f}, forced {res['forced'] - tol:5.2f}); "
          f"end exact: {res['exact']}")


def random_arcs(n: int, seed: int) -> list[tuple[str, tuple[float, float], float]]:
    rnd = random.Random(seed)
    out = []
    for _ in range(n):
        r = rnd.choice([1.0, 3.0, 10.0, 40.0])
        a0 = rnd.uniform(0, 2 * math.pi)
        a1 = a0 + rnd.uniform(-2 * math.pi, 2 * math.pi)
        c = (round(-r * math.cos(a0), 4), round(-r * math.sin(a0), 4))
        tx, ty = round(c[0] + r * math.cos(a1), 3), round(c[1] + r * math.sin(a1), 3)
        line = (f"G{2 if a1 < a0 else 3} X{tx} Y{ty} I{c[0]} J{c[1]} "
                f"F{rnd.choice([600, 3000, 6000])}")
        out.append((line, c, rnd.choice([0.002, 0.01])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=40, help="random arcs")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    for exact_stop in (False, True):
        name = "exact stop ($171=1)" if exact_stop else "look-ahead"
        print(f"1. the tests' arcs, {name}:")
        for line, centre in ARCS:
            if centre is None:
                _e, centre = arc_center_from_radius((0.0, 0.0), (7.5, -2.5), -5.0,
                                                    Plane.XY, False)
            show(line, run_arc(line, centre, 0.002, exact_stop))
    if args.random:
        for exact_stop in (False, True):
            name = "exact stop ($171=1)" if exact_stop else "look-ahead"
            res = [run_arc(line, c, tol, exact_stop)
                   for line, c, tol in random_arcs(args.random, args.seed)]
            beyond = [x["worst"] - x["tol"] * SPU for x in res]
            inside = [x["inside"] - x["tol"] * SPU for x in res]
            last = [x["last"] - x["tol"] * SPU - x["end"] for x in res]
            print(f"2. {len(res)} random arcs (seed {args.seed}), {name}: beyond $12 "
                  f"worst {max(beyond):.2f} steps; inside the arc {max(inside):.2f}; "
                  f"last chord minus the target's own distance {max(last):.2f}; "
                  f"ends exact {sum(x['exact'] for x in res)}/{len(res)}")
            at_end = [b for b, x in zip(beyond, res, strict=True) if x["worst"] == x["forced"]]
            other = [b for b, x in zip(beyond, res, strict=True) if x["worst"] != x["forced"]]
            over = sum(x["forced"] - x["tol"] * SPU > 1 for x in res)
            print(f"   worst at a point the end rule forces in {len(at_end)} arcs (worst "
                  f"{max(at_end, default=0.0):.2f}; such a point beyond $12 + 1 in {over}); "
                  f"elsewhere in {len(other)} (worst {max(other, default=0.0):.2f})")


if __name__ == "__main__":
    main()
