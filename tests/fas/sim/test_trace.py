"""fas.sim.trace: edges in global time order, VCD files that viewers and readers accept."""

from __future__ import annotations

import subprocess

from fas import Engine
from fas.sim import SimBackend
from fas.sim.trace import (
    IRQ_BLOCKED,
    EdgeStream,
    VcdTrace,
    timescale_factor,
    vcd_timescale,
)
from rigs.tools import need_tools
from rigs.vcd import read_vcd

SIGNALS = {9: "StepA", 5: "DirA", 6: "EnableA", 10: "StepB", 7: "DirB", 8: "EnableB"}


class Collect:
    """An ordered-edge consumer that keeps everything (pin, tick, level)."""

    def __init__(self) -> None:
        self.edges: list[tuple[int, int, int]] = []

    def edge_run(self, pin, times, levels) -> None:
        self.edges.extend((pin, t, lv) for t, lv in zip(times, levels, strict=True))


def two_steppers(backend: SimBackend):
    engine = Engine(backend)
    engine.init()
    out = []
    for step, direction, enable in ((9, 5, 6), (10, 7, 8)):
        s = engine.stepper_connect_to_pin(step)
        s.set_direction_pin(direction)
        s.set_enable_pin(enable)
        s.set_auto_enable(True)
        out.append(s)
    return engine, out


def move_both(backend, a, b) -> None:
    a.set_speed_in_us(100)
    a.set_acceleration(20000)
    b.set_speed_in_us(70)
    b.set_acceleration(50000)
    a.move(3000)
    b.move(-2500)
    backend.wait_until(lambda: not a.is_running() and not b.is_running())
    a.move(-1000)
    backend.run_for_ms(300)


def test_timescale_is_the_coarsest_exact_standard_unit():
    assert vcd_timescale(16_000_000) == ("100 ps", 625, 1)
    assert vcd_timescale(1_000_000) == ("1 us", 1, 1)
    ts, num, den = vcd_timescale(20_000_000)
    assert ts == "10 ns" and (num, den) == (5, 1)
    # 21 MHz has no exact decimal period: picoseconds, rounded down, ticks stay distinct
    assert vcd_timescale(21_000_000) == ("1 ps", 10**12, 21_000_000)
    assert timescale_factor("1 ns", 16_000_000) == (125, 2)
    assert timescale_factor("100 ps", 16_000_000) == (625, 1)


def test_stream_hands_on_edges_in_global_time_order_and_complete():
    backend = SimBackend("atmega328p", record=True)
    stream = EdgeStream(backend, flush_edges=64)  # flush often: exercise the watermark
    got = Collect()
    stream.add(got)
    stream.start()
    _, (a, b) = two_steppers(backend)
    move_both(backend, a, b)
    stream.stop()
    times = [t for _, t, _ in got.edges]
    assert times == sorted(times)
    assert stream.late_edges == 0
    rec = backend.recorder
    for pin in (9, 10, 5, 7, 6, 8):
        mine = [(t, lv) for p, t, lv in got.edges if p == pin]
        rt, rl = rec.pin_edges(pin)
        assert mine == list(zip(rt, rl, strict=True)), pin
    # both steppers really ran at the same time, so the blocks had to be interleaved
    first_b = min(t for p, t, _ in got.edges if p == 10)
    last_a = max(t for p, t, _ in got.edges if p == 9)
    assert first_b < last_a


def test_stream_memory_is_bounded_by_the_flush_size_not_the_run():
    backend = SimBackend("atmega328p")
    stream = EdgeStream(backend, flush_edges=4096)
    stream.start()
    engine = Engine(backend)
    engine.init()
    s = engine.stepper_connect_to_pin(9)
    s.set_direction_pin(5)
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(60_000)
    backend.wait_until(lambda: not s.is_running())
    stream.stop()
    assert stream.edges_out >= 120_000
    assert stream.peak_buffered < 4096 + 2 * 255 * 2 + 16


def test_interrupt_block_windows_become_a_signal():
    backend = SimBackend("atmega328p")
    stream = EdgeStream(backend)
    got = Collect()
    stream.add(got)
    stream.start()
    m = backend.machine
    for start in (1000, 5000, 9000):
        m.run_until(start)
        m.block_interrupts(1600)
    m.run_until(20_000)
    stream.stop()
    irq = [(t, lv) for p, t, lv in got.edges if p == IRQ_BLOCKED]
    assert irq == [(1000, 1), (2600, 0), (5000, 1), (6600, 0), (9000, 1), (10600, 0)]


