"""bench/pulse_widths.py: the situations of the replica's step pulses and the run beside
the model, on a small replica run written here (edges and interrupts by cycle)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import pulse_widths as pw  # noqa: E402

# compare A is vector 11, the ramp task 13, timer 0 16, the UART 19 (ATmega328P)
EV = """\
1000 V 11
1120 R
5000 V 16
5100 R
5101 V 11
5221 R
9000 V 13
9050 V 11
9170 R
9600 R
12000 V 11
12120 R
"""
# a lone pulse (60 ticks), one behind timer 0 (rise inside it, its interrupt enters at
# its reti), one nested in the ramp task, one the loop held (entered 9 ticks late)
PINS = """\
1000 B1 1
1060 B1 0
5040 B1 1
5040 B1 1
5160 B1 0
9050 B1 1
9112 B1 0
11991 B1 1
12060 B1 0
"""


def _write(folder: Path) -> None:
    (folder / "c.ev").write_text(EV)
    (folder / "c.pins").write_text(PINS)


def test_situations_of_the_replica_pulses(tmp_path: Path) -> None:
    _write(tmp_path)
    starts, spans = pw.routines(tmp_path / "c.ev")
    pulses = pw.replica_pulses(tmp_path / "c.pins", "B1")
    assert [b - a for a, b in pulses] == [60, 120, 62, 69]
    got = [pw.situation(a, 11, 13, starts, spans) for a, _ in pulses]
    assert got == ["alone", "behind 16", "in task", "loop cli"]


def test_hold_lengths_per_routine(tmp_path: Path) -> None:
    # the pulse rising in timer 0's routine (entry 5000, reti 5100) is held until the
    # step interrupt enters at 5101: 101 ticks from timer 0's entry, its routine 100
    _write(tmp_path)
    holds = pw.hold_lengths(tmp_path / "c.ev", tmp_path / "c.pins", "B1", 11)
    assert holds[16] == ([100], [101])
    # the pulse in the ramp task entered while it ran (nested): the report leaves it out
    assert holds[13] == ([600], [50])
    out = subprocess.run([sys.executable, "bench/pulse_widths.py", "--holds", "--replica",
                          str(tmp_path), "c"], cwd=ROOT, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert "| 11 (A) | 16 | 100 | 1 | 101, 101.0 |" in out.stdout
    assert "| 11 (A) | 13 |" not in out.stdout


def test_excess_bins_count_beyond_the_commonest_width() -> None:
    pulses = [(0, 60), (100, 160), (200, 263), (300, 372), (400, 500), (500, 900)]
    bins = pw.excess_bins(pulses)
    assert pw.plain_width(pulses) == 60
    assert bins["0"] == [2, 0]
    assert bins["1-4"] == [1, 3]
    assert bins["5-20"] == [1, 12]
    assert bins["21-60"] == [1, 40]
    assert bins["> 150"] == [1, 340]


def test_the_tool_runs_the_model_beside_a_replica_run(tmp_path: Path) -> None:
    # what users run: the script on a replica folder and a conformance folder
    conf = tmp_path / "conf" / "c"
    conf.mkdir(parents=True)
    (conf / "input.txt").write_text("M1 A1000 V2000 R4\n")
    (conf / "result.txt").write_text(
        "   StepA:        4*L->H,        4*H->L, Max High=7us Total High=19us\n")
    _write(tmp_path)
    out = subprocess.run([sys.executable, "bench/pulse_widths.py", "--replica", str(tmp_path),
                          "--conformance", str(tmp_path / "conf"), "c"],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert "total high: firmware 19 us, replica 19.4 us (4 pulses), model" in text
    # the model's lone pulse: 60 ticks since the fiftieth pass (61 before)
    assert "| alone | 1 | 60.00 | 60.00 |" in text
    assert "plain width: replica 60 ticks, model 60 ticks" in text
