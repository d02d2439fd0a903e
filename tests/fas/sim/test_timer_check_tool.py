"""Timer 1's compares against the hardware rule (``bench/replica/timer_check.py``, the
replica runner's ``TIMER_CHECK`` file; docs/timing-model.md, "twenty-fifth pass"): the
checker on written event lines, and simavr's rule that loses a compare due one cycle
after the timer's wrap, shown with a tiny AVR program run by the replica's runner."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import timer_check  # noqa: E402

P = timer_check.PERIOD


def test_every_hardware_match_is_a_flag_or_reported_missing() -> None:
    base = 1000  # overflows at 1000 + k * P (one start-up overflow elsewhere)
    lines = ["T 77", "W 500 0 100"]
    lines += [f"T {base + k * P + (k % 2)}" for k in range(1, 6)]  # processed 0-1 late
    # OCR1A = 100 -> flags at base + k P + 101; the one of k = 3 is not raised
    lines += [f"C {base + k * P + 101} 0" for k in (1, 2, 4)]
    lines += [f"W {base + 4 * P + 140} 0 30000", f"C {base + 4 * P + 30001 + 2} 0",
              f"C {base + 5 * P + 30001} 0", f"C {base + 5 * P + 7777} 0",  # this one: extra
              f"T {base + 6 * P}"]  # the last event ends what is judged
    lines.sort(key=lambda s: int(s.split()[1]))
    rep = timer_check.check(lines)
    assert rep.phase == base % P
    assert rep.expected[0] == 6  # k = 0 precedes the first kept overflow
    assert [(m.cycle, m.ocr, m.after_overflow) for m in rep.missing] == [
        (base + 3 * P + 101, 100, 101)]
    assert rep.extra[0] == 1
    assert "1 missing, 1 extra" in rep.summary()


def test_a_late_overflow_does_not_move_the_moment() -> None:
    # every overflow processed 2 cycles late: the compares' flags place the wrap
    lines = ["W 10 0 5000"]
    for k in range(1, 4):
        lines += [f"T {k * P + 2}", f"C {k * P + 5001} 0"]
    lines.append(f"T {4 * P + 2}")
    rep = timer_check.check(lines)
    assert rep.phase == 0
    assert not rep.missing and rep.expected[0] == 3


PROGRAM = r"""
#include <avr/io.h>
#include <avr/interrupt.h>
/* timer 1 in normal mode, prescaler 1: a compare every 8192 cycles, one in eight at
   OCR1A = 0, one cycle after the wrap; the main program runs call/ret pairs (4 cycles
   each), so the wrap often falls inside an instruction */
ISR(TIMER1_COMPA_vect) { OCR1A += 8192; }
ISR(TIMER1_OVF_vect) {}
__attribute__((noinline)) void f(void) { __asm__ volatile(""); }
int main(void) {
    TCCR1A = _BV(COM1A0);
    TCCR1B = _BV(CS10);
    OCR1A = 8192;
    OCR1B = 30000;
    DDRB |= _BV(1);
    TIMSK1 = _BV(OCIE1A) | _BV(TOIE1);
    sei();
    for (;;) f();
}
"""


def _simavr_flags() -> list[str] | None:
    if shutil.which("avr-gcc") is None or shutil.which("pkg-config") is None:
        return None
    r = subprocess.run(["pkg-config", "--cflags", "--libs", "simavr", "libelf"],
                       capture_output=True, text=True, check=False)
    return r.stdout.split() if r.returncode == 0 else None


@pytest.mark.skipif(_simavr_flags() is None, reason="needs avr-gcc and libsimavr-dev")
def test_simavr_loses_a_compare_due_one_cycle_after_a_late_wrap(tmp_path: Path) -> None:
    flags = _simavr_flags()
    assert flags is not None
    runner = tmp_path / "replica_run"
    runner_src = ROOT / "bench" / "replica" / "replica_run.c"
    subprocess.run(["gcc", "-O2", "-o", str(runner), str(runner_src), *flags, "-lm"], check=True)
    src = tmp_path / "t.c"
    src.write_text(PROGRAM)
    elf = tmp_path / "t.elf"
    subprocess.run(["avr-gcc", "-mmcu=atmega328p", "-Os", "-o", str(elf), str(src)], check=True)
    events = tmp_path / "t.timer"
    env = {"TASK_VECTOR": "13", "QUEUES": "2", "TIMER_CHECK": str(events)}
    subprocess.run([str(runner), str(elf), "atmega328p", "300", str(tmp_path / "t"), "B1"],
                   env=env, check=True, capture_output=True)
    rep = timer_check.check(events.read_text().splitlines())
    assert rep.overflows >= 70
    assert rep.expected[0] > 200 and rep.expected[1] >= 60
    # the rule: only the compares due one cycle after the wrap (OCR 0) are lost, on both
    # channels' timer alike; OCR1B = 30000 never is
    lost = rep.missing
    assert lost, "no compare lost: simavr's arming rule changed"
    assert {(m.channel, m.ocr, m.after_overflow) for m in lost} == {(0, 0, 1)}
    # the pin shows it as a gap of the period plus one or more wraps (toggle mode)
    edges: list[int] = []
    for line in (tmp_path / "t.pins").read_text().splitlines():
        c = int(line.split()[0])
        if c > P and (not edges or edges[-1] != c):  # from the first wrap on
            edges.append(c)
    gaps = [b - a for a, b in zip(edges, edges[1:], strict=False)]
    wraps = [g for g in gaps if g > 8200]
    assert wraps and all((g - 8192) % P <= 4 or (g - 8192) % P >= P - 4 for g in wraps)
    assert all(abs(g - 8192) <= 4 for g in gaps if g <= 8200)
