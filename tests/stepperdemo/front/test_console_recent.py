"""The console records the recent motion by default (issue 16): /plot, /report and
/vcd without /trace on, the bound on the edges kept, /trace off|on|recent, /arch.
On virtual time: a fake wall clock drives the real-time driver."""

from __future__ import annotations

import pytest
from prompt_toolkit.output import DummyOutput

from rigs.console import advance, make_console, run_session, settle, wait
from rigs.vcd import read_vcd
from stepperdemo.front.console import Console
from stepperdemo.watch.observe import Observers
from stepperdemo.watch.recent import MAX_EDGES, RecentTrace

TPS = 16_000_000


@pytest.fixture
def console(tmp_path):
    c = make_console(tmp_path)
    yield c
    c.trace.close()


def run(c: Console, line: str) -> list[str]:
    n = len(c.lines)
    c.handle_line(line)
    return c.lines[n:]


def field(lines: list[str], label: str) -> str:
    return next(ln for ln in lines if ln.startswith(label))


def pins_position(report: list[str], n: int = 1) -> int:
    block = report[report.index(next(ln for ln in report if ln.startswith(f"M{n}  step pin"))):]
    line = field(block, "  pulses ")
    return int(line.split("position ")[1].split()[0])


def test_plot_report_and_vcd_right_after_a_move(console, tmp_path):
    assert isinstance(console.trace.recording, RecentTrace)
    console.handle_line("M1 A1000 V1000 R300")
    advance(console, 1.5)
    report = run(console, "/report")
    assert report[0].startswith("timing report: atmega328p, 0.000 s .. 1.5")
    assert "  pulses       300 (the channel counted 300), net +300 steps, position 300 by " \
           "the pins" in report
    assert "  vs. plan     all 299 step intervals as planned" in report
    assert not any("older ones dropped" in ln for ln in report)
    plot = run(console, "/plot")
    assert plot[0] == "M1 position [steps]"
    assert any(0x2800 <= ord(ch) <= 0x28FF for line in plot for ch in line)
    status = run(console, "/trace")
    assert status[0].startswith("trace recent: ")
    assert status[0].endswith(f"(keeps the last {MAX_EDGES})")  # nothing dropped
    path = tmp_path / "recent.vcd"
    wrote = run(console, f"/vcd {path}")[0]
    assert wrote.startswith(f"wrote {path}: ") and "dropped" not in wrote
    vcd = read_vcd(str(path))
    assert len(vcd.rising("StepA")) == 300


def test_help_states_the_bound(console):
    text = "\n".join(run(console, "/help"))
    assert f"the\nlast {MAX_EDGES} pin edges (about 10.5 s of one stepper at 25 kHz)" in text
    assert "/trace recent" in text and "/trace off" in text


def test_the_bound_holds_over_a_long_session_and_positions_stay_absolute(console, tmp_path):
    rec = console.trace.recording
    console.handle_line("M1 A1000000 V40 f")  # 25 000 steps/s: 50 000 edges/s
    advance(console, 16.0)
    console.handle_line("S")
    advance(console, 0.5)
    console.handle_line("b")  # back, through the dropped part and beyond
    advance(console, 8.0)
    console.handle_line("S")
    advance(console, 0.5)
    rec.flush()
    assert rec.dropped > MAX_EDGES  # about 1.2 million edges went by
    assert rec.peak_held <= MAX_EDGES and rec.held <= MAX_EDGES
    assert rec.held >= MAX_EDGES - rec.chunk_edges
    library = console.app.steppers[0].get_current_position()
    report = run(console, "/report")
    assert report[1] == (f"  (the recent recording: {rec.held} pin edges kept, {rec.dropped} "
                         "older ones dropped; positions carried forward)")
    assert pins_position(report) == library  # no "the library says" line either
    assert not any("the library says" in ln for ln in report)
    pulses = field(report, "  pulses ")
    n = int(pulses.split()[1])
    assert f"(the channel counted {n})" in pulses
    net = int(pulses.split("net ")[1].split()[0])
    forward, backward = (n + net) // 2, (n - net) // 2
    assert forward > 0 and backward > 190_000  # the end of the run forward, all of the back
    plan = field(report, "  vs. plan ")  # two motions in the window: n - 2 intervals
    assert plan == f"  vs. plan     all {n - 2} step intervals as planned"
    queue = field(report, "  queue ")
    assert queue.startswith("  queue        2 motion(s), ran empty 2x,"), queue
    start = float(report[0].split(", ")[1].split(" s")[0])
    assert start > 10.0  # the window moved on
    wrote = run(console, f"/vcd {tmp_path / 'tail.vcd'}")[0]
    assert wrote.endswith(f" - the start was dropped: the recent recording keeps the last "
                          f"{MAX_EDGES}")
    vcd = read_vcd(str(tmp_path / "tail.vcd"))
    assert len(vcd.rising("StepA")) == n
    status = run(console, "/trace")[0]
    assert f"; {rec.dropped} older edges dropped)" in status


def test_a_window_starting_inside_a_move_counts_from_its_head(tmp_path):
    # a small bound: the head moves several times during the moves
    c = make_console(tmp_path, trace_edges=4096)
    rec = c.trace.recording
    c.handle_line("M1 A20000 V100 R3000")
    advance(c, 1.0)
    c.handle_line("M1 R-1000")  # while still moving: lands at 2029
    advance(c, 0.6)
    report = run(c, "/report")
    assert rec.dropped >= 4096 and rec.peak_held <= 4096
    assert pins_position(report) == c.app.steppers[0].get_current_position() == 2029
    pulses = field(report, "  pulses ")
    n = int(pulses.split()[1])
    net = int(pulses.split("net ")[1].split()[0])
    assert 0 < n < 2048 and f"(the channel counted {n})" in pulses
    assert -1000 <= net < 0  # the window starts before the reversal
    plan = field(report, "  vs. plan ")  # the reversal starts a new motion: n - 2 intervals
    assert plan == f"  vs. plan     all {n - 2} step intervals as planned"
    c.trace.close()


