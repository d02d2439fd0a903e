"""``bench/replica/start_steps.py``: each stepper start's first step, the model beside build
d's replica, split into the start task's pieces (docs/timing-model.md, "forty-fifth pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))
sys.path.insert(0, str(ROOT / "bench"))

import start_steps  # noqa: E402

LAG = 96

# a written replica run: a task without a start, then a start task of queue 1131 (two
# command writes and the start call's own write) with a UART interrupt (118) and timer 0
# (92) nested in it; stepper A's pin rises 85 cycles after the call
EV = """0 C 0
1000 V 13 | |
1200 R
5000 V 13 | |
5500 M 0 945 11320 1 1 945
7000 M 2 1131 11320 1 1 7000
7100 V 19
7218 R
9000 M 2 1131 6536 2 1 9000
9100 V 16
9192 R
9400 M 2 1131 0 0 1 9400
9479 M 1 1131 192 1 257 1131
9600 R
"""
PINS = """0 B1 0
0 B2 0
9564 B1 1
9624 B1 0
10500 B1 1
10560 B1 0
"""


def test_the_replicas_start_its_stepper_and_pieces() -> None:
    (s,) = start_steps.replica_starts(EV.splitlines(), PINS.splitlines(), LAG)
    assert s.stepper == 0  # the pin that rises 85 after the call
    assert (s.entry, s.call, s.rise) == (5000 - LAG, 9479 - LAG, 9564 - LAG)
    assert s.to_step == 4564
    assert s.writes == 2  # the start call's own write is not a command
    # own CPU: the first write 2000, the second 4000 - 118 = 3882, the call 4479 - 118 -
    # 92 = 4269; nested 210; the rise 85 after the call
    assert s.pieces == {"first": 2000, "pitch": 1882, "tail": 387, "nested": 210, "start": 85}


def test_a_queue_is_the_stepper_whose_pin_rises_after_its_call() -> None:
    pins = PINS.replace("B1", "B2")
    (s,) = start_steps.replica_starts(EV.splitlines(), pins.splitlines(), LAG)
    assert s.stepper == 1
    assert s.rise == 9564 - LAG


def test_the_pieces_differences_put_the_tail_and_the_queue_start_together() -> None:
    r = start_steps.Start(0, 0, 4000, 4100, 2, pieces={"first": 2000, "pitch": 1500,
                                                       "tail": 400, "nested": 100,
                                                       "start": 100})
    m = start_steps.Start(0, 0, 3990, 4000, 2, pieces={"first": 2010, "pitch": 1400,
                                                       "tail": 470, "nested": 110,
                                                       "start": 10})
    assert start_steps.piece_diffs(r, m) == {"first": 10, "pitch": -100, "tail": -20,
                                             "nested": 10}
    assert m.to_step - r.to_step == 10 - 100 - 20 + 10  # type: ignore[operator]


def test_the_models_start_d35_by_default() -> None:
    """The model's d35 (``M1 A1000000 V40 e R20000 W``): one start of A, a move with a
    direction pin, its fourteen commands written in the start task; the pieces add up to
    the task's entry to the first step."""
    text = (ROOT.parent.parent / "shared" / "conformance" / "d35" / "input.txt")
    src = text.read_text().strip() if text.exists() else "M1 A1000000 V40 e R20000 W"
    (s,) = start_steps.model_starts(src)
    assert s.stepper == 0 and s.writes == 14
    assert s.kind == {"run": False, "dir": True, "en": False, "steps": 1, "end": False,
                      "in_task": True}
    assert s.to_step == sum(s.pieces.values())


def test_the_models_start_of_a_run_without_a_direction_pin() -> None:
    (s,) = start_steps.model_starts("M1 u A1000000 V40 f w2000 a-10000 W")
    assert start_steps.kind_text(s.kind) == "run no dir"


def test_the_tables_pair_the_kth_start_of_each_stepper(capsys: pytest.CaptureFixture[str],
                                                       tmp_path: Path) -> None:
    (tmp_path / "x01-T.ev").write_text(EV)
    (tmp_path / "x01-T.pins").write_text(PINS)
    conf = tmp_path / "conf" / "x01"
    conf.mkdir(parents=True)
    (conf / "input.txt").write_text("M1 A1000 V100 R200 W\n")
    assert start_steps.main(["--work", str(tmp_path), "--tag", "T", "--conformance",
                             str(tmp_path / "conf"), "x01"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| x01 | A0 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[2] == "move dir" and cells[5] == "4564"
    assert "| move dir | default | 1 |" in out


def test_a_missing_run_is_a_one_line_error(capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    assert start_steps.main(["--work", str(tmp_path), "nothing"]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0
    assert start_steps.main(["--config", "Z99", "x"]) == 2


def test_a_queue_whose_start_begins_with_a_pause_is_the_pin_that_rises_after_it() -> None:
    # stepper B alone, its first entry auto enable's pause: no rise within the window
    pins = "0 B1 0\n0 B2 0\n40000 B2 1\n40070 B2 0\n"
    (s,) = start_steps.replica_starts(EV.splitlines(), pins.splitlines(), LAG)
    assert s.stepper == 1 and s.rise == 40000 - LAG
