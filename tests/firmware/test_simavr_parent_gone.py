"""``stepperdemo device --simavr`` killed outright (SIGKILL: a CI job cancelled, a
timeout, the OOM killer) does not leave its simavr harness behind.  The harness runs
the chip in real time on a pty; orphaned, it went on for ever at a quarter of a core,
holding its pty.  It now ends when the process that started it is gone.  Real
processes; the wait for the harness's end is on its pidfd, with a limit."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from rigs import ROOT
from rigs.firmware import need_firmware

WAIT_S = 30  # limit of each wait (never reached when it works)


@pytest.fixture(scope="module", autouse=True)
def firmware():
    need_firmware()


def children(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux: /proc/PID/task/*/children)."""
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(p) for p in (task / "children").read_text().split()]
    return found


@pytest.mark.skipif(not hasattr(os, "pidfd_open") or not sys.platform.startswith("linux"),
                    reason="waits on a pidfd (Linux)")
def test_the_harness_ends_when_device_simavr_is_killed():
    dev = subprocess.Popen([sys.executable, "-m", "stepperdemo", "device", "--simavr",
                            "--quiet"], cwd=ROOT, stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    harness = None
    ended = False
    try:
        assert dev.stdout.readline().startswith("/dev/")  # the harness is serving
        (harness,) = children(dev.pid)
        assert Path(f"/proc/{harness}/cmdline").read_bytes().split(b"\0")[1] == b"--pty"
        pidfd = os.pidfd_open(harness)
        dev.send_signal(signal.SIGKILL)  # no chance to stop its harness itself
        dev.wait(timeout=WAIT_S)  # (its pipes stay open while the harness has them)
        readable, _, _ = select.select([pidfd], [], [], WAIT_S)  # readable: it has ended
        os.close(pidfd)
        ended = bool(readable)
        assert ended, f"the harness {harness} still runs {WAIT_S} s after its parent died"
    finally:
        if dev.poll() is None:
            dev.kill()
            dev.wait(timeout=WAIT_S)
        if harness is not None and not ended:
            os.kill(harness, signal.SIGKILL)  # the orphan (before the fix)
        dev.stdout.close()
        dev.stderr.close()


@pytest.mark.skipif(not hasattr(os, "pidfd_open") or not sys.platform.startswith("linux"),
                    reason="waits on a pidfd (Linux)")
def test_the_harness_ends_when_its_parent_died_before_it_looked():
    """The race CI met: the parent killed between the harness's first line and its first
    look at its parent.  ``--parent`` names the parent; one already gone ends the run."""
    from fas.device.simavr import build

    firmware = build()  # (re)builds the harness from source too
    gone = subprocess.Popen(["true"])
    gone.wait()  # a process that has ended: the parent the harness is told to watch
    harness = subprocess.Popen([str(firmware.harness), "--pty", "--parent", str(gone.pid),
                                str(firmware.elf)], stdin=subprocess.DEVNULL,
                               stdout=subprocess.PIPE, text=True)
    try:
        assert harness.stdout.readline().startswith("/dev/")  # it served the pty ...
        harness.wait(timeout=WAIT_S)  # ... and ended by itself
        assert harness.returncode == 0
        assert "simulated in" in harness.stdout.read()  # its summary: a clean end
    finally:
        if harness.poll() is None:
            harness.kill()
            harness.wait(timeout=WAIT_S)
        harness.stdout.close()
