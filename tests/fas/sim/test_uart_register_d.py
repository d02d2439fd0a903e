"""The console UART's transmitter and the ramp task's auto enable as build d's replica
shows them (docs/timing-model.md, "forty-second pass"): the simulator's transmitter has
one register (``SimTiming.uart_tx_single_register``, variant U42 of ``bench/d_corpus.py``
with the banner and the task's phase read again under it), and auto enable's
``enableOutputs()`` costs a start task CPU (``SimTiming.fill_enable_ticks``, variant
E42).  Both are off by default: with them the corpus fails (the pass's table); what the
default misses is a strict xfail naming the model's value."""

from __future__ import annotations

import sys
from collections import deque

import pytest

from fas.arch import ATMEGA328P
from fas.sim import SimBackend
from fas.sim.timing import sim_timing
from fas.sim.uart import Uart
from rigs import ROOT
from stepperdemo.program import make_program

sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import pulse_widths  # noqa: E402

from .build_d_with import default_with  # noqa: E402

BYTE = 1496  # one character on the simulator's line (11 bits at 136 cycles)
SD07 = "M1 V40 A1000000 R53 w1000 R53 w1000 ? W"  # test_sd_07_328p's input
SD01A = "? M1 A1000 V100 R3200 W t W"  # test_sd_01a_328p's input
# build d's replica (less its 96-tick lead): the banner's first character handed to the
# serial driver, test_sd_07_328p and test_sd_01a_328p (their inputs' lengths apart)
FIRST_CHAR = {SD07: 23120, SD01A: 23012}
# ... test_sd_07_328p's two moves: the first rising step edges (the firmware's own
# steps_A.tsv: 231 386.188 us and 1 238 990.375 us)
SD07_FIRST_STEPS = (3702179, 19823846)

README_MOVE = "M1 A1000 V100 R3200 W"
# build d's replica of README_MOVE (its own run, forty-second pass): each 100 ms status
# line's first character comes this long after timer 0's overflow before it (35 lines:
# 29 within 408-854 - the pass of W that reads the new millis(), then output_info() -
# and 6 later, a ramp task or a longer print in between)
STATUS_AFTER_TIMER0 = (408, 4030)


def _first_char(text: str) -> tuple[int, int]:
    """(the banner's first character's hand-over, the first transmit interrupt's load)
    of ``text``'s run in build d, up to the end of setup()."""
    backend = SimBackend("atmega328p", build="d")
    uart = backend.machine.uart
    writes: list[int] = []

    class Records(deque[list[int]]):  # the UART's records: each appended one is a hand-over
        def append(self, x: list[int]) -> None:
            writes.append(x[0])
            super().append(x)

    uart.records = Records(maxlen=uart.capacity)
    app = make_program("demo", backend, scripted=True)
    app.load_script(text)  # (run_script's built-in line: copied at reset)
    app.setup()
    return writes[0], uart.loads[0]


def _first_steps(text: str) -> list[int]:
    backend = SimBackend("atmega328p", record=True, build="d")
    app = make_program("demo", backend, scripted=True)
    app.run_script(text, firmware_end=True)
    return [a for a, _ in pulse_widths.backend_pulses(backend)["A"]]


@pytest.mark.parametrize("build", [None, "d", "e"])
def test_the_single_register_and_auto_enables_cost_are_off_by_default(build) -> None:
    t = sim_timing(ATMEGA328P, build)
    assert not t.uart_tx_single_register and t.fill_enable_ticks == 0
    assert t.uart_tx_buffer == 64


def test_one_register_loads_each_character_when_the_one_before_has_gone() -> None:
    u = Uart(BYTE, 63, single_register=True)
    for t in (1000, 1121, 1242):  # a print on a quiet line: three characters 121 apart
        u.put(t)
    starts = [c[2] for c in u.records]
    assert starts == [1000, 1000 + BYTE, 1000 + 2 * BYTE]
    # the simulator raises the transmit interrupt when a character is done: the first
    # one loads character 1 a character's time after character 0 was written
    assert u.loads == [1000 + BYTE, 1000 + 2 * BYTE]
    # a real chip's data register takes character 1 at once (it is no load)
    r = Uart(BYTE, 64)
    for t in (1000, 1121, 1242):
        r.put(t)
    assert r.loads == [1000 + BYTE]


def test_one_register_a_full_ring_of_63_waits_for_the_load_of_the_character_63_back() -> None:
    u = Uart(BYTE, 63, single_register=True)
    for _ in range(63):  # character 0 on the line, 1..62 in the ring
        assert u.room_at() < 0
        u.put(0)
    assert u.room_at() == 0  # character 63 fills the ring's 63rd place at once
    u.put(0)
    assert u.room_at() == BYTE  # character 64: when character 1 is loaded
    u.interrupts_blocked(BYTE - 10, BYTE + 500)  # a load held by a section waits for it
    assert u.loads[0] == BYTE + 500


@pytest.mark.parametrize("text", [SD07, SD01A])
def test_u42_hands_the_banners_first_character_over_at_the_replicas_tick(
        monkeypatch: pytest.MonkeyPatch, text: str) -> None:
    default_with(monkeypatch, "U42")
    first, load = _first_char(text)
    assert first == FIRST_CHAR[text]
    assert load == first + BYTE  # the replica: every transmit interrupt on this grid


