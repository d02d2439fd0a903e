"""The bounded recording of the recent motion (stepperdemo.watch.recent, issue 16):
a replay equals a live recording, the head state carries positions and plans forward
when the oldest edges are dropped, and memory stays within the bound."""

from __future__ import annotations

import pytest

from fas.sim import SimBackend
from rigs.vcd import read_vcd
from stepperdemo.demo.app import StepperDemo
from stepperdemo.watch import report
from stepperdemo.watch.observe import Observers
from stepperdemo.watch.recent import BIND_MARK, MAX_EDGES, RecentTrace

STEP_A = 9  # ATmega328P demo wiring: M1 step pin


def session(arch: str = "atmega328p"):
    b = SimBackend(arch)
    app = StepperDemo(b, scripted=False)
    tps = b.profile.ticks_per_s

    def run(line: str, seconds: float) -> None:
        app.feed(line + "\n")
        app.run_until(b.now() + int(seconds * tps))

    return b, app, run


def kept_rises(ring: RecentTrace, pin: int, last: int) -> int:
    """Rising edges of ``pin`` among the last ``last`` edges the ring holds."""
    runs = []
    for c in ring.chunks:
        runs.extend((p, c.levels[a:b]) for p, a, b in c.runs() if p > BIND_MARK)
    rises, seen = 0, 0
    for p, levels in reversed(runs):
        take = min(len(levels), last - seen)
        if p == pin:
            rises += levels[len(levels) - take:].count(1)
        seen += take
        if seen == last:
            break
    return rises


def moves(run) -> None:
    run("M1 A20000 V100 R3000", 1.0)
    run("M2 A5000 V200 R-2000", 0.2)
    run("M1 R-1000 ", 3)
    run("M1 A100000 V40 f", 0.3)
    run("M1 S", 2)


def test_a_replay_without_drops_equals_the_live_recording():
    b, app, run = session()
    ring = RecentTrace(b).start()
    live = Observers(b).start()
    moves(run)
    positions = report.library_positions(app)
    replayed = report.report_lines(ring.window(), positions=positions)
    assert ring.dropped == 0
    assert replayed == report.report_lines(live, positions=positions)
    assert "  pulses       12002 (the channel counted 12002), net +10002 steps, position 10002 " \
           "by the pins" in replayed


@pytest.mark.parametrize("max_edges,chunk", [(4096, 512), (4096, 64), (1024, 1)])
def test_dropping_the_head_carries_positions_and_plans(max_edges, chunk, tmp_path):
    b, app, run = session()
    big = RecentTrace(b).start()
    small = RecentTrace(b, max_edges=max_edges, chunk_edges=chunk).start()
    moves(run)
    window = small.window()
    big.flush()
    assert small.dropped > 0 and small.peak_held <= max_edges
    assert small.held + small.dropped == big.held
    m1, m2 = window.analysis.steppers[:2]
    assert m1.position == app.steppers[0].get_current_position() == 10002
    assert m2.position == app.steppers[1].get_current_position() == -2000
    assert m1.pulses == kept_rises(big, STEP_A, small.held)
    assert m1.channel_count("pulses") == m1.pulses
    assert m1.dev_compared and not m1.dev_late and not m1.dev_early  # the plan carried on
    assert window.stream.start_tick == small.head_tick > 0
    path = tmp_path / "tail.vcd"
    small.export_vcd(str(path))
    vcd = read_vcd(str(path))
    assert len(vcd.rising("StepA")) == m1.pulses


def test_a_planner_switch_inside_the_window():
    b, app, run = session()
    run("M1 A1000 V100 R200", 1.0)
    small = RecentTrace(b, positions=report.library_positions(app), max_edges=2048).start()
    run("c M1 l1 p8 x M1 A1000 V100 R3200", 5)  # QuickStep: another channel on the pin
    run("M1 R-300", 2)
    window = small.window()
    m1 = window.analysis.steppers[0]
    assert small.dropped > 0
    assert m1.position == app.steppers[0].get_current_position()
    assert m1.channel_count("pulses") == m1.pulses > 0
    assert m1.dev_compared and not m1.dev_late and not m1.dev_early


def test_a_finished_recording_keeps_its_counts():
    b, app, run = session()
    ring = RecentTrace(b).start()
    run("M1 A1000 V1000 R300", 1.5)
    ring.finish()
    run("M1 R100", 1.0)  # after the end: neither pins nor channel counts
    m1 = ring.window().analysis.steppers[0]
    assert (m1.pulses, m1.channel_count("pulses"), m1.position) == (300, 300, 300)
    assert ring.now_tick() == ring.end_tick < b.now()


def test_memory_stays_within_the_bound_over_a_long_run():
    b, app, run = session()
    ring = RecentTrace(b, max_edges=1 << 16).start()
    run("M1 A1000000 V40 f", 1.0)
    sizes = []
    for _ in range(12):  # 50 000 edges a second: the bound is passed many times over
        run("", 1.0)
        ring.flush()
        sizes.append(ring.nbytes())
        assert len(ring.chunks) <= ring.max_chunks
    assert ring.dropped > 8 * (1 << 16) and ring.peak_held <= 1 << 16
    # about 9 bytes per edge, plus the queue entries not yet consumed (compacted in
    # batches): 600 000 edges went by, 12 bytes per edge of the bound hold them all
    assert max(sizes) < (1 << 16) * 12


def test_a_bound_smaller_than_one_chunk_is_refused():
    b, _, _ = session()
    with pytest.raises(ValueError):
        RecentTrace(b, max_edges=100, chunk_edges=512)
    assert RecentTrace(b).max_edges == MAX_EDGES
