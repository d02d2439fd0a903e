"""Build d's `e` block and the UART's phase, read on build d's replica
(docs/timing-model.md, "thirty-first pass"): the block's length (landed), the line's start
after a hand-over (``SimTiming.uart_idle_start_ticks``, off by default), and the corpus
files that the measured phases move on the figures fitted before the fortieth pass (build
d) (build d's default since then reads its ramp task and both phases), with the firmware's
figures and tolerances."""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas.arch import ATMEGA328P
from fas.sim import timing as sim_timing_module
from fas.sim.backend import SimBackend
from fas.sim.timing import sim_timing
from fas.sim.uart import Uart
from rigs import ROOT
from stepperdemo.demo.build import demo_build
from stepperdemo.program import make_program
from stepperdemo.scenarios.runner import run_file

# build d's replica: cli to the SREG restore of every `e` block (d30: 4 905 blocks);
# build e's replica and firmware runs (e01-e18): 1 582
BUILD_D_BLOCK, BUILD_E_BLOCK = 1599, 1582
# build d's replica (60 runs): the firmware's transmit interrupts enter this much after
# the model's characters start on the wire, in every run
UART_LAG = 257


def test_build_ds_block_is_the_replicas_and_build_es_its_own() -> None:
    assert demo_build(ATMEGA328P, "d").irq_block_ticks == BUILD_D_BLOCK
    assert demo_build(ATMEGA328P).irq_block_ticks == BUILD_D_BLOCK  # the default build
    assert demo_build(ATMEGA328P, "e").irq_block_ticks == BUILD_E_BLOCK


def test_every_e_block_of_a_build_d_run_is_the_replicas_length() -> None:
    backend = SimBackend("atmega328p", build="d")
    blocks: list[tuple[int, int]] = []
    backend.machine.block_listeners.append(lambda a, b: blocks.append((a, b)))
    app = make_program("demo", backend, scripted=True)
    app.run_script("M1 A2000 V40 e R400 W", firmware_end=True)
    assert len(blocks) > 100
    assert {b - a for a, b in blocks} == {BUILD_D_BLOCK}


@pytest.mark.parametrize("build", [None, "d", "e"])
def test_the_uarts_start_lag_is_off_by_default(build) -> None:
    assert sim_timing(ATMEGA328P, build).uart_idle_start_ticks == 0


def test_a_hand_over_to_an_idle_line_starts_late_and_its_interrupts_keep_that_phase() -> None:
    u = Uart(1496, 64, idle_start=UART_LAG)
    for t in (1000, 1121, 1242):  # a print: three characters 121 ticks apart
        u.put(t)
    starts = [c[2] for c in u.records]
    assert starts == [1000 + UART_LAG, 1000 + UART_LAG + 1496, 1000 + UART_LAG + 2 * 1496]
    # characters 1 and 2 wait in the buffer: the transmit interrupt loads each when the
    # one before it starts
    assert u.loads == starts[:2]
    u.put(starts[-1] + 100)  # a hand-over while a character is on the wire: no lag
    assert u.records[-1][2] == starts[-1] + 1496
    u.put(10**6)  # the line idle again: the lag again
    assert u.records[-1][2] == 10**6 + UART_LAG


def test_a_load_held_by_a_blocked_section_starts_at_its_end() -> None:
    u = Uart(1496, 64, idle_start=UART_LAG)
    for _ in range(3):
        u.put(0)
    assert [c[2] for c in u.records] == [UART_LAG, UART_LAG + 1496, UART_LAG + 2992]
    u.interrupts_blocked(1000, 6000)  # character 2's load waits for the section's end
    assert [c[2] for c in u.records] == [UART_LAG, UART_LAG + 1496, 6000]


def _measured_d(monkeypatch: pytest.MonkeyPatch, uart: int) -> None:
    """Build d's 328P as fitted before the fortieth pass with both phases as the replica
    measures them (the ramp task 217 ticks later with its entry 217 shorter, timer 0 405;
    thirtieth pass) and the UART's line ``uart`` ticks after a hand-over."""
    _fitted(monkeypatch)
    t = sim_timing_module.BY_FAMILY["avr"]
    monkeypatch.setitem(sim_timing_module.BY_FAMILY, "avr", replace(
        t, task_phase_ticks=t.task_phase_ticks + 217, fill_entry_ticks=t.fill_entry_ticks - 217,
        timer0_lag_ticks=405, timer0_data_align=2, uart_idle_start_ticks=uart))


