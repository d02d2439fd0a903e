"""Write ``sequences/gcode/zigzag1000.gcode``: 1 000 lines a sender streams (issue 24).

    python tools/gcode_zigzag.py [OUT]

A raster of short G1 lines over X and Y with Z steps between the rows, the user
outputs switched on the way - synchronized (M62, M63, M67) and at once (M64, M68) -
a dwell and a G92 offset, ending away from the origin so that the final machine
position says whether a step was lost.  In steps (one step per unit, the default).
"""

from __future__ import annotations

import sys
from pathlib import Path

LINES = 1000
OUT = Path(__file__).resolve().parent.parent / "sequences" / "gcode" / "zigzag1000.gcode"


def program() -> list[str]:
    lines = ["; 1000 lines for G-code senders (tools/gcode_zigzag.py): a raster with outputs",
             "G21 G90 G94", "G0 X0 Y0 Z0", "F60000"]
    row = 0
    x = 0
    while len(lines) < LINES - 8:
        n = len(lines)
        if n == 100:
            lines.append("M62 P0                  ; Dout0 on after the motion before it")
        elif n == 300:
            lines.append("M67 E0 Q25              ; Aout0 25 % after the motion before it")
        elif n == 500:
            lines.append("M63 P0                  ; Dout0 off after the motion before it")
        elif n == 600:
            lines.append("G4 P0.05")
        elif n == 700:
            lines.append("M64 P1                  ; Dout1 on at once")
        elif n == 800:
            lines.append("M68 E0 Q12.5            ; Aout0 12.5 % at once")
        elif n % 40 == 39:
            row += 1
            lines.append(f"G0 Y{row * 40} Z{row % 3 * 20}")
        else:
            x = 400 - x if n % 2 else x + 7
            lines.append(f"G1 X{x}")
    lines += ["G0 X1234 Y567 Z89", "G92 X0 Y0 Z0           ; call it the origin",
              "G1 X10 Y10 F60000", "G92.1", "G91 G1 X-4 Y-7", "G90", "M2"]
    lines.insert(len(lines) - 1, "M65 P1                  ; Dout1 off at once")
    return lines


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    lines = program()
    assert len(lines) == LINES, len(lines)
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"{out}: {len(lines)} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
