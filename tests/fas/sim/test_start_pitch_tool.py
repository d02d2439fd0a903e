"""``bench/replica/start_pitch.py``: a starting ramp's commands on build d's replica, each
classed by the branches the ramp's arithmetic took (docs/timing-model.md,
"forty-seventh pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import start_pitch  # noqa: E402

TAG = "Os-nolto-inall-pad1"
# the profile's functions, by line: 0 _getNextCommand, 1 calculate_ticks, 2 __mulsi3
FUNCS = ("3092 38d8 _getNextCommand(ramp_ro_s\n"
         "2fa2 3074 ramp_config_s::calculate_ticks(unsigned\n"
         "6f4a 6f6a __mulsi3\n")
# a start task (no queue running at its entry) writing six commands of stepper 945: one
# step, then five of several steps; a UART interrupt (118) nested in the fourth pitch;
# then a task of a running queue, whose command is left out
EV = """1000 V 13 | |
1100 P 0:300 1:80
1500 M 0 945 11320 1 1 945
1600 P 0:500 1:80
4000 M 0 945 6536 2 1 945
4100 P 0:500 1:80
6400 M 0 945 1143 24 1 945
6500 P 0:530 1:80 2:28
6600 V 19
6718 R
9000 M 0 945 1012 27 1 945
9100 P 0:480
11100 M 0 945 1012 30 1 945
11200 P 0:650 1:80 2:28
13800 M 0 945 1100 31 1 945
14000 R
20000 V 13 |1 945 2| |
20100 P 0:500 1:80
20500 M 0 945 1000 30 1 945
20600 P 0:500 1:80
23000 M 0 945 990 30 1 945
23500 R
"""


@pytest.fixture
def work(tmp_path: Path) -> Path:
    (tmp_path / f"x01-{TAG}.ev").write_text(EV)
    (tmp_path / "x01.funcs").write_text(FUNCS)
    return tmp_path


def test_the_start_tasks_commands_and_their_classes(work: Path) -> None:
    names = start_pitch.function_names(work / "x01.funcs")
    rows = start_pitch.replica.pitches_of(work / f"x01-{TAG}", start_pitch.TASK_VECTOR)
    cmds = start_pitch.start_commands(rows, names)
    assert [(c, r["pitch"]) for c, r in cmds] == [
        ("after 1", 2500),  # holds the first write's enable: not a class's figure
        ("acc maths", 2400),
        ("acc near check maths", 2600 - 118),  # the nested interrupt left out
        ("coast near no maths", 2100),
        ("dec near check maths", 2700),
    ]  # the running task's command is not a start's


def test_the_table_gives_each_class_against_a_plain_command(
        work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert start_pitch.main(["--work", str(work), "--commands", "x01"]) == 0
    out = capsys.readouterr().out
    assert "x01 t=14000 1143x24 -> 1012x27 pitch 2482 acc near check maths" in out
    assert "| acc maths | 1 | 2400 / 2400 (2400..2400) | +0.0 | x01 |" in out
    assert "| acc near check maths | 1 | 2482 / 2482 (2482..2482) | +82.0 | x01 |" in out
    assert "| coast near no maths | 1 | 2100 / 2100 (2100..2100) | -300.0 | x01 |" in out
    assert "| after 1 | 1 | 2500 / 2500 (2500..2500) |  | x01 |" in out


def test_a_missing_run_is_one_line(work: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert start_pitch.main(["--work", str(work), "x02"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("start_pitch: no replica run") and err.count("\n") == 1
