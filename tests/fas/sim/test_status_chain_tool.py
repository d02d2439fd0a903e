"""bench/replica/status_chain.py: a held W's status lines, the replica's side on a written
log and the model's on the simulator's own records (docs/timing-model.md, "forty-eighth
pass")."""

from __future__ import annotations

import sys

import pytest

from rigs import ROOT

sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import status_chain  # noqa: E402

# a replica log (lag 0): a millis() read at 1000, timer 0 at 2000-2092 with a read inside
# it (not the main program's), the main program's reads at 2300 and 2630; a line's
# hand-overs at 2930 (the register), 3037 and 3144 (the buffer), 2 000 000 and 2 000 107;
# the UART's routine 4430-4548 with the step interrupt nested in it 4450-4470
LOG = """1000 C c4a
1009 S c5c
2000 V 16
2010 C c4a
2092 R
2300 C c4a
2309 S c5c
2630 C c4a
2639 S c5c
2930 C 1074
2940 S 1088
3037 C 1064
3047 S 1088
3144 C 1064
3154 S 1088
4430 V 19
4450 V 11
4470 R
4548 R
2000000 C 1074
2000010 S 1088
2000107 C 1064
2000117 S 1088
"""
PINS = """4400 B1 1
4460 B1 0
4440 B1 1
4600 B1 0
"""


def _rep() -> status_chain.ReplicaRun:
    return status_chain.ReplicaRun(LOG.splitlines(), PINS.splitlines(), 0)


def test_the_replicas_reads_hand_overs_and_routines() -> None:
    rep = _rep()
    assert rep.reads == [1000, 2300, 2630]  # not the one inside timer 0's routine
    assert rep.chars == [2930, 3037, 3144, 2000000, 2000107]
    assert rep.timer0 == [2000] and rep.uart == [4430]
    assert rep.routines == [(2000, 2092), (4430, 4548)]  # the outermost only
    # the main program's ticks: the span less the routines entered in it
    assert rep.cpu(2930, 3037) == 107
    assert rep.cpu(4400, 4600) == 200 - 118
    assert rep.cpu(1900, 2050) == 150 - 50  # a routine that runs on past the span's end


def test_lines_and_the_rises_near_a_transmit_request() -> None:
    rep = _rep()
    assert status_chain.line_starts(rep.chars) == [3]
    assert status_chain.line_length(rep.chars, 0) == 3
    assert status_chain.line_length(rep.chars, 3) == 2
    assert status_chain.before(rep.reads, 2929) == 2630
    assert status_chain.after(rep.reads, 2300) == 2630
    # the rise 10 ticks after the request (entry 4430 less 4) waits: 160 ticks wide;
    # the one before the request does not count
    near = status_chain.near_rises(rep.pulses, [t - status_chain.VECTOR_ENTRY for t in rep.uart])
    assert near == [(14, 160)]


README_SHORT = "M1 A10000 V100 R3000 W"  # a move of about 0.4 s: status lines while it runs


@pytest.fixture(scope="module")
def model_run() -> status_chain.ModelRun:
    return status_chain.ModelRun(README_SHORT)


def test_the_models_side_keeps_every_hand_over_load_and_pass(model_run) -> None:
    mod = model_run
    assert len(mod.text) == len(mod.chars) == len(mod.char_cpu)
    starts = [i for i in status_chain.line_starts(mod.chars) if mod.text[i:i + 4] == b"M1: "]
    assert len(starts) >= 3
    for i in starts:
        # the line's second character goes into the free register, the third waits for
        # the first to start: the first transmit interrupt 1 496 ticks after the hand-over
        assert status_chain.after(mod.loads, mod.chars[i]) - mod.chars[i] == 1496
        # every hand-over lies in a loop pass
        assert status_chain.before(mod.starts, mod.chars[i]) is not None
    # a character of a text printed from a buffer costs the loop its 107 ticks
    i = starts[0]
    q = mod.text.index(b"Queue", i)
    assert mod.cpu(q) == mod.cpu(q + 1) == 107


def test_both_sides_in_one_table(model_run) -> None:
    # the replica's log paired with the model's run: only the line both have
    rep = _rep()
    rows = status_chain.lines_table(rep, model_run)
    assert len(rows) == 1
    (row,) = rows
    assert row["handover_after_read"] == 2000000 - 2630
    assert row["handover"] == model_run.chars[status_chain.line_starts(model_run.chars)[-1]] \
        - 2000000


def test_a_missing_run_is_one_line(tmp_path, capsys) -> None:
    assert status_chain.main(["--work", str(tmp_path), "--conformance", str(tmp_path),
                              "nothing"]) == 2
    assert "no replica run" in capsys.readouterr().err