def test_vcd_of_two_steppers_reads_back_with_the_simulators_counts(tmp_path):
    backend = SimBackend("atmega328p")
    path = str(tmp_path / "two.vcd")
    trace = VcdTrace(backend, path, SIGNALS).start()
    _, (a, b) = two_steppers(backend)
    move_both(backend, a, b)
    trace.close()
    vcd = read_vcd(path)
    assert vcd.timescale == "100 ps"
    pins = backend.machine.pins
    for pin, name in SIGNALS.items():
        assert len(vcd.rising(name)) == pins.rising(pin), name
        assert len(vcd.falling(name)) == pins.falling(pin), name
    # exact ticks: 625 VCD units per tick
    assert all(t % 625 == 0 for t in vcd.times)
    assert vcd.times == sorted(vcd.times)
    # the position from the pins: count rising steps, up while the dir pin is HIGH
    for name, dname, stepper in (("StepA", "DirA", a), ("StepB", "DirB", b)):
        dir_edges = vcd.edges(dname)
        pos, level, j = 0, vcd.initial[vcd.ids[dname]], 0
        for t in vcd.rising(name):
            while j < len(dir_edges) and dir_edges[j][0] <= t:
                level = dir_edges[j][1]
                j += 1
            pos += 1 if level else -1
        assert pos == stepper.get_current_position()


def test_trace_switched_on_and_off_while_running(tmp_path):
    backend = SimBackend("atmega328p", record=True)
    _, (a, _) = two_steppers(backend)
    a.set_speed_in_us(50)
    a.set_acceleration(100_000)
    a.move(20_000)
    backend.run_for_ms(100)
    path = str(tmp_path / "mid.vcd")
    trace = VcdTrace(backend, path, SIGNALS).start()
    assert trace.stream in backend.machine.pins.sinks
    backend.run_for_ms(200)
    trace.close()
    assert trace.stream not in backend.machine.pins.sinks
    assert trace.stream.late_edges == 0
    vcd = read_vcd(path)
    rec_times, rec_levels = backend.recorder.pin_edges(9)
    recorded = set(zip(rec_times, rec_levels, strict=True))
    mine = [(t // 625, v) for t, v in vcd.edges("StepA")]
    assert len(mine) > 1000
    assert set(mine) <= recorded
    start = vcd.times[0] // 625
    assert all(t >= start for t, _ in mine)


def test_gtkwave_reads_the_file(tmp_path):
    need_tools("vcd2fst", "fst2vcd", package="gtkwave")
    backend = SimBackend("atmega328p")
    path = str(tmp_path / "g.vcd")
    trace = VcdTrace(backend, path, SIGNALS).start()
    _, (a, b) = two_steppers(backend)
    move_both(backend, a, b)
    trace.close()
    fst = str(tmp_path / "g.fst")
    subprocess.run(["vcd2fst", path, fst], check=True, capture_output=True)
    back = subprocess.run(["fst2vcd", fst], check=True, capture_output=True, text=True).stdout
    again = tmp_path / "back.vcd"
    again.write_text(back)
    vcd = read_vcd(str(again))
    assert len(vcd.rising("StepA")) == backend.machine.pins.rising(9)
    assert len(vcd.rising("StepB")) == backend.machine.pins.rising(10)


def test_sigrok_reads_the_file_as_pulseview_does(tmp_path):
    need_tools("sigrok-cli", package="sigrok-cli")
    backend = SimBackend("atmega328p")
    path = str(tmp_path / "s.vcd")
    trace = VcdTrace(backend, path, SIGNALS).start()
    _, (a, _) = two_steppers(backend)
    a.set_speed_in_us(200)
    a.set_acceleration(50_000)
    a.move(300)
    backend.wait_until(lambda: not a.is_running())
    trace.close()
    out = str(tmp_path / "sr.vcd")
    # PulseView imports through libsigrok; downsample 625 gives one sample per tick
    subprocess.run(["sigrok-cli", "-I", "vcd:downsample=625", "-i", path, "-O", "vcd",
                    "-o", out], check=True, capture_output=True)
    with open(out) as f:
        text = f.read()
    ident = next(line.split()[3] for line in text.splitlines()
                 if line.startswith("$var") and line.split()[4] == "StepA")
    rises = sum(tok == "1" + ident for line in text.splitlines() if not line.startswith("$")
                for tok in line.split())
    assert rises == 300


def _sampled_run(settle: bool):
    backend = SimBackend("atmega328p", record=True)
    stream = EdgeStream(backend)
    stream.start()
    _, (a, b) = two_steppers(backend)
    a.set_speed_in_us(60)
    a.set_acceleration(40_000)
    b.set_speed_in_us(90)
    b.set_acceleration(30_000)
    a.move(4000)
    b.move(-3000)
    seen = []
    for _ in range(300):
        backend.run_for(16_000 * 7 // 3)  # odd interval: lands inside blocks
        if settle:
            stream.flush(settle=True)
        seen.append((a.get_current_position(), b.get_current_position(),
                     a.get_current_speed_in_milli_hz(), b.is_running()))
    stream.stop()
    rec = backend.recorder
    return seen, [rec.pin_edges(p) for p in (9, 10, 5, 7, 6, 8)]


def test_settling_blocks_for_a_trace_does_not_change_the_run():
    assert _sampled_run(settle=True) == _sampled_run(settle=False)