def test_trace_off_keeps_the_last_recording_and_on_records_unbounded(console):
    console.handle_line("M1 A1000 V1000 R300")
    advance(console, 1.5)
    off = run(console, "/trace off")[0]
    assert off.startswith("trace off: recording stopped; the recent ") and \
        off.endswith("stay for /vcd, /plot and /report")
    stream = console.trace.recording.stream
    assert stream not in console.backend.machine.pins.sinks
    console.handle_line("M1 R100")  # not recorded
    advance(console, 1.0)
    assert "  pulses       300 (the channel counted 300), net +300 steps, position 300 by " \
           "the pins" in run(console, "/report")
    assert run(console, "/plot")[0] == "M1 position [steps]"
    assert run(console, "/trace")[0].startswith("trace off: the last recording (")
    assert run(console, "/trace off") == ["trace is off"]
    on = run(console, "/trace on")[0]
    assert on.startswith("trace on: recording the pins of every stepper from t=2.5")
    assert isinstance(console.trace.recording, Observers)
    console.handle_line("M1 A1000000 V40 f")  # past the recent bound: all of it is kept
    advance(console, 11.0)
    console.handle_line("S")
    advance(console, 0.5)
    rec = console.trace.recording
    rec.flush()
    assert rec.edges() > MAX_EDGES
    report = run(console, "/report")
    assert pins_position(report) == console.app.steppers[0].get_current_position()
    assert "net +" in field(report, "  pulses ") and not any("dropped" in ln for ln in report)
    net = int(field(report, "  pulses ").split("net ")[1].split()[0])
    assert net == console.app.steppers[0].get_current_position() - 400
    assert run(console, "/trace on")[0].startswith("trace is already on")
    back = run(console, "/trace recent")[0]
    assert back.startswith(f"trace recent: recording the last {MAX_EDGES} pin edges")
    assert isinstance(console.trace.recording, RecentTrace)
    assert run(console, "/trace recent")[0].startswith("trace recent is already on")


def test_arch_switch_records_the_new_chip(console):
    old = console.trace.recording
    console.handle_line("/arch esp32")
    rec = console.trace.recording
    assert isinstance(rec, RecentTrace) and rec is not old and rec.active
    assert rec.backend is console.backend
    assert old.stream not in old.backend.machine.pins.sinks
    console.handle_line("0")  # the pin configuration the ESP32 build asks for
    advance(console, 0.2)
    console.handle_line("M3 A1000 V1000 R200")
    advance(console, 1.5)
    report = run(console, "/report")
    assert report[0].startswith("timing report: esp32,")
    assert any(ln.startswith("M3  step pin") for ln in report)
    assert pins_position(report, 3) == 200
    # /trace on, then /arch: the unbounded recording of the old chip stays
    console.handle_line("/trace on")
    kept = run(console, "/arch atmega328p")
    assert kept[-1] == ("trace off: the recording on the esp32 stays for /vcd, /plot and "
                        "/report; /trace recent or /trace on records the new chip")
    assert not console.trace.recording.active
    assert console.trace.recording.backend is not console.backend
    # off stays off on the next chip
    console.handle_line("/arch atmega2560")
    assert not console.trace.recording.active
    assert run(console, "/trace recent")[0].startswith("trace recent: recording")


@pytest.mark.parametrize("edges", [MAX_EDGES, 2048])
def test_the_winder_replays_its_interlock_from_the_window(tmp_path, edges):
    # the program's own consumer (the interlock meter) is fed the replay and starts
    # from the window's positions: with 2048 edges the start of the motion is dropped
    c = make_console(tmp_path, program="winder", trace_edges=edges)
    advance(c, 0.2)
    c.handle_line("ratio 1:3 interlock 1 pots pot 1 900")
    advance(c, 0.8)
    report = run(c, "/report")
    assert bool(c.trace.recording.dropped) == (edges == 2048)
    interlock = field(report, "interlock ")
    error = float(interlock.split("= ")[1].split()[0])
    assert interlock.startswith("interlock    1 stretch(es) at 1:3:") and error < 1.0
    assert pins_position(report, 2) == c.app.steppers[1].get_current_position()
    c.trace.close()


def test_plot_and_report_through_the_prompt(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("M1 A1000 V1000 R300\r")
        await wait(clock, 1.5)
        inp.send_text("/report\r")
        await settle()
        inp.send_text("/plot\r")
        await settle()

    console, rc = run_session(script, tmp_path, redraw_postpone_s=None)
    assert rc == 0
    assert "  pulses       300 (the channel counted 300), net +300 steps, position 300 by " \
           "the pins" in console.lines
    assert "M1 position [steps]" in console.lines


def test_the_gcode_console_records_too(tmp_path):
    c = make_console(tmp_path, program="gcode")
    advance(c, 0.2)
    c.handle_line("G1 X10 F600")
    advance(c, 2.0)
    report = run(c, "/report")
    assert report[0].startswith("timing report: atmega328p, 0.000 s")
    assert pins_position(report) == c.app.steppers[0].get_current_position() > 0
    c.trace.close()


def test_nothing_is_recorded_on_a_device(tmp_path):
    from fas.device.loopback import Loopback

    with Loopback() as lb:
        c = Console(backend=lb.backend, output=DummyOutput(), history=str(tmp_path / "h"))
        assert c.trace.recording is None  # the pins are on the device
        assert run(c, "/plot") == ["/plot: not on a device (its profile and clock are its own)"]
