"""StepperDemo as the firmware is built for each platform: start-up texts, the ESP32
commands (r, reset, p, pc), status with the pulse counter, driver types, the
ATmega32U4's smaller build, sequences 08/09 without a pulse counter, interactive W."""

from __future__ import annotations

import re

from fas.sim import SimBackend
from rigs.demo import EndReason, run, text
from stepperdemo.demo.app import StepperDemo

ESP32_START = (
    "Select pin configuration:\r\n  0: Test-HW\r\n  1: Driver-Types\r\n"
    "Press number to select, else 0\r\nUsing config 0: Test-HW\r\nLOG start\r\n\r\n"
    "ESP-IDF: 4.4\r\nStepperDemo Version ")


def test_esp32_start_up_texts_and_the_5_s_prompt():
    app, reason = run("", arch="esp32")
    t = text(app)
    assert t.startswith(ESP32_START)
    assert "    F_CPU=240000000\r\n    TICKS_PER_S=16000000\r\n    Steppers=14\r\n" in t
    # the prompt waits 5 s for a digit (scripted runs have no serial input then)
    assert app.backend.millis() >= 5000
    assert "    r         ... restart the chip (ESP.restart())" in t
    assert "    p<n>,l,h  ..." in t and "digitalRead" not in t
    table = [ln for ln in t.splitlines() if re.match(r"(>>|  ) M\d+: ", ln)]
    assert len(table) == 14
    assert table[0].endswith(" MCPWM_PCNT") and table[13].endswith(" RMT")


def test_esp32_idf5_and_variants_start_texts():
    app, _ = run("", arch="esp32_idf5")
    t = text(app)
    assert "ESP-IDF: 5.3\r\n" in t and "    Steppers=49\r\n" in t
    table = [ln for ln in t.splitlines() if re.match(r"(>>|  ) M\d+: ", ln)]
    # ten steppers in the Test-HW table: eight RMT, then the two I2S controllers
    assert [ln.rsplit(" ", 1)[1] for ln in table] == ["RMT"] * 8 + ["I2S_DIRECT"] * 2
    app, _ = run("", arch="esp32c3")
    t = text(app)
    assert "  0: C3-Test\r\n" in t and "Using config 0: C3-Test\r\n" in t
    assert "    Steppers=2\r\n" in t and "MCPWM" not in t and " RMT" not in t
    app, _ = run("", arch="rp2040")
    t = text(app)
    assert t.startswith("Select pin configuration:\r\n  0: Default\r\n")
    assert "ESP-IDF" not in t and "    F_CPU=133000000\r\n" in t and "Steppers=8\r\n" in t


