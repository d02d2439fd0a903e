"""Upstream's sketches rebuilt and run cycle by cycle (``bench/replica/sketch_replica.py``;
docs/timing-model.md, "The upstream sketches' loop sections"): how it reads the runner's
records - pulses, the interrupts and the loop's own sections by cycle, which of them
held each pulse, and the loop's pass - and the figures read with it
(:mod:`fas.sim.sketch_loops`)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from fas.sim.sketch_loops import SKETCH_LOOP_POLLS, sketch_loop_poll

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import sketch_replica  # noqa: E402


def write(tmp: Path, pins: str, ev: str) -> Path:
    prefix = tmp / "run"
    Path(f"{prefix}.pins").write_text(pins)
    Path(f"{prefix}.ev").write_text(ev)
    return prefix


def test_pulses_pair_rises_with_falls_and_ignore_repeated_levels(tmp_path: Path) -> None:
    prefix = write(tmp_path, "10 B1 1\n12 B1 1\n72 B1 0\n100 B2 1\n500 B1 1\n570 B1 0\n"
                   "900 B1 1\n", "")
    e = sketch_replica.edges(prefix)
    assert e["B1"] == [(10, 1), (72, 0), (500, 1), (570, 0), (900, 1)]
    assert sketch_replica.pulses(e["B1"]) == [(10, 72), (500, 570)]  # the last is open


def test_timeline_keeps_outermost_interrupts_and_the_loop_sections(tmp_path: Path) -> None:
    ev = ("100 V 13\n150 V 11\n272 R\n900 R\n"  # a task with a step interrupt nested
          "1000 C 53c\n1013 S 55e\n"
          "2000 V 16\n2092 R\n")
    prefix = write(tmp_path, "", ev)
    runs, loops = sketch_replica.timeline(prefix)
    assert runs == [(100, 900, 13), (2000, 2092, 16)]
    assert loops == [(1000, 1013, 0x53C)]


def test_classify_names_what_held_each_pulse() -> None:
    runs = [(100, 900, 13), (2000, 2092, 16), (3000, 3122, 11)]
    loops = [(1000, 1013, 0x53C)]
    step = [(1005, 1005 + 62 + 9),   # inside micros()'s section: held to its end + 1
            (2050, 2050 + 62 + 44),  # behind timer 0
            (500, 500 + 62),         # inside the task, interrupts on: not held
            (3000, 3000 + 62),       # its own step interrupt's entry: alone
            (5000, 5000 + 63)]
    got = sketch_replica.classify(step, runs, loops, plain=62)
    assert got == {"loop cli": (1, 9), "behind 16": (1, 44), "behind 13": (1, 0),
                   "alone": (2, 1)}


def test_passes_count_only_passes_no_interrupt_entered(tmp_path: Path) -> None:
    ev = ("0 C 53c\n13 S 55e\n64 C 53c\n77 S 55e\n128 C 53c\n141 S 55e\n"
          "150 V 11\n272 R\n"  # this pass is interrupted: not counted
          "314 C 53c\n327 S 55e\n378 C 53c\n389 S 55e\n"
          "400 M 0 0 0 0 0 0\n453 C 53c\n")  # nor the pass across a marked call
    prefix = write(tmp_path, "", ev)
    assert dict(sketch_replica.passes(prefix)[0x53C]) == {64: 3}
    assert sketch_replica.marks(prefix) == [(400, 0)]


def test_sketch_loop_polls_have_the_machine_poll_form() -> None:
    for chips in SKETCH_LOOP_POLLS.values():
        for loops in chips.values():
            for period, sections in loops.values():
                assert period > 0
                for offset, ticks in sections:
                    assert offset >= 0 and ticks > 0 and offset + ticks <= period
    assert sketch_loop_poll("upstream_time_measurement", "atmega328p", "delay") == (
        64, ((24, 14),))
    assert sketch_loop_poll("d", "atmega328p", "delay") is None
    assert sketch_loop_poll("upstream_time_measurement", "atmega2560", "delay") is None


@pytest.mark.parametrize("loop", ["delay", "speed_read"])
def test_sketch_loops_hold_requests_inside_their_sections(loop: str) -> None:
    """Machine.loop_hold with a sketch's poll: a request inside the section waits to its
    end, one outside does not."""
    from fas.sim import SimBackend

    b = SimBackend("atmega328p", build="upstream_time_measurement")
    poll = sketch_loop_poll("upstream_time_measurement", "atmega328p", loop)
    assert poll is not None
    period, ((offset, ticks),) = poll
    m = b.machine
    m.poll_begin(period, ((offset, ticks),))
    t0 = m.now
    step_period = 1 << 20  # no step interrupt taken from the loop's time in between
    assert m.loop_hold(t0 + offset, step_period, 0) == ticks
    assert m.loop_hold(t0 + offset + ticks - 1, step_period, 0) == 1
    assert m.loop_hold(t0 + offset + ticks, step_period, 0) == 0
    m.poll_end()


def test_fill_cmd_mask_sections_mask_each_command_as_laid_out() -> None:
    """SimTiming.fill_cmd_mask_sections: each command the ramp task writes masks the
    interrupts in those sections, placed before the write's end (off by default)."""
    from dataclasses import replace

    from fas import Engine
    from fas.sim import SimBackend
    from fas.sim.timing import UPSTREAM_TM_CMD_MASK_SECTIONS

    def masks(sections: tuple[tuple[int, int], ...]) -> list[tuple[int, int]]:
        b = SimBackend("atmega328p", build="upstream_time_measurement")
        b.machine.timing = replace(b.machine.timing, fill_cmd_mask_sections=sections)
        e = Engine(b)
        e.init()
        s = e.stepper_connect_to_pin(9)
        s.set_speed_in_hz(20000)
        s.set_acceleration(100000)
        s.move(3000, blocking=True)
        m = b.machine
        return list(zip(m.exit_starts, m.exit_ends, strict=True))

    plain = masks(())
    laid = masks(UPSTREAM_TM_CMD_MASK_SECTIONS)
    assert all(e - s == 83 + 5 for s, e in plain)  # only the task's exits
    widths = [e - s for s, e in laid if e - s != 88]
    pattern = [w for _, w in UPSTREAM_TM_CMD_MASK_SECTIONS]
    runs = sum(widths[i:i + len(pattern)] == pattern for i in range(len(widths)))
    assert runs >= 3  # whole commands' worth, in order
    starts = [s for s, _ in laid]
    assert starts == sorted(starts)  # the machine's masks stay in order


def test_task_sections_split_entry_exit_inner_and_distance_to_the_write(tmp_path: Path) -> None:
    ev = ("1000 V 13\n1085 s b24\n"            # entry: 85 ticks to its sei
          "1200 c eca\n1243 s ede\n"           # an inner section of 43 ticks
          "1300 V 11\n1422 R\n"                # a step interrupt nested: not the task's CPU
          "1500 c 17d4\n1508 s 17e0\n"
          "1555 M 0 0 0 0 0 0\n"               # the write: 55 - 0 ticks of task CPU after
          "1600 c 1bca\n1683 R\n")             # exit: 83 ticks from its cli
    prefix = write(tmp_path, "", ev)
    got = sketch_replica.task_sections(prefix, write_mark=0)
    assert got["entry"] == {85: 1} and got["exit"] == {83: 1}
    assert got["eca"] == {43: 1} and got["17d4"] == {8: 1}
    assert got["before:17d4"] == {55: 1}
    assert got["before:eca"] == {1555 - 1200 - 122: 1}  # the nested interrupt left out
