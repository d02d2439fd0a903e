"""Test mode: the built-in sequences 01-13 and the `e` / `r` error injections."""

import re

import pytest

from rigs.demo import EndReason, after_setup, run, text
from rigs.pins import periods
from stepperdemo.front.cli import main


def run_test(line: str, max_s: float = 600, **kw):
    app, reason = run(line, max_s=max_s, **kw)
    t = text(app)
    return app, reason, t


@pytest.mark.parametrize("seq", ["01", "02", "03", "04", "05", "06", "11"])
def test_sequences_that_return_to_their_start_pass(seq):
    app, reason, t = run_test(f"t M1 {seq} R W")
    assert reason == EndReason.IDLE
    assert t.endswith("test passed\ntest completed\n")
    assert app.steppers[0].get_current_position() == 0
    assert f"Select test sequence: {seq}\r\nrun test \n" in t


def test_sequence_07_prints_its_timings_inside_the_windows():
    app, reason, t = run_test("t M1 07 R W")
    numbers = [int(ln) for ln in after_setup(app).replace("\r", "").split("\n")
               if re.fullmatch(r"-?\d+", ln)]
    coast_ms, home_ms, final = numbers[-3:]
    assert abs(coast_ms - 792) <= 40
    assert abs(home_ms - 1495) <= 30
    assert final == 0
    assert "test passed\n" in t


def test_sequence_10_passes_and_prints_all_speed_pairs():
    app, reason, t = run_test("t M1 10 R W")
    assert "test passed\n" in t
    changes = re.findall(r"Speed changes 64us <=> (\d+)us\r\n", t)
    assert [int(c) for c in changes[:4]] == [65, 63, 66, 62]
    assert len(changes) == 48 and changes[-1] == "40"


def test_sequence_13_raw_commands():
    app, reason, t = run_test("t M1 13 R W")
    assert "test passed\n" in t
    assert app.steppers[0].get_current_position() == 4


def test_two_steppers_run_different_sequences_at_once():
    app, reason, t = run_test("t M1 02 M2 03 R W")
    assert t.count("test passed\n") == 1 and "Failed" not in t
    assert [s.get_current_position() for s in app.steppers] == [0, 0]
    assert app.backend.machine.pins.rising(9) > 0 and app.backend.machine.pins.rising(10) > 0


def test_a_failed_sequence_sets_the_exit_code(capsysbinary):
    # sequence 11 must start at position 0
    assert main(["-c", "M1 @5 t M1 11 R W"]) == 1
    out = capsysbinary.readouterr().out
    assert b"Failed status from test \ntest completed\n" in out
    assert main(["-c", "t M1 13 R W"]) == 0


# `w` in test mode is our extension (switched on with test_mode_wait): the firmware has
# no way to let an endless sequence run for a while in a built-in line
def test_sequence_08_pulse_counter_agrees_for_50_moves():
    app, reason, t = run_test("t M1 08 R w150000 x", arch="esp32", test_mode_wait=True)
    log = app.test_slots[0].log
    assert len(log) >= 50
    assert all((e["counter"] & 0x3FFF) == (e["position"] & 0x3FFF) for e in log)
    assert "stepper pos=" not in t and "Failed" not in t


def test_sequence_09_forced_stops_never_step_afterwards_for_50_runs():
    app, reason, t = run_test("t M1 09 R w70000 x X", arch="esp32", test_mode_wait=True)
    log = app.test_slots[0].log
    assert len(log) >= 50
    assert "Step AFTER stop" not in t and t.count("Steps needed for stop=") >= 50
    assert all(entry["after_stop"] == 0 for entry in log)


def test_sequence_08_without_a_pulse_counter_passes_at_once():
    # the AVR build compiles 08 as "finished": the table and the verdict right away
    app, reason, t = run_test("t M1 08 R W")
    assert reason == EndReason.IDLE
    body = after_setup(app)
    assert body.endswith("run test \n>> M1: @0 acceleration  [steps/s^2]=0 speed "
                         "[us/step]=0 \r\n   M2: @0 acceleration  [steps/s^2]=0 speed "
                         "[us/step]=0 \r\ntest passed\ntest completed\n")
    assert app.backend.machine.pins.rising(9) == 0


def test_sequence_09_without_a_pulse_counter_prints_no_counter_lines():
    app, reason, t = run_test("t M1 09 R w3500 x X", test_mode_wait=True)
    assert t.count("speed=") >= 3 and "Steps needed" not in t and "Step AFTER" not in t


def test_w_in_test_mode_is_unknown_as_in_the_firmware():
    app, reason, t = run_test("t w100 x w100")
    body = after_setup(app)
    assert "Unknown command: w100\r\n" in body
    assert body.count("100 ms wait\n") == 1 and body.endswith("Wait complete\n")


def test_x_leaves_test_mode_and_unknown_letters_there():
    app, reason, t = run_test("t A100 99 x A100")
    body = after_setup(app)
    assert "Unknown command: A100\r\n" in body and "Unknown command: 99\r\n" in body
    assert "Exit to main menu\n" in body and body.endswith(
        "   M2: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 \r\nset acceleration to 100\r\n")


# ------------------------------------------------------------------ injections
def step_times(app, pin=9):
    return app.backend.recorder.rising(pin)


def test_interrupt_block_at_25khz_keeps_every_step_but_takes_longer():
    with_e, _ = run("M1 A1000000 V40 e R20000 W", record=True)
    without, _ = run("M1 A1000000 V40 R20000 W", record=True)
    a, b = step_times(with_e), step_times(without)
    assert len(a) == len(b) == 20000
    dur_e = (a[-1] - a[0]) / 16000
    dur = (b[-1] - b[0]) / 16000
    # the firmware (sequences/reference/d36, d35): 822.68275 ms and 1150.362876 ms from
    # first to last step; without `e` within 1 us (upstream's evaluation reports whole
    # us), with `e` within one 4.1 ms timer wrap per `e` window the run spans (five):
    # issue 23's acceptance rule, gaps per window within +-1 of the firmware's
    assert abs(dur - 822.68275) <= 0.001
    assert abs(dur_e - 1150.362876) <= 5 * 4.096
    gaps = [(y - x) / 16 for x, y in zip(a, a[1:], strict=False) if y - x > 16000]
    assert gaps and all(4000 < g < 4200 for g in gaps)  # ~4.1 ms timer wraps
    pins = with_e.backend.machine.pins
    assert 90 * 16 < pins.high_max[9] < 110 * 16  # pulses held high ~100 us
    assert without.backend.machine.pins.high_max[9] < 16 * 16
    assert "erroneous 100 set acceleration to , counting s ISR BLOCK IS ON\n" in text(with_e)


def test_interrupt_block_at_low_rate_does_not_move_steps():
    with_e, _ = run("M1 A2000 V40 e R4000 W", record=True)
    without, _ = run("M1 A2000 V40 R4000 W", record=True)
    a, b = step_times(with_e), step_times(without)
    assert len(a) == len(b) == 4000
    assert periods(a) == periods(b)


def test_stray_digital_read_changes_no_step_and_is_counted():
    with_r, _ = run("M1 A20000 V60 r R3000 W", record=True)
    without, _ = run("M1 A20000 V60 R3000 W", record=True)
    a, b = step_times(with_r), step_times(without)
    assert len(a) == len(b) == 3000
    assert periods(a) == periods(b)
    backend = with_r.backend
    assert backend.stray_reads > 1000
    assert 0 < backend.stray_reads_during_pulse < backend.stray_reads
