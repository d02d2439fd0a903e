"""The G-code program as G-code senders drive it, fuzzed (issue 24 item 7): bad input
from a sender on every profile, the stream checks themselves, and a seeded stream
through the real ``stepperdemo gcode --pty`` endpoint with a sender-like client."""

import os
import random
import re
import select
import time
import tty
from collections import deque

import pytest

from fas.arch import PROFILES
from fas.sim import SimBackend
from rigs.processes import end, read_line, spawn
from stepperdemo.fuzz.common import BYTES, Case, FuzzResult
from stepperdemo.fuzz.gcode import (
    ANSWER,
    BANNER,
    GRBL_REALTIME,
    RX_SIZE,
    Sender,
    check_gcode,
    check_output,
    grbl_stream,
    line_ends,
    responses,
)
from stepperdemo.program import make_program


def _sender(arch: str, seconds: float = 30.0) -> tuple[Sender, FuzzResult]:
    backend = SimBackend(arch, record=True)
    program = make_program("gcode", backend, scripted=True)
    program.run_until(backend.now())
    res = FuzzResult(b"", arch, "gcode")
    return Sender(program, res, counting=True,
                  limit=backend.now() + int(seconds * backend.profile.ticks_per_s)), res


def _answers(s: Sender, data: bytes) -> list[str]:
    """Send one line (at serial speed) and let it be done: its answers."""
    mark = len(s.transcript)
    assert s.send_line(data)
    s.come_to_rest(s.limit)
    return responses(bytes(s.transcript[mark:]))


@pytest.mark.parametrize("arch", list(PROFILES))
def test_bad_input_from_a_sender_is_answered_as_grbl_does_and_the_session_goes_on(arch):
    s, res = _sender(arch)
    # overlong: past the 128-byte buffer (its comment is not kept: executed) ...
    assert _answers(s, b"G1 X1 F600 (" + b"c" * 200 + b")\n") == ["ok"]
    # ... and past the line buffer (255 characters kept): error:11, nothing executed
    assert _answers(s, b"G0 X" + b"1" * 300 + b"\n") == ["error:11"]
    # bytes >= 0x80 that are no real-time command (0x98 is none) never enter a line
    assert _answers(s, b"G0 X\xff2\xc3\x98\x80\n") == ["ok"]
    assert s.rx.dropped_high == 4
    # unknown words and $ commands
    assert _answers(s, b"G0 U1\n") == ["error:20"]
    assert _answers(s, b"$abc\n") == ["error:2"]  # Grbl reads a setting number: none
    assert _answers(s, b"$XX\n") == ["error:3"]
    # real-time bytes inside a line act and leave the line as it was
    assert _answers(s, b"G0 ?X\x913\x90\n") == ["ok"]
    # a reset while moving: ALARM:3; then a line while in alarm: error:9; $ commands work
    assert s.send_line(b"G91 G1 X5000 F600\n")
    s.wait(100)
    s.send_realtime(b"\x18")
    text = bytes(s.transcript).decode("latin-1")
    assert "ALARM:3" in text and text.rstrip().endswith("[MSG:'$H'|'$X' to unlock]"), text[-200:]
    assert _answers(s, b"G0 X1\n") == ["error:9"]
    assert _answers(s, b"$$\n") == ["ok"]
    assert _answers(s, b"$X\n") == ["ok"]
    assert _answers(s, b"G91 G0 X1\n") == ["ok"]
    s.send_realtime(b"?")
    assert s.last_state == "Idle"
    s.finish()
    check_output(res, bytes(s.transcript))
    assert res.ok, res.violations
    assert s.rx.dropped == 0


def test_line_ends_as_grbl_counts_them():
    assert line_ends(b"G0\nG1\r\nG2\rG3\n\n") == (5, False)
    assert line_ends(b"G0\r") == (1, True)
    assert line_ends(b"\n", after_cr=True) == (0, False)
    assert line_ends(b"G0\r?\x91\n") == (1, False)  # real-time bytes are not in the stream
    assert line_ends(b"G0\r\xff\n") == (1, False)
    assert {0x98, 0x9F, 0x80} & GRBL_REALTIME == set()
    assert {ord("?"), ord("!"), ord("~"), 0x18, 0x84, 0x85, 0x9E, 0xA0, 0xA1} <= GRBL_REALTIME


def test_a_lost_answer_is_caught(monkeypatch):
    # a controller that reads a line and never answers it: the sender's account of the
    # stretch does not close
    from stepperdemo.gcode.machine import GcodeMachine

    real = GcodeMachine._line  # noqa: SLF001 - a controller broken on purpose

    def forgetful(self, line, now):
        if line.text == "G4P0":
            self.lines += 1
            return None
        return real(self, line, now)

    monkeypatch.setattr(GcodeMachine, "_line", forgetful)
    res = check_gcode(Case(BYTES, chunks=((0, b"G91\n"), (0, b"G4 P0\n"), (0, b"$G\n")),
                           sender="count"), probe_session=False)
    assert res.violations == ["2 answers (ok/error) to 3 lines sent"]


