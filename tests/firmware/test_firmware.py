"""The device firmware (firmware/) in simavr behind the serial backend, end to end.

The host opens the chip's UART through a real pty with pyserial - the path of
``stepperdemo --port`` - and the chip runs in lockstep with the host's virtual clock
(``Loopback(device="simavr")``), so every run is deterministic.  What must come out:
the simulated backend's positions and pulse counts, on the device's own counters and
on its pins (rising step edges, counted with the direction pin levels).
"""

from __future__ import annotations

import pytest

from fas.device.loopback import Loopback
from fas.serial.protocol import D_ESTOP, D_WATCHDOG
from rigs import ROOT
from rigs.demo import moving
from rigs.firmware import need_firmware, run_firmware
from rigs.serial import LINES, NOISY, TPS, run_sim
from stepperdemo.demo.app import StepperDemo

QUICK = {LINES[0], LINES[5], LINES[10]}  # in the default run; the rest with -m long


@pytest.fixture(scope="module", autouse=True)
def firmware():
    need_firmware()


def _check_clean(out) -> None:
    c = out.counters
    assert c["entries_lost"] == c["entries_duplicated"] == c["overflows"] == 0
    assert c["rejected"] == 0


@pytest.mark.parametrize("line", [pytest.param(ln, marks=() if ln in QUICK else pytest.mark.long)
                                  for ln in LINES])
def test_acceptance_line_ends_like_the_simulation(line):
    sim = run_sim(line)
    fw = run_firmware(line)
    assert fw.positions == sim.positions
    assert fw.device_positions == sim.positions
    if "@" not in line:  # `@` renames the position; the pins count the steps made
        assert fw.pin_positions == sim.positions
    assert fw.pin_pulses == sim.pulses == fw.status_pulses
    _check_clean(fw)


def test_two_steppers_one_after_the_other():
    """The issue's acceptance line: M1 3200 pulses at 3200, M2 1000 at -1000."""
    fw = run_firmware("M1 A1000 V100 R3200 W M2 A2000 V200 R-1000 W")
    assert fw.positions == fw.device_positions == fw.pin_positions == [3200, -1000]
    assert fw.pin_pulses == fw.status_pulses == [3200, 1000]
    assert "M1: @3200" in fw.transcript
    _check_clean(fw)


@pytest.mark.parametrize("line", [LINES[0], pytest.param(LINES[5], marks=pytest.mark.long)])
def test_noisy_line_loses_and_repeats_no_command(line):
    """1 % corrupted, 0.5 % dropped, 0.5 % duplicated bytes, 1 ms latency each way."""
    sim = run_sim(line)
    fw = run_firmware(line, faults=NOISY)
    assert fw.positions == fw.device_positions == fw.pin_positions == sim.positions
    assert fw.pin_pulses == sim.pulses
    c = fw.counters
    assert c["entries_lost"] == c["entries_duplicated"] == 0
    assert fw.link["retransmissions"] > 0  # the faults were there, and repaired
    assert c["crc_errors"] + c["framing_errors"] > 0
    assert c["frames_duplicate"] + c["frames_out_of_order"] > 0


TWO_25KHZ = "M1 A100000 V40 R20000 M2 A100000 V40 R-20000 W M2 W"


@pytest.mark.parametrize("baud", [115200, 1_000_000])
def test_two_steppers_at_25_khz(baud):
    """The link's hardest case at both line speeds: every byte taken (the receive path
    keeps up with 1 000 000 baud while both steppers run), no frame sent again, no
    underrun."""
    fw = run_firmware(TWO_25KHZ, baud=baud)
    assert fw.positions == fw.pin_positions == [20000, -20000]
    assert fw.pin_pulses == [20000, 20000]
    _check_clean(fw)
    assert fw.rx_overruns == 0
    assert fw.counters["underruns"] == fw.counters["late_starts"] == 0
    assert fw.link["retransmissions"] == 0


def _moving(lb: Loopback, steps: int = 100_000, run_ms: int = 500):
    return moving(lb.backend, steps=steps, speed_us=100, accel=1000, after_ms=run_ms)


