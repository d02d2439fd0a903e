"""bench/loop_cli.py: the loop's own critical sections, its passes and the holds they make,
on a small replica run written here (cli/sei of the main program, interrupts, edges)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import loop_cli  # noqa: E402

# three passes of 260 ticks of loop CPU: the queue read (site 4b62, 10 ticks) at the
# start, millis() (5270, 9 ticks) 148 later; the second pass is interrupted by a step
# interrupt of 116 ticks (+ its 4-tick entry), so its wall time is 380
EV = """\
1000 C 4b62
1010 S 4b62
1148 C 5270
1157 S 5270
1260 C 4b62
1270 S 4b62
1300 V 11
1416 R
1528 C 5270
1537 S 5270
1640 C 4b62
1650 S 4b62
1788 C 5270
1797 S 5270
1900 C 4b62
1910 S 4b62
"""
# a plain pulse; one rising 3 ticks before the queue read's sei: 60 plain + 3 + the
# instruction after the sei (1); one rising 5 ticks before millis()'s end: + 5 + 2; a
# plain one
PINS = """\
995 B1 1
1055 B1 0
1267 B1 1
1331 B1 0
1792 B1 1
1859 B1 0
1950 B1 1
2010 B1 0
"""


def _write(folder: Path) -> None:
    (folder / "c.ev").write_text(EV)
    (folder / "c.pins").write_text(PINS)


def test_sections_in_the_loop_cpu_time(tmp_path: Path) -> None:
    _write(tmp_path)
    sections, isrs = loop_cli.read_ev(tmp_path / "c.ev")
    assert isrs == [(1300, 1416)]
    # (wall tick, loop CPU tick, site, ticks): the interrupt's 116 + 4 taken out after it
    assert sections[:4] == [(1000, 1000, "4b62", 10), (1148, 1148, "5270", 9),
                            (1260, 1260, "4b62", 10), (1528, 1408, "5270", 9)]
    assert sections[4][1] - sections[2][1] == 260


def test_the_tool_reports_sites_passes_and_holds(tmp_path: Path) -> None:
    # what users run: the script on a replica folder
    _write(tmp_path)
    out = subprocess.run([sys.executable, "bench/loop_cli.py", "--replica", str(tmp_path), "c"],
                         cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    # the span: first rise to last
    assert "| 4b62 | 10 | 4 |" in text
    assert "| 5270 | 9 | 3 |" in text
    assert "| 4b62 5270 | 3 | [0 148] (3) | 260 (3) |" in text
    assert "plain width 60 ticks" in text
    assert "| 4b62 | 1 | 1 (1) |" in text
    assert "| 5270 | 1 | 2 (1) |" in text
