"""The console on a device: one line when the device is lost, /reconnect, /link."""

import os

from prompt_toolkit.output import DummyOutput

from fas.device.loopback import Loopback
from rigs.serial import TPS
from stepperdemo.front.console import Console


def _run(console, ms: int) -> None:
    backend = console.backend
    console.app.run_until(backend.now() + ms * TPS // 1000)
    console.flush()


def test_lost_device_is_one_line_and_reconnect_restores_the_session(tmp_path):
    with Loopback() as lb:
        console = Console(backend=lb.backend, output=DummyOutput(),
                          history=str(tmp_path / "history"))
        console.handle_line("M1 A1000 V100 R100000")
        _run(console, 500)
        assert any(line.startswith("M1: @") for line in console.lines)
        lb.unplug()
        _run(console, 300)
        lost = [line for line in console.lines if line.startswith("device lost")]
        assert len(lost) == 1 and "/reconnect" in lost[0]
        assert not console.app.steppers[0].is_running()
        # the console keeps running: its own commands are answered; StepperDemo's wait
        # for the device (issue 26: a move was answered OK and "ran" for ever)
        for line in ("?", "R100"):
            n = len(console.lines)
            console.handle_line(line)
            _run(console, 300)
            assert console.lines[n:] == [
                f"no device ({lb.backend.lost_reason}) - /reconnect first; the line was "
                "not sent"]
        n = len(console.lines)
        console.handle_line("/estop")
        assert console.lines[n:] == [
            f"emergency stop: no device ({lb.backend.lost_reason}) - nothing sent; a device "
            "that loses its host stops by its watchdog; /reconnect"]
        n = len(console.lines)
        console.handle_line("/link")  # the device's figures: said to be from before
        assert console.lines[n + 1] == ("the device's figures below are its last report, "
                                        "from before the connection ended")
        assert " rtt 0 us;" not in console.lines[n]  # the last round trip measured
        assert not console.app.steppers[0].is_running()
        lb.replug()
        console.handle_line("/reconnect")
        assert console.lines[-1].startswith("device back on")
        pos = console.app.steppers[0].get_current_position()
        assert pos == lb.device.position(0) > 0
        console.handle_line("?")  # taken again
        _run(console, 100)
        assert console.lines[-1].startswith("   M2: @")
        console.handle_line("R-100")
        console.handle_line("W")
        _run(console, 1500)
        assert "STOPPED" in console.lines
        assert console.app.steppers[0].get_current_position() == pos - 100
        console.handle_line("/link")
        assert any(line.startswith("link: ") and "2 session(s)" in line
                   for line in console.lines)
        assert any(line.startswith("device: ") for line in console.lines)
        # issue 18: how far ahead the host plans, the device's queue and window
        assert any(line.startswith("planning: ") and "device queue 64 entries" in line
                   and "9 frames of 32 bytes" in line for line in console.lines)


def test_simulator_only_commands_are_refused_on_a_device(tmp_path):
    with Loopback() as lb:
        console = Console(backend=lb.backend, output=DummyOutput(),
                          history=str(tmp_path / "history"))
        console.handle_line("/speed 10")
        console.handle_line("/arch esp32")
        assert console.lines[-2:] == [
            "/speed: not on a device (its profile and clock are its own)",
            "/arch: not on a device (its profile and clock are its own)"]
        assert console.backend.profile.name == "atmega328p"


def test_serial_commands_need_a_device(tmp_path):
    console = Console(output=DummyOutput(), history=str(tmp_path / "history"))
    console.handle_line("/reconnect")
    assert console.lines[-1] == "/reconnect: only with a device (stepperdemo --port DEVICE)"


def test_console_driver_runs_the_program_while_the_device_clock_runs(tmp_path):
    """The console's ticker on a device: one pass per call, sleeping until the next wake."""
    with Loopback() as lb:
        console = Console(backend=lb.backend, output=DummyOutput(),
                          history=str(tmp_path / "history"))
        backend = console.backend

        def drive(until_tick: int) -> None:
            while backend.now() < until_tick and "STOPPED" not in console.lines:
                delay = console.driver.advance()
                console.flush()
                sleep_ticks = TPS // 20 if delay is None else int(delay * TPS)
                backend.app_wait_until(backend.now() + max(sleep_ticks, 1))

        console.handle_line("M1 A2000 V200 R2000")
        drive(backend.now() + TPS)
        console.handle_line("W")
        drive(backend.now() + 4 * TPS)
        assert "STOPPED" in console.lines
        status = [line for line in console.lines if line.startswith("M1: @")]
        assert len(status) > 5  # status lines every 100 ms while it moved
        # as in the firmware, W blocks the loop: no status line until STOPPED
        waited = console.lines[console.lines.index("Blocking wait for running stepper "
                                                   "to stop"):]
        assert not any(line.startswith("M1: @") for line in waited[:waited.index("STOPPED")])
        assert console.app.steppers[0].get_current_position() == 2000


def test_a_move_given_after_the_loss_does_not_run_for_ever():
    """The library on a lost device (a program that moves by itself, not by typed
    input): what cannot start is dropped at the next task run - the stepper stands
    where it stood, no status lines with an undefined speed for ever."""
    with Loopback() as lb:
        backend = lb.backend
        console = Console(backend=backend, output=DummyOutput(), history=os.devnull)
        console.handle_line("M1 A1000 V100 R100 W")
        _run(console, 1000)
        assert console.app.steppers[0].get_current_position() == 100
        lb.unplug()
        _run(console, 300)
        stepper = console.app.steppers[0]
        assert stepper.move(100) == 0  # (the request is taken: FastAccelStepper's API)
        n = len(console.lines)
        _run(console, 1000)
        assert not stepper.is_running()
        assert stepper.get_current_position() == 100
        status = [line for line in console.lines[n:] if line.startswith("M1: @")]
        assert len(status) <= 1  # (the one after the drop: it stands, no ramp state)
        assert not any(state in line for line in status for state in ("ACC", "COAST", "RED"))