def test_bytes_lost_by_a_sender_that_counts_are_caught(monkeypatch):
    from stepperdemo.gcode import grbl_rx

    monkeypatch.setattr(grbl_rx, "RX_SIZE", 64)  # a 64-byte buffer (an Arduino's)
    monkeypatch.setattr(grbl_rx.GrblReceiver.__init__, "__defaults__", (64, grbl_rx.LINE_MAX))
    lines = tuple((0, f"G91 G1 X{n} F6000 (a comment to make it longer)\n".encode())
                  for n in range(1, 6))
    res = check_gcode(Case(BYTES, chunks=((0, b"$SLP\n"), *lines), sender="count"),
                      probe_session=False)
    assert any("dropped for a full buffer" in v for v in res.violations), res.violations


def test_output_that_senders_cannot_parse_is_caught():
    res = FuzzResult(b"", "atmega328p", "gcode")
    check_output(res, b"ok\r\n<Idle|MPos:0.000,0.000|FS:0,0>\r\n")  # two axes
    check_output(res, b"error:77\r\n")
    check_output(res, b"$100=1e+06\r\n")
    check_output(res, b"ALARM:aborted\r\n")
    assert len(res.violations) == 4, res.violations


# ---- a seeded stream through the real endpoint ---------------------------------------
WAIT_S = 20  # limit of every wait on the endpoint (never reached when it works)
STALL_S = 2.0  # no answer for this long: the client asks '?' and acts as a sender does
PTY_SEED = 24


class PtyHost:
    """A sender on the pty: raw mode, counts characters against Grbl's 128 bytes,
    keeps the account of lines and answers between resets and alarms."""

    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        self.rest = b""
        self.out = bytearray()
        self.inflight: deque[int] = deque()
        self.stretches: list[list[int]] = [[0, 0]]  # [lines sent, answers] per stretch
        self.after_cr = False
        self.state = ""
        self.high = 0

    def close(self) -> None:
        os.close(self.fd)

    def read(self, timeout: float) -> bool:
        """What arrived within ``timeout`` (False: nothing)."""
        r, _, _ = select.select([self.fd], [], [], timeout)
        if not r:
            return False
        data = os.read(self.fd, 4096)
        self.out += data
        *lines, self.rest = (self.rest + data).split(b"\n")
        for raw in lines:
            ln = raw.rstrip(b"\r").decode("latin-1")
            if ANSWER.match(ln):
                self.stretches[-1][1] += 1
                if self.inflight:
                    self.inflight.popleft()
            elif BANNER.match(ln) or ln == "ALARM:3":  # (the alarms that flush the buffer)
                self.stretches.append([0, 0])
                self.inflight.clear()
                self.after_cr = False
            elif ln.startswith("<"):
                self.state = ln[1:].split("|", 1)[0]
        return True

    def write(self, data: bytes) -> None:
        self.high += sum(1 for b in data if b >= 0x80 and b not in GRBL_REALTIME)
        n, self.after_cr = line_ends(data, self.after_cr)
        self.stretches[-1][0] += n
        os.write(self.fd, data)
        while self.read(0):
            pass

    def unstick(self, stalls: int) -> None:
        """No answer for a while: ask, then do as a sender's user does."""
        self.write(b"?")
        end_at = time.monotonic() + WAIT_S
        state = self.state
        while self.state == state and self.read(min(1.0, end_at - time.monotonic())):
            pass
        if self.state in ("Hold:0", "Door:0"):
            self.write(b"~")
        elif self.state == "Sleep" or stalls > 2:
            self.reset()

    def wait_for_room(self, size: int) -> None:
        stalls = 0
        while self.inflight and sum(self.inflight) + size > RX_SIZE:
            if not self.read(STALL_S):
                stalls += 1
                self.unstick(stalls)
                assert stalls < 10, bytes(self.out[-300:])

    def reset(self) -> None:
        """Ctrl-X: what follows it counts once its banner is read."""
        stretches = len(self.stretches)
        os.write(self.fd, b"\x18")
        end_at = time.monotonic() + WAIT_S
        while len(self.stretches) == stretches and time.monotonic() < end_at:
            self.read(1.0)
        assert len(self.stretches) > stretches, bytes(self.out[-300:])

    def send(self, data: bytes) -> None:
        if line_ends(data)[0] == 0 and all(b in GRBL_REALTIME for b in data):
            for b in data:
                self.reset() if b == 0x18 else self.write(bytes([b]))
            return
        size = sum(1 for b in data if b not in GRBL_REALTIME)
        self.wait_for_room(size)
        self.inflight.append(size)
        for k, piece in enumerate(data.split(b"\x18")):
            if k:
                self.reset()
                if self.inflight or piece:
                    self.inflight.clear()
                    self.inflight.append(len(piece))
            self.write(piece)
        text = bytes(b for b in data if 0x20 < b < 0x7F).upper()
        if text.startswith(b"$RST=") or text == b"$C":  # a reset may follow its answer
            while self.inflight and self.read(STALL_S):
                pass
            while self.read(0.3):
                pass

    def rest_and_probe(self) -> None:
        """Until every line is answered and the machine rests; then the session goes
        on: $X, $$, G4 P0 and a move answered ok, a status report Idle."""
        stalls = 0
        while self.inflight or self.state not in ("Idle", "Alarm"):
            if not self.read(STALL_S):
                stalls += 1
                self.unstick(stalls)
                assert stalls < 10, bytes(self.out[-300:])
        for line in (b"$X\n", b"$$\n", b"G4 P0\n", b"G91 G1 X5 F6000\n"):
            mark = self.stretches[-1][1]
            self.send(line)
            end_at = time.monotonic() + WAIT_S
            while self.stretches[-1][1] == mark and time.monotonic() < end_at:
                self.read(1.0)
            assert self.stretches[-1][1] == mark + 1, (line, bytes(self.out[-300:]))
        self.state = ""
        self.unstick(0)
        assert self.state == "Idle" or self.state == "Run", bytes(self.out[-300:])


