"""bench/replica/pulse_holders.py: step pulses by holder, the replica's side on written
logs and the model's side on the simulator's own records (docs/timing-model.md,
"forty-fourth pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from rigs import ROOT

sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import pulse_holders  # noqa: E402

# a replica log (lag 0): timer 0 at 1000-1092; a ramp task 2000-2600 whose sei comes at
# 2047, with its own section 2300-2340 and its last cli at 2560; the UART at 3000-3118;
# the main program's millis() section 4000-4009 and queueEntries() 5000-5010; the step
# interrupt (vector 11) entered after each rise, and once more at 7000
LOG = """1000 V 16
1092 R
1096 V 11
1116 R
2000 V 13 | |
2020 V 11
2040 R
2047 s 4500
2300 c 2ea0
2340 s 2eae
2341 V 11
2361 R
2560 c 38aa
2600 R
2601 V 11
2621 R
3000 V 19
3125 V 11
3145 R
3118 R
4000 C c4a
4009 S c5c
4011 V 11
4031 R
5000 C 1650
5010 S 165e
5012 V 11
5032 R
6000 V 11
6020 R
7000 V 11
7020 R
8000 V 11
8020 R
9000 V 11
9020 R
"""
# stepper A's pin: plain pulses (6000, 8000, 9000), and pulses held by timer 0 (rise
# 1010), the task's entry (2010), its own section (2310), its exit (2570), the UART (3010),
# millis() (4003) and queueEntries() (5004)
PINS = """1010 B1 1
1156 B1 0
2010 B1 1
2080 B1 0
2310 B1 1
2401 B1 0
2570 B1 1
2661 B1 0
3010 B1 1
3185 B1 0
4003 B1 1
4071 B1 0
5004 B1 1
5072 B1 0
6000 B1 1
6060 B1 0
8000 B1 1
8060 B1 0
9000 B1 1
9060 B1 0
"""


def _log() -> pulse_holders.ReplicaLog:
    return pulse_holders.ReplicaLog(LOG.splitlines(), 0)


def test_the_replicas_task_is_read_with_its_sei_sections_and_last_cli() -> None:
    log = _log()
    (task,) = log.tasks
    assert (task.entry, task.reti, task.sei, task.last_cli) == (2000, 2600, 2047, 2560)
    assert task.sections == [(2300, 2340)]
    assert log.sections == [(4000, 4009, "c4a"), (5000, 5010, "1650")]


def test_what_holds_the_cpu_at_a_rise_on_the_replica() -> None:
    log = _log()
    assert log.holder_at(1010, "11") == ("timer 0", 1092)
    assert log.holder_at(2010, "11") == ("task entry", 2047)
    assert log.holder_at(2310, "11") == ("task sections", 2340)
    assert log.holder_at(2100, "11") is None  # the task with interrupts on: it nests
    assert log.holder_at(2570, "11") == ("task exit", 2600)
    assert log.holder_at(3010, "11") == ("UART", 3118)
    assert log.holder_at(4003, "11") == ("loop: millis()", 4009)
    assert log.holder_at(5004, "11") == ("loop: queueEntries()", 5010)
    # channel A's own interrupt holds nothing against itself; it holds B's
    assert log.holder_at(7010, "11") is None
    assert log.holder_at(7010, "12") == ("step A", 7020)


def test_a_chain_runs_from_the_rise_to_the_step_interrupts_entry() -> None:
    log = _log()
    # behind timer 0 to its reti (82 ticks), then 4 more to the entry: timer 0's too
    assert log.chain(1010, "11") == [("timer 0", 86)]
    assert log.chain(3010, "11") == [("UART", 115)]
    assert log.chain(6000, "11") == []  # entered at the rise


def test_the_tables_count_each_held_pulse_once_and_split_its_chain() -> None:
    log = _log()
    rep = pulse_holders.replica_pulses(PINS.splitlines(), "B1", 0)
    assert len(rep) == 10
    widths = [b - a for a, b in rep]
    chains = [log.chain(a, "11") if w > 60 else [] for (a, _), w in zip(rep, widths, strict=True)]
    first, split = pulse_holders.tables(widths, 60, chains)
    assert first["timer 0"] == [1, 86]
    assert first["task entry"] == [1, 10]
    assert first["task sections"] == [1, 31]
    assert first["task exit"] == [1, 31]
    assert first["UART"] == [1, 115]
    assert first["loop: millis()"] == [1, 8]
    assert first["loop: queueEntries()"] == [1, 8]
    assert sum(n for n, _ in first.values()) == 7  # the plain pulse is not counted
    assert sum(t for _, t in first.values()) == sum(w - 60 for w in widths)
    assert {k: v[1] for k, v in split.items()} == {k: v[1] for k, v in first.items()}


def test_the_models_held_pulses_are_all_attributed() -> None:
    # d02 in build d's default: every tick beyond the plain width has a holder the
    # simulator names (none left over as "?"), and the first-holder rows add up to it
    pulses, plain, chains = pulse_holders.model_run("M1 A500 V80 R300 W")
    widths = [b - a for a, b in pulses]
    # (the model's plain pulse: 60 since the fiftieth pass, 61 before)
    assert len(pulses) == 300 and plain == 60
    first, split = pulse_holders.tables(widths, plain, chains)
    beyond = sum(w - plain for w in widths if w > plain)
    assert beyond > 0
    assert sum(t for _, t in first.values()) == beyond
    assert sum(t for _, t in split.values()) == beyond
    assert "?" not in first and "?" not in split
    assert set(first) <= {"UART", "timer 0", "task entry", "task exit", "task sections",
                          "step B", "loop: queueEntries()", "loop: millis()"}


def test_the_tool_prints_both_sides_in_the_same_rows(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "conf" / "x").mkdir(parents=True)
    (tmp_path / "conf" / "x" / "input.txt").write_text("M1 A500 V80 R300 W \n")
    (tmp_path / "x-t.ev").write_text(LOG)
    (tmp_path / "x-t.pins").write_text(PINS)
    assert pulse_holders.main(["--work", str(tmp_path), "--tag", "t", "--lag", "0",
                               "--conformance", str(tmp_path / "conf"), "--longest", "2",
                               "x"]) == 0
    out = capsys.readouterr().out
    assert "replica: 10 pulses, plain 60" in out
    assert "model (default): 300 pulses, plain 60" in out  # (61 before the fiftieth pass)
    assert "| first holder | replica: pulses / ticks | model default: pulses / ticks |" in out
    assert "| timer 0 | 1 / 86 |" in out
    assert "| replica pulse | ticks | rise | held by |" in out
    assert "first rise: replica 1010, model " in out
    # no replica run: a one-line error
    assert pulse_holders.main(["--work", str(tmp_path), "--tag", "none",
                               "--conformance", str(tmp_path / "conf"), "x"]) == 2
    assert "no replica run" in capsys.readouterr().err
