"""Scripted runs print what the firmware prints, byte for byte where it matters."""

import re

from fas.arch import ATMEGA328P
from fas.sim import SimBackend
from fas.sim.timing import sim_timing
from rigs.demo import EndReason, after_setup, lines, run, text
from stepperdemo import messages as msg
from stepperdemo.demo.app import StepperDemo
from stepperdemo.demo.build import demo_build
from stepperdemo.scenarios import transcript as tr

STATUS = re.compile(r"^M1: @-?\d+ => 3200 QueueEnd=-?\d+ v=\d+us/\d+ticks (ACC  |RED  |COAST) $")


def test_move_3200_transcript():
    app, reason = run("M1 A1000 V100 R3200 W")
    assert reason == EndReason.IDLE
    t = after_setup(app)
    assert t.startswith("Select stepper 1\r\nset acceleration to 1000\r\n"
                        "set speed (us/step) to 100\r\nMove steps 3200\r\nOK\n")
    status = [ln for ln in lines(app) if ln.startswith("M1: @") and "=> 3200" in ln]
    assert len(status) >= 30  # every 100 ms for 3.5 s
    assert all(STATUS.match(ln) for ln in status[1:])
    assert ">> M1: @3200 acceleration  [steps/s^2]=1000 speed [us/step]=100 \r\n" in t
    assert "   M2: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 \r\n" in t
    assert app.steppers[0].get_current_position() == 3200


def test_start_banner_and_usage():
    app, _ = run("")
    t = text(app)
    assert t.startswith(msg.BANNER_VERSION + "    F_CPU=16000000\r\n"
                        "    TICKS_PER_S=16000000\r\n    Steppers=2\r\n")
    assert msg.USAGE_NORMAL in t
    assert len(msg.USAGE_NORMAL.encode()) == msg.USAGE_NORMAL_LENGTH
    for letter in "MVHhAaJjUPRfbK@EDNFOSXIWw+-Ttur eQ?c":
        if letter != " ":
            assert f"\n    {letter}" in msg.USAGE_NORMAL


def test_error_lines():
    app, _ = run("M1 R100")
    assert "Move steps 100\r\nERROR speed is not defined\n" in text(app)
    app, _ = run("M1 V100 R100")
    assert "ERROR acceleration is not defined\n" in text(app)
    app, _ = run("M1 A100 V100 u R-10")
    assert ("set unidirectional stepper\nMove steps -10\r\n"
            "ERROR no direction pin => impossible move\n") in text(app)
    app, _ = run("V0")
    assert "set speed (us/step) to 0\r\nERROR invalid value\n" in text(app)
    app, _ = run("A-5")
    assert "set acceleration to -5\r\nERROR invalid value\n" in text(app)


def test_unknown_commands():
    app, _ = run("Zzz R12x M9 M1,2 x")
    t = after_setup(app)
    for cmd in ("Zzz", "R12x", "M9", "M1,2", "x"):
        assert f"Unknown command: {cmd}\r\n" in t
    assert app.rejected == 5


def test_very_long_token_is_harmless():
    token = "A" * 300
    app, reason = run(f"{token} M1 A1000 V100 R10")
    assert reason == EndReason.IDLE
    # the firmware's 255-character command buffer starts over
    assert "Unknown command: " + "A" * 45 + "\r\n" in text(app)
    assert app.steppers[0].get_current_position() == 10


def test_numbers_parse_like_strtol():
    app, _ = run("M1 A+1000 V 100 H")
    t = after_setup(app)
    assert "set acceleration to 1000\r\n" in t
    assert "Unknown command: V\r\n" not in t  # 'V' alone is V0: invalid value
    assert "set speed (us/step) to 0\r\nERROR invalid value\n" in t
    assert "Unknown command: 100\r\n" in t
    assert "set speed (steps /s) to 0\r\nERROR invalid value\n" in t
    app, _ = run("R99999999999")
    assert "Move steps 2147483647\r\n" in text(app)


def test_enable_time_return_codes_print_as_unsigned():
    app, _ = run("M1 E10 E100000000 E1000")
    t = after_setup(app)
    assert "set enable timeto 10\r\nreturncode = 255\r\n" in t
    assert "set enable timeto 100000000\r\nreturncode = 254\r\n" in t
    assert "set enable timeto 1000\r\nreturncode = 0\r\n" in t


