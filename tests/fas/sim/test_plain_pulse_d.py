"""Build d's plain step pulse as its replica measures it (docs/timing-model.md, "forty-third
pass"): 60 ticks on channel A, 70 on B, 62 / 72 with SIMAVR_TIME_MEASUREMENT
(``BUILD_D_REPLICA_PLAIN_PULSE_TICKS``, variant P43 of ``bench/d_corpus.py``).  Off by
default: alone it makes the corpus's pulse-high totals short (the model has no entry
waiting behind an instruction or the loop's and the ramp task's own sections); with S42 it
meets d11, which S42 alone fails, and fails d02.  Build d's ramp task's own sections per
command (``BUILD_D_REPLICA_CMD_MASK_SECTIONS``, variant K43, off) close d02; with the
loop's sections in a held W's passes as well (variant L43) the corpus fails test_sd_14
only.  Strict xfails name the values.  Since the fiftieth pass the four are build d's
default (with R47 N44 F44 T44): the tests of a variant start from the figures before it
(variant PRE49), where their values were read."""

from __future__ import annotations

import collections
import sys

import pytest

from fas.arch import ATMEGA328P
from fas.sim import SimBackend
from fas.sim import timing as sim_timing_module
from fas.sim.timing import sim_timing
from rigs import ROOT
from stepperdemo.program import make_program

sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import d_corpus  # noqa: E402
import plain_pulse  # noqa: E402
import pulse_widths  # noqa: E402

from .build_d_with import default_with  # noqa: E402

# the conformance inputs (sequences/conformance/d11.toml, d02.toml) and the firmware's
# Total High of stepper A with the corpus's tolerance (1.44 % + 1 us: upstream's widest
# for the 328P, the scenario files' justification; stepperdemo.scenarios.runner)
D11 = "M1 A6000 V90 R5000 M2 A5000 V110 R-4000 W M1 W"
D02 = "M1 A500 V80 R300 W"
FIRMWARE_HIGH_US = {D11: 19712, D02: 1156}
TOLERANCE = 0.0144


def _within(high: float, firmware: int) -> bool:
    return abs(high - firmware) <= TOLERANCE * firmware + 1
TWO = "M1 A1000 V100 R200 M2 A1000 V100 R200 W"  # both channels step, one after the other


def _pulses(text: str, build: str = "d") -> dict[str, list[tuple[int, int]]]:
    backend = SimBackend("atmega328p", record=True, build=build)
    app = make_program("demo", backend, scripted=True)
    app.run_script(text, firmware_end=True)
    return pulse_widths.backend_pulses(backend)


def _plain(pulses: list[tuple[int, int]]) -> int:
    return collections.Counter(b - a for a, b in pulses).most_common(1)[0][0]


def _high_us(text: str) -> float:
    return sum(b - a for a, b in _pulses(text)["A"]) / 16


def test_p43_sets_build_ds_tables_and_leaves_the_other_builds(
        monkeypatch: pytest.MonkeyPatch) -> None:
    e_before = sim_timing(ATMEGA328P, "e").isr_latency_ticks
    default_with(monkeypatch, "PRE49", "P43")
    assert sim_timing(ATMEGA328P, "d").isr_latency_ticks == (60, 70, 70)
    assert sim_timing(ATMEGA328P, "d_time_measurement").isr_latency_ticks == (62, 72, 72)
    assert sim_timing(ATMEGA328P, "e").isr_latency_ticks == e_before


def test_p43_makes_both_channels_plain_pulses_the_replicas(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "P43")
    pulses = _pulses(TWO)
    assert len(pulses["A"]) == len(pulses["B"]) == 200
    assert (_plain(pulses["A"]), _plain(pulses["B"])) == (60, 70)


def test_the_defaults_plain_pulses_are_the_replicas(monkeypatch: pytest.MonkeyPatch) -> None:
    # every build-d replica run's: 60 / 70 (bench/replica/plain_pulse.py, forty-third
    # pass); the default's since the fiftieth pass (a strict xfail before: 61 / 71, a
    # fitted figure, which PRE49 puts back)
    pulses = _pulses(TWO)
    assert (_plain(pulses["A"]), _plain(pulses["B"])) == (60, 70)
    default_with(monkeypatch, "PRE49")
    pulses = _pulses(TWO)
    assert (_plain(pulses["A"]), _plain(pulses["B"])) == (61, 71)


def test_s42_with_p43_meets_d11s_pulse_high_total(monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "P43")
    high = _high_us(D11)
    assert _within(high, FIRMWARE_HIGH_US[D11])


@pytest.mark.xfail(strict=True, reason="with S42 and P43 d02's pulse-high total is 1 136 us "
                   "against the firmware's 1 156 +- 17.6: the replica's 300 pulses hold 503 "
                   "ticks beyond the plain 60 (the ramp task's own sections 152, timer 0 "
                   "136, the loop's millis() 97 and queueEntries() 51, the UART 67), the "
                   "model's 191 (forty-third pass)")
def test_s42_with_p43_meets_d02s_pulse_high_total(monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "P43")
    high = _high_us(D02)
    assert int(high) == 1136  # (the value named)
    assert _within(high, FIRMWARE_HIGH_US[D02])


# the tool's readers on a written log: channel A's pulses (a repeated write of the same
# level is one edge) and vector 11's entries
PINS = """100 B1 1
100 B1 1
160 B1 0
160 B1 0
1000 B1 1
1065 B1 0
2000 B2 1
2070 B2 0
3000 B1 1
3060 B1 0
"""
EV = """100 V 11
236 R
1005 V 11
1140 R
2000 V 12
3000 V 11
3136 R
"""


