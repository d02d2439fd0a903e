"""The main loop's own critical sections (docs/timing-model.md, fourteenth and
twenty-sixth passes): off by default in every build; switched on, a step interrupt
requested inside one of the loop's cli..sei sections waits for its end, the chip takes
the widths measured on the replica together with them, and build d's pulse-high known
deviations d14 and d38 come within the firmware's tolerance while d12 and test_sd_07 go
out of theirs (the builds' own spread: the replica, build e, is outside both too)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas.arch import ATMEGA32U4, ATMEGA328P, ATMEGA2560
from fas.sim import timing as sim_timing_module
from fas.sim.machine import Machine
from fas.sim.timing import sim_timing
from rigs import ROOT
from stepperdemo.demo import build as demo_build_module
from stepperdemo.demo.build import demo_build
from stepperdemo.scenarios.runner import run_file

from .build_d_with import default_with

CHIPS = (ATMEGA328P, ATMEGA2560, ATMEGA32U4)


@pytest.mark.parametrize("build", ["d", "e"])
@pytest.mark.parametrize("profile", CHIPS, ids=lambda p: p.name)
def test_off_by_default(profile, build) -> None:
    # ... but in build d's ATmega328P since the fiftieth pass (variant L43 of
    # bench/d_corpus.py, with the other seven read in the forty-second to forty-seventh)
    on = profile is ATMEGA328P and build == "d"
    t = sim_timing(profile, build)
    assert t.loop_section_widths is on
    assert t.reti_next_ticks == (2 if on else 0)
    assert demo_build(profile, build).loop_sections is on


def test_the_replicas_figures_come_with_the_switch(monkeypatch: pytest.MonkeyPatch) -> None:
    d = sim_timing_module.AVR_TIMING
    assert d.isr_latency_ticks == (61, 71, 71) and d.isr_ocr_ticks == 29
    monkeypatch.setitem(sim_timing_module.BY_FAMILY, "avr", replace(d, loop_section_widths=True))
    on = sim_timing(ATMEGA328P, "d")
    # the replica: the pin falls 60 / 70 ticks after an entry at once, the next compare
    # 30 after it; the UART's routine 118 ticks to its reti, the reti 4, one instruction
    assert on.isr_latency_ticks == (60, 70, 70) and on.isr_ocr_ticks == 30
    assert (on.uart_hold_ticks, on.reti_next_ticks) == (122, 2)
    e = sim_timing_module.BY_BUILD["e"]
    monkeypatch.setitem(e, ATMEGA2560.name, replace(e[ATMEGA2560.name], loop_section_widths=True))
    mega = sim_timing(ATMEGA2560, "e")
    assert mega.isr_latency_ticks == (63, 73, 73) and mega.uart_hold_ticks == 126 + 5


def test_a_step_interrupt_waits_for_the_loops_section() -> None:
    m = Machine(ATMEGA328P, "d")
    start = m.now
    m.poll_begin(260, ((0, 11), (111, 11), (148, 11)))
    assert m.loop_polling
    big = 10**9  # no step interrupt of the asking channel in between
    assert m.loop_hold(start + 5, big, 0) == 6
    assert m.loop_hold(start + 50, big, 0) == 0
    assert m.loop_hold(start + 115, big, 0) == 7
    assert m.loop_hold(start + 260 + 148, big, 0) == 11  # the next pass
    # the passes run in the loop's own CPU time: a step interrupt of 20 ticks every 100
    # takes 20 from the first 131 ticks, so tick 131 is the pass's 111th
    assert m.loop_hold(start + 131, 100, 20) == 11
    assert m.loop_hold(start - 1, big, 0) == 0  # before the poll
    m.run_until(start + 1000)
    m.poll_end()
    assert not m.loop_polling
    assert m.loop_hold(start + 5, big, 0) == 6  # a block of pulses may still ask
    assert m.loop_hold(start + 1000 + 5, big, 0) == 0  # after the poll's end


def _sections_in_build_d(monkeypatch: pytest.MonkeyPatch) -> None:
    t = sim_timing_module.BY_FAMILY["avr"]
    monkeypatch.setitem(sim_timing_module.BY_FAMILY, "avr", replace(t, loop_section_widths=True))
    b = demo_build_module.BY_PROFILE[ATMEGA328P.name]
    monkeypatch.setitem(demo_build_module.BY_PROFILE, ATMEGA328P.name,
                        replace(b, loop_sections=True))


def _pulse_high(name: str):
    res = run_file(ROOT / "sequences" / "conformance" / f"{name}.toml")
    assert res.error is None, res.error
    (check,) = [c for c in res.checks if c.what == "A pulse high total us"]
    return check


# with build d's own loop passes (its replica, twenty-seventh pass; build e's gave 207
# and 11 481)
# (thirty-first pass: with build d's block and loop passes as its replica measures them;
# before them 205 and 11 464.  Fortieth pass: build d's figures read, the default, meet
# both without the sections; with the figures fitted before, 208 and 11 588 without them
# and 206 and 11 470 with them)
@pytest.mark.parametrize("name, off, on", [("d14", 205, 204), ("d38", 11518, 11384)])
def test_build_d_former_known_deviations_stay_met_with_the_sections(
        monkeypatch, name, off, on) -> None:
    # (the default: the sections and the seven with them, fiftieth pass)
    check = _pulse_high(name)
    assert abs(check.measured - check.expected) <= check.tolerance
    # the sections alone on the figures before the fiftieth pass (variant PRE49)
    default_with(monkeypatch, "PRE49")
    check = _pulse_high(name)
    assert not check.known and check.measured == off
    assert abs(check.measured - check.expected) <= check.tolerance
    _sections_in_build_d(monkeypatch)
    check = _pulse_high(name)
    assert check.measured == on
    assert abs(check.measured - check.expected) <= check.tolerance


# d12 and test_sd_07 with build d's own loop passes (twenty-seventh pass: 479 and 424;
# with build e's 477 and 428 us, out); test_sd_14 (the V40 lock of the steps against
# timer 0, twenty-sixth pass) still out
@pytest.mark.parametrize("name", [
    "d12", "test_sd_07_328p",
    pytest.param("test_sd_14_328p", marks=pytest.mark.xfail(
        strict=True, reason="with the sections 310 870 us against 312 737 +- 1 000 (build "
                            "d's figures read, fortieth pass: 313 033 without "
                            "them; 311 189 with the figures fitted before; the replica of build d "
                            "312 737.4)")),
])
def test_build_d_checks_with_the_sections(monkeypatch, name) -> None:
    # (the sections alone, on the figures before the fiftieth pass: the default's
    # since meets test_sd_14 with the other seven, tests/fas/sim/test_holders_d.py)
    default_with(monkeypatch, "PRE49")
    _sections_in_build_d(monkeypatch)
    check = _pulse_high(name)
    assert abs(check.measured - check.expected) <= check.tolerance