def test_speed_in_hz_switches_status_and_table_units():
    app, _ = run("M1 H2000 A3000 R1000 W")
    t = text(app)
    assert re.search(r"M1: @\d+ => 1000 QueueEnd=\d+ v=\d+mSteps/s", t)
    assert ">> M1: @1000 acceleration  [steps/s^2]=3000 speed [mstep/s]=2000000 \r\n" in t


def test_run_forward_then_stop_and_keep_running():
    app, reason = run("M1 A6000 V60 f w600 K w300 S W")
    t = text(app)
    assert "run forward\nreturncode = 0\r\n" in t
    assert "600 ms wait\n" in t and t.count("Wait complete\n") == 2
    assert "Keep running\n" in t and "stop\n" in t
    assert re.search(r"M1: @\d+ nonstop QueueEnd=\d+ v=", t)
    assert reason == EndReason.IDLE and not app.any_running()


def test_w_on_a_stepper_that_never_stops_ends_at_max_time():
    app, reason = run("M1 A1000 V100 f W", max_s=5)
    assert reason == EndReason.MAX_TIME
    assert app.backend.now() >= 5 * 16_000_000


def test_toggles_and_modes():
    app, _ = run("I Q e r t x c M2 d7,1,500 dc x ?")
    t = after_setup(app)
    for piece in ("Toggle stepper info\n", "Toggle usage info\n",
                  "Toggle erroneous 100 set acceleration to , counting s ISR block\n",
                  "Toggle erroneous digitalRead() to step pin \n",
                  "Enter test mode\n", "Exit to main menu\n", "Enter config mode\n",
                  "Select stepper 2\r\n", "direction pin set to pin 7\r\n",
                  "direction pin high counts down\r\n", "delay in us = 500\r\n", "disabled\n",
                  "erroneous 100 set acceleration to , counting s ISR BLOCK IS ON\n",
                  "erroneous digitalRead() to step pin IS ON !!!\n"):
        assert piece in t, piece
    assert app.steppers[1].get_direction_pin() == 255


def test_r_is_unknown_where_the_firmware_has_no_stray_read():
    for arch in ("sam_due", "rp2040"):
        app, _ = run("r", arch=arch)
        assert "Unknown command: r\r\n" in text(app)


def test_single_steps_and_direct_drive():
    app, _ = run("M1 + + + - W", record=True)
    t = after_setup(app)
    assert t.count("Stepped forward\n") == 3 and "Stepped backward\n" in t
    assert app.steppers[0].get_current_position() == 2
    app, _ = run("M1 T", record=True)
    assert "test direct drive\n" in text(app)
    assert app.backend.machine.pins.rising(9) == 6400
    assert app.steppers[0].get_current_position() == 0  # the library saw nothing


def test_immediate_stop_sets_zero():
    app, _ = run("M1 A9000 V120 R4000 w150 X w100 W")
    t = text(app)
    assert "150 ms wait\n" in t and "immediate stop\n" in t
    assert app.steppers[0].get_current_position() == 0


def test_set_position_and_move_to():
    app, _ = run("M1 A3000 V250 R2000 W @500 P0 W")
    t = text(app)
    assert "set position 500\r\nMove to position 0\r\nOK\n" in t
    assert app.steppers[0].get_current_position() == 0


def test_firmware_end_stops_one_second_after_the_input():
    app, reason = run("M1 A1000 V100 f", firmware_end=True)
    assert reason == EndReason.FIRMWARE_END
    assert app.backend.now() - app.input_consumed_at == 16_000_000
    assert app.any_running()


def test_other_profiles_run_the_demo():
    for arch, steppers in (("atmega2560", 3), ("atmega32u4", 3), ("esp32", 14),
                           ("esp32_idf5", 49), ("esp32_idf6", 8), ("rp2040", 8),
                           ("rp2350", 12)):
        app, reason = run("M2 A10000 V200 R1000 W", arch=arch)
        assert reason == EndReason.IDLE
        assert f"    Steppers={steppers}\r\n" in text(app)
        assert app.steppers[1].get_current_position() == 1000


def test_the_sam_build_connects_only_its_first_stepper():
    # StepperPins_sam.h: GPIO 17 is a PWM pin, GPIO 15 (the second entry) is not, so
    # setup() stops there; M2 does not exist
    app, reason = run("M2 A10000 V200 R1000 M1 A10000 V200 R1000 W", arch="sam_due")
    t = text(app)
    assert "    Steppers=6\r\n" in t and "Unknown command: M2\r\n" in t
    assert [s is not None for s in app.steppers] == [True] + [False] * 5
    assert app.steppers[0].get_step_pin() == 17
    assert app.steppers[0].get_current_position() == 2000


