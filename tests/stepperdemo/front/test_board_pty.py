"""The board console end to end: ``stepperdemo device --pty --console`` is the board.

The simulated StepperDemo firmware runs in real time (sped up with ``--speed``)
behind a pty; ``--board`` talks to it as to a board on a USB port: ``-c``, ``run
--board``, and the REPL driven through prompt-toolkit's pipe input.  Nothing here
asserts on how long anything took; every wait reads output, with a generous limit.
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import subprocess
import sys
import time

import pytest
from prompt_toolkit.document import Document
from prompt_toolkit.input import create_pipe_input
from prompt_toolkit.output import DummyOutput

from rigs import ROOT
from rigs.processes import end, read_line, spawn, wait_for
from stepperdemo.front.board import BoardConsole
from stepperdemo.front.board_link import SimBoardLink
from stepperdemo.front.board_session import BoardSession
from stepperdemo.front.console import ProgramCompleter
from stepperdemo.watch.status_lines import parse_status

SPEED = "8"
QUIET = ("--quiet-ms", "200")  # the device runs 8x: 200 ms are 16 status-line periods
LIMIT_S = 60.0  # a limit for a wait that reads output, not a measured time
END_S = 30.0  # the same for a process to end
README_LINE = "M1 A1000 V100 R3200 W"


def _start_device(link: str) -> subprocess.Popen:
    proc = spawn("device", "--pty", "--console", "--speed", SPEED, "--link", link)
    assert "console device atmega328p" in read_line(proc, LIMIT_S)
    return proc


@pytest.fixture
def board(tmp_path):
    link = str(tmp_path / "board")
    proc = _start_device(link)
    yield proc, link
    end(proc, END_S)


def _cli(*args: str, timeout: float = 180, columns: str | None = "200"
         ) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
    if columns is not None:
        env["COLUMNS"] = columns
    if "--board" in args:
        args = (*args, *QUIET)
    return subprocess.run([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT,
                          capture_output=True, timeout=timeout, check=False, env=env)


def _without_status_lines(data: bytes) -> bytes:
    return b"".join(line for line in data.splitlines(keepends=True)
                    if parse_status(line.decode().rstrip("\r\n")) is None)


# --------------------------------------------------------------------- -c
def test_c_on_the_board_prints_the_firmware_transcript_ending_with_m1_at_3200(board):
    proc, link = board
    res = _cli("--board", link, "-c", README_LINE)
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert out.startswith(b"StepperDemo Version ")  # the open restarted the board
    assert out.endswith(b">> M1: @3200 acceleration  [steps/s^2]=1000 speed [us/step]=100 \r\n"
                        b"   M2: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 \r\n")
    assert b"Blocking wait for running stepper to stop\nSTOPPED\r\n" in out
    # byte for byte the simulated firmware's text; only the number of status lines
    # depends on the moment each command arrived
    twin = BoardSession(SimBoardLink("atmega328p"))
    twin.wait_ready()
    twin.run_script(README_LINE, 60)
    assert _without_status_lines(out) == _without_status_lines(bytes(twin.transcript))
    _out, _ = end(proc, END_S)
    assert "console: 1 start(s)" in _out and "(0 lost: receive buffer full)" in _out
    assert "console: positions M1 3200, M2 0" in _out


def test_c_exit_codes_failed_test_max_time_and_bad_port(board, tmp_path):
    _proc, link = board
    failed = _cli("--board", link, "-c", "M1 A1000 V100 R100 W t M1 13 R W x", "--lf")
    assert failed.returncode == 1, failed.stderr
    assert b"Failed status from test \ntest completed\n" in failed.stdout
    busy = _cli("--board", link, "-c", "M1 A1000 V100 f", "--max-time", "1", "--lf",
                "--log", str(tmp_path / "log"))
    assert busy.returncode == 3
    assert b"the board was still busy (a stepper runs: the table after its stop" in busy.stderr
    log = (tmp_path / "log").read_text().splitlines()
    assert log[0].startswith("# stepperdemo ") and " board log: " in log[0]
    assert re.fullmatch(r" +\d+\.\d{3} > f", [ln for ln in log if "> f" in ln][0])
    assert any(re.fullmatch(r" +\d+\.\d{3} < M1: @\d+ nonstop .*", ln) for ln in log)
    missing = _cli("--board", str(tmp_path / "nothing"), "-c", "M1")
    assert missing.returncode == 2 and b"cannot open the board" in missing.stderr


def test_c_ends_with_code_5_when_the_board_goes_away(board):
    proc, link = board
    host = spawn("--board", link, "-c", "M1 A1000 V100 R200000 W", "--lf")
    try:
        wait_for(host, r"^Blocking wait for running stepper to stop", LIMIT_S)
        proc.send_signal(signal.SIGKILL)
        _out, err = host.communicate(timeout=LIMIT_S)
    finally:
        end(host, END_S)
    assert host.returncode == 5
    # one line, without the REPL's "/reconnect" (issue 26, item 8)
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("stepperdemo: board lost: ")
    assert "/reconnect" not in err


# -------------------------------------------------------------- run --board
def test_run_board_passes_the_examples_with_no_position_difference(board):
    proc, link = board
    # three of the examples, and two for other chips: skipped (issue 26, item 4)
    files = [f"sequences/examples/{name}.toml"
             for name in ("move_3200", "esp32_200khz", "test_sequence_13",
                          "mega2560_three_steppers", "two_steppers")]
    res = _cli("run", "--board", link, *files, "-v", columns=None)  # piped, no COLUMNS
    text = res.stdout.decode()
    assert res.returncode == 0, text + res.stderr.decode()
    assert "3 scenarios, 0 failed, 2 skipped" in text
    assert ("esp32_200khz: skipped: written for esp32 (F_CPU=240000000 TICKS_PER_S=16000000 "
            "Steppers=14); the board's banner says F_CPU=16000000 TICKS_PER_S=16000000 "
            "Steppers=2") in text
    assert "mega2560_three_steppers: skipped: written for atmega2560 (" in text
    assert "…" not in text  # a file gets the tables whole, not squeezed into 80 columns
    assert "┃ lines ┃ first dt ┃ last dt ┃ max dt ┃" in text  # every heading whole
    assert "twin check: 6 stepper(s), largest position difference 0," in text
    for row in ("test_sequence_13 │ M1 │ 4 ", "two_steppers     │ M2 │ -2000 │ -2000 │ +0 "):
        assert row in text
    assert "A twin position diff" in text and "test passed" in text
    out, _ = end(proc, END_S)
    # a reset between the files: the pty closed and opened again, the firmware restarted
    assert out.count("host opened the port: firmware restarted") == 3
    assert "console: 3 start(s)" in out


# --------------------------------------------------------------------- REPL
async def _until(pred, what: str, console=None) -> None:
    """Wait (reading the console's output) until ``pred()``; fail after LIMIT_S."""
    deadline = time.monotonic() + LIMIT_S
    while not pred():
        if time.monotonic() > deadline:
            seen = "" if console is None else "; last lines: " + repr(console.lines[-12:])
            raise AssertionError(f"waited for {what}{seen}")
        await asyncio.sleep(0.01)


def _repl(link: str, tmp_path, script):
    async def main():
        with create_pipe_input() as inp:
            console = BoardConsole(link, input=inp, output=DummyOutput(),
                                   history=str(tmp_path / "history"))
            task = asyncio.ensure_future(console.run())
            await _until(lambda: any(ln.startswith("   M2: @") for ln in console.lines),
                         "the start banner and table")
            await script(inp, console)
            inp.send_text("\x04")  # Ctrl-D
            return console, await asyncio.wait_for(task, LIMIT_S)

    return asyncio.run(main())


async def history_of(console, mode: str) -> None:
    """Wait until the prompt has reloaded its history for ``mode``."""
    buf = console.prompt_session.default_buffer
    await _until(lambda: console._history_mode == mode and len(buf._working_lines) > 1,  # noqa: SLF001 - the history's mode, prompt-toolkit's loaded lines: no public reader
                 f"the history of {mode} mode")


def test_repl_history_and_completion_follow_the_boards_mode(board, tmp_path):
    _proc, link = board

    async def line(inp, console, text: str, answer: str) -> None:
        n = len(console.lines)
        inp.send_text(text)
        await _until(lambda: answer in console.lines[n:], answer, console)

    async def script(inp, console):
        st = console.session.state
        completer = ProgramCompleter(console)

        def offered(word: str) -> set[str]:
            return {c.display_text for c in completer.get_completions(Document(word), None)}

        assert "R<n>" in offered("R") and "f" in offered("f")
        await line(inp, console, "M1 A1000 V100\r", "set speed (us/step) to 100")
        await line(inp, console, "t\r", "Enter test mode")
        assert st.mode == "test" and console.app.mode_name() == "test"
        assert offered("R") == {"R"} and "01..13" in offered("0") and not offered("f")
        await line(inp, console, "M2\r", "Select stepper 2")
        await line(inp, console, "x\r", "Exit to main menu")
        assert st.mode == "normal"
        # Up in normal mode: the last line typed in normal mode ("t"), not "x"
        await history_of(console, "normal")
        await line(inp, console, "\x1b[A\r", "Enter test mode")
        # Up in test mode: the last line typed in test mode ("x")
        await history_of(console, "test")
        await line(inp, console, "\x1b[A\r", "Exit to main menu")
        assert st.mode == "normal"

    console, rc = _repl(link, tmp_path, script)
    assert rc == 0
    assert console.lines.count("Enter test mode") == 2
    assert console.lines.count("Exit to main menu") == 2
    history = (tmp_path / "history").read_text()
    assert history.count("mode=normal") == 2 and history.count("mode=test") == 2


def test_repl_plot_and_report_from_the_status_lines(board, tmp_path):
    _proc, link = board

    async def script(inp, console):
        inp.send_text("M1 A1000 V100 R3200\r")
        await _until(lambda: ">> M1: @3200 acceleration  [steps/s^2]=1000 speed [us/step]=100 "
                     in console.lines, "the table after the stop")
        n = len(console.lines)
        inp.send_text("/plot\r")
        await _until(lambda: "M1 speed [steps/s]" in console.lines[n:], "the plot")
        inp.send_text("/report\r")
        await _until(lambda: any(ln.startswith("  runs ") for ln in console.lines[n:]),
                     "the report")
        inp.send_text("/state\r")
        await _until(lambda: any(ln.startswith("board: normal mode") for ln in console.lines),
                     "the state")

    console, _ = _repl(link, tmp_path, script)
    text = "\n".join(console.lines)
    status = [ln for ln in console.lines if ln.startswith("M1: @")]
    assert len(status) > 5
    assert "M1 position [steps]" in text and chr(0x2800) < max(text)  # braille dots
    assert re.search(r"M1  \d+ status lines, first", text)
    assert re.search(r"position     \d+ -> 3200 \(net \+\d+\); 3200 in the last stepper table",
                     text)
    assert "running: -; positions: M1 3200, M2 0" in text


def test_repl_ctrl_c_stops_every_stepper_and_keeps_the_session(board, tmp_path):
    _proc, link = board

    async def script(inp, console):
        inp.send_text("M2 A1000 V200 f M1 A1000 V100 f\r")
        await _until(lambda: console.session.state.running() == [1, 2], "both running",
                     console)
        inp.send_text("\x03")  # Ctrl-C
        await _until(lambda: console.lines.count("immediate stop") == 2, "the stops", console)
        await _until(lambda: any(ln.startswith(">> M1: @0 ") for ln in console.lines),
                     "the table after the stop", console)
        inp.send_text("R100 W\r")  # the session goes on
        await _until(lambda: any(ln.startswith(">> M1: @100 ") for ln in console.lines),
                     "the table after the next move", console)

    console, rc = _repl(link, tmp_path, script)
    assert rc == 0
    assert "stop: X sent to M1 M2" in console.lines
    assert console.session.state.positions() == {1: 100, 2: 0}


def test_repl_lost_board_is_one_line_and_reconnect_restores_it(board, tmp_path):
    proc, link = board
    second = []

    async def script(inp, console):
        inp.send_text("M1 A1000 V100 R200\r")
        await _until(lambda: "OK" in console.lines, "the move")
        proc.send_signal(signal.SIGKILL)
        await _until(lambda: any(ln.startswith("board lost:") for ln in console.lines),
                     "the lost line")
        inp.send_text("M1\r")
        await _until(lambda: any(ln.startswith("no board") for ln in console.lines),
                     "the refusal")
        second.append(_start_device(link))
        n = len(console.lines)
        inp.send_text("/reconnect\r")
        await _until(lambda: any(ln.startswith("board back on") for ln in console.lines[n:]),
                     "the reconnect", console)
        await _until(lambda: any(ln.startswith("   M2: @") for ln in console.lines[n:]),
                     "the new start", console)
        inp.send_text("M1 A1000 V100 R-50 W\r")  # a new start: speed and ramp again
        await _until(lambda: any(ln.startswith(">> M1: @-50 ") for ln in console.lines[n:]),
                     "the table after a move on the new board", console)

    try:
        console, rc = _repl(link, tmp_path, script)
    finally:
        for p in second:
            end(p, END_S)
    assert rc == 0
    assert len([ln for ln in console.lines if ln.startswith("board lost:")]) == 1
    assert console.session.state.positions()[1] == -50  # the new board started at 0
    assert console.session.lost is None


def test_device_refuses_a_port(tmp_path):
    res = _cli("device", "--console", "--port", str(tmp_path / "x"))
    assert res.returncode == 2 and b"--console serves a new pty" in res.stderr
