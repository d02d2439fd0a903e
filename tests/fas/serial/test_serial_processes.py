"""Real processes on real ptys in real time: ``stepperdemo device``, ``relay``, ``--port``.

The device runs sped up (``--speed``), so a line takes a fraction of its real
duration; nothing here asserts on how long anything took.  Waiting is done by
reading what the processes print.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys

import pytest

from fas.serial import SerialBackend
from fas.serial.protocol import D_WATCHDOG
from rigs import ROOT
from rigs.processes import end, read_line, spawn, wait_for
from stepperdemo.demo.app import StepperDemo

PTY_RE = re.compile(r"(/dev/pts/\d+)")
SPEED = 4
READ_S, WAIT_S, END_S = 20.0, 30.0, 20.0  # limits of a wait that reads output


@pytest.fixture
def device(tmp_path):
    link = str(tmp_path / "device")
    proc = spawn("device", "--pty", "--speed", str(SPEED), "--link", link)
    path = PTY_RE.search(read_line(proc, READ_S)).group(1)
    yield proc, path, link
    end(proc, END_S)


def _host(port: str, line: str, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stepperdemo", "--port", port, "-c", line,
                           "--lf", *extra], cwd=ROOT, capture_output=True, text=True,
                          timeout=120, check=False)


def test_cli_port_runs_a_line_on_a_device_process(device):
    proc, path, _ = device
    # a generous watchdog: a busy test machine must not stop the device (see the kill test)
    res = _host(path, "M1 A1000 V100 R3200 W", "--watchdog-ms", "2000")
    assert res.returncode == 0, res.stderr
    assert ">> M1: @3200 " in res.stdout
    assert "device M1: position 3200, 3200 pulses" in res.stderr
    assert re.search(r"device: 2030 commands, 0 lost, 0 duplicated", res.stderr)
    out, _ = end(proc, END_S)
    assert "M1: position 3200, 3200 pulses in the last session" in out
    assert "session closed" in out


def test_closed_pty_is_reported_and_a_new_device_takes_over(device, tmp_path):
    proc, _path, link = device
    backend = SerialBackend(link, watchdog_ms=2000)
    app = StepperDemo(backend, scripted=True)
    app.run_script("M1 A2000 V200 R1000 W")
    assert app.steppers[0].get_current_position() == 1000
    events = []
    backend.listeners.append(lambda e, t: events.append(e))
    end(proc, END_S)  # the device goes away, its pty is closed
    backend.app_spend(200 * 16000)
    assert events == ["lost"] and not backend.connected
    second = spawn("device", "--pty", "--speed", str(SPEED), "--link", link)
    try:
        read_line(second, READ_S)
        backend.reconnect()
        assert backend.connected and backend.sessions == 2
        app.steppers[0].move(-400)
        backend.wait_until(lambda: not app.steppers[0].is_running())
        assert app.steppers[0].get_current_position() == 600
        backend.close()
        out, _ = end(second, END_S)
        assert "M1: position 600, 400 pulses in the last session, 400 since" in out
    finally:
        end(second, END_S)


@pytest.mark.long
def test_relay_with_faults_between_processes(device):
    _proc, path, _ = device
    relay = spawn("relay", path, "--corrupt", "0.01", "--drop", "0.005", "--dup", "0.005",
                  "--latency-ms", "1", "--seed", "3")
    try:
        host_path = PTY_RE.search(read_line(relay, READ_S)).group(1)
        res = _host(host_path, "M1 A6000 V90 R5000 M2 A5000 V110 R-4000 W M1 W")
        assert res.returncode == 0, res.stderr
        assert "device M1: position 5000, 5000 pulses" in res.stderr
        assert "device M2: position -4000, 4000 pulses" in res.stderr
        assert re.search(r"commands, 0 lost, 0 duplicated", res.stderr)
        retrans = int(re.search(r"(\d+) retransmitted", res.stderr).group(1))
        assert retrans > 0
    finally:
        out, _ = end(relay, END_S)
    assert re.search(r"relay to device: \d+ bytes in, \d+ out, \d+ dropped", out)


@pytest.mark.long
def test_killed_host_leaves_a_stopped_device(device):
    proc, path, link = device
    host = spawn("--port", path, "-c", "M1 A1000 V100 R200000 W", "--lf")
    try:
        wait_for(host, r"M1: @\d{3,} ", WAIT_S)
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=10)
    finally:
        end(host, END_S)
    wait_for(proc, r"watchdog: host silent, motion stopped", WAIT_S)
    backend = SerialBackend(link)
    try:
        assert backend.device_status.state & D_WATCHDOG
        assert backend.device_status.watchdog_trips == 1
        pos = backend.statuses[0].position
        assert 0 < pos < 200_000
        assert backend.statuses[0].pulses == pos
        assert not backend.statuses[0].progress().running
    finally:
        backend.close()


def test_scripted_run_ends_with_code_5_when_the_device_goes(device):
    proc, path, _ = device
    host = spawn("--port", path, "-c", "M1 A1000 V100 R200000 W", "--lf",
                 "--watchdog-ms", "2000")
    try:
        wait_for(host, r"M1: @\d{2,} ", WAIT_S)
        proc.send_signal(signal.SIGKILL)
        _out, err = host.communicate(timeout=30)
    finally:
        end(host, END_S)
    assert host.returncode == 5
    lines = err.splitlines()
    assert lines[-1].startswith("stepperdemo: device lost:")
    assert "/reconnect" not in err  # (a console command: not in a scripted run)
    # the device's counters are from its last report before the loss, and say so
    assert lines[1] == ("the device's figures below are its last report, from before the "
                        "connection ended")
    assert lines[0].startswith("link: ") and " rtt 0 us;" not in lines[0]
