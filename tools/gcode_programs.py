"""Write the generated G-code programs of ``sequences/gcode/`` (issue 25) and print the
figures their scenario files expect.

    python tools/gcode_programs.py [surface|raster]

* ``surface3d.gcode`` - a 3D surface finished with short straight segments, as CAM
  writes it: the height ``z = 1.5 sin(x / 4) cos(y / 5)`` mm over 20 x 12 mm, rows
  along X every 2 mm (back and forth), a point every 0.5 mm.
* ``laser_raster.gcode`` - a laser engraving a grey ramp: rows along X every 0.5 mm,
  each row eight 2.5 mm cells of S100 .. S800 in M4 (dynamic power), G0 back between rows.

The figures are the program's own: the pulses of an axis are the sum of the whole-step
differences between its consecutive targets, each target rounded to the nearest step
(80 steps/mm) as Grbl's planner rounds it.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

SPU = 80
HERE = Path(__file__).resolve().parent.parent / "sequences" / "gcode"
SETUP = ["$100=80", "$101=80", "$102=80", "$110=6000", "$111=6000", "$112=6000",
         "$120=2000", "$121=2000", "$122=2000"]


def steps(v: float) -> int:
    return math.floor(v * SPU + 0.5)


def surface() -> tuple[list[str], list[tuple[float, float, float]]]:
    lines = ["; A 3D surface of short segments (tools/gcode_programs.py, surface3d.toml):",
             "; z = 1.5 sin(x/4) cos(y/5) mm, rows along X every 2 mm, a point every 0.5 mm",
             *SETUP, "G90 G21 G17 G94 G54", "M3 S10000", "G0 Z3", "G0 X0 Y0"]
    points = [(0.0, 0.0, 0.0), (0.0, 0.0, 3.0)]
    first = True
    for row in range(7):
        y = 2.0 * row
        xs = [0.5 * k for k in range(41)]
        if row % 2:
            xs.reverse()
        for x in xs:
            z = round(1.5 * math.sin(x / 4) * math.cos(y / 5), 3)
            if first:
                lines.append(f"G1 Z{z:.3f} F600")
                lines.append("F3000")
                first = False
                points.append((x, y, z))
            if (x, y, z) != points[-1]:
                lines.append(f"G1 X{x:g} Y{y:g} Z{z:.3f}")
            points.append((x, y, z))
    lines += ["G0 Z3", "M5", "G0 X0 Y0", "M2"]
    points += [(points[-1][0], points[-1][1], 3.0), (0.0, 0.0, 3.0)]
    return lines, points


def raster() -> tuple[list[str], list[tuple[float, float, float]]]:
    lines = ["; A laser raster in M4 (tools/gcode_programs.py, laser_raster.toml): eight",
             "; cells of rising power per row, rows every 0.5 mm, G0 back between rows",
             *SETUP[:2], *SETUP[3:5], *SETUP[6:8],
             "$30=1000               ; S1000 = full power", "$32=1                  ; laser mode",
             "$141=1000              ; the laser's PWM (Aout1) at 1 kHz",
             "G90 G21 G17 G94 G54", "G0 X0 Y0", "M4 S0", "G1 F3000"]
    points = [(0.0, 0.0, 0.0)]
    for row in range(8):
        y = 0.5 * row
        if row:
            lines.append(f"G0 X0 Y{y:g}")
            points.append((0.0, y, 0.0))
        for cell in range(8):
            x = 2.5 * (cell + 1)
            lines.append(f"G1 X{x:g} S{100 * (cell + 1)}")
            points.append((x, y, 0.0))
    lines += ["M5", "G0 X0 Y0", "M2"]
    points.append((0.0, 0.0, 0.0))
    return lines, points


def figures(points: list[tuple[float, float, float]]) -> str:
    out = []
    for axis in range(3):
        s = [steps(p[axis]) for p in points]
        pulses = sum(abs(b - a) for a, b in zip(s, s[1:], strict=False))
        out.append(f"{'ABC'[axis]}: position {s[-1]}, pulses {pulses}")
    return "; ".join(out)


def main(argv: list[str]) -> int:
    which = argv[1:] or ["surface", "raster"]
    for name in which:
        lines, points = {"surface": surface, "raster": raster}[name]()
        path = HERE / {"surface": "surface3d.gcode", "raster": "laser_raster.gcode"}[name]
        path.write_text("\n".join(lines) + "\n")
        print(f"{path.name}: {len(lines)} lines; {figures(points)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
