"""bench/slot_jumps.py: where two step time lines part (a ramp-task slot, a timer wrap),
and the moves the loop starts after a stop, on lines and a replica log written here and
on a model run."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

import slot_jumps  # noqa: E402

P = slot_jumps.PERIOD


def _line(start: int, gaps: list[int]) -> list[int]:
    out = [start]
    for g in gaps:
        out.append(out[-1] + g)
    return out


def test_a_lost_compare_is_a_wrap_with_nothing_beyond_the_period() -> None:
    # 6724-tick steps; the firmware's fourth gap is one period longer (+1 tick of jitter)
    model = _line(1000, [6724] * 6)
    fw = _line(1000, [6724, 6724, 6724, 6724 + P + 1, 6724, 6724])
    found = slot_jumps.jumps(model, fw, 2000)
    assert found == [(4, 0, -P - 1)]
    assert slot_jumps.wrap_excess(fw, 4) == 1
    assert slot_jumps.wrap_excess(model, 4) is None
    kind = slot_jumps.classify(("model", "firmware"), model, fw, 4, -P - 1)
    assert kind == "wrap in firmware (+1: compare lost)"


def test_a_dry_queue_restart_wraps_ten_ticks_beyond() -> None:
    fw = _line(0, [6724, 6724, 6724 + P + slot_jumps.RESTART_TICKS, 6716])
    model = _line(0, [6724, 6724, 6724, 6716])
    kind = slot_jumps.classify(("model", "firmware"), model, fw, 3, -P - 10)
    assert kind == "wrap in firmware (+10: dry-queue restart)"


def test_a_move_started_a_task_later_is_a_slot() -> None:
    # a move from rest: the gap before its first step is longer than a task period
    fw = _line(0, [6000, 370538, 6000])
    model = _line(0, [6000, 370538 + P + 36, 6000])
    assert slot_jumps.jumps(model, fw, 2000) == [(2, 0, P + 36)]
    assert slot_jumps.classify(("model", "firmware"), model, fw, 2, P + 36) == "slot (+1)"
    # the same change inside a run of short gaps is not a slot
    a = _line(0, [6000, 6000 + P + 2500, 6000])
    b = _line(0, [6000, 6000, 6000])
    assert slot_jumps.classify(("a", "b"), a, b, 2, P + 2500) == "other"
    lines = slot_jumps.report(("model", "firmware"), model, fw, 2000)
    assert lines == ["  step 2 at 0.0235 s: model - firmware +0 -> +65572 ticks "
                     "(gaps 436110 / 370538): slot (+1)"]


def test_report_lists_at_most_the_given_number() -> None:
    a = _line(0, [10000 * (k + 1) for k in range(6)])
    b = _line(0, [10000] * 6)
    lines = slot_jumps.report(("a", "b"), a, b, 2000, most=2)
    assert len(lines) == 3 and lines[-1] == "  ... 3 more"


# the replica's log: a step interrupt (vector 11) enters at 4951 and finds the queue
# empty; the loop's cli inside move() (0x319e) comes 736 ticks later; the ramp task
# (vector 13) enters at 6000; a cli elsewhere (0x636c) and interrupts nested in the
# task are not calls
EV = """\
1000 V 11
1120 R
3000 C 636c
3009 S 636c
4951 V 11
5087 R
5400 C 636c
5409 S 636c
5687 C 319e
5700 S 319e
6000 V 13
6100 V 11
6200 R
6300 C 319e
6400 R
6500 C 319e
6520 S 319e
70000 V 13
70500 R
"""


def test_replica_calls_pair_the_stop_the_call_and_the_next_task(tmp_path: Path) -> None:
    ev = tmp_path / "c.ev"
    ev.write_text(EV)
    rows = slot_jumps.replica_calls(ev, [(0x3190, 0x31c0)])
    # the cli at 6300 runs inside the task (not the main program); the one at 6500 is
    # the main program's after the step interrupt at 6100-6200
    assert rows == [(4951, 5687, 6000), (6100, 6500, 70000)]
    table = slot_jumps.calls_table("replica", rows)
    assert table[1] == "     0.0003 s: call +736, task +1049, margin 313"


def test_model_calls_time_a_move_started_after_a_stop() -> None:
    rows, backend = slot_jumps.model_calls("M1 A10000 V200 R50 W R-50 W", "atmega328p", "d")
    assert len(rows) == 1  # the first R starts from power-on: no stop before it
    stop, call, task = rows[0]
    assert stop < call < task <= call + backend.profile.fill_period_ticks
    # the W's "STOPPED" and the status line come between: the call is after the prints
    assert call - stop > 10_000
