"""bench/replica/uart_phase.py's readers on written replica logs (docs/timing-model.md,
"forty-second pass")."""

from __future__ import annotations

import sys
from pathlib import Path

from rigs import ROOT

sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import uart_phase  # noqa: E402

LOG = """0 C 0
12000 S d38
23216 C 1074
23233 S 1088
23340 C 1064
23354 S 1088
24723 V 19
24730 C 1064
24735 S 1088
24841 R
26000 V 13 | |
26100 V 19
26218 R
30000 R
30100 C 1650
30110 S 1650
"""
PINS = """26150 B1 1
26150 B1 1
26400 B1 0
30105 B1 1
30175 B1 0
40000 B2 1
"""


def _write(tmp_path: Path) -> tuple[Path, Path]:
    ev, pins = tmp_path / "x.ev", tmp_path / "x.pins"
    ev.write_text(LOG)
    pins.write_text(PINS)
    return ev, pins


def test_the_drivers_sections_of_the_main_program_are_its_characters(tmp_path: Path) -> None:
    ev, _ = _write(tmp_path)
    events = uart_phase.replica_events(ev)
    # the section inside the transmit interrupt is not a hand-over; the lag comes off
    assert uart_phase.replica_chars(events, 96) == [23120, 23244]
    assert uart_phase.replica_vector(events, "19", 96) == [24623, 26000]


def test_pulses_and_what_held_them(tmp_path: Path) -> None:
    ev, pins = _write(tmp_path)
    events = uart_phase.replica_events(ev)
    pulses = uart_phase.replica_pulses(pins, 0)
    assert pulses == [(26150, 26400), (30105, 30175)]  # B1 only, repeated levels once
    spans, sections = uart_phase.holders(events, 0)
    starts, sec_starts = [s[0] for s in spans], [s[0] for s in sections]
    # inside the long ramp task, behind the UART's routine nested in it
    assert uart_phase.held_by(26150, spans, starts, sections, sec_starts) == "V19"
    # the loop's own section with interrupts off
    assert uart_phase.held_by(30105, spans, starts, sections, sec_starts) == "cli 1650"
    assert uart_phase.held_by(29000, spans, starts, sections, sec_starts) == "V13's own sections"
    assert uart_phase.held_by(50000, spans, starts, sections, sec_starts) == "-"


def test_the_full_buffers_offset_and_the_status_lines() -> None:
    rep = [0, 114, 1610, 3106, 4602, 2_000_000, 2_000_114]
    mod = [5, 119, 1466, 2962, 4458, 2_000_300, 2_000_414]
    # only characters a character's time after the one before on both sides count
    # (the model's third came 1 347 after its second: its buffer was not full yet)
    assert uart_phase.full_offset(rep, mod) == (-144, 2)
    text = b"ab\r\n\rM1: "
    assert uart_phase.status_starts(rep, text) == [5]
