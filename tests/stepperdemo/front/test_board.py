"""The board console on virtual time: the simulated board behind its serial line, the
status-line parser and board state, input pacing, the session's end of a run, the
twin check, the per-mode history.  Everything here runs on the simulated board's
clock (:class:`SimBoardLink`): deterministic, no wall clock."""

from __future__ import annotations

import asyncio
import re

import pytest

from fas.arch import get_profile
from fas.sim.timing import sim_timing
from stepperdemo import messages as msg
from stepperdemo.demo.serial_board import SimulatedBoard
from stepperdemo.front.board_input import InputPacer, split_commands
from stepperdemo.front.board_link import SimBoardLink
from stepperdemo.front.board_session import BoardSession, End
from stepperdemo.front.mode_history import ModeHistory
from stepperdemo.scenarios import board_runner
from stepperdemo.scenarios.scenario import load
from stepperdemo.watch import status_report
from stepperdemo.watch.status_lines import BoardState, parse_status, parse_table


def session(arch: str = "atmega328p", **kw) -> BoardSession:
    s = BoardSession(SimBoardLink(arch), **kw)
    assert s.wait_ready()
    return s


def lines_of(s: BoardSession) -> list[str]:
    return s.transcript.decode().replace("\r", "").split("\n")


# ------------------------------------------------------------- the parser
def test_status_lines_and_table_rows_of_the_firmware_are_parsed():
    entries = parse_status("M1: @120 => 3200 QueueEnd=160 v=100us/1600ticks ACC   "
                           "M2: @-7 nonstop QueueEnd=-9 v=-2500mSteps/s COAST ")
    assert [(e.number, e.position, e.target, e.queue_end, e.state) for e in entries] == [
        (1, 120, 3200, 160, "ACC"), (2, -7, None, -9, "COAST")]
    assert entries[0].speed_sps == 10_000 and entries[1].speed_sps == -2.5
    manual = parse_status("M1: @1 => 0 QueueEnd=1 v=0us/0ticks MANU ")[0]
    assert manual.state == "MANU" and manual.speed_sps == 0
    fresh = parse_status("M1: @0 => 0 QueueEnd=0 v=268435455us/4294967295ticks ACC   ")[0]
    assert not fresh.speed_known and fresh.speed_sps == 0
    row = parse_table(">> M1: @3200 acceleration  [steps/s^2]=1000 speed [us/step]=100 ")
    assert (row.number, row.selected, row.position, row.acceleration, row.speed_us) == (
        1, True, 3200, 1000, 100)
    other = parse_table("   M2: @-5 acceleration  [steps/s^2]=7 speed [mstep/s]=2000000 ")
    assert (other.selected, other.position, other.speed_mhz, other.running) == (
        False, -5, 2000000, None)
    running = parse_table(">> M1: @10 => 50 QueueEnd=20 v=500us/8000ticks RED   ")
    assert running.running.target == 50 and running.running.state == "RED"
    assert parse_status("Move steps 3200") is None and parse_table("OK") is None


def test_board_state_follows_the_answers():
    st = BoardState()
    feed = [msg.BANNER_VERSION.rstrip("\n"), msg.BANNER_STEPPERS + "2",
            "Select stepper 2", msg.ENTER_TEST_MODE.rstrip("\n"),
            msg.TOGGLE_MOTOR_INFO.rstrip("\n"), msg.RUN_TESTS.rstrip("\n")]
    kinds = [st.feed(line, 0.0) for line in feed]
    assert kinds[0] == "reset" and st.resets == 1 and st.banner.steppers == 2
    assert (st.selected, st.mode, st.verbose, st.test_running) == (2, "test", False, True)
    st.feed(msg.FAILED_STATUS.rstrip("\n"), 1.0)
    assert st.feed(msg.TEST_COMPLETED.rstrip("\n"), 1.0) == "test_done"
    assert (st.test_running, st.test_result, st.tests_failed) == (False, "failed", 1)
    st.feed(msg.EXIT_TO_MAIN_MENU.rstrip("\n"), 2.0)
    st.feed("run forward", 2.0)
    assert st.mode == "normal" and st.selected_runs_for_ever()
    assert st.feed(msg.BLOCKING_WAIT.rstrip("\n"), 2.0) == "spin" and not st.spinning
    st.feed(msg.STOP.rstrip("\n"), 2.0)
    st.feed(msg.BLOCKING_WAIT.rstrip("\n"), 2.0)
    assert st.spinning  # a stopping stepper is waited for
    assert st.feed(msg.STOPPED, 3.0) == "stopped" and not st.spinning
    st.feed("Unknown command: W", 3.0)
    assert st.feed(msg.BANNER_VERSION.rstrip("\n"), 4.0) == "reset"
    assert (st.mode, st.selected, st.verbose, st.resets) == ("normal", 1, True, 2)


