"""G-code programs for the look-ahead tests (issue 25): what they send, and the path
they command in steps."""

from __future__ import annotations

import bisect
import math
from typing import Any

SPU = 80  # steps/mm
#: 80 steps/mm, 12 000 mm/min and 1 000 mm/s^2 per axis, junction deviation 0.01 mm
SETUP = [f"$10{i}={SPU}" for i in range(2)] + [f"$11{i}=12000" for i in range(2)] + [
    f"$12{i}=1000" for i in range(2)] + ["$11=0.01"]


def cam_program() -> tuple[str, list[tuple[int, int]]]:
    """A polygon of 90 chords (r = 6 mm, 0.42 mm each) at F3000 and three raster lines
    of 0.5 mm segments 0.1 mm apart at F6000: lines and the vertices in steps."""
    pts = [(6.0 * math.cos(2 * math.pi * k / 90), 6.0 * math.sin(2 * math.pi * k / 90))
           for k in range(91)]
    lines = ["G0 X6 Y0"] + [f"G1 X{x:.4f} Y{y:.4f} F3000" for x, y in pts[1:]]
    x, y = pts[-1]
    for row in range(3):
        y += 0.1
        lines.append(f"G1 X{x:.4f} Y{y:.4f} F6000")
        step = 0.5 if row % 2 == 0 else -0.5
        for _ in range(40):
            x += step
            lines.append(f"G1 X{x:.4f} Y{y:.4f}")
    verts = [(0, 0)]
    for ln in lines:
        words = dict((w[0], float(w[1:])) for w in ln.split()[1:])
        verts.append((round(words["X"] * SPU), round(words["Y"] * SPU)))
    return "\n".join(lines) + "\n", verts


def path_from_pins(g: Any, axes: int = 2) -> list[tuple[int, tuple[int, ...]]]:
    """(tick, position per axis) after every step, from the step and direction pins."""
    rec = g.backend.recorder
    events = []
    for i, s in enumerate(g.machine.steppers[:axes]):
        dir_ticks, dir_levels = rec.pin_edges(s.get_direction_pin())
        up_high = s.direction_pin_high_counts_up()
        for t in rec.rising(s.get_step_pin()):
            k = bisect.bisect_right(dir_ticks, t) - 1
            level = dir_levels[k] if k >= 0 else 0
            events.append((t, i, 1 if bool(level) == up_high else -1))
    events.sort()
    pos = [0] * axes
    out = []
    for t, i, d in events:
        pos[i] += d
        out.append((t, tuple(pos)))
    return out