def _pty_stream(seed: int) -> list[bytes]:
    """A seeded stream of the fuzzer's sender streams: no line past the 128-byte
    buffer (a counting sender cannot send one without overfilling it)."""
    rng = random.Random(seed)
    chunks: list[bytes] = []
    while len(chunks) < 60:
        chunks += [data for _, data in grbl_stream(rng).chunks
                   if sum(1 for b in data if b not in GRBL_REALTIME) <= RX_SIZE]
    return chunks


def test_a_seeded_sender_stream_through_the_pty_endpoint():
    proc = spawn("gcode", "--pty", "--arch", "atmega2560", "--speed", "20")
    host = None
    try:
        first = read_line(proc, WAIT_S)
        where = re.search(r" on (\S+?)(,| \()", first)
        assert where, first
        host = PtyHost(where.group(1))
        while len(host.stretches) < 2:  # opening the port is a reset: the banner
            assert host.read(WAIT_S), bytes(host.out)
        chunks = _pty_stream(PTY_SEED)
        for data in chunks:
            host.send(data)
        host.rest_and_probe()
    finally:
        if host is not None:
            host.close()
        out, err = end(proc, WAIT_S)
    assert err == "", err[-2000:]
    res = FuzzResult(b"", "atmega2560", "gcode")
    check_output(res, bytes(host.out))
    assert res.ok, res.violations
    *closed, last = host.stretches
    assert all(answers <= lines for lines, answers in closed), host.stretches
    assert last[1] == last[0], host.stretches
    stats = re.search(r"received (\d+) bytes \((\d+) dropped: receive buffer full, (\d+) "
                      r"dropped: >= 0x80\)", out)
    assert stats, out
    assert int(stats.group(2)) == 0 and int(stats.group(3)) == host.high, (out, host.high)
    assert len(host.stretches) >= 2 and sum(s[0] for s in host.stretches) >= 40


@pytest.mark.parametrize("arch", ["esp32", "sam_due"])
def test_settings_are_plain_numbers_for_any_frequency(arch):
    # found by fuzzing: $$ printed $141=1e+06 after $141=1000000 (a sender's $N=value
    # parser reads no exponent)
    s, res = _sender(arch)
    assert _answers(s, b"$141=1000000\n") == ["ok"]
    mark = len(s.transcript)
    assert _answers(s, b"$$\n") == ["ok"]
    settings = bytes(s.transcript[mark:]).decode().split("\r\n")
    assert "$141=1000000" in settings
    check_output(res, bytes(s.transcript))
    assert res.ok, res.violations


@pytest.mark.parametrize("arch", list(PROFILES))
def test_a_senders_stream_into_every_profiles_g_mode(arch):
    # StepperDemo on a serial line (device --pty --console, then g): a seeded stream
    # of the fuzzer's, every line answered once between resets, x leaves, ? after
    from stepperdemo.fuzz.demo import check_gmode_stream, gmode_stream

    rng = random.Random(f"g-mode {arch}")
    for _ in range(2):
        case = gmode_stream(rng)
        res = check_gmode_stream(case, arch, max_time_s=3.0)
        assert res.ok and res.lines >= 1, (str(case)[:300], res.violations[:3])


def test_g_mode_streams_never_hold_the_line_that_leaves():
    # found by the long run: "$160=?\x18x\r" - after the reset, "x" was a line of its
    # own and left the g mode in the middle of the stream
    from stepperdemo.fuzz.demo import _grbl_text, gmode_stream

    rng = random.Random(7)
    for _ in range(300):
        data = b"".join(d for _, d in gmode_stream(rng).chunks)
        assert all(_grbl_text(p) != "X" for p in re.split(rb"[\r\n\x18]", data)), data