@pytest.mark.xfail(strict=True, reason="the default hands the banner's first character "
                   "over 1 239 ticks after the replica (24 359 against 23 120 in "
                   "test_sd_07_328p) and its data register loads one character early: "
                   "its transmit interrupts come 257 ticks before the firmware's "
                   "(forty-second pass; U42 reads both)")
def test_the_default_hands_the_banner_over_at_the_replicas_tick() -> None:
    first, load = _first_char(SD07)
    assert (first, load) == (24359, 24359 + BYTE)  # (the values the reason names)
    assert first == FIRST_CHAR[SD07]


def test_u42_keeps_the_ramp_tasks_phase_and_the_moves(monkeypatch: pytest.MonkeyPatch) -> None:
    # (on the figures before the fiftieth pass, where it was read: with the eight of
    # the default since, U42 moves test_sd_07's steps 114 ticks - a transmit interrupt
    # fewer in its start task)
    default_with(monkeypatch, "PRE49")
    before = _first_steps(SD07)
    default_with(monkeypatch, "U42")
    assert _first_steps(SD07) == before  # engine.init() moves, the task's phase with it


def test_e42_charges_auto_enable_in_the_first_moves_start_task_only(
        monkeypatch: pytest.MonkeyPatch) -> None:
    before = _first_steps(SD07)
    default_with(monkeypatch, "E42")
    after = _first_steps(SD07)
    # the first move turns the outputs on: its start task 311 ticks longer (with E45's
    # ramp end in it, the default since the forty-fifth pass, no further transmit
    # interrupt falls into it: 311 + 114 before); the second finds them on
    assert after[0] - before[0] == 311
    assert after[53] == before[53]


@pytest.mark.xfail(strict=True, reason="test_sd_07_328p's second move starts 189 ticks "
                   "late against its first (the firmware's 16 121 667 ticks apart, the "
                   "model's 16 121 856 with the eight as build d's default, fiftieth "
                   "pass; 16 121 970 before); the first move's start task lacks auto "
                   "enable's 311 ticks and the start tasks' fit absorbed them (-122 with "
                   "E42 before the eight, forty-second pass)")
def test_sd07s_second_move_starts_as_the_firmwares_after_its_first() -> None:
    steps = _first_steps(SD07)
    assert steps[53] - steps[0] == 16121856  # (the value the reason names)
    assert steps[53] - steps[0] == SD07_FIRST_STEPS[1] - SD07_FIRST_STEPS[0]


def _status_after_timer0(text: str) -> list[int]:
    """Each 100 ms status line's first character after timer 0's overflow before it."""
    backend = SimBackend("atmega328p", build="d")
    m = backend.machine
    writes: list[int] = []

    class Records(deque[list[int]]):
        def append(self, x: list[int]) -> None:
            writes.append(x[0])
            super().append(x)

    m.uart.records = Records(maxlen=m.uart.capacity)
    app = make_program("demo", backend, scripted=True)
    app.run_script(text, firmware_end=True)
    out = bytes(app.transcript)
    return [(writes[i] - m._millis_phase) % m.timing.millis_overflow_ticks  # noqa: SLF001
            for i in range(1, len(writes))
            if writes[i] - writes[i - 1] > 1_000_000 and out[i:i + 2] == b"M1"]


def test_s42_starts_the_status_lines_where_the_replicas_passes_do(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42")  # S42 on the figures before the eight
    after = sorted(_status_after_timer0(README_MOVE))
    assert len(after) == 35
    assert after[0] >= STATUS_AFTER_TIMER0[0]
    assert STATUS_AFTER_TIMER0[0] <= after[len(after) // 2] <= 854  # the replica's band


def test_s42_makes_the_readme_moves_longest_pulse_the_firmwares_whole_us(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # S42 alone on the figures before the eight (with all eight, the default since the
    # fiftieth pass: 179 ticks, a strict xfail in tests/stepperdemo/watch/test_observe.py)
    default_with(monkeypatch, "PRE49", "S42")
    backend = SimBackend("atmega328p", record=True, build="d")
    app = make_program("demo", backend, scripted=True)
    app.run_script(README_MOVE, firmware_end=True)
    longest = max(b - a for a, b in pulse_widths.backend_pulses(backend)["A"])
    # the firmware's Max High (test_sd_01a_328p: 10 us; the replica of this line: 174
    # ticks) - upstream's eval.awk prints it truncated to whole us
    assert longest // 16 == 10


def test_readme_moves_status_lines_start_where_the_replicas_do(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # build d's replica: 408-854 ticks after timer 0's overflow (W's pass chain reads
    # millis() where it is, then output_info()); the default's since the fiftieth pass
    # (S42 in it).  Before, a strict xfail: every line 146 ticks after the overflow (an
    # idle W woke at the deadline itself), which PRE49 puts back
    after = sorted(_status_after_timer0(README_MOVE))
    assert len(after) == 35
    assert after[0] >= STATUS_AFTER_TIMER0[0]
    assert STATUS_AFTER_TIMER0[0] <= after[len(after) // 2] <= 854  # the replica's band
    default_with(monkeypatch, "PRE49")
    assert min(_status_after_timer0(README_MOVE)) == 146
