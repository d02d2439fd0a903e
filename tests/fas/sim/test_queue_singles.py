"""The ramp task's queue sum on build d (SimChannel.queue_sum_ticks) reads the queue's
per-slot single flags (StepperQueue.singles): they must say what the entries say."""

from __future__ import annotations

import random

from fas.codes import AqeResult
from fas.quickstep.orders import RING
from rigs.sim import make
from tests.fas.quickstep.test_quickstep import _setup


def _by_entries(ch) -> int:
    """The sum as its definition has it: the entries queued after the running one."""
    q = ch.q
    p = ch.m.timing
    per_entry = p.fill_queued_entry_ticks
    per_single = p.fill_queued_single_ticks or per_entry
    total = 0
    k = (q.read_idx + 1) & 0xFF
    while q.read_idx != q.next_write_idx and k != q.next_write_idx:
        e = q.entries[k % q.queue_len]
        total += per_single if e.total_steps <= 1 else per_entry
        k = (k + 1) & 0xFF
    return total


def test_queue_sum_follows_the_entries_around_the_ring():
    backend, _, s = make(auto_enable=False)
    ch = s.queue.channel
    p = backend.machine.timing
    # build d's figures: a single step and a pause are summed at their own cost
    assert p.fill_queued_single_ticks and p.fill_queued_single_ticks != p.fill_queued_entry_ticks
    rng = random.Random(25)
    checked = 0
    for _ in range(400):
        steps = rng.choice((0, 1, 1, 2, 3, 7))
        res = s.add_queue_entry(rng.randrange(2_000, 6_000), steps, rng.random() < 0.8)
        assert res in (AqeResult.OK, AqeResult.QUEUE_FULL)
        backend.machine.run_until(backend.machine.now + rng.randrange(0, 30_000))
        assert ch.queue_sum_ticks(s.queue.read_idx) == _by_entries(ch)
        checked += 1
    assert s.queue.entries_added > 300  # the ring wrapped many times
    assert checked == 400


def test_a_shortened_quickstep_order_keeps_its_single_flag():
    _, _, s = _setup(depth=32)
    q = s.queue
    assert q.add_order(4_000, 1, True, None) == AqeResult.OK  # (running: the head)
    assert q.add_order(4_000, 5, True, None) == AqeResult.OK
    w = (q.next_write_idx - 1) & 0xFF
    assert q.singles[w % RING] == 0
    q.shorten_last(1)  # 5 steps -> 1: an order of one step now
    assert q.entries[w % RING].total_steps == 1
    assert q.singles[w % RING] == 1
    assert q.channel.queue_sum_ticks(q.read_idx) == _by_entries(q.channel)
