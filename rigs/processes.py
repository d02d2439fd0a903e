"""``python -m stepperdemo`` as a real process in the checkout, as a user starts it; waiting
is done by reading what it prints, each wait with a limit (not a measured time)."""

from __future__ import annotations

import re
import select
import signal
import subprocess
import sys
import time

from rigs import ROOT


def spawn(*args: str) -> subprocess.Popen:
    """``stepperdemo ARGS`` running: its output read line by line as text."""
    return subprocess.Popen([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            bufsize=1)


def read_line(proc: subprocess.Popen, timeout_s: float) -> str:
    """The next line ``proc`` prints; fails when none comes within ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        r, _, _ = select.select([proc.stdout], [], [], min(0.5, max(end - time.monotonic(), 0)))
        if r:
            line = proc.stdout.readline()
            if line:
                return line
            break  # the process closed its output
    raise AssertionError(f"no output from {proc.args}")


def wait_for(proc: subprocess.Popen, pattern: str, timeout_s: float) -> str:
    """The first line ``proc`` prints that matches ``pattern``, within ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        line = read_line(proc, end - time.monotonic())
        if re.search(pattern, line):
            return line
    raise AssertionError(f"{pattern!r} not seen")


def end(proc: subprocess.Popen, timeout_s: float) -> tuple[str, str]:
    """Stop ``proc`` with SIGTERM (as ``kill`` does) unless it has ended; what it printed
    (stdout, stderr)."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    return proc.communicate(timeout=timeout_s)


def first_serial_line(host, timeout_s: float) -> bytes:
    """The first non-empty line a port opened with pyserial (``timeout=timeout_s``)
    receives, without its line end."""
    while True:
        line = host.readline()
        assert line.endswith(b"\n"), f"no line within {timeout_s} s: {line!r}"
        if line.strip():
            return line.rstrip(b"\r\n")
