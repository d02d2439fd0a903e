"""``--board`` on a port that is not StepperDemo (issue 26, item 3): the run ends
within ``NO_ANSWER_S`` of the first command, saying that no StepperDemo answer came
and what did; the REPL says it once.  On virtual time (a mute link), and once on a
real pty that never answers, as a user meets it."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import tty

from prompt_toolkit.output import DummyOutput

from rigs import ROOT
from stepperdemo.front.board import BoardConsole
from stepperdemo.front.board_link import BoardLink, SimBoardLink
from stepperdemo.front.board_session import NO_ANSWER_S, BoardSession, End
from stepperdemo.watch.status_lines import BoardState

GARBAGE = b"\x00\xffhello from another sketch\r\n"


class MuteLink(BoardLink):
    """A port on virtual time whose other end reads and never answers - or answers
    every write with another sketch's line (``garbage``)."""

    name = "mute"

    def __init__(self, garbage: bytes = b"") -> None:
        self.t = 0.0
        self.garbage = garbage
        self.pending = b""
        self.written = b""

    def now(self) -> float:
        return self.t

    def write(self, data: bytes) -> None:
        self.written += data
        self.pending += self.garbage

    def read(self, timeout_s: float) -> bytes:
        data, self.pending = self.pending, b""
        if not data:
            self.t += max(timeout_s, 0.001)
        return data

    def reset(self) -> None:
        pass

    def reopen(self, port: str | None = None) -> None:
        pass

    def close(self) -> None:
        pass


def test_a_silent_port_ends_a_run_after_no_answer_s_saying_nothing_came():
    link = MuteLink()
    s = BoardSession(link, boot_wait_s=2.5)
    assert s.wait_ready() is False  # no banner: a board without auto-reset, or not one
    assert s.run_script("M1 A1000 V100 R3200 W", 3600) == End.NO_ANSWER
    assert link.written == b"M1 A1000 V100 R3200 W\n"  # all sent; the W waits for ever
    assert NO_ANSWER_S <= link.t - s.input_start_s < NO_ANSWER_S + 0.2
    assert s.silent_reason() == "no start banner, nothing received"


def test_another_sketch_is_told_by_its_bytes():
    s = BoardSession(MuteLink(GARBAGE), boot_wait_s=0)
    assert s.run_script("M1 R100", 3600) == End.NO_ANSWER  # (no W: not held, but no answer)
    n = len(s.transcript)
    assert n == 2 * len(GARBAGE)
    assert s.silent_reason() == (f"no start banner; {n} bytes received, no line of them "
                                 "StepperDemo's")


def test_stepperdemo_answers_are_recognised_and_a_board_run_ends_idle():
    s = BoardSession(SimBoardLink("atmega328p"))
    assert s.wait_ready()
    assert s.run_script("M1 A1000 V100 R100 W", 600) == End.IDLE
    assert s.silent_reason() is None and s.state.answers > 5
    st = BoardState()  # without banner or status lines, the answers alone count
    for line in ("Select stepper 1", "set acceleration to 1000", "Move steps 100", "OK",
                 "Blocking wait for running stepper to stop", "STOPPED", "250 ms wait"):
        st.feed(line, 0.0)
    assert st.answers == 7
    for line in ("hello from another sketch", "OKAY", "", "Select"):
        st.feed(line, 0.0)
    assert st.answers == 7


def test_repl_notes_it_once(tmp_path):
    link = MuteLink()
    console = BoardConsole("mute", link=link, boot_wait_s=0, output=DummyOutput(),
                           history=str(tmp_path / "history"))
    console.handle_line("M1 A1000 V100 R3200 W")
    while link.t < 2 * NO_ANSWER_S:
        console.driver.advance()
        console.session.poll(0.05)
    notes = [ln for ln in console.lines if ln.startswith("no answer from StepperDemo")]
    assert notes == ["no answer from StepperDemo within 3 s of the first command (no start "
                     "banner, nothing received): is the board running StepperDemo at 115200 "
                     "baud? (/reconnect PORT tries another port)"]


def test_board_c_on_a_pty_that_never_answers_exits_5_with_one_line(tmp_path):
    """No --max-time: before, this waited for the default hour."""
    master, slave = os.openpty()
    tty.setraw(slave)
    stop = threading.Event()

    def drain() -> None:  # the other end reads (a sketch that ignores its input)
        while not stop.is_set():
            try:
                os.read(master, 4096)
            except OSError:
                return

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    port = os.ttyname(slave)
    try:
        run = subprocess.run([sys.executable, "-m", "stepperdemo", "--board", port, "-c",
                              "M1 A1000 V100 R3200 W", "--boot-wait", "0.5"],
                             cwd=ROOT, capture_output=True, text=True, timeout=60)
    finally:
        stop.set()
        os.close(slave)
        os.close(master)
    assert run.returncode == 5
    assert run.stdout == ""
    assert run.stderr.splitlines() == [
        f"stepperdemo: no answer from StepperDemo at {port} within 3 s of the first command "
        "(no start banner, nothing received): is the board running StepperDemo at 115200 "
        "baud?"]


def test_run_board_stops_at_the_first_file_without_an_answer(monkeypatch, capsys):
    from stepperdemo.front.cli import main
    from stepperdemo.scenarios import board_runner

    monkeypatch.setattr(board_runner, "SerialBoardLink", lambda port, baud: MuteLink())
    monkeypatch.delenv("COLUMNS", raising=False)  # (pytest-xdist's workers have 80)
    examples = ROOT / "sequences" / "examples"
    rc = main(["run", "--board", "mute", str(examples / "move_3200.toml"),
               str(examples / "two_steppers.toml")])
    out = capsys.readouterr().out
    assert rc == 4
    assert "1 scenarios, 1 failed" in out  # the second file did not wait as long again
    assert ("stopped: no answer from StepperDemo at mute (no start banner, nothing received) - "
            "is the board running StepperDemo at this baud rate?") in out
    assert any(line.split()[:2] == ["end", "idle"] and "no answer from StepperDemo" in line
               for line in out.splitlines())  # the file's end, among its checks
