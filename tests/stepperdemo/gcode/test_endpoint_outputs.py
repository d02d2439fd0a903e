"""``stepperdemo gcode --tcp ... --report --plot`` as a user ends it: after Ctrl-C (or
SIGTERM) the timing report is printed line by line, as ``stepperdemo gcode FILE
--report`` prints it, and a plot that cannot be written is said on stderr.  The real
endpoint process, a host on TCP; every wait is on an answer, with a limit."""

import re
import shutil
import socket

from rigs.processes import end, read_line, spawn

WAIT_S = 60  # limit of every wait (never reached when it works)


def start(*args: str):
    proc = spawn("gcode", "--arch", "atmega2560", "--speed", "20", "--set", "$120=100000",
                 "--tcp", "0", *args)
    first = read_line(proc, WAIT_S)
    where = re.search(r" on tcp://127\.0\.0\.1:(\d+)", first)
    assert where, first
    return proc, int(where.group(1))


def move_and_wait(port: int, line: bytes) -> None:
    """One host: send ``line``, then ask ``?`` until the machine is Idle again."""
    with socket.create_connection(("127.0.0.1", port), timeout=WAIT_S) as s:
        buf = b""

        def read_line_() -> bytes:
            nonlocal buf
            while b"\n" not in buf:
                data = s.recv(4096)
                assert data, "the endpoint closed the connection"
                buf += data
            got, _, buf = buf.partition(b"\n")
            return got.rstrip(b"\r")

        while read_line_() != b"Grbl 1.1h ['$' for help]":
            pass
        s.sendall(line)
        assert read_line_() == b"ok"
        while True:
            s.sendall(b"?")
            status = read_line_()
            if status.startswith(b"<Idle|"):
                return


def test_the_report_of_an_endpoint_is_printed_as_lines(tmp_path):
    png = tmp_path / "run.png"
    proc, port = start("--report", "--plot", str(png))
    try:
        move_and_wait(port, b"G0 X100\n")
    finally:
        out, err = end(proc, WAIT_S)
    assert err == "", err
    lines = out.splitlines()
    assert "['" not in out and "None" not in lines, out
    assert any(line.startswith("timing report: atmega2560, 0.000 s ..") for line in lines), out
    m1 = lines.index(next(line for line in lines if line.startswith("M1  step pin")))
    assert re.match(r"  pulses +100 \(the channel counted 100\), net \+100 steps", lines[m1 + 1])
    assert png.stat().st_size > 0


def test_a_plot_that_cannot_be_written_at_the_end_is_said(tmp_path):
    folder = tmp_path / "gone"
    folder.mkdir()
    proc, port = start("--plot", str(folder / "run.png"))
    try:
        move_and_wait(port, b"G0 X10\n")
        shutil.rmtree(folder)  # the folder is gone by the time the endpoint ends
    finally:
        out, err = end(proc, WAIT_S)
    assert proc.returncode == 2, (out, err)
    assert err.strip().startswith(f"stepperdemo: cannot write {folder / 'run.png'}"), err
    assert "Traceback" not in err
