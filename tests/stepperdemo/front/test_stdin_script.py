"""Standard input that is not a terminal is a script (issue 26, item 7): a pipe or a
file into ``stepperdemo`` (and ``winder``, ``gcode``) runs on virtual time exactly as
the same text given to ``-c`` (or ``gcode -``) - before, the console read the line,
met the end of its input and left before the chip had run it."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from rigs import ROOT

MOVE = "M1 A1000 V100 R3200 W"


def stepperdemo(*args: str, stdin: bytes | None) -> subprocess.CompletedProcess[bytes]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT, env=env,
                          input=stdin, stdin=None if stdin is not None else subprocess.DEVNULL,
                          capture_output=True, timeout=120, check=False)


def test_a_line_piped_into_stepperdemo_runs_as_with_c() -> None:
    piped = stepperdemo("--lf", stdin=(MOVE + "\n").encode())
    given = stepperdemo("--lf", "-c", MOVE, stdin=None)
    assert piped.returncode == 0, piped.stderr
    assert piped.stderr == b""  # no prompt-toolkit "Input is not a terminal"
    lines = piped.stdout.decode().splitlines()
    assert "Move steps 3200" in lines and "bye" not in lines
    assert lines[-2].startswith(">> M1: @3200 ")  # the transcript ends at the move's end
    assert piped.stdout == given.stdout


def test_a_file_on_stdin_is_a_script_of_many_lines_and_may_be_watched(tmp_path) -> None:
    script = tmp_path / "script.txt"
    script.write_text("M1 A1000 V100\nR3200 W\n")
    with open(script, "rb") as f:
        res = subprocess.run([sys.executable, "-m", "stepperdemo", "--lf", "--report"],
                             cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)), stdin=f,
                             capture_output=True, timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    out = res.stdout.decode()
    assert ">> M1: @3200 " in out
    assert "  pulses       3200 (the channel counted 3200)" in out  # --report goes with it


@pytest.mark.parametrize(("args", "stdin", "wanted"), [
    (("winder",), b"move 1 100 w500 status\n", "S1 spindle  @100 "),
    (("gcode",), b"G1 X100 F6000\nM2\n", "ok\n[MSG:Pgm End]\nok\n"),
])
def test_winder_and_gcode_read_a_script_from_stdin(args, stdin, wanted) -> None:
    res = stepperdemo(*args, "--lf", stdin=stdin)
    assert res.returncode == 0, res.stderr
    assert wanted in res.stdout.decode()
    assert b"Input is not a terminal" not in res.stderr


def test_bytes_that_are_not_text_are_one_unknown_command_not_a_traceback() -> None:
    res = stepperdemo("--lf", stdin=b"\xff\xfe R100 W\n")
    assert res.returncode == 0, res.stderr
    assert b"Traceback" not in res.stderr
    assert res.stdout.decode().count("Unknown command") == 1
