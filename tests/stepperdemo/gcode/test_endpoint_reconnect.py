"""``stepperdemo gcode --tcp``: a sender that disconnects with lines still in flight and
connects again at once (a Disconnect / Connect in its window) is the next host - it gets
the reset and the banner, not ``[MSG:busy: another host is connected]``, nor the old
host's answers.  The endpoint refused it because it took the new connection for a
second host while the old one's last bytes were still being read; and when the old host
had gone while being answered (a failed send), it took the new one on without the reset
and the banner.  The real endpoint process; every wait is on an answer, with a limit."""

import re
import socket

from rigs.processes import end, read_line, spawn

WAIT_S = 60  # limit of every wait (never reached when it works)
BANNER = b"Grbl 1.1h ['$' for help]"


def first_line(sock: socket.socket) -> bytes:
    """The first non-empty line the endpoint sends this host."""
    buf = b""
    while True:
        while b"\n" not in buf:
            data = sock.recv(4096)
            assert data, f"closed after {buf!r}"
            buf += data
        line, _, buf = buf.partition(b"\n")
        if line.strip():
            return line.rstrip(b"\r")


def test_a_sender_that_leaves_with_lines_in_flight_and_comes_back_is_served():
    proc = spawn("gcode", "--tcp", "0")
    try:
        where = re.search(r" on tcp://127\.0\.0\.1:(\d+)", read_line(proc, WAIT_S))
        assert where
        address = ("127.0.0.1", int(where.group(1)))
        for read_first in (True, False, True, False):
            with socket.create_connection(address, timeout=WAIT_S) as old:
                if read_first:
                    assert first_line(old) == BANNER
                else:  # it leaves with the banner unread: a reset (RST), sends fail
                    assert old.recv(1) == b"\r"  # (served: its banner has begun)
                old.sendall(b"G4 P0\n" * 20)  # 120 bytes in flight, as a counting sender
            with socket.create_connection(address, timeout=WAIT_S) as new:
                assert first_line(new) == BANNER  # a reset for the new host, not "busy"
                new.sendall(b"?")
                assert first_line(new).startswith(b"<Idle|MPos:0.000,0.000,0.000|")
    finally:
        out, err = end(proc, WAIT_S)
    assert err == "", err
    assert "gcode: 8 host(s)" in out, out
