"""The main loop's passes and a library call against the ramp task, read from a replica's
interrupt log (``bench/replica/loop_passes.py``; docs/timing-model.md, "twenty-ninth
pass"), and build d's loop figures of the ATmega328P against that reading."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import loop_passes  # noqa: E402

from fas.arch import get_profile  # noqa: E402
from stepperdemo.demo.build import demo_build  # noqa: E402

TASK = 13
LOOP, CALL, RUN, MILLIS = 5, 4, 6, 7  # mark numbers in the synthetic log


def _log() -> list[str]:
    return [
        f"1000 M {LOOP} 0 0 0 0 0",    # pass 1: 1000 .. 1600
        f"1100 M {MILLIS} 0 0 0 0 0",
        "1200 V 11",                    # a step interrupt of 120 cycles
        "1320 R",
        f"1400 M {RUN} 0 0 0 0 0",
        f"1600 M {LOOP} 0 0 0 0 0",    # pass 2: 1600 .. 9000, holds the ramp task
        "2000 V 13 | 3 |",
        "2050 V 11",                    # nested in the task: counted once, with the task
        "2100 R",
        "5000 R",                       # the task ends: 3000 cycles
        f"6000 M {CALL} 0 0 0 0 0",     # the call, after the task
        f"9000 M {LOOP} 0 0 0 0 0",
        "70000 V 13 | |",
        "70500 R",
        f"71000 M {LOOP} 0 0 0 0 0",
    ]


def test_passes_take_the_interrupts_out() -> None:
    tr = loop_passes.Trace(_log(), TASK)
    assert tr.tasks == [2000, 70000]
    assert tr.irq == [(1200, 1320), (2000, 5000), (70000, 70500)]
    rows = loop_passes.passes(tr, LOOP, 0, 10_000, {"isRunning": RUN, "millis": MILLIS})
    assert [(s, n) for s, n, _ in rows] == [(1000, 600 - 120), (1600, 7400 - 3000),
                                            (9000, 62000 - 500)]
    assert rows[0][2] == {"isRunning": [400 - 120], "millis": [100]}


def test_a_call_against_its_ramp_tasks() -> None:
    tr = loop_passes.Trace(_log(), TASK)
    # the call: 4000 after the task's entry, 64000 before the next; its pass began 4400
    # before it, 1400 of them without interrupts
    assert loop_passes.call_rows(tr, CALL, LOOP) == [(6000, 2000, 70000, 1600)]
    assert tr.irq_between(1600, 6000) == 3000


# landed with build d's `e` block and `W` (thirty-first pass): d30 49 444 us, firmware
# 49 248 +- 710
def test_build_d_loop_figures_are_the_replicas_passes() -> None:
    """d21's replica of build d (two steppers connected): passes of 376 ticks with both
    idle, 330 with one running, 338 in a `w` with one running, 467 for `W`'s command."""
    d = demo_build(get_profile("atmega328p"), "d")
    both_idle = d.loop_pass_ticks + 2 * d.loop_idle_stepper_ticks
    one_running = d.loop_pass_ticks + d.loop_running_stepper_ticks + d.loop_idle_stepper_ticks
    assert (both_idle, one_running, one_running + d.loop_pause_ticks) == (376, 330, 338)
    assert one_running + d.cmd_ticks["W"] == 467  # `W` held: the command's pass
