"""``--link PATH`` where no link can be made (a folder that does not exist, a folder in
its place): every server that takes it says so in one line before it starts (exit 2),
as ``--plot`` and ``--vcd`` do - it ended in a FileNotFoundError traceback after the pty
was opened.  The real command, as a user starts it."""

import subprocess
import sys

import pytest

from rigs import ROOT

SERVERS = [
    ["gcode", "--pty"],
    ["device", "--pty"],
    ["device", "--pty", "--console"],
    ["relay", "/dev/null"],
]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=60,
                          stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("server", SERVERS, ids=lambda s: " ".join(s))
def test_a_link_in_a_folder_that_does_not_exist_is_refused_in_one_line(server, tmp_path):
    link = tmp_path / "no" / "such" / "port"
    done = run(*server, "--link", str(link))
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stdout == ""
    assert done.stderr == (f"stepperdemo: --link {link}: no folder {link.parent} to make "
                           f"the link in\n")


@pytest.mark.parametrize("server", SERVERS[:1], ids=lambda s: " ".join(s))
def test_a_link_where_a_folder_is_is_refused_in_one_line(server, tmp_path):
    done = run(*server, "--link", str(tmp_path))
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert done.stderr == f"stepperdemo: --link {tmp_path}: a folder is in its place\n"
