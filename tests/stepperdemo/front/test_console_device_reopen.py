"""``stepperdemo device --pty --console``: a host that closes the port and opens it again
at once (no gap) restarts the firmware every time, as an Arduino's auto-reset does - the
start banner comes first, not what the old host's commands printed.  The device saw a
close only when it looked while nobody had the pty open.  The real device process and
pyserial as the host; every wait is on an answer, with a limit."""

import re

import serial

from rigs.processes import end, read_line, spawn

WAIT_S = 60  # limit of every wait (never reached when it works)


def first_line(host: serial.Serial) -> bytes:
    """The first non-empty line the device sends this host."""
    while True:
        line = host.readline()
        assert line.endswith(b"\n"), f"no line within {WAIT_S} s: {line!r}"
        if line.strip():
            return line.rstrip(b"\r\n")


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
