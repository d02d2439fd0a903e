"""``stepperdemo gcode --pty`` / ``--tcp`` as senders use them (issue 24): the real
endpoint process in (accelerated) real time, a real sender from the package index
(pygrbl-streamer, the test extra) on the pty, and a sender that counts characters
against Grbl's 128-byte receive buffer on TCP.  Every wait is on an answer, with a
limit; nothing is timed."""

import re
import socket
import threading
from collections import deque

import pytest

from rigs.processes import end, read_line, spawn

ARCH = "atmega2560"
# fast axes: 400-step lines take 0.13 s of simulated time
SETUP = ["--set", "$120=100000", "--set", "$121=100000", "--set", "$122=100000"]
WAIT_S = 60  # limit of every wait on the endpoint (never reached when it works)


def program(rows: int = 60) -> list[str]:
    """A raster with the user outputs switched on the way; ends at X1234 Y567 Z89."""
    lines = ["G21 G90 G94", "G0 X0 Y0 Z0", "F600000"]
    x = 0
    for n in range(rows):
        x = 400 - x if n % 2 else x + 7
        lines.append(f"G1 X{x} Y{n * 3}")
        if n == 10:
            lines.append("M62 P0")  # synchronized: holds the parser until the motion is done
        if n == 30:
            lines.append("M67 E0 Q25")
        if n == 40:
            lines.append("M64 P1")
    lines += ["G0 X1234 Y567 Z89", "M63 P0", "M2"]
    return lines


def start(*args: str):
    proc = spawn("gcode", "--arch", ARCH, "--speed", "20", *SETUP, *args)
    first = read_line(proc, WAIT_S)
    where = re.search(r" on (\S+?)(,| \()", first)
    assert where, first
    return proc, where.group(1)


def finish(proc) -> str:
    out, err = end(proc, WAIT_S)
    assert err == "", err
    return out


def test_pygrbl_streamer_streams_with_a_jog_before_and_a_feed_hold_in_the_middle():
    pygrbl = pytest.importorskip("pygrbl_streamer", reason="the test extra (pip install "
                                 "-e '.[test]') brings pygrbl-streamer")
    proc, path = start("--pty")
    g = pygrbl.GrblStreamer(path)
    seen: dict[str, list[str]] = {"errors": [], "alarms": [], "states": []}
    want = {"state": "", "event": threading.Event()}

    def received(line: str) -> None:  # a status answers a ?: ask again until it is there
        if line.startswith("<"):
            state = line[1:].split("|")[0]
            seen["states"].append(state)
            if want["state"] and state.startswith(want["state"]):
                want["state"] = ""
                want["event"].set()
            elif want["state"]:
                g.realtime(b"?")

    def wait_for(state: str) -> None:
        want["state"], want["event"] = state, threading.Event()
        g.realtime(b"?")
        assert want["event"].wait(WAIT_S), (state, seen["states"][-5:])

    g.receive_callback = received
    g.error_callback = seen["errors"].append
    g.alarm_callback = seen["alarms"].append
    lines = program()
    held = {"done": False}

    def progress(percent: int, _command: str) -> None:
        if percent >= 50 and not held["done"]:  # halfway: feed hold, wait, cycle start
            held["done"] = True
            g.pause()
            threading.Thread(target=hold_then_resume, daemon=True).start()

    def hold_then_resume() -> None:
        wait_for("Hold:0")
        g.resume()

    g.progress_callback = progress
    try:
        g.connect()
        assert g.command("$J=G91 X10 F3000", timeout=WAIT_S)
        wait_for("Idle")  # the jog is done (a sender waits for it before streaming)
        assert g.stream(lines, total=len(lines), completion_timeout=WAIT_S)
        wait_for("Idle")
        final = g.last_status["raw"]
    finally:
        g.disconnect()
        out = finish(proc)
    assert seen["errors"] == [] and seen["alarms"] == []
    assert held["done"] and "Hold:0" in seen["states"]
    assert final.startswith("<Idle|MPos:1234.000,567.000,89.000|")
    assert re.search(r"1 host\(s\), \d+ line\(s\), 0 error\(s\), 0 alarm\(s\); received \d+ "
                     r"bytes \(0 dropped: receive buffer full, 0 dropped", out), out
    assert "gcode: MPos 1234.000,567.000,89.000, state Idle" in out