def test_plain_pulse_reads_pulses_and_their_entries() -> None:
    pulses = plain_pulse.pulses(PINS.splitlines(), "B1")
    assert pulses == [(100, 60), (1000, 65), (3000, 60)]
    pairs = plain_pulse.waits(pulses, plain_pulse.vector_entries(EV.splitlines(), 11))
    assert pairs == [(0, 60), (5, 65), (0, 60)]
    s = plain_pulse.summary(pairs)
    assert (s["plain"], s["at_once"], s["waiting"]) == (60, 2, 1)
    assert s["widths_equal_plain_plus_wait"] == 3
    assert s["mean_short"] == pytest.approx(185 / 3)


LISTING = """
00000010 <__vector_11>:
      10:	1f 92       	push	r1
      12:	80 91 cf 04 	lds	r24, 0x04CF	; 0x8004cf <fas_queue+0x60>
      16:	83 13       	cpse	r24, r19
      18:	01 c0       	rjmp	.+2      	; 0x1c <__vector_11+0xc>
      1a:	ff cf       	rjmp	.-2      	; 0x1a <__vector_11+0xa>
      1c:	80 e8       	ldi	r24, 0x80	; 128
      1e:	80 93 82 00 	sts	0x0082, r24	; 0x800082 <__TEXT_REGION_LENGTH__+0x7f8082>
      22:	18 95       	reti
"""


def test_plain_pulse_walks_the_vector_to_the_force_compare_write() -> None:
    path = plain_pulse.path_cycles(LISTING, 11)
    assert [c for _, c in path] == [2, 2, 1, 2, 1]


def test_s42_with_p43_keeps_the_readme_moves_longest_pulse_the_firmwares_whole_us(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "P43")
    longest = max(b - a for a, b in _pulses("M1 A1000 V100 R3200 W")["A"])
    # the firmware's Max High (test_sd_01a_328p: 10 us, truncated to whole us by
    # upstream's eval.awk; the replica of this line: 174 ticks)
    assert longest // 16 == 10


def test_d_corpus_sets_a_tuple_and_the_time_measurement_table_alone(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49")
    d_corpus.set_build_d(["isr_latency_ticks=59,69", "tm.isr_latency_ticks=63,74,74"])
    assert sim_timing(ATMEGA328P, "d").isr_latency_ticks == (59, 69)
    assert sim_timing(ATMEGA328P, "d_time_measurement").isr_latency_ticks == (63, 74, 74)
    d_corpus.set_build_d(["fill_tail_mask_ticks="])  # a tuple set empty: off
    assert sim_timing(ATMEGA328P, "d").fill_tail_mask_ticks == ()
    for bad in ("isr_latency_ticks=60,x", "tm.w_every_pass=1"):
        with pytest.raises(ValueError, match="--set"):
            d_corpus.set_build_d([bad])


# test_sd_14_328p's input and the firmware's Total High (sequences/conformance; upstream's
# expect.txt holds it to 1 000 us)
SD14 = "M1 u A1000000 V40 f w2000 a-10000 W"
SD14_HIGH_US = 312737


def test_k43_sets_build_ds_task_sections_and_leaves_the_other_builds(
        monkeypatch: pytest.MonkeyPatch) -> None:
    e_before = sim_timing(ATMEGA328P, "e").fill_cmd_mask_sections
    default_with(monkeypatch, "PRE49", "K43")
    sections = sim_timing(ATMEGA328P, "d").fill_cmd_mask_sections
    assert sections == sim_timing_module.BUILD_D_REPLICA_CMD_MASK_SECTIONS
    assert sum(t for _, t in sections) == 155  # the thirteen widths read, per command
    assert sim_timing(ATMEGA328P, "e").fill_cmd_mask_sections == e_before


def test_s42_p43_k43_meet_d02s_and_d11s_pulse_high_totals(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "P43", "K43")
    assert _within(_high_us(D02), FIRMWARE_HIGH_US[D02])
    assert _within(_high_us(D11), FIRMWARE_HIGH_US[D11])


def test_l43_puts_the_loops_sections_into_the_passes_of_a_held_w(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "K43", "L43")
    with_sections = _pulses(D02)["A"]
    d_corpus.set_build_d(["w_pass_millis_before_end=0"])
    without = _pulses(D02)["A"]
    assert len(with_sections) == len(without) == 300
    # the same steps; more of them wait behind the passes' sections
    assert sum(b - a for a, b in with_sections) > sum(b - a for a, b in without)
    assert _within(sum(b - a for a, b in with_sections) / 16, FIRMWARE_HIGH_US[D02])


@pytest.mark.xfail(strict=True, reason="with S42 P43 K43 L43 (every build-d figure read "
                   "here) test_sd_14's pulse-high total is 310 688 us against the "
                   "firmware's 312 737 +- 1 000, the corpus's one failure: its start task "
                   "charges the direction checks a stepper without a direction pin skips "
                   "(its steps 2 203 ticks late, so timer 0 and the task hold other pulses; "
                   "forty-fourth pass: with N44 it is met, test_holders_d)")
def test_s42_p43_k43_l43_meet_test_sd_14s_pulse_high_total(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch, "PRE49", "S42", "P43", "K43", "L43")
    high = _high_us(SD14)
    assert int(high) == 310688  # (the value named)
    assert abs(high - SD14_HIGH_US) <= 1000
