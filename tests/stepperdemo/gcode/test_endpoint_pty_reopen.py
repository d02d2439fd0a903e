"""``stepperdemo gcode --pty``: a host that closes the port and opens it again at once
(no gap: a sender's Disconnect/Connect, a port probe) gets a reset every time - the
banner, machine position 0 - and none of the old host's answers.  The endpoint saw a
host's close only when it looked while nobody had the pty open, so the reopened host
was taken for the old one: it got the old host's ``ok``s and no banner.  The real
endpoint process and pyserial as senders open it; every wait is on an answer, with a
limit."""

import re

import serial

from rigs.processes import end, first_serial_line, read_line, spawn

WAIT_S = 60  # limit of every wait (never reached when it works)
BANNER = b"Grbl 1.1h ['$' for help]"


def first_line(host: serial.Serial) -> bytes:
    return first_serial_line(host, WAIT_S)


def test_a_host_that_closes_and_opens_the_pty_at_once_gets_a_reset_every_time():
    proc = spawn("gcode", "--pty")
    try:
        where = re.search(r" on (/dev/\S+?),", read_line(proc, WAIT_S))
        assert where
        path = where.group(1)
        host = serial.Serial(path, 115200, timeout=WAIT_S)
        assert first_line(host) == BANNER
        for _ in range(5):
            host.write(b"G4 P0\n" * 20)  # 120 bytes in flight, then gone
            host.close()
            host = serial.Serial(path, 115200, timeout=WAIT_S)  # at once
            assert first_line(host) == BANNER  # not the old host's "ok"s
            host.write(b"?")
            assert first_line(host).startswith(b"<Idle|MPos:0.000,0.000,0.000|")
        host.close()
    finally:
        out, err = end(proc, WAIT_S)
    assert err == "", err
    assert "gcode: 6 host(s)" in out, out
    assert out.count("gcode: host opened the port: reset") == 6, out