class CountingSender:
    """Streams as bCNC, cncjs and grbl-streamer do: at most 128 bytes in flight,
    a line's length is given back at its answer."""

    def __init__(self, address: tuple[str, int]) -> None:
        self.sock = socket.create_connection(address, timeout=WAIT_S)
        self.buf = b""
        self.inflight: deque[int] = deque()
        self.answers: list[str] = []
        self.statuses: list[str] = []
        self.other: list[str] = []

    def read_line(self) -> str:
        while b"\n" not in self.buf:
            data = self.sock.recv(4096)
            assert data, "the endpoint closed the connection"
            self.buf += data
        line, _, self.buf = self.buf.partition(b"\n")
        return line.decode().rstrip("\r")

    def take(self) -> str:
        line = self.read_line()
        if line == "ok" or line.startswith("error:"):
            self.answers.append(line)
            self.inflight.popleft()
        elif line.startswith("<"):
            self.statuses.append(line)
        else:
            self.other.append(line)
        return line

    def send(self, line: str) -> None:
        data = (line + "\n").encode()
        while sum(self.inflight) + len(data) > 128:
            self.take()
        self.sock.sendall(data)
        self.inflight.append(len(data))

    def drain(self) -> None:
        while self.inflight:
            self.take()

    def status(self) -> str:
        count = len(self.statuses)
        self.sock.sendall(b"?")
        while len(self.statuses) == count:
            self.take()
        return self.statuses[-1]

    def wait_for(self, state: str) -> str:
        while not (got := self.status())[1:].startswith(state):
            pass
        return got


def test_a_character_counting_sender_on_tcp_with_jog_hold_and_jog_cancel():
    proc, where = start("--tcp", "0")
    host, port = where.removeprefix("tcp://").rsplit(":", 1)
    assert host == "127.0.0.1"  # loopback unless asked otherwise
    s = CountingSender((host, int(port)))
    try:
        assert s.read_line() == "" and s.read_line() == "Grbl 1.1h ['$' for help]"
        for line in ("$$", "$#", "$G", "$I"):  # what senders ask on connect
            s.send(line)
        s.send("$J=G91 X20000 F60000")  # a long jog, cancelled on the way
        s.wait_for("Jog")
        s.sock.sendall(b"\x85")
        s.wait_for("Idle")
        s.send("$J=G91 X10 F3000")
        s.wait_for("Idle")
        lines = program()
        for n, line in enumerate(lines):
            s.send(line)
            if n == len(lines) // 2:
                s.sock.sendall(b"!")
                s.wait_for("Hold:0")
                s.sock.sendall(b"~")
        s.drain()
        final = s.wait_for("Idle")
        s.sock.sendall(b"?\x85\x91")  # bytes senders send when nothing happens
        s.wait_for("Idle")
    finally:
        s.sock.close()
        out = finish(proc)
    assert [a for a in s.answers if a != "ok"] == []
    assert len(s.answers) == 4 + 2 + len(lines)
    assert any(line.startswith("[VER:1.1h") for line in s.other)
    assert final.startswith("<Idle|MPos:1234.000,567.000,89.000|Bf:15,128|")
    assert re.search(r"0 error\(s\), 0 alarm\(s\); received \d+ bytes \(0 dropped: receive "
                     r"buffer full, 0 dropped: >= 0x80\)", out), out


def test_one_host_at_a_time_and_each_new_host_is_a_reset():
    proc, where = start("--tcp", "127.0.0.1:0")
    host, port = where.removeprefix("tcp://").rsplit(":", 1)
    try:
        one_host_at_a_time(host, int(port))
    finally:
        out = finish(proc)
    assert "gcode: 2 host(s)" in out


def one_host_at_a_time(host: str, port: int) -> None:
    first = CountingSender((host, port))
    try:
        assert first.read_line() == ""
        first.send("G0 X100")
        first.drain()
        second = socket.create_connection((host, port), timeout=WAIT_S)
        assert second.recv(100) == b"[MSG:busy: another host is connected]\r\n"
        assert second.recv(100) == b""  # closed
        second.close()
        first.wait_for("Idle")
    finally:
        first.sock.close()
    third = CountingSender((host, port))
    try:
        assert third.read_line() == ""  # the banner again: a reset, MPos 0
        assert third.read_line() == "Grbl 1.1h ['$' for help]"
        assert third.status().startswith("<Idle|MPos:0.000,0.000,0.000|")
    finally:
        third.sock.close()