# ---------------------------------------------------------- input pacing
def test_commands_are_split_with_their_separators():
    assert split_commands(b"M1 A1000  V100\nW") == [b"M1 ", b"A1000  ", b"V100\n", b"W"]
    assert split_commands(b"  \n") == [b"  \n"]


def test_pacer_holds_after_w_until_the_wait_is_over():
    st = BoardState()
    p = InputPacer()
    p.put(b"W R100\n")
    assert p.next_command(0.0, 0.0) == b"W "
    assert p.next_command(5.0, 0.0) is None and p.held_by() == "W"
    st.feed(msg.BLOCKING_WAIT.rstrip("\n"), 5.0)
    p.on_line("spin", st, 5.0)
    assert p.next_command(9.0, 5.0) is None and p.held_by() == "W stop"
    p.on_line(st.feed(msg.STOPPED, 9.0), st, 9.0)
    assert p.next_command(9.0, 9.0) == b"R100\n"
    # after an ordinary command: a line came, then 20 ms of quiet
    p.put(b"A5 ")
    assert p.next_command(9.01, 9.0) is None
    p.on_line(None, st, 9.02)
    assert p.next_command(9.03, 9.02) is None
    assert p.next_command(9.041, 9.02) == b"A5 "


def test_pacer_in_test_mode_waits_for_the_test_to_complete():
    st = BoardState(mode="test", test_running=True)
    p = InputPacer()
    p.put(b"W x\n")
    p.next_command(0.0, 0.0)
    p.on_line(st.feed(msg.BLOCKING_WAIT.rstrip("\n"), 0.1), st, 0.1)
    p.on_line(st.feed(msg.STOPPED, 0.2), st, 0.2)
    assert p.held_by() == "W test" and p.next_command(10.0, 0.2) is None
    p.on_line(st.feed(msg.TEST_COMPLETED.rstrip("\n"), 11.0), st, 11.0)
    assert p.next_command(11.0, 11.0) == b"x\n"