def test_watchdog_stops_the_motion_when_the_host_goes_silent():
    with Loopback(device="simavr", watchdog_ms=200) as lb:
        _app, s = _moving(lb)
        dev = lb.device
        moving = dev.pins()[9].rising
        assert moving > 100
        # the host is gone: nobody drives the link any more; the chip runs on
        lb.clock.run_until(lb.clock.now_ns() + 10**9)
        stopped = dev.pins()[9].rising
        assert moving < stopped < 100_000
        # the last pulse came at most the watchdog time after the host's last frame
        last_pulse = dev.trace().rising(9)[-1]
        lb.clock.run_until(lb.clock.now_ns() + 10**9)
        assert dev.pins()[9].rising == stopped  # and nothing since
        events = []
        lb.backend.listeners.append(lambda e, t: events.append((e, t)))
        lb.backend.app_spend(50 * TPS // 1000)
        assert events == [("lost", "device watchdog stopped the motion")]
        status = lb.backend.device_status
        assert status.state & D_WATCHDOG and status.watchdog_trips == 1
        assert not s.is_running()
        # a new session (the cable plugged in again) takes the positions where the
        # pulses stopped
        lb.unplug()
        lb.replug()
        lb.backend.reconnect()
        assert lb.backend.connected
        assert lb.backend.statuses[0].position == stopped == s.get_current_position()
        assert last_pulse > 0


def test_emergency_stop_halts_at_once_and_the_positions_are_the_devices():
    with Loopback(device="simavr") as lb:
        backend = lb.backend
        _app, s = _moving(lb)
        assert backend.emergency_stop()
        pulses = lb.device.pins()[9].rising
        assert backend.connected and not s.is_running()
        assert s.get_current_position() == pulses == backend.statuses[0].position
        backend.app_spend(200 * TPS // 1000)
        assert lb.device.pins()[9].rising == pulses  # stopped for good
        s.move(100)  # the new session moves again
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        backend.request_status()
        assert s.get_current_position() == pulses + 100 == backend.statuses[0].position
        assert lb.device.pins()[9].rising == pulses + 100


def test_after_an_emergency_stop_a_new_session_moves():
    with Loopback(device="simavr") as lb:
        backend = lb.backend
        _app, s = _moving(lb, run_ms=200)
        assert backend.emergency_stop()
        assert backend.device_status.state & D_ESTOP  # the state as the new session found it
        assert backend.request_status() is not None
        assert backend.device_status.state & D_ESTOP == 0


def test_x_halts_the_device_at_once():
    with Loopback(device="simavr") as lb:
        backend = lb.backend
        app, s = _moving(lb, run_ms=800)
        app.run_script("X")
        backend.settle()
        backend.request_status()
        assert not s.is_running()
        assert s.get_current_position() == 0 == backend.statuses[0].position
        assert backend.device_counters()["halts"] == 1


def test_s_decelerates_from_where_the_motor_is():
    with Loopback(device="simavr") as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        app.run_script("M1 A20000 V40 R200000 w300 S W", max_ticks=60 * TPS)
        backend.settle()
        backend.request_status()
        s = app.steppers[0]
        pos = s.get_current_position()
        assert 0 < pos < 200_000
        assert pos == backend.statuses[0].position == lb.device.pins()[9].rising
        assert backend.device_counters()["cuts"] >= 1


# --------------------------------------------------- real processes, real time
def test_device_simavr_serves_a_pty_for_port():
    """``stepperdemo device --simavr`` (real time, sped up) and ``--port PTY -c LINE``
    as a user runs them; waiting is done by reading what the processes print."""
    import re
    import signal
    import subprocess
    import sys

    dev = subprocess.Popen([sys.executable, "-m", "stepperdemo", "device", "--simavr",
                            "--speed", "4"], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        first = dev.stdout.readline()
        assert first.startswith("device atmega328p (firmware ")
        path = re.search(r" on (/dev/pts/\d+)", first).group(1)
        res = subprocess.run([sys.executable, "-m", "stepperdemo", "--port", path, "-c",
                              "M1 A1000 V100 R3200 W M2 A2000 V200 R-1000 W", "--lf",
                              "--watchdog-ms", "2000"], cwd=ROOT, capture_output=True,
                             text=True, timeout=120, check=False)
        assert res.returncode == 0, res.stderr
        assert "device M1: position 3200, 3200 pulses" in res.stderr
        assert "device M2: position -1000, 1000 pulses" in res.stderr
        assert re.search(r"device: \d+ commands, 0 lost, 0 duplicated", res.stderr)
    finally:
        dev.send_signal(signal.SIGINT)
        out, _ = dev.communicate(timeout=30)
    assert "pin 9: 3200 rising, 3200 falling edges" in out
    assert "pin 10: 1000 rising, 1000 falling edges" in out


@pytest.mark.parametrize("line", [LINES[0], pytest.param(LINES[5], marks=pytest.mark.long)])
def test_step_edges_agree_with_the_python_device(line):
    """The same session on both: the bytes the chip received, at the ticks they reached
    its UART, replayed into the Python device.  The compare unit makes the rising
    edges on the same ticks (one cycle later in simavr); the falling edges come with
    the interrupt latency (the model's 61/73 ticks, the firmware's second compare)."""
    from fas.device.simavr import replay_on_python_device

    fw = run_firmware(line)
    tr = fw.trace
    py = replay_on_python_device(fw.rx_log, tr.timer1_start, 10 * 17 * 8,
                                 tr.end_cycle - tr.timer1_start)
    for pin in (9, 10):
        f, p = tr.rising(pin), py.recorder.rising(pin)
        assert len(f) == len(p)
        if not f:
            continue
        assert all(0 <= a - b <= 1 for a, b in zip(f, p, strict=True))
        # every pulse is high at least 2.5 us and low again well before the next step
        times, levels = tr.edges(pin)
        phases = [(levels[i], times[i + 1] - times[i]) for i in range(len(times) - 1)]
        assert all(dt >= 40 for _, dt in phases)
        assert max(dt for high, dt in phases if high) < min(dt for high, dt in phases
                                                             if not high)


def test_user_outputs_of_a_gcode_program_on_the_device():
    """Issue 12's acceptance program on the Uno: Dout0 (pin 2) synchronized between the
    moves, Dout1 (pin 4) at once when its line is read - after M63 has changed (a
    synchronized output holds the parser, issue 24) - Aout1 (pin 11, timer 2) at
    23.87 % - the nearest count, 61 of 256 at 7812.5 Hz (timer 2's TOP is fixed,
    prescaler 8)."""
    from stepperdemo.program import make_program

    program = ("G1 X2000 F600000\nM62 P0\nG1 X0\nM63 P0\nM64 P1\nM67 E1 Q23.87\nG4 P0.05\n"
               "M2\n")
    with Loopback(device="simavr") as lb:
        app = make_program("gcode", lb.backend, scripted=True)
        app.run_script(program, max_ticks=60 * TPS)
        assert lb.backend.settle()
        assert "error" not in app.transcript.decode()
        assert lb.backend.device_counters()["rejected"] == 0
        tr = lb.device.trace()
    steps = tr.rising(9)
    assert len(steps) == 4000
    d0 = list(zip(*tr.edges(2), strict=True))
    assert [lv for _, lv in d0] == [1, 0]
    assert steps[1999] < d0[0][0] < steps[2000] and d0[1][0] > steps[-1]
    assert tr.rising(4)[0] >= d0[1][0]  # M64: at once, read after M63 has changed
    times, levels = tr.edges(11)
    assert times[0] > d0[1][0]  # M67 E1 (immediate) comes after the motion before it
    # 61 of 256 counts of 8 cycles high in a period of 2048 (the timer's own edges are
    # time-stamped at simavr's instruction boundaries: a few cycles of play)
    periods = [(times[i + 1] - times[i], times[i + 2] - times[i])
               for i in range(0, len(times) - 2) if levels[i]]
    assert len(periods) > 50
    assert all(abs(high - 488) <= 4 and abs(period - 2048) <= 4 for high, period in periods)
