"""Build d's ATmega328P default with variants of bench/d_corpus.py for one test: shared by
the tests of the forty-second and forty-third passes (test_uart_register_d.py,
test_plain_pulse_d.py)."""

from __future__ import annotations

import sys

import pytest

from fas.sim import timing as sim_timing_module
from rigs import ROOT
from stepperdemo.demo import build as demo_build_module

sys.path.insert(0, str(ROOT / "bench"))

import d_corpus  # noqa: E402


def default_with(monkeypatch: pytest.MonkeyPatch, *variants: str) -> None:
    """Build d's ATmega328P default with ``variants`` of bench/d_corpus.py for this test
    (the tables are put back when the test ends)."""
    for table, key in ((sim_timing_module.BY_FAMILY, "avr"),
                       (sim_timing_module.BY_BUILD["d_time_measurement"], "atmega328p")):
        monkeypatch.setitem(table, key, table[key])
    monkeypatch.setitem(demo_build_module.BY_PROFILE, "atmega328p",
                        demo_build_module.BY_PROFILE["atmega328p"])
    d_corpus.set_build_d([s for v in variants for s in d_corpus.VARIANTS[v]])
