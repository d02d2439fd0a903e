"""The timing report's acceleration of a short motion (issue 26, item 10): a 53-step
move at A=1 000 000 took no two 10 ms windows, and the report said "acceleration up
to 0".  The figures now come from the step times; the reference is the same
estimator on the original firmware's step times for the same input."""

from __future__ import annotations

import re

import pytest

from rigs import ROOT
from stepperdemo.front.cli import EXIT_OK, main
from stepperdemo.scenarios.evaluate import read_reference_track
from stepperdemo.watch.ramp_rates import phase_rates

TPS = 16_000_000
REFERENCE = ROOT / "sequences" / "reference" / "test_sd_07_328p"
LINE = "M1 V40 A1000000 R53 w1000 R53 w1000 ? W"  # that reference's input


def reference_moves() -> list[list[float]]:
    """The firmware's rising edges of StepA in ticks, one list per move."""
    times_us, _ = read_reference_track(REFERENCE / "steps_A.tsv.gz")
    ticks = [t * TPS / 1_000_000 for t in times_us]
    moves, start = [], 0
    for i in range(1, len(ticks)):
        if ticks[i] - ticks[i - 1] > TPS // 10:  # the w1000 between the moves
            moves.append(ticks[start:i])
            start = i
    moves.append(ticks[start:])
    return moves


def tolerance(move: list[float]) -> float:
    """The firmware's own scatter of one interval length within a stair, relative (the
    reference times carry whole-ns rounding; the peak stair is 2312 +- 3 ticks)."""
    peak = [b - a for a, b in zip(move, move[1:], strict=False)][14:29]
    assert len(peak) == 15
    return (max(peak) - min(peak)) / (sum(peak) / len(peak))


def reported_rates(capsys, argv) -> tuple[float, float]:
    assert main(argv) == EXIT_OK
    out = capsys.readouterr().out
    m = re.search(r"acceleration up to (\S+), deceleration up to (\S+) steps/s\^2", out)
    assert m, out
    return float(m.group(1)), float(m.group(2))


def test_a_53_step_move_at_a_million_has_its_acceleration_measured(capsys):
    moves = reference_moves()
    assert [len(m) for m in moves] == [53, 53]
    ref = [phase_rates(m, TPS) for m in moves]
    tol = max(tolerance(m) for m in moves)
    acc_ref = max(a for a, _ in ref)
    dec_ref = max(d for _, d in ref)
    assert 1.2e6 < acc_ref < 1.35e6 and 0.5e6 < dec_ref < 0.65e6  # a staircase, not 1e6
    acc, dec = reported_rates(capsys, ["-c", LINE, "--report"])
    assert acc == pytest.approx(acc_ref, rel=tol)
    assert dec == pytest.approx(dec_ref, rel=tol)


def test_the_issues_command_is_not_zero(capsys):
    acc, dec = reported_rates(capsys, ["-c", "M1 A1000000 V40 R53 W", "--report"])
    (move,) = reference_moves()[:1]
    acc_ref, dec_ref = phase_rates(move, TPS)
    assert acc == pytest.approx(acc_ref, rel=tolerance(move))
    assert dec == pytest.approx(dec_ref, rel=tolerance(move))


def test_long_moves_keep_the_window_figures(capsys):
    # the README move: A=1000 over 3200 steps (the windows see its 1.8 s ramps)
    acc, dec = reported_rates(capsys, ["-c", "M1 A1000 V100 R3200 W", "--report"])
    assert 900 < acc < 1200 and 900 < dec < 1200


def test_one_step_has_no_rate_to_show(capsys):
    assert main(["-c", "M1 A1000 V100 R2 W", "--report"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "acceleration up to -, deceleration up to - steps/s^2" in out