def test_interactive_prompt_takes_a_digit_and_drops_other_characters():
    app = StepperDemo(SimBackend("esp32"), scripted=False)
    app.feed("x1M2 A1000 V100 R100\n")  # 'x' is dropped, '1' selects Driver-Types
    app.run_until(app.backend.now() + 16_000_000 // 10)
    assert "Using config 1: Driver-Types\r\n" in text(app)  # no 5 s wait after a digit
    app.run_until(app.backend.now() + 2 * 16_000_000)
    assert app.steppers[0].driver_type_string() == "RMT"
    assert app.steppers[0].get_step_pin() == 17
    assert app.steppers[1].driver_type_string() == "MCPWM_PCNT"
    assert app.steppers[1].get_step_pin() == 2 and app.steppers[2] is None
    assert app.steppers[1].get_current_position() == 100


def test_pulse_counter_commands_and_status():
    app, reason = run("M1 p7,-32767,32767 A10000 V100 R1000 W p8 p7 pc p1,2 R-10 W",
                      arch="esp32")
    t = text(app)
    assert "attach pulse counter 7\r\n" in t
    assert t.count("attach pulse counter 8\r\nERROR attaching pulse counter \n") == 1
    assert "clear pulse counter \n" in t and "Unknown command: p1,2\r\n" in t
    assert ">> M1: @1000 [1000] acceleration" in t
    assert ">> M1: @990 [-10] acceleration" in t  # cleared at 1000, then 10 back
    # status lines while running: position and counter (upstream's pcnt sync check)
    for pos, pcnt in re.findall(r"\nM1: @(-?\d+) \[(-?\d+)\]", t[:t.index("clear pulse")]):
        assert abs(int(pos) % 32767 - int(pcnt) % 32767) <= 66


def test_without_a_pulse_counter_p_is_unknown():
    for arch in ("esp32c3", "esp32_idf6", "atmega328p"):
        app, _ = run("p7 pc", arch=arch)
        t = text(app)
        assert "Unknown command: p7\r\n" in t and "Unknown command: pc\r\n" in t


def test_r_restarts_the_esp32_and_reset_too():
    app, reason = run("M1 A1000 V100 R200 W r", arch="esp32")
    t = text(app)
    assert reason == EndReason.IDLE and app.restarts == 1
    assert ">> M1: @200 acceleration" in t
    assert "ESP restart\r\nSelect pin configuration:" in t
    assert t.count("    Steppers=14\r\n") == 2
    assert app.steppers[0].get_current_position() == 0  # the library started empty
    app, reason = run("reset", arch="esp32")
    assert "ESP reset\r\nSelect pin configuration:" in text(app) and app.restarts == 1
    # what the chip had already received is lost with its RAM (here: everything the
    # scripted line fed while W held the input), as on the board
    app, reason = run("M1 A1000 V100 R200 W r A10", arch="esp32")
    assert "set acceleration to 10\r\n" not in text(app)


def test_restart_then_new_input_after_the_prompt():
    app = StepperDemo(SimBackend("esp32"), scripted=False)
    tps = 16_000_000
    app.feed("0")
    app.run_until(tps)
    app.feed("M1 A1000 V100 R300\n")
    app.run_until(app.backend.now() + 2 * tps)
    assert app.steppers[0].get_current_position() == 300
    app.feed("r\n")
    app.run_until(app.backend.now() + tps // 10)
    app.feed("1")  # answers the new prompt: Driver-Types
    app.run_until(app.backend.now() + tps // 10)
    app.feed("M1 A1000 V100 R50\n")
    app.run_until(app.backend.now() + tps)
    t = text(app)
    assert "ESP restart\r\n" in t and "Using config 1: Driver-Types\r\n" in t
    assert app.steppers[0].driver_type_string() == "RMT"
    assert app.steppers[0].get_current_position() == 50


def test_sequences_08_and_09_as_compiled_without_a_pulse_counter():
    for arch in ("sam_due", "rp2040", "esp32c3"):
        app, reason = run("t M1 08 R W", arch=arch)
        assert text(app).endswith("test passed\ntest completed\n"), arch
    app, reason = run("t M1 09 R w4000 x X", arch="rp2040", test_mode_wait=True)
    t = text(app)
    assert t.count("speed=") >= 3 and "Steps needed" not in t


def test_atmega32u4_build():
    app, reason = run("? M1 A1000 V100 R3200 W T t 13 12 x c d5 x", arch="atmega32u4")
    t = text(app)
    assert "    Steppers=3\r\n" in t and app.steppers[2] is None
    usage = t[t.index("Enter commands"):t.index(">> M1")]
    for gone in ("    W ", "    w<ms>", "    + ", "    T ", "    t ", "    u "):
        assert gone not in usage
    assert "    r         ... stray digitalRead()" in usage
    assert "Unknown command: T\r\n" in t and "Unknown command: 13\r\n" in t
    assert "Select test sequence: 12\r\n" in t and "Unknown command: d5\r\n" in t
    assert "Enter test mode\n>> M1" in t  # no test usage text in this build
    assert app.steppers[0].get_current_position() == 3200


def test_atmega32u4_sequence_12_never_ends():
    app, reason = run("t M1 12 R W", arch="atmega32u4", max_s=20)
    assert reason == EndReason.MAX_TIME and app.test_ongoing
    assert app.backend.machine.pins.rising(9) == 0


def test_interactive_w_in_test_mode_blocks_on_the_selected_stepper():
    app = StepperDemo(SimBackend("atmega328p"), scripted=False)
    app.feed("t M1 02 R W ?\n")
    tps = 16_000_000
    app.run_until(app.backend.now() + 30 * tps)
    t = text(app)
    body = t[t.index("run test \n"):]
    assert body.startswith("run test \nBlocking wait for running stepper to stop\n")
    stopped = body.index("STOPPED\r\n")
    # the loop stood still: no status line while waiting; the ? after it was taken
    assert "M1: @" not in body[:stopped]
    assert body.index("Enter commands", stopped) > stopped or "M1: @" in body[stopped:]
    assert app.test_ongoing  # 02 goes on after the first of its moves stopped


def test_restart_switches_user_outputs_off():
    # seed 003: power-on and reset leave every user output off
    app = StepperDemo(SimBackend("sam_due"), scripted=True)  # its output pins are free
    app.run_script("")
    b = app.backend
    outputs = app.engine.outputs
    pin_d, pin_a = outputs.digital_pin(0), outputs.analog_pin(0)
    assert outputs.digital(0, True, synchronized=False) == 0
    assert outputs.analog(0, 50.0, synchronized=False) == 0
    b.run_for_ms(5)
    assert b.read_pin(pin_d) == 1 and pin_a in b.machine.outputs.waves
    app.restart()
    b.run_for_ms(5)
    assert b.read_pin(pin_d) == 0 and not b.machine.outputs.waves
    assert b.read_pin(pin_a) == 0


def test_sam_due_milli_hz_status_and_stopped_line_wrap_as_the_cpp():
    """On the SAM Due (TICKS_PER_S 21 MHz) the firmware's milli-Hz figures are
    computed in uint32_t and wrap: the status line while coasting at the fastest
    period (420 ticks) shows getCurrentSpeedInMilliHz() = 9095548, the stepper
    table after the stop getSpeedInMilliHz() = 9095550 (divForMilliHz rounds)."""
    app, reason = run("M1 A1000000 H50000 R100000 W", arch="sam_due")
    t = text(app)
    assert reason == EndReason.IDLE
    assert "v=9095548mSteps/s COAST" in t and "50000000" not in t
    assert ">> M1: @100000 acceleration  [steps/s^2]=1000000 speed [mstep/s]=9095550" in t


def test_a0_without_a_speed_then_r_answers_speed_undefined_and_does_not_move():
    app, reason = run("M1 a0 R100 W", record=True)
    t = text(app)
    assert "Move steps 100\r\nERROR speed is not defined\n" in t
    assert app.steppers[0].get_current_position() == 0
    assert app.backend.recorder.rising(9) == []
