"""``stepperdemo device --pty --console``: a host that closes the port and opens it again
at once (no gap) restarts the firmware every time, as an Arduino's auto-reset does - the
start banner comes first, not what the old host's commands printed.  The device saw a
close only when it looked while nobody had the pty open.  The real device process and
pyserial as the host; every wait is on an answer, with a limit."""

import os
import re

import pytest
import serial

from rigs.processes import end, first_serial_line, read_line, spawn

WAIT_S = 60  # limit of every wait (never reached when it works)


def first_line(host: serial.Serial) -> bytes:
    return first_serial_line(host, WAIT_S)


def test_a_host_that_closes_and_opens_the_pty_at_once_restarts_the_firmware():
    proc = spawn("device", "--pty", "--console", "--speed", "8")
    try:
        where = re.search(r" on (/dev/\S+?),", read_line(proc, WAIT_S))
        assert where
        path = where.group(1)
        host = serial.Serial(path, 115200, timeout=WAIT_S)
        assert first_line(host).startswith(b"StepperDemo Version")
        for _ in range(4):
            host.write(b"M1 A1000 V100 R3200\nM2 R100\n")  # answered: OK, status lines
            host.close()
            host = serial.Serial(path, 115200, timeout=WAIT_S)  # at once
            assert first_line(host).startswith(b"StepperDemo Version")
        host.close()
    finally:
        out, err = end(proc, WAIT_S)
    assert err == "", err
    assert "console: 5 start(s)" in out, out
    assert out.count("console: host opened the port: firmware restarted") == 5, out


def test_the_pty_gives_a_leaving_hosts_last_bytes_to_it_and_the_next_host_its_own():
    """HangupPty itself, on a real pty, its clock stepped by hand: a host writes more
    than one read's worth and closes, the next opens at once and writes - the first
    host's bytes, all of them, then None (it left), then nothing until the new host's
    boot time is over, then only the new host's bytes; what the device sent the first
    host and it did not read never reaches the second.  (Bytes the new host writes
    before its open has been noticed cannot be told from the old host's: docs/gcode.md
    names that limit.)"""
    from stepperdemo.front.console_device import BOOT_S, HangupPty

    now = [0.0]
    pty = HangupPty(clock=lambda: now[0])
    try:
        if pty.watch is None:  # pragma: no cover - not Linux
            pytest.skip("no inotify here: only the hang-up is seen")
        first = os.open(pty.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        assert pty.read() is None  # opened just now: not taken on yet
        now[0] += BOOT_S
        assert pty.read() == b""  # taken on
        assert pty.write(b"unread answer\r\n") == 15
        sent = b"".join(b"G4 P0 ; line %05d\n" % i for i in range(500))  # 9 000 bytes
        os.write(first, sent)
        os.close(first)
        second = os.open(pty.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        got = b""
        while (data := pty.read()) is not None:
            got += data
        assert got == sent  # every byte of the first host
        assert pty.write(b"late answer for the first host\r\n") == 0
        os.write(second, b"$I\n")  # in its boot time: it waits for the second host
        assert pty.read() is None  # the second host is not taken on before its boot time
        now[0] += BOOT_S
        assert pty.read() == b"$I\n"
        assert pty.write(b"\r\nGrbl\r\n") == 8
        assert os.read(second, 100) == b"\r\nGrbl\r\n"  # not the first host's answer
        os.close(second)
    finally:
        pty.close()
