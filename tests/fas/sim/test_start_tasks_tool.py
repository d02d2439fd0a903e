"""``bench/replica/start_tasks.py``: the pieces of a ramp task that starts a queue, read
from the replica's marks (docs/timing-model.md, "twenty-eighth pass")."""

from __future__ import annotations

import collections
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import replica  # noqa: E402
import start_tasks  # noqa: E402

W, S, Q = replica.WRITE, replica.START, replica.QUEUE_WRITE


def _task(marks: list[tuple[int, int, int, int, int]], cpu: int) -> replica.Task:
    """A replica task with marks (cpu, mark, queue, ticks, steps); cycles follow the cpu."""
    t = replica.Task(1000, [])
    t.marks = [(c, k, q, ticks, steps, 1000 + c) for c, k, q, ticks, steps in marks]
    t.cpu = cpu
    return t


def test_the_pieces_of_a_lone_start() -> None:
    # one step, one step, a pause, then the call that starts the queue
    t = _task([(100, W, 7, 40000, 1), (2200, Q, 7, 0, 0),
               (2300, W, 7, 30000, 1), (4100, Q, 7, 0, 0),
               (4200, W, 7, 30000, 0), (5400, Q, 7, 0, 0),
               (5450, W, 7, 30000, 1), (6400, S, 7, 0, 0)], cpu=6900)
    idle = _task([(100, W, 7, 40000, 1), (2200, Q, 7, 0, 0)], cpu=2500)  # no start
    pieces: start_tasks.Pieces = collections.defaultdict(list)
    start_tasks.start_pieces("x01", [idle, t], pieces)
    assert dict(pieces) == {
        "first write (lone start)": [("x01", 2200)],
        "single -> single": [("x01", 1900)],
        "single -> pause": [("x01", 1300)],
        "last pause -> startQueue()": [("x01", 1000)],
        "startQueue() -> task end": [("x01", 500)],
    }
    lines = start_tasks.report(pieces)
    assert lines[2] == "| first write (lone start) | 1 | 2200.0 | 2200 | 2200 | 2200 | x01:2200 |"


def test_a_start_after_another_steppers_writes() -> None:
    t = _task([(100, W, 1, 20000, 1), (1800, Q, 1, 0, 0),
               (2000, W, 2, 40000, 1), (5900, Q, 2, 0, 0),
               (6000, W, 2, 40000, 1), (6900, S, 2, 0, 0)], cpu=7400)
    pieces: start_tasks.Pieces = collections.defaultdict(list)
    start_tasks.start_pieces("x02", [t], pieces)
    assert pieces["first write after another stepper's last"] == [("x02", 4100)]
    assert pieces["last single -> startQueue()"] == [("x02", 1000)]
    assert "first write (lone start)" not in pieces


def test_the_pitches_to_a_longer_command_are_pooled() -> None:
    """"any -> command" (docs/timing-model.md, "thirty-second pass"): every pitch that
    ends in a command of several steps, whatever came before it."""
    t = _task([(100, W, 1, 20000, 1), (1800, Q, 1, 0, 0),
               (2000, W, 1, 9000, 2), (3850, Q, 1, 0, 0),
               (4000, W, 1, 8000, 3), (5970, Q, 1, 0, 0),
               (6000, W, 1, 8000, 3), (6900, S, 1, 0, 0)], cpu=7400)
    pieces: start_tasks.Pieces = collections.defaultdict(list)
    start_tasks.start_pieces("x03", [t], pieces)
    assert pieces["single -> command"] == [("x03", 2050)]
    assert pieces["command -> command"] == [("x03", 2120)]
    assert pieces["any -> command"] == [("x03", 2050), ("x03", 2120)]
    assert pieces["last command -> startQueue()"] == [("x03", 930)]


def test_the_running_fills_pieces() -> None:
    """``--running`` ("thirty-second pass"): a task without a start where one stepper
    runs gives its first write and the CPU after its last; a task where two run gives
    only the pitches; a start task gives nothing."""
    lone = _task([(100, W, 1, 20000, 1), (1880, Q, 1, 0, 0),
                  (1900, W, 1, 19000, 1), (3710, Q, 1, 0, 0)], cpu=4820)
    lone.queues = [[1, 1, 1], []]
    two = _task([(100, W, 1, 20000, 1), (1800, Q, 1, 0, 0),
                 (1900, W, 1, 19000, 1), (3600, Q, 1, 0, 0),
                 (3700, W, 2, 30000, 1), (5900, Q, 2, 0, 0)], cpu=7000)
    two.queues = [[1, 1], [1]]
    start = _task([(100, W, 1, 20000, 1), (2200, Q, 1, 0, 0),
                   (2300, W, 1, 20000, 1), (3200, S, 1, 0, 0)], cpu=3700)
    pieces: start_tasks.Pieces = collections.defaultdict(list)
    start_tasks.running_pieces("x04", [lone, two, start], pieces)
    assert pieces["running: first write, single"] == [("x04", 1880)]
    assert pieces["running: after the last write, single"] == [("x04", 1110)]
    assert pieces["running: single -> single"] == [("x04", 1830), ("x04", 1800)]
    assert len(pieces) == 3


def test_a_piece_of_many_pitches_shows_each_runs_mean() -> None:
    pieces: start_tasks.Pieces = {"single -> single": [("x05", 1800)] * 9 + [("x06", 1900)] * 8}
    line = start_tasks.report(pieces)[2]
    assert line.endswith("| x05:1800 x06:1900 |")
    assert "| 17 | 1847.1 | 1800 | 1800 | 1900 |" in line