# ------------------------------------------------------- the simulated board
def test_simulated_board_takes_characters_at_line_rate_into_a_small_buffer():
    board = SimulatedBoard("atmega328p")
    p = board.profile
    board.run_until(p.ticks_per_s)  # started, idle
    board.take_output()
    board.receive(b"M1 A1000 V100 R30000 W ")
    board.run_until(board.now() + p.ticks_per_s // 2)
    assert board.app.waiting_interactive  # spinning in W: reads nothing
    board.receive(b"x" * 100)
    board.run_until(board.now() + 100 * sim_timing(p).uart_byte_ticks + 1)
    assert len(board.app.rx) == sim_timing(p).uart_rx_buffer == 63
    assert board.rx_dropped == 100 - 63
    assert b"Blocking wait for running stepper to stop\n" in board.take_output()


def test_interactive_w_prints_no_status_lines_while_it_spins():
    s = session()
    assert s.run_script("M1 A1000 V100 R3200 W", 60) == End.IDLE
    text = lines_of(s)
    spin = text.index("Blocking wait for running stepper to stop")
    assert text[spin + 1] == "STOPPED"  # nothing between: the firmware spins in W
    assert text[-3:] == [">> M1: @3200 acceleration  [steps/s^2]=1000 speed [us/step]=100 ",
                         "   M2: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 ", ""]
    assert s.link.board.rx_dropped == 0


def test_w_spins_with_the_error_injections_on():
    """While W spins, neither the stray reads (r) nor the interrupt blocks (e) run."""
    s = session()
    assert s.run_script("r e M1 A1000 V100 R3200 W", 60) == End.IDLE
    assert s.state.positions()[1] == 3200
    assert lines_of(s).count("STOPPED") == 1


# ----------------------------------------------------------------- session
def test_scripted_run_ends_when_the_board_is_idle_and_positions_are_read():
    s = session()
    assert s.run_script("M1 A3000 V100 R2000 M2 A3000 V100 R-2000", 60) == End.IDLE
    assert s.state.positions() == {1: 2000, 2: -2000}
    assert s.state.running() == [] and s.busy_reason() is None
    trace = s.state.trace
    assert trace.steppers[1].status_lines > 5 and trace.steppers[1].final_position == 2000


def test_status_lines_off_the_run_still_waits_for_the_stop_table():
    s = session()
    assert s.run_script("I M1 A1000 V100 R3200", 60) == End.IDLE
    assert s.state.trace.lines == 0 and s.state.positions()[1] == 3200


def test_a_long_line_with_waits_loses_no_character():
    line = " ".join(["M1 A20000 V100 R500 W R-500 W"] * 6 + ["M2 A20000 V100 R300 W"])
    s = session()
    assert len(line) > 3 * 63
    assert s.run_script(line, 60) == End.IDLE
    assert s.link.board.rx_dropped == 0
    assert s.state.positions() == {1: 0, 2: 300}
    assert "Unknown command" not in s.transcript.decode()


def test_test_mode_run_ends_after_the_test_and_reports_failure():
    s = session()
    assert s.run_script("M1 A1000 V100 R100 W t M1 13 R W x", 60) == End.IDLE
    st = s.state
    assert (st.mode, st.tests_completed, st.tests_failed) == ("normal", 1, 1)
    assert "Exit to main menu" in lines_of(s)


def test_max_time_ends_a_run_that_never_gets_quiet():
    s = session()
    assert s.run_script("M1 A1000 V100 f", 2.0) == End.MAX_TIME
    assert s.busy_reason() == "motion" and s.state.running() == [1]
    numbers, left = s.stop_all()
    assert (numbers, left) == ([1, 2], None)
    assert s.settle(5.0) == End.IDLE
    assert s.state.positions()[1] == 0 and s.state.running() == []  # X: position 0


def test_ctrl_c_in_test_mode_leaves_it_first():
    s = session()
    s.run_script("t", 5)
    assert s.state.mode == "test"
    assert s.stop_all() == ([1, 2], "test")
    assert s.settle(5.0) == End.IDLE
    assert s.state.mode == "normal" and lines_of(s).count("immediate stop") == 2


def test_a_restart_nobody_asked_for_gives_one_note():
    notes = []
    s = session(notes=notes.append)
    s.send("M1 A1000 V100 R100000\n")
    while s.now() < 4.0:  # past the start-up window of the open
        s.poll()
    s.link.reset()  # e.g. a brown-out: the board starts again by itself
    assert s.settle(10) == End.RESET
    assert notes == [msg.BOARD_RESTARTED.format(dropped="")]
    assert s.state.resets == 2 and s.state.positions().get(1) == 0


def test_status_trace_gives_plot_series_and_a_report():
    s = session()
    s.run_script("M1 A1000 V100 R3200", 60)
    series = status_report.series_of(s.state.trace)
    assert [x.number for x in series] == [1]
    assert series[0].position[-1] == 3200 and series[0].speed[-1] == 0
    peak = (2 * 1000 * 1600) ** 0.5  # a triangle: half the way up at 1000 steps/s^2
    assert max(series[0].speed) == pytest.approx(peak, rel=0.03)
    report = status_report.report_lines(s.state.trace, "twin")
    assert report[1].startswith("M1  ")
    first = series[0].position[0]  # the first status line comes before or at the first step
    assert first in (0, 1)
    assert f"{first} -> 3200 (net +{3200 - first}); 3200 in the last stepper table" in report[2]
    reported = float(report[3].split("peak ")[1].split()[0])
    acc = float(report[3].split("acceleration up to ")[1].split(",")[0])
    assert reported == pytest.approx(peak, rel=0.03) and acc == pytest.approx(1000, rel=0.3)


# --------------------------------------------------------- run --board parts
def test_run_side_and_twin_of_an_example_on_two_simulated_boards():
    sc = load("sequences/examples/two_steppers.toml")
    a = board_runner.run_side(session(), sc, reset=True)
    b = board_runner.run_side(BoardSession(SimBoardLink()), sc, reset=False)
    assert a.restarted and b.restarted and a.end == b.end == "idle"
    assert a.positions == b.positions == {1: 2000, 2: -2000}
    rows, checks = board_runner.twin_of(sc, a, b)
    assert [r.position_diff for r in rows] == [0, 0] and all(c.ok for c in checks)
    assert rows[0].board_lines == rows[0].sim_lines > 0
    assert rows[0].max_dt_s == pytest.approx(0, abs=1e-9)  # deterministic: the same on both
    assert all(c.ok for c in board_runner.checks_of(sc, a))


def test_board_checks_catch_a_wrong_position_and_a_failed_test(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text('name = "bad"\ninput = "M1 A1000 V100 R100 W t M1 13 R W x"\n'
                 '[steppers.A]\nposition = 4\n')
    sc = load(f)
    side = board_runner.run_side(session(), sc, reset=False)
    failed = {c.what for c in board_runner.checks_of(sc, side) if not c.ok}
    assert failed == {"A position", "test passed"}


# ----------------------------------------------------------------- history
def test_history_recalls_the_lines_of_the_current_mode(tmp_path):
    path = tmp_path / "history"
    path.write_text("\n# 2024-01-01 00:00:00\n+old line\n")  # a history without modes
    mode = ["normal"]

    def loaded(history):
        async def load_all():
            return [s async for s in history.load()]
        return asyncio.run(load_all())

    h = ModeHistory(str(path), lambda: mode[0])
    assert loaded(h) == ["old line"]
    for m, line in (("normal", "M1 A1000"), ("normal", "t"), ("test", "01 R"),
                    ("test", "x")):
        mode[0] = m
        h.append_string(line)
    mode[0] = "normal"
    assert h.get_strings() == ["old line", "M1 A1000", "t"]
    mode[0] = "test"
    assert loaded(ModeHistory(str(path), lambda: mode[0])) == ["x", "01 R", "old line"]
    assert path.read_text().count("mode=test") == 2


class _SlowPty:
    """A pty whose host reads little: each write takes at most ``per_write`` bytes."""

    master = -1

    def __init__(self, per_write: int) -> None:
        self.per_write = per_write
        self.taken = bytearray()
        self.pending_input = [b"M1 A1000 V100 R3200\n"]

    def read(self) -> bytes:
        return self.pending_input.pop() if self.pending_input else b""

    def write(self, data: bytes) -> int:
        n = min(self.per_write, len(data))
        self.taken += data[:n]
        return n


def test_console_device_delays_output_for_a_slow_host_but_loses_none(monkeypatch):
    from stepperdemo.front import console_device

    monkeypatch.setattr(console_device.select, "select", lambda *a: ([], [], []))
    profile = get_profile("atmega328p")
    now = [0.0]
    slow = _SlowPty(per_write=4)
    device = console_device.ConsoleDevice(SimulatedBoard(profile), slow,
                                          clock=lambda: now[0])
    for _ in range(2000):  # 5 s in 2.5 ms calls; the host takes 4 bytes a call
        now[0] += 0.0025
        device.step()
    assert device.tx_unsent > 0  # the host fell behind ...
    while device.tx_unsent:  # ... and catches up without a character lost
        device.step()
    text = slow.taken.decode()
    assert text.count("Move steps 3200") == 1 and ">> M1: @3200 " in text
    assert device.board.tx_bytes == len(slow.taken)


class _LaggingLink(SimBoardLink):
    """A simulated board behind a slow host: what the board prints after a command
    reaches us only ``lag_s`` after the command went out."""

    def __init__(self, lag_s: float) -> None:
        super().__init__()
        self.lag_s = lag_s
        self._held = bytearray()
        self._hold_until = 0.0

    def write(self, data: bytes) -> None:
        super().write(data)
        self._hold_until = self.now() + self.lag_s

    def read(self, timeout_s: float) -> bytes:
        self._held += super().read(timeout_s)
        if self.now() < self._hold_until:
            return b""
        out = bytes(self._held)
        self._held.clear()
        return out


def test_run_side_waits_for_the_final_table_of_a_slow_board(tmp_path):
    # with Q the board prints nothing after the stop: the positions come only from the
    # table of the final "?", whose answer arrives later than the no-answer window
    path = tmp_path / "q.toml"
    path.write_text('name = "q"\nprofile = "atmega328p"\n'
                    'input = "Q M1 A1000 V200 R500 W"\n[steppers.A]\nposition = 500\n')
    s = BoardSession(_LaggingLink(0.3))
    assert s.wait_ready()
    side = board_runner.run_side(s, load(str(path)), reset=False)
    assert side.end == "idle" and side.positions[1] == 500


class _JitteryLink(SimBoardLink):
    """The simulated board behind a USB adapter: what it prints reaches the host in
    bursts, each up to ``jitter_s`` late (seeded)."""

    def __init__(self, jitter_s: float, seed: int = 26) -> None:
        super().__init__()
        import random

        self.jitter_s = jitter_s
        self.rng = random.Random(seed)
        self._held = bytearray()
        self._release_at: float | None = None

    def read(self, timeout_s: float) -> bytes:
        self._held += super().read(timeout_s)
        if self._held and self._release_at is None:
            self._release_at = self.now() + self.rng.uniform(0, self.jitter_s)
        if self._release_at is None or self.now() < self._release_at:
            return b""
        out = bytes(self._held)
        self._held.clear()
        self._release_at = None
        return out


@pytest.mark.parametrize("acc", [500, 1000, 2000])
def test_status_line_acceleration_is_the_pins_despite_arrival_jitter(acc, tmp_path):
    """Issue 26: the board report said 3762 steps/s^2 for A <= 2000 - the change
    between two lines over their arrival times, which USB latency scatters.  With 60 ms
    of jitter the slope over each ramp stays within 2 x jitter / ramp time of the slope
    the pins of the same run show (the step rate over the rise and over the fall)."""
    import csv

    from stepperdemo.watch import observe
    from stepperdemo.watch.ramp_rates import phase_rates

    jitter = 0.06
    link = _JitteryLink(jitter)
    s = BoardSession(link)
    assert s.wait_ready()
    pins = observe.attach(link.board.backend, csv=str(tmp_path / "steps.csv"))
    steps = 4 * acc  # a triangle, about 2 s up and 2 s down ...
    assert s.run_script(f"M1 A{acc} V100 R{steps}", 60) == End.IDLE
    pins.finish()
    with open(tmp_path / "steps.csv") as f:
        ticks = [int(row["tick"]) for row in csv.DictReader(f)]
    assert len(ticks) == steps
    pin_acc, pin_dec = phase_rates(ticks, link.profile.ticks_per_s)
    ramp_s = (steps / acc) ** 0.5  # ... half the steps each way: t = sqrt(2 * s/2 / a)
    tol = 2 * jitter / ramp_s
    report = status_report.report_lines(s.state.trace, "jittery")
    got = re.search(r"acceleration up to (\d+), deceleration up to (\d+)", report[3])
    assert got, report
    assert float(got.group(1)) == pytest.approx(pin_acc, rel=tol)
    assert float(got.group(2)) == pytest.approx(pin_dec, rel=tol)
