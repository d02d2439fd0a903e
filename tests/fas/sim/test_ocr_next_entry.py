"""The step interrupt writes its next compare later where it takes up the next queue entry.

FastAccelStepper's AVR compare interrupt clears the pin first and adds the period to the
compare register at its very end.  Where the running entry has more steps that end comes
25 cycles after the pin's clear; where the entry's last step is done and the next entry
is taken up (index, the entry's address, its direction bit, its step count) 49 (build e's
replica, the 328P and the 2560 alike: docs/timing-model.md, "thirty-fourth pass").  A
compare held back by a blocked section is missed - the 16-bit timer wraps first - when
the next one lies before that write: on the entry-switch path up to 24 ticks further into
the block.  ``SimTiming.isr_ocr_next_ticks`` (0 by default) adds that.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas import Engine
from fas.sim import SimBackend
from fas.sim import timing as sim_timing_module
from stepperdemo.demo.build import demo_build

PERIOD = 1600  # 10 kHz
BLOCK = 4 * (4 * 100 - 5) + 2  # StepperDemo's `e`: cli, delayMicroseconds(100), sei
WRAP = 65536


def _interval_after_block(monkeypatch: pytest.MonkeyPatch, next_extra: int, steps: int,
                          d: int) -> tuple[int, int]:
    """One-step (``steps`` 1) or two-step entries at PERIOD; a blocked section begins
    ``d`` ticks before the 7th step's compare: (that step's interval to the next, the
    threshold of the plain path: BLOCK + sei + lat + ocr - PERIOD)."""
    table = {k: replace(v, isr_ocr_next_ticks=(next_extra,))
             for k, v in sim_timing_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)
    backend = SimBackend("atmega328p", record=True, build="e")
    engine = Engine(backend)
    engine.init()
    pin = demo_build(backend.profile).steppers[0].step
    s = engine.stepper_connect_to_pin(pin)
    assert s is not None
    s.set_direction_pin(5)
    for _ in range(12 // steps):
        assert s.add_queue_entry(PERIOD, steps, True) == 0
    t = backend.machine.timing
    backend.run_for(3 * PERIOD)
    rises = backend.recorder.rising(pin)
    c = rises[0] + 6 * PERIOD  # the 7th step (of one-step entries: one entry of its own)
    backend.run_until(c - d)
    backend.machine.block_interrupts(BLOCK)
    backend.run_for(10 * WRAP)
    rises = backend.recorder.rising(pin)
    i = rises.index(c)
    return rises[i + 1] - c, BLOCK + t.sei_ticks + t.isr_latency(0) + t.isr_ocr_ticks - PERIOD


def test_without_the_figure_every_path_misses_at_one_threshold(monkeypatch) -> None:
    _, threshold = _interval_after_block(monkeypatch, 0, 1, 0)
    assert _interval_after_block(monkeypatch, 0, 1, threshold)[0] == PERIOD + WRAP
    assert _interval_after_block(monkeypatch, 0, 1, threshold + 1)[0] == PERIOD


def test_the_entry_switch_writes_its_compare_24_ticks_later(monkeypatch) -> None:
    _, threshold = _interval_after_block(monkeypatch, 24, 1, 0)
    # one-step entries: every interrupt takes up the next entry
    assert _interval_after_block(monkeypatch, 24, 1, threshold + 24)[0] == PERIOD + WRAP
    assert _interval_after_block(monkeypatch, 24, 1, threshold + 25)[0] == PERIOD
    # two-step entries: the 7th step is the first of its entry, the interrupt goes on
    # with the same entry and writes at the plain figure
    c7_first = _interval_after_block(monkeypatch, 24, 2, threshold + 1)[0]
    assert c7_first == PERIOD