def test_boot_time_grows_with_the_built_in_line_as_in_the_firmware():
    # the firmware's built-in input is start-up data: reset takes 9 ticks per byte
    # longer, which moves the console, millis() and the ramp task alike; the copy is
    # rounded up to even bytes (build d's replica: docs/timing-model.md, thirtieth pass)
    origins = []
    for line in ("M1 A1000 V100 R100 W", "M1  A1000 V100 R100 W", "M1   A1000 V100 R100 W"):
        app, _ = run(line)
        origins.append((app.backend.tasks.origin, app.backend.machine._millis_phase))  # noqa: SLF001 - when timer 0 started: no public reader
    per_byte = sim_timing(ATMEGA328P).boot_script_byte_ticks
    assert sim_timing(ATMEGA328P).boot_data_align == 2
    assert origins[1] == origins[0]  # 21 and 22 bytes: both copy 22
    assert origins[2][0] - origins[0][0] == 2 * per_byte  # 23 bytes: 24
    assert origins[2][1] - origins[0][1] == 2 * per_byte
    boot = sim_timing(ATMEGA328P).boot_ticks
    # ... and timer 0 starts 405 ticks after that (build d's replica, timer0_lag_ticks:
    # the default since the fortieth pass)
    lag = sim_timing(ATMEGA328P).timer0_lag_ticks
    assert lag == 405
    assert origins[0][1] == boot + (len("M1 A1000 V100 R100 W ") + 1) * per_byte + lag


def test_printing_a_text_first_scans_the_message_table():
    b = SimBackend("atmega328p")
    app = StepperDemo(b, scripted=True)
    lead, lead_lookups, total, lookups = msg.TABLE_SCAN[msg.STOP]
    t0 = b.now()
    app.print(msg.STOP)
    p = demo_build(ATMEGA328P)
    first_char = b.machine.uart.records[0][2]
    lead_ticks = lead * p.msg_scan_byte_ticks + lead_lookups * p.msg_lookup_ticks
    assert first_char == t0 + lead_ticks
    # all of the scan is spent by the time the text is handed over
    spent = total * p.msg_scan_byte_ticks + lookups * p.msg_lookup_ticks
    assert b.now() - t0 == spent + len(msg.STOP) * sim_timing(ATMEGA328P).char_ticks


def test_transcript_comparison_masks_only_what_timing_decides():
    ours = ("StepperDemo Version <version>\n<usage>set speed (steps /s) to 100\r\n"
            "M1: @12 => 100 QueueEnd=14 v=900us/14400ticks ACC   \r\n809\n")
    same = ours.replace("@12 => 100 QueueEnd=14", "@13 nonstop QueueEnd=15").replace(
        "809", "810")
    assert tr.first_difference(ours, same) is None
    changed = ours.replace("(steps /s)", "(steps/s)")
    assert tr.first_difference(ours, changed).startswith("line 2:")
    assert tr.first_difference(ours, ours + "x\n") is not None


def test_reference_transcripts_get_markers_for_version_and_usage():
    usage = "u" * 20
    ref = ("StepperDemo Version 9.9\n    F_CPU=1\n    T=1\n    S=2\n" + usage
           + "M1 done\n" + usage + "\n").encode()
    marked = tr.mark_reference(ref, len(usage))
    assert marked == ("StepperDemo Version <version>\n    F_CPU=1\n    T=1\n    S=2\n"
                      "<usage>M1 done\n<usage>\n")
    app, _ = run("")
    assert tr.ours_marked(app.transcript).startswith("StepperDemo Version <version>\n")
    assert "<usage>" in tr.ours_marked(app.transcript)


def test_the_input_ring_full_behind_a_held_w_counts_what_the_rewind_skips():
    app, reason = run(" ".join(["M1 A1000 V100 R10 W"] * 20))
    assert reason == EndReason.IDLE
    assert app.steppers[0].get_current_position() == 80
    assert app.dropped_input() == 256  # one whole ring, the held W with it
    app, _ = run(" ".join(["M1 A1000 V100 R10 W"] * 13))
    assert app.steppers[0].get_current_position() == 130 and app.dropped_input() == 0
