"""The console's /trace, /vcd, /plot and /report (issue 6), on a fake wall clock."""

from __future__ import annotations

import os

import pytest

from rigs.console import advance, make_console
from rigs.vcd import read_vcd
from stepperdemo.front.console import META_COMMANDS, Console
from stepperdemo.watch import plots


@pytest.fixture
def console(tmp_path):
    c = make_console(tmp_path)
    yield c
    c.trace.close()


def said(c: Console, start: int) -> list[str]:
    return c.lines[start:]


def test_trace_commands_are_offered_for_completion():
    for name in ("/trace", "/vcd", "/plot", "/report"):
        assert name in META_COMMANDS


def test_nothing_to_show_when_started_without_the_recent_trace(tmp_path):
    c = make_console(tmp_path, recent_trace=False)
    n = len(c.lines)
    c.handle_line("/report")
    c.handle_line(f"/vcd {tmp_path / 'x.vcd'}")
    c.handle_line("/trace")
    assert said(c, n) == ["nothing recorded: /trace recent or /trace on records the pins"] * 2 \
        + ["trace is off"]
    assert not (tmp_path / "x.vcd").exists()


def test_trace_on_records_from_now_and_off_unsubscribes(console, tmp_path):
    advance(console, 0.5)
    sinks = console.backend.machine.pins.sinks
    console.handle_line("/trace on")
    assert console.lines[-1].startswith("trace on: recording the pins of every stepper from t=0.5")
    stream = console.trace.observers.stream
    assert stream in sinks
    console.handle_line("/trace on")
    assert console.lines[-1].startswith("trace is already on")
    console.handle_line("M1 A1000 V1000 R300")
    advance(console, 1.0)  # still moving: a VCD of what happened so far
    mid = tmp_path / "mid.vcd"
    console.handle_line(f"/vcd {mid}")
    assert console.lines[-1].startswith(f"wrote {mid}:")
    partial = read_vcd(str(mid))
    assert 0 < len(partial.rising("StepA")) < 300
    advance(console, 1.5)
    console.handle_line("/trace off")
    assert console.lines[-1].startswith("trace off:")
    assert stream not in sinks
    # after /trace off the recording is still there to save and analyse
    full = tmp_path / "full.vcd"
    console.handle_line(f"/vcd {full}")
    vcd = read_vcd(str(full))
    assert len(vcd.rising("StepA")) == 300
    assert vcd.timescale == "1 us"  # the console's unit: PulseView opens it at once
    assert vcd.times[0] >= 490_000  # from /trace on, not from boot
    n = len(console.lines)
    console.handle_line("/report")
    text = "\n".join(said(console, n))
    assert "pulses       300 (the channel counted 300), net +300 steps" in text
    assert "all 299 step intervals as planned" in text
    # moves after /trace off are not recorded
    console.handle_line("M1 R50")
    advance(console, 1.0)
    console.handle_line("/report")
    assert "pulses       300 " in "\n".join(console.lines[n:])


def test_report_while_moving_is_up_to_date(console):
    console.handle_line("/trace on")
    console.handle_line("M1 A100000 V100 R20000")
    advance(console, 0.6)
    pos = console.app.steppers[0].get_current_position()
    n = len(console.lines)
    console.handle_line("/report")
    text = "\n".join(said(console, n))
    # blocks of up to 255 pulses are reported when asked: at most one pulse in flight
    pulses = int(text.split("pulses       ")[1].split()[0])
    assert 0 <= pos - pulses <= 1 and pos > 1000


def test_plot_in_the_terminal_and_as_png(console, tmp_path):
    console.handle_line("/trace on")
    console.handle_line("M1 A2000 V500 R600")
    advance(console, 1.5)
    n = len(console.lines)
    console.handle_line("/plot")
    out = said(console, n)
    assert out[0] == "M1 position [steps]"
    assert any(0x2800 <= ord(ch) <= 0x28FF for line in out for ch in line)
    if plots.png_available():
        png = tmp_path / "p.png"
        console.handle_line(f"/plot {png}")
        assert console.lines[-1] == f"wrote {png}"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_arguments_and_arch_switch(console, tmp_path):
    console.handle_line("/trace maybe")
    assert console.lines[-1] == "/trace: on, off or recent"
    console.handle_line("/trace on")
    console.handle_line("/vcd")
    assert console.lines[-1] == ("/vcd: give a file name and, if you like, a time unit: "
                                 "/vcd FILE [1us|100ns|exact]")
    console.handle_line(f"/vcd {tmp_path}/x.vcd 3us")
    assert console.lines[-1] == ("/vcd: '3us' is no VCD time unit: give 1, 10 or 100 and s, "
                                 "ms, us, ns, ps or fs, e.g. 1us, or exact")
    assert not (tmp_path / "x.vcd").exists()
    console.handle_line(f"/vcd {tmp_path}/missing/dir/x.vcd")
    assert console.lines[-1].startswith("cannot write")
    spool = console.trace.observers.vcd_path
    assert os.path.exists(spool)
    console.handle_line("/arch esp32")  # the recording belonged to the old chip
    assert not console.trace.observers.active
    console.handle_line("/trace on")  # a new recording on the new chip
    assert console.trace.observers.backend is console.backend
    assert not os.path.exists(spool)  # the old spool file is gone