def _fitted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Build d's 328P as fitted before the fortieth pass (``bench/d_corpus.py``'s
    FIT)."""
    import sys  # noqa: PLC0415

    from stepperdemo.demo import build as demo_build_module  # noqa: PLC0415

    sys.path.insert(0, str(ROOT / "bench"))
    import d_corpus  # noqa: PLC0415

    for table, key in ((sim_timing_module.BY_FAMILY, "avr"),
                       (sim_timing_module.BY_BUILD["d_time_measurement"], "atmega328p"),
                       (demo_build_module.BY_PROFILE, "atmega328p")):
        monkeypatch.setitem(table, key, table[key])
    d_corpus.set_build_d(d_corpus.VARIANTS["FIT"])


def _check(name: str, what: str = "A pulse high total us"):
    res = run_file(ROOT / "sequences" / "conformance" / f"{name}.toml")
    assert res.error is None, res.error
    (check,) = [c for c in res.checks if c.what == what]
    return check


# d30 (`M1 A2000 V40 e R4000 W`) with both phases: its steps lie 215 ticks before the
# firmware's (one UART interrupt that the firmware runs inside the first ramp task runs
# before it in the model), 42 after with the UART's phase as well; its pulse-high total
# follows where the blocks fall against the steps
@pytest.mark.parametrize("uart, measured", [(0, 51218), (UART_LAG, 51099)])
@pytest.mark.xfail(strict=True, reason="d30 51 218 us with both phases, 51 099 with the "
                   "UART's as well, against 49 248 +- 710")
def test_d30_with_the_measured_phases(monkeypatch: pytest.MonkeyPatch, uart: int,
                                      measured: int) -> None:
    _measured_d(monkeypatch, uart)
    check = _check("d30")
    assert check.measured == measured  # (the value the reason names)
    assert abs(check.measured - check.expected) <= check.tolerance


# both phases close two deviations of the fitted figures (known deviations until the
# fortieth pass; the firmware's figures and tolerances)
@pytest.mark.parametrize("name, fitted, measured", [("d14", 208, 205), ("d38", 11588, 11537)])
def test_known_deviations_close_with_the_measured_phases(
        monkeypatch: pytest.MonkeyPatch, name: str, fitted: int, measured: int) -> None:
    _fitted(monkeypatch)
    check = _check(name)
    assert check.measured == fitted and abs(check.measured - check.expected) > check.tolerance
    _measured_d(monkeypatch, 0)
    check = _check(name)
    assert check.measured == measured
    assert abs(check.measured - check.expected) <= check.tolerance


# the files that the UART's phase puts out, and one it keeps (pulse high totals)
@pytest.mark.parametrize("name", [
    pytest.param("d29", marks=pytest.mark.xfail(
        strict=True, reason="5 817 us against 5 730 +- 83.5")),
    pytest.param("test_sd_07_328p", marks=pytest.mark.xfail(
        strict=True, reason="432 us against 420 +- 7.0")),
    "test_sd_09_328p",
])
def test_build_d_checks_with_the_measured_phases_and_the_uarts(
        monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    _measured_d(monkeypatch, UART_LAG)
    check = _check(name)
    assert abs(check.measured - check.expected) <= check.tolerance


# the `e` branch's own check (DemoBuild.e_check_ticks, off): build d's replica, d30's
# passes in a window 4 ticks beyond the loop's 330 / 467 and the block, 3 outside one
E_CHECK = {"e_check_ticks": 4, "e_outside_saved_ticks": 1}


def _e_check_in_build_d(monkeypatch: pytest.MonkeyPatch) -> None:
    from stepperdemo.demo import build as demo_build_module
    b = demo_build_module.BY_PROFILE[ATMEGA328P.name]
    monkeypatch.setitem(demo_build_module.BY_PROFILE, ATMEGA328P.name, replace(b, **E_CHECK))


@pytest.mark.parametrize("build", [None, "d", "e"])
def test_the_e_check_is_off_by_default(build) -> None:
    assert demo_build(ATMEGA328P, build).e_check_ticks == 0


def test_with_the_e_check_the_blocks_lie_as_far_apart_as_the_replicas(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import collections
    import sys
    sys.path.insert(0, str(ROOT / "bench" / "replica"))
    import block_pulses

    _e_check_in_build_d(monkeypatch)
    _, blocks, _ = block_pulses.model_run("M1 A2000 V40 e R4000 W")
    first = block_pulses.windows(blocks)[0]
    gaps = collections.Counter(b[0] - a[0] for a, b in zip(first, first[1:], strict=False))
    # the replica's two commonest (d30's first window): the letter's pass and `W`'s
    assert {g for g, _ in gaps.most_common(2)} == {1599 + 330 + 4, 1599 + 467 + 4}


@pytest.mark.xfail(strict=True, reason="with the e check (4 / 1) d30 50 481 us against "
                   "49 248 +- 710 (six of the eight as build d's default, fiftieth pass; "
                   "50 506 with all eight; 50 612 before, with build d's figures read, "
                   "fortieth pass; 48 307 "
                   "with those fitted before): the windows' starts and the blocks per window "
                   "are not the replica's yet (thirty-first pass)")
def test_d30_with_the_e_check(monkeypatch: pytest.MonkeyPatch) -> None:
    _e_check_in_build_d(monkeypatch)
    check = _check("d30")
    assert check.measured == 50481  # (the value the reason names)
    assert abs(check.measured - check.expected) <= check.tolerance
